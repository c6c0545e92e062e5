"""The SpacetreeMesh ParaView plugin through paraview.simple (run by both pvpython and pvbatch).

- LoadPlugin puts the three filters into paraview.simple; OpenDataFile picks the plugin's NIfTI
  reader for aal.nii.gz and reads 181 x 217 x 181 voxels.
- The default pipeline ImageToSpacetree -> SpacetreeBalance -> SpacetreeTessellate gives only
  tetrahedra whose Material values are exactly the non-zero AAL labels, each material's volume
  equal to its voxel count (1 mm^3 voxels).
- SaveData as an inline-binary .vtu (DataMode='Binary', not ParaView's default 'Appended') and
  reading it back: under pvpython the mesh comes back identical; under pvbatch the balanced
  spacetree comes back identical and tessellates to the same mesh.
- A 2D label image made in memory (PVTrivialProducer) gives a conforming triangle mesh whose
  area per label equals the pixel count exactly.
"""
import os

import numpy as np

from paraview.modules.vtkRemotingCore import vtkProcessModule
from paraview.simple import (
    Delete,
    LoadPlugin,
    OpenDataFile,
    PVTrivialProducer,
    SaveData,
)

import stmtesting as T
from vtkmodules.vtkCommonDataModel import VTK_TETRA, VTK_TRIANGLE
from vtkmodules.util.numpy_support import vtk_to_numpy

PLUGIN = T.env("STM_PLUGIN")
AAL = T.env("STM_AAL")
DRIVER = T.env("STM_DRIVER")

# pvbatch runs in batch mode, pvpython as a client with a builtin server.
BATCH = vtkProcessModule.GetProcessType() == vtkProcessModule.PROCESS_BATCH
T.check_equal(BATCH, DRIVER == "pvbatch", "batch mode under %s" % DRIVER)


def vtk_output(proxy):
    """The VTK output of a proxy (builtin session: the server is this process)."""
    proxy.UpdatePipeline()
    return proxy.GetClientSideObject().GetOutputDataObject(0)


# --- the plugin ---------------------------------------------------------------------------------
LoadPlugin(PLUGIN, ns=globals())
for function in ("ImageToSpacetree", "SpacetreeBalance", "SpacetreeTessellate"):
    T.check(callable(globals().get(function)), "LoadPlugin(ns=globals()) did not define %s"
            % function)

# --- the reader ---------------------------------------------------------------------------------
reader = OpenDataFile(AAL)
T.check(reader is not None, "OpenDataFile found no reader for %s" % AAL)
T.check_equal(reader.GetXMLName(), "stmNIFTIReader", "reader chosen by OpenDataFile")
T.check_equal(reader.GetXMLGroup(), "sources", "reader proxy group")
reader.UpdatePipeline()
info = reader.GetDataInformation()
T.check_equal(info.GetDataSetTypeAsString(), "vtkImageData", "reader output type")
T.check_equal(tuple(info.GetExtent()), (0, 180, 0, 216, 0, 180), "reader extent")
image = vtk_output(reader)
T.check_equal(image.GetDimensions(), (181, 217, 181), "image dimensions")
T.check_equal(image.GetSpacing(), (1.0, 1.0, 1.0), "image spacing")
labels = T.image_labels(image)
T.check_equal(len(labels), 181 * 217 * 181, "number of voxels")
counts = T.voxel_counts(labels, background=0)
body = sorted(counts)
# The AAL atlas: labels 1 to 116 around background 0.
T.check_equal((len(body), body[0], body[-1]), (116, 1, 116), "AAL labels (count, first, last)")
voxel_volume = float(np.prod(image.GetSpacing()))

# --- the default pipeline -----------------------------------------------------------------------
tree = ImageToSpacetree(Input=reader)
# The label array domain picked the reader's scalars (needs the reader updated first).
T.check_equal(list(tree.LabelArray), ["POINTS", image.GetPointData().GetScalars().GetName()],
              "default LabelArray")
balance = SpacetreeBalance(Input=tree)
mesh = SpacetreeTessellate(Input=balance, SeparatingFunction="No Function")
mesh.UpdatePipeline()

tree_data = vtk_output(tree)
balanced_data = vtk_output(balance)
T.check(T.is_hexahedral_spacetree(tree_data), "ImageToSpacetree output is not all hexahedra")
T.check(T.is_hexahedral_spacetree(balanced_data), "SpacetreeBalance output is not all hexahedra")
T.check(balanced_data.GetNumberOfCells() >= tree_data.GetNumberOfCells(),
        "balancing removed leaves: %d -> %d"
        % (tree_data.GetNumberOfCells(), balanced_data.GetNumberOfCells()))
