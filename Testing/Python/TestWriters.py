"""The finite-element writers from Python (run by pvpython).

- paraview.simple's SaveData picks the plugin's writer by the file's extension (.msh, .mesh,
  .inp, .feb, .exo), as File > Save Data does, and the Gmsh writer's Binary property reaches it.
- The files are read back by independent readers: Gmsh's own Python API and meshio (Debian's
  python3-gmsh, python3-meshio) and, for FEBio, ElementTree. Each has the mesh's points bit for
  bit, its element count, and per material (Material: 2 and 5 here) the same number of elements,
  in a group named from the label table (stmLabelTable on the mesh's field data).
- spacetreemesh.report.write_report makes the visual report of a mesh in memory.
- The wrapped classes used VTK-style: stmLabelTable reads an atlas's label file, a writer
  reports a clear error for a mesh of polygons and leaves no file behind, and the threaded XML
  writers write the bytes of VTK's.
"""
import os
import xml.etree.ElementTree as ET

import numpy as np

from paraview.simple import LoadPlugin, PVTrivialProducer, SaveData

import spacetreemesh
import stmtesting as T
from vtkmodules.vtkCommonCore import vtkPoints
from vtkmodules.vtkCommonDataModel import VTK_POLYGON, VTK_WEDGE, vtkPolyData, vtkUnstructuredGrid

PLUGIN = T.env("STM_PLUGIN")
LoadPlugin(PLUGIN, ns=globals())

# Two boxes of labels 2 and 5 in a background of 0, meshed with the background dropped by the
# tessellation (no boundary layer): tetrahedra of Material 2 and 5.
labels = np.zeros((8, 10, 12), dtype=np.uint8)
labels[1:7, 1:7, 2:6] = 2
labels[1:7, 1:7, 6:9] = 5
producer = PVTrivialProducer()
producer.GetClientSideObject().SetOutput(T.make_image(labels))
mesh = SpacetreeTessellate(Input=SpacetreeBalance(Input=ImageToSpacetree(Input=producer)),
                           SeparatingFunction="No Function")
mesh.UpdatePipeline()
grid = vtkUnstructuredGrid()
grid.ShallowCopy(mesh.GetClientSideObject().GetOutputDataObject(0))
materials = [int(grid.GetCellData().GetArray("Material").GetTuple1(c))
             for c in range(grid.GetNumberOfCells())]
per_material = {m: materials.count(m) for m in sorted(set(materials))}
T.check_equal(sorted(per_material), [2, 5], "materials of the mesh")
points = np.array([grid.GetPoint(p) for p in range(grid.GetNumberOfPoints())])

# The label names, as stmesh --label-names puts them: through the wrapped stmLabelTable.
table_file = T.temp_path("names.txt")
with open(table_file, "w") as names:
    names.write("2 Left box\n5 Right_box 2001\n")
table = spacetreemesh.stmLabelTable()
T.check(table.ReadFile(table_file), "stmLabelTable.ReadFile: %s" % table.GetLastError())
T.check_equal([(table.GetLabel(i), table.GetName(i)) for i in range(table.GetNumberOfLabels())],
              [(2, "Left"), (5, "Right_box")], "the label table")
table.SetName(2, "Left box")
named = PVTrivialProducer()
named_grid = vtkUnstructuredGrid()
named_grid.ShallowCopy(grid)
table.WriteFieldData(named_grid.GetFieldData())
named.GetClientSideObject().SetOutput(named_grid)
named.UpdatePipeline()
NAMES = {2: "Left box", 5: "Right_box"}

import gmsh  # noqa: E402
import meshio  # noqa: E402


def check_points(read, what):
    T.check(read.shape == points.shape and np.array_equal(read, points),
            "%s: the points differ from the mesh's" % what)


for binary in (0, 1):
    path = T.temp_path("boxes%d.msh" % binary)
    SaveData(path, proxy=named, Binary=binary)
    with open(path, "rb") as msh:
        T.check_equal(msh.read(19), b"$MeshFormat\n4.1 %d 8" % binary, "the MSH header")
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.open(path)
    groups = {}
    for dim, tag in gmsh.model.getPhysicalGroups():
        count = sum(len(tags) for entity in gmsh.model.getEntitiesForPhysicalGroup(dim, tag)
                    for tags in gmsh.model.mesh.getElements(dim, entity)[1])
        groups[tag] = (gmsh.model.getPhysicalName(dim, tag), count)
    gmsh.finalize()
    T.check_equal(groups, {m: (NAMES[m], n) for m, n in per_material.items()},
                  "Gmsh's physical groups")
    read = meshio.read(path)
    check_points(read.points, path)
    T.check_equal(sum(len(block.data) for block in read.cells), grid.GetNumberOfCells(),
                  "elements of %s" % path)