for name in ("Level", "Material", "LatticeIndex"):
    T.cell_array(tree_data, name)
T.check(tree_data.GetFieldData().GetArray("SpacetreeDimension") is not None,
        "the spacetree lacks its field data")

mesh_info = mesh.GetDataInformation()
T.check_equal(mesh_info.GetDataSetTypeAsString(), "vtkUnstructuredGrid", "mesh type (proxy)")
mesh_data = vtk_output(mesh)
T.check_equal(mesh_data.GetClassName(), "vtkUnstructuredGrid", "mesh class")
cells = mesh_data.GetNumberOfCells()
T.check(cells > 0, "the mesh is empty")
T.check_equal(mesh_info.GetNumberOfCells(), cells, "cell count (data information vs data)")
types = T.cell_types(mesh_data)
T.check(bool(np.all(types == VTK_TETRA)),
        "the mesh holds cell types other than tetrahedra: %s" % sorted(set(types.tolist())))

material = T.cell_array(mesh_data, "Material")
T.check_equal(mesh.CellData["Material"].GetRange(), (float(body[0]), float(body[-1])),
              "Material range (proxy data information)")
T.check_equal((int(material.min()), int(material.max())), (body[0], body[-1]), "Material range")
T.check_equal(T.distinct(material), body, "set of Material values")
T.check_measures(mesh_data, counts, voxel_volume, 1e-6, "AAL volume per material")

# --- save as inline binary .vtu and read back ---------------------------------------------------
# DataMode="Binary" (the XML writer proxy's DataMode: Ascii, Binary, Appended) writes the arrays
# base64-encoded inside their DataArray elements. ParaView's default, Appended, puts raw bytes
# after the XML, which some expat versions (Debian 12 security updates) refuse on reading.
# To stay within the time budget, pvpython saves the mesh (LZ4-compressed, 4.6 M tetrahedra) and
# --- Interface Surface on the staircase of all 116 labels: the area of every pair's facets is
# the number of voxel faces between the two labels (the outside, -1: background and image border).
interfaces = InterfaceSurface(Input=mesh)
interface_data = vtk_output(interfaces)
T.check_equal(interface_data.GetClassName(), "vtkPolyData", "Interface Surface output class")
pair_labels = vtk_to_numpy(interface_data.GetCellData().GetArray("BoundaryLabels"))
polys = interface_data.GetPolys()
triangles = vtk_to_numpy(polys.GetConnectivityArray()).reshape(-1, 3)
corners = T.points(interface_data)[triangles]
areas = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]),
                             axis=1)
measured = {}
for (first, second), area in zip(map(tuple, pair_labels.tolist()), areas):
    measured[(first, second)] = measured.get((first, second), 0.0) + area
volume_labels = labels.reshape(image.GetDimensions()[::-1]).astype(np.int64)
padded = np.pad(volume_labels, 1)  # the image border counts as background
expected = {}
for axis in range(3):
    low = np.moveaxis(padded, axis, 0)[:-1].ravel()
    high = np.moveaxis(padded, axis, 0)[1:].ravel()
    differ = low != high
    low, high = low[differ], high[differ]
    first = np.where((low == 0) | (high == 0), np.maximum(low, high), np.minimum(low, high))
    second = np.where((low == 0) | (high == 0), -1, np.maximum(low, high))
    keys, face_counts = np.unique(np.stack([first, second], axis=1), axis=0, return_counts=True)
    for key, count in zip(map(tuple, keys.tolist()), face_counts.tolist()):
        expected[key] = expected.get(key, 0) + count * voxel_volume ** (2.0 / 3.0)
T.check_equal(sorted(measured), sorted(expected), "material pairs of Interface Surface")
worst_pair = max(expected, key=lambda key: abs(measured.get(key, 0.0) - expected[key]))
T.check(abs(measured.get(worst_pair, 0.0) - expected[worst_pair]) <= 1e-6 * expected[worst_pair],
        "Interface Surface: pair %r measures %r, its voxel faces %r"
        % (worst_pair, measured.get(worst_pair), expected[worst_pair]))
Delete(interfaces)
del interface_data, pair_labels, triangles, corners, areas

# pvbatch saves the balanced spacetree, read back and tessellated again.


def check_inline_binary(path):
    with open(path, "rb") as stream:
        content = stream.read()
    T.check(len(content) > 0, "SaveData wrote nothing to %s" % path)
    T.check(b"<AppendedData" not in content, "%s is in appended mode" % path)
    T.check(b'format="appended"' not in content, "%s has appended arrays" % path)
    T.check(b'format="binary"' in content, "%s has no inline binary arrays" % path)


if not BATCH:
    vtu = T.temp_path("aal_mesh.vtu")
    if os.path.exists(vtu):
        os.remove(vtu)
    SaveData(vtu, proxy=mesh, DataMode="Binary", CompressorType="LZ4")
    check_inline_binary(vtu)
    copy = OpenDataFile(vtu)
    T.check(copy is not None, "OpenDataFile found no reader for %s" % vtu)
    T.check_equal(copy.GetXMLName(), "XMLUnstructuredGridReader", "reader of the .vtu")
    copy_data = vtk_output(copy)
    T.check_equal(copy_data.GetNumberOfCells(), cells, "cells read back")
    T.check_equal(copy_data.GetNumberOfPoints(), mesh_data.GetNumberOfPoints(), "points read back")
    T.check(bool(np.all(T.cell_types(copy_data) == VTK_TETRA)), "cell types read back differ")
    T.check(bool(np.array_equal(T.cell_array(copy_data, "Material"), material)),
            "Material values read back differ")
    T.check(bool(np.array_equal(T.points(copy_data), T.points(mesh_data))),
            "points read back differ")
    T.check(bool(np.array_equal(T.connectivity(copy_data, 4), T.connectivity(mesh_data, 4))),
            "connectivity read back differs")
    Delete(copy)
    del copy_data
    os.remove(vtu)
else:
    # A spacetree saved and read back rebuilds the same tree: its tessellation is the same mesh.
    tree_vtu = T.temp_path("aal_spacetree.vtu")
    if os.path.exists(tree_vtu):
        os.remove(tree_vtu)
    SaveData(tree_vtu, proxy=balance, DataMode="Binary")
    check_inline_binary(tree_vtu)
    saved_tree = OpenDataFile(tree_vtu)
    T.check(saved_tree is not None, "OpenDataFile found no reader for %s" % tree_vtu)
    T.check_equal(saved_tree.GetXMLName(), "XMLUnstructuredGridReader", "reader of the spacetree")
    saved_tree_data = vtk_output(saved_tree)
    T.check_equal(saved_tree_data.GetNumberOfCells(), balanced_data.GetNumberOfCells(),
                  "leaves read back")
    T.check_equal(saved_tree_data.GetNumberOfPoints(), balanced_data.GetNumberOfPoints(),
                  "spacetree points read back")
    for name in ("Level", "Material", "LatticeIndex"):
        T.check(bool(np.array_equal(T.cell_array(saved_tree_data, name),
                                    T.cell_array(balanced_data, name))),
                "spacetree cell array %s read back differs" % name)
    mesh_of_saved = SpacetreeTessellate(Input=saved_tree, SeparatingFunction="No Function")
    mesh_of_saved_data = vtk_output(mesh_of_saved)
    T.check_equal(mesh_of_saved_data.GetNumberOfCells(), cells,
                  "cells of the saved spacetree's mesh")
    T.check(bool(np.array_equal(T.cell_array(mesh_of_saved_data, "Material"), material)),
            "the saved spacetree's mesh has other Material values")
    T.check(bool(np.array_equal(T.connectivity(mesh_of_saved_data, 4),
                                T.connectivity(mesh_data, 4))),
            "the saved spacetree's mesh has another connectivity")
    Delete(mesh_of_saved)
    Delete(saved_tree)
    del saved_tree_data, mesh_of_saved_data
    os.remove(tree_vtu)
del mesh_data, tree_data, balanced_data
for proxy in (mesh, balance, tree, reader):
    Delete(proxy)

# --- 2D: a disc and a square in a 64 x 48 image --------------------------------------------------
DISC, SQUARE = 3, 7
y, x = np.mgrid[0:48, 0:64]
pixels = np.zeros((1, 48, 64), dtype=np.int16)
pixels[0][(x - 20) ** 2 + (y - 24) ** 2 <= 12 ** 2] = DISC
pixels[0][(x >= 40) & (x <= 55) & (y >= 10) & (y <= 30)] = SQUARE
image2d = T.make_image(pixels, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0), name="labels2d")
counts2d = T.voxel_counts(pixels.ravel())
T.check_equal(sorted(counts2d), [DISC, SQUARE], "2D labels")