path = T.temp_path("boxes.mesh")
SaveData(path, proxy=named)
read = meshio.read(path)
check_points(read.points, path)
refs = np.concatenate(read.cell_data["medit:ref"])
T.check_equal({int(m): int((refs == m).sum()) for m in set(refs)}, per_material, "Medit references")

path = T.temp_path("boxes.inp")
SaveData(path, proxy=named)
read = meshio.read(path)
check_points(read.points, path)
T.check_equal({name: sum(len(block) for block in blocks) for name, blocks in read.cell_sets.items()},
              {"Left_box": per_material[2], "Right_box": per_material[5]}, "Abaqus element sets")

path = T.temp_path("boxes.feb")
SaveData(path, proxy=named)
root = ET.parse(path).getroot()
T.check_equal(root.get("version"), "4.0", "FEBio format")
parts = {part.get("name"): len(part.findall("elem")) for part in root.iter("Elements")}
T.check_equal(parts, {"Left_box": per_material[2], "Right_box": per_material[5]}, "FEBio parts")
T.check_equal(len(list(root.iter("node"))), len(points), "FEBio nodes")
T.check_equal({d.get("name"): d.get("mat") for d in root.iter("SolidDomain")},
              {"Left_box": "Left_box", "Right_box": "Right_box"}, "FEBio domains")

path = T.temp_path("boxes.exo")
SaveData(path, proxy=named)
from vtkmodules.vtkIOExodus import vtkExodusIIReader  # noqa: E402
exodus = vtkExodusIIReader()
exodus.SetFileName(path)
exodus.UpdateInformation()
blocks = {exodus.GetObjectId(exodus.ELEM_BLOCK, i): (exodus.GetObjectName(exodus.ELEM_BLOCK, i),
                                                     exodus.GetNumberOfEntriesInObject(
                                                         exodus.ELEM_BLOCK, i))
          for i in range(exodus.GetNumberOfObjects(exodus.ELEM_BLOCK))}
T.check_equal(blocks, {m: (NAMES[m], n) for m, n in per_material.items()}, "Exodus element blocks")
T.check_equal(exodus.GetNumberOfNodesInFile(), len(points), "Exodus nodes")

# A wedge (none of the pipeline's outputs has one), positive in VTK's order, whose first
# triangle the finite-element formats turn toward the second.
wedge = vtkUnstructuredGrid()
wedge_points = vtkPoints()
for x in [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, -1), (1, 0, -1), (0, 1, -1)]:
    wedge_points.InsertNextPoint(x)
wedge.SetPoints(wedge_points)
wedge.InsertNextCell(VTK_WEDGE, 6, [0, 1, 2, 3, 4, 5])
from vtkmodules.vtkFiltersVerdict import vtkCellSizeFilter  # noqa: E402
positive = vtkCellSizeFilter()
positive.SetInputData(wedge)
positive.Update()
T.check(positive.GetOutput().GetCellData().GetArray("Volume").GetValue(0) > 0, "the VTK wedge")
wedge_exo = T.temp_path("wedge.exo")
writer = spacetreemesh.stmExodusWriter()
writer.SetInputData(wedge)
writer.SetFileName(wedge_exo)
writer.Write()
exodus = vtkExodusIIReader()
exodus.SetFileName(wedge_exo)
exodus.UpdateInformation()
exodus.SetObjectStatus(exodus.ELEM_BLOCK, 0, 1)
exodus.Update()
read_wedge = exodus.GetOutput().GetBlock(0).GetBlock(0)
T.check_equal(read_wedge.GetCellType(0), VTK_WEDGE, "the Exodus wedge's type")
# Exodus orders a wedge as Gmsh does (its side 4, the first triangle reversed, faces out), VTK's
# reader takes the corners as they are: the file holds VTK's corners 0 2 1 3 5 4.
corners = read_wedge.GetCell(0).GetPointIds()
T.check_equal([read_wedge.GetPoint(corners.GetId(k)) for k in range(6)],
              [wedge.GetPoint(k) for k in (0, 2, 1, 3, 5, 4)], "the Exodus wedge's corners")