producer = PVTrivialProducer()
producer.GetClientSideObject().SetOutput(image2d)
producer.UpdatePipeline()
T.check_equal(tuple(producer.GetDataInformation().GetExtent()), (0, 63, 0, 47, 0, 0), "2D extent")
tree2d = ImageToSpacetree(Input=producer)
mesh2d = SpacetreeTessellate(Input=SpacetreeBalance(Input=tree2d),
                             SeparatingFunction="No Function")
mesh2d_data = vtk_output(mesh2d)
T.check(T.is_hexahedral_spacetree(vtk_output(tree2d), dimension=2),
        "2D spacetree is not all quads")
types2d = T.cell_types(mesh2d_data)
T.check(len(types2d) > 0 and bool(np.all(types2d == VTK_TRIANGLE)),
        "the 2D mesh is not all triangles: %s" % sorted(set(types2d.tolist())))
T.check_equal(float(np.abs(T.points(mesh2d_data)[:, 2]).max()), 0.0, "2D mesh z coordinates")
jj, ii = np.nonzero(pixels[0])
T.check_equal(mesh2d_data.GetBounds(),
              (ii.min() - 0.5, ii.max() + 0.5, jj.min() - 0.5, jj.max() + 0.5, 0.0, 0.0),
              "2D mesh bounds")
xyz2d = T.points(mesh2d_data)
material2d = T.cell_array(mesh2d_data, "Material")
# Pixel (i, j) covers [i - 0.5, i + 0.5] x [j - 0.5, j + 0.5]: the mesh spans the labelled pixels.
for label in (DISC, SQUARE):
    jj, ii = np.nonzero(pixels[0] == label)
    conn = T.connectivity(mesh2d_data, 3)[material2d == label]
    used = xyz2d[np.unique(conn)]
    T.check_equal((used[:, 0].min(), used[:, 0].max(), used[:, 1].min(), used[:, 1].max()),
                  (ii.min() - 0.5, ii.max() + 0.5, jj.min() - 0.5, jj.max() + 0.5),
                  "2D bounds of label %d" % label)
T.check_measures(mesh2d_data, counts2d, 1.0, 0.0, "2D area per label", exact=True)
perimeter, most = T.boundary_measure(mesh2d_data)
T.check_equal(perimeter, T.voxel_boundary_measure(pixels > 0, (1.0, 1.0, 1.0)),
              "2D boundary length (conformity)")
T.check(most <= 2, "2D: an edge is shared by %d triangles" % most)
vtk_areas = T.per_material(T.vtk_measures(mesh2d_data), material2d)
for label, count in counts2d.items():
    T.check_close(vtk_areas[label], float(count), 1e-12, "2D vtkCellSizeFilter area of label %d" % label)

# --- the cut (README): default function, surface, and the analytic ball with the sphere widget --
tessellated = SpacetreeTessellate(Input=balance)
cut = MarchingSimplices(Input=tessellated)
cut.UpdatePipeline()
cut_data = vtk_output(cut)
T.check_equal(cut_data.GetClassName(), "vtkUnstructuredGrid", "cut mesh class")
T.check(bool(np.all(T.cell_types(cut_data) == VTK_TETRA)), "the cut mesh has non-tetrahedra")
T.check_equal(sorted(set(T.cell_array(cut_data, "Material").tolist())), [0, 1], "cut materials")
T.check_equal(len(set(T.cell_array(cut_data, "OriginalMaterial").tolist())), 117,
              "original materials (116 labels and the background layer)")
surface = MarchingSimplices(Input=tessellated, OutputMode="Surface")
surface.UpdatePipeline()
T.check_equal(surface.GetDataInformation().GetDataSetTypeAsString(), "vtkPolyData",
              "surface type (proxy)")
T.check(surface.GetDataInformation().GetNumberOfCells() > 100000, "the surface is nearly empty")
ball = SeparatingFunction(Input=tessellated, ImplicitFunction="Sphere")
ball.ImplicitFunction.Center = [90, 108, 90]
ball.ImplicitFunction.Radius = 40
inside_ball = MarchingSimplices(Input=ball, KeepSide="Inside")
inside_ball.UpdatePipeline()
bounds = inside_ball.GetDataInformation().GetBounds()
T.check(inside_ball.GetDataInformation().GetNumberOfCells() > 0, "nothing inside the ball")
for axis, centre in enumerate((90, 108, 90)):
    T.check(centre - 40 - 1e-9 <= bounds[2 * axis] and bounds[2 * axis + 1] <= centre + 40 + 1e-9,
            "the inside of the ball leaves the sphere along axis %d: %r" % (axis, bounds))
# Boundary Smooth on the inside of the ball (all one material: its whole boundary is the
# surface), projected back onto the sphere: the same cells and points, with those of split
# interior edges appended (SplitInteriorEdges: each split adds one point and the three or more
# cells around its edge once more), moved points on the sphere.
smooth_ball = BoundarySmooth(Input=inside_ball, ProjectToFunction=1, ImplicitFunction="Sphere")
smooth_ball.ImplicitFunction.Center = [90, 108, 90]
smooth_ball.ImplicitFunction.Radius = 40
smoothed = vtk_output(smooth_ball)
inside_data = vtk_output(inside_ball)
added_points = smoothed.GetNumberOfPoints() - inside_data.GetNumberOfPoints()
added_cells = smoothed.GetNumberOfCells() - inside_data.GetNumberOfCells()
T.check(added_points >= 0 and 3 * added_points <= added_cells <= 30 * added_points,
        "smoothing added %d points and %d cells" % (added_points, added_cells))
T.check_equal(T.cell_array(smoothed, "Material")[:inside_data.GetNumberOfCells()].tolist(),
              T.cell_array(inside_data, "Material").tolist(), "smoothed cells' materials")
displacements = vtk_to_numpy(smoothed.GetPointData().GetArray("SmoothingDisplacement"))
moved_points = int(np.count_nonzero(np.any(displacements != 0, axis=1)))
T.check(moved_points > 1000, "Boundary Smooth moved only %d points" % moved_points)
smoothed_points = T.points(smoothed)
radii = np.linalg.norm(smoothed_points - np.array([90.0, 108.0, 90.0]), axis=1)
T.check(float(radii.max()) <= 40 + 1e-6, "a smoothed point leaves the sphere: %r" % radii.max())
# Each added point m splits an edge (a, b) and takes the mean of their point data. An end may be a
# point an earlier split added: its data was read from beyond the input's arrays (garbage such
# as 2e-310 for 20 to 49 of the 1,164 points here, from run to run). a and b are neighbours of
# m, or, when a later split cut the edge between m and one of them, neighbours of that later
# point.
separating = vtk_to_numpy(smoothed.GetPointData().GetArray("SeparatingFunction"))
first_added = inside_data.GetNumberOfPoints()
split_cells = T.connectivity(smoothed, 4)
split_cells = split_cells[np.any(split_cells >= first_added, axis=1)]


def neighbours_of(point):
    return np.setdiff1d(split_cells[np.any(split_cells == point, axis=1)], [point])


not_midpoints = []
for added in range(first_added, smoothed.GetNumberOfPoints()):
    near = neighbours_of(added)
    ends = np.union1d(near, np.concatenate([neighbours_of(p) for p in near if p >= first_added]
                                           + [near]))
    first, second = np.triu_indices(len(ends), 1)
    means = (separating[ends[first]] + separating[ends[second]]) / 2
    if not np.any(means == separating[added]):
        not_midpoints.append(added)
T.check_equal(not_midpoints, [], "added points whose SeparatingFunction is no mean of two ends")

# --- vertex snapping before the cut: fewer tetrahedra, the same two materials ------------------
snapped = VertexSnap(Input=tessellated)
snapped_cut = MarchingSimplices(Input=snapped)
snapped_data = vtk_output(snapped_cut)
snap_data = vtk_output(snapped)
T.check(snap_data.GetPointData().GetArray("Snapped") is not None, "no Snapped point array")
moved = int(vtk_to_numpy(snap_data.GetPointData().GetArray("Snapped")).sum())
T.check(moved > 0, "VertexSnap moved no point")
T.check(bool(np.all(T.cell_types(snapped_data) == VTK_TETRA)), "the snapped cut has non-tetrahedra")
T.check(0 < snapped_data.GetNumberOfCells() < cut_data.GetNumberOfCells(),
        "snapping gives %d tetrahedra, the cut alone %d"
        % (snapped_data.GetNumberOfCells(), cut_data.GetNumberOfCells()))
T.check_equal(sorted(set(T.cell_array(snapped_data, "Material").tolist())), [0, 1],
              "materials after snapping")

print("%s: plugin test passed (%d tetrahedra, %d triangles)"
      % (DRIVER, cells, mesh2d_data.GetNumberOfCells()))