wedge_msh = T.temp_path("wedge.msh")
writer = spacetreemesh.stmGmshWriter()
writer.SetInputData(wedge)
writer.SetFileName(wedge_msh)
writer.Write()
gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
gmsh.open(wedge_msh)
element_types, element_tags, _ = gmsh.model.mesh.getElements(3)
_, determinants, _ = gmsh.model.mesh.getJacobians(int(element_types[0]), [1.0 / 3, 1.0 / 3, 0.0])
gmsh.finalize()
T.check(len(determinants) == 1 and determinants[0] > 0,
        "Gmsh finds the wedge's Jacobian %r" % list(determinants))

# VTK-style: a mesh the formats cannot hold gets an error and leaves no file.
polygons = vtkUnstructuredGrid()
corners = vtkPoints()
for x in [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0.5, 1.5, 0)]:
    corners.InsertNextPoint(x)
polygons.SetPoints(corners)
polygons.InsertNextCell(VTK_POLYGON, 5, [0, 1, 2, 4, 3])
for name in ("stmGmshWriter", "stmMeditWriter", "stmAbaqusWriter", "stmFEBioWriter",
             "stmExodusWriter"):
    writer = getattr(spacetreemesh, name)()
    observer = T.ErrorCollector(writer)
    path = T.temp_path("polygons_" + name)
    writer.SetFileName(path)
    writer.SetInputData(polygons)
    writer.Write()
    T.check(observer.errors and "VTK cell type 7" in observer.errors[-1],
            "%s: errors %r" % (name, observer.errors))
    T.check(not os.path.exists(path) and not [f for f in os.listdir(os.path.dirname(path))
                                              if f.startswith("polygons_" + name)],
            "%s left a file behind" % name)
# The threaded XML writers from Python: the bytes of VTK's own writers.
from vtkmodules.vtkIOXML import vtkXMLPolyDataWriter, vtkXMLUnstructuredGridWriter  # noqa: E402


def xml_bytes(writer_class, data):
    writer = writer_class()
    writer.SetInputData(data)
    writer.SetWriteToOutputString(True)
    writer.SetDataModeToBinary()
    writer.SetCompressorTypeToLZ4()
    writer.SetBlockSize(256)  # several blocks even for this small mesh
    T.check_equal(writer.Write(), 1, "%s writes" % writer.GetClassName())
    return writer.GetOutputString()


T.check(xml_bytes(spacetreemesh.stmXMLUnstructuredGridWriter, named_grid) ==
        xml_bytes(vtkXMLUnstructuredGridWriter, named_grid),
        "stmXMLUnstructuredGridWriter writes what vtkXMLUnstructuredGridWriter does")
surface = vtkPolyData()
surface.SetPoints(corners)
surface.Allocate(1)
surface.InsertNextCell(VTK_POLYGON, 5, [0, 1, 2, 4, 3])
T.check(xml_bytes(spacetreemesh.stmXMLPolyDataWriter, surface) ==
        xml_bytes(vtkXMLPolyDataWriter, surface),
        "stmXMLPolyDataWriter writes what vtkXMLPolyDataWriter does")
T.check(spacetreemesh.stmXMLUnstructuredGridWriter().IsA("vtkXMLUnstructuredGridWriter"),
        "stmXMLUnstructuredGridWriter is a vtkXMLUnstructuredGridWriter")

# The visual report as a function (what stmesh --report runs): its figures count the mesh.
from spacetreemesh import report  # noqa: E402
report_directory = T.temp_path("report")
figures = report.write_report(named_grid, report_directory, title="two boxes")
T.check_equal({e["material"]: e["elements"] for e in figures["materials"]}, per_material,
              "the report's elements per material")
for name in ("index.html", "quality.json", "quality_histograms.png", "cut.png"):
    T.check(os.path.getsize(os.path.join(report_directory, name)) > 0, "the report's %s" % name)
with open(os.path.join(report_directory, "index.html")) as page:
    T.check("Left box" in page.read(), "the report's page names the materials")

print("writers: 5 formats read back by Gmsh, meshio, ElementTree and VTK's Exodus reader")
