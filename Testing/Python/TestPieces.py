"""Requests for pieces (pvbatch and pvserver under MPI): piece 0 meshes the whole image and the
other pieces are empty, so the union over the ranks is the serial mesh, with no seam.

Regression: under `mpiexec -n 2 pvbatch`, an image reader that can split its extent (.vti) gave
each rank a slab, and each rank meshed its slab on its own: 3,663,747 + 3,131,184 tetrahedra of
the AAL atlas with a doubled boundary where the slabs met, instead of the serial 6,635,905. A
reader that cannot split (NIfTI) gave rank 1 an empty image, and every stage there printed an
error.

Run twice: by pvpython, where the filters are asked for pieces with UpdatePiece, and by
`mpiexec -n 2 pvbatch --symmetric`, where every rank runs this script on its own piece.
"""
import os

import numpy as np

import stmtesting as T
from paraview import simple
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOImage import vtkNIFTIImageWriter
from vtkmodules.vtkIOXML import vtkXMLImageDataReader, vtkXMLImageDataWriter
from vtkmodules.vtkParallelCore import vtkMultiProcessController

simple.LoadPlugin(T.env("STM_PLUGIN"), ns=globals())
import spacetreemesh  # noqa: E402 (after the plugin, like the other tests)

controller = vtkMultiProcessController.GetGlobalController()
ranks = controller.GetNumberOfProcesses() if controller else 1
rank = controller.GetLocalProcessId() if controller else 0
T.exit_all_ranks_on_failure(ranks)
folder = T.env("STM_TEMP_DIR")
labels_vti = os.path.join(folder, "labels.vti")
labels_nii = os.path.join(folder, "labels.nii")
gray_vti = os.path.join(folder, "gray.vti")
slice_vti = os.path.join(folder, "slice.vti")

# Nested ellipsoids, 46 x 40 x 34 voxels: labels 1 and 2, and a gray image of the outer one.
z, y, x = np.mgrid[0:34, 0:40, 0:46].astype(float)
r = ((x - 22.5) / 17.0) ** 2 + ((y - 19.5) / 14.0) ** 2 + ((z - 16.5) / 12.0) ** 2
labels = np.where(r < 0.35, 2, np.where(r < 1.0, 1, 0)).astype(np.uint8)
if rank == 0:
    for path, image in ((labels_vti, T.make_image(labels)),
                        (gray_vti, T.make_image((1.0 - r).astype(np.float32), name="gray"))):
        writer = vtkXMLImageDataWriter()
        writer.SetInputData(image)
        writer.SetDataModeToBinary()  # inline: Debian's expat fails on appended data
        writer.SetFileName(path)
        T.check(writer.Write() == 1, "writing " + path)
    nifti = vtkNIFTIImageWriter()
    nifti.SetInputData(T.make_image(labels))
    nifti.SetFileName(labels_nii)
    nifti.Write()
    slice_writer = vtkXMLImageDataWriter()
    slice_writer.SetInputData(T.make_image(labels[17:18]))  # the middle slice, 2D
    slice_writer.SetDataModeToBinary()
    slice_writer.SetFileName(slice_vti)
    T.check(slice_writer.Write() == 1, "writing " + slice_vti)
if controller and ranks > 1:
    controller.Barrier()


def read(path):
    reader = vtkXMLImageDataReader()
    reader.SetFileName(path)
    return reader


def serial_chain(source, gray=None):
    """The stages as VTK objects on the whole image, asked for no piece: the reference."""
    stages = list(T.spacetree_chain(source))
    if gray is not None:
        stages.append(T.gray_separating_function(stages[-1], gray.GetOutputPort(), 0.0))
    T.append_stages(stages, spacetreemesh.stmVertexSnap, spacetreemesh.stmMarchingSimplices,
                    spacetreemesh.stmBoundarySmooth)
    return stages


def check_same_mesh(mesh, reference, what):
    T.check_equal(mesh.GetNumberOfCells(), reference.GetNumberOfCells(), what + ": cells")
    T.check(np.array_equal(vtk_to_numpy(mesh.GetPoints().GetData()),
                           vtk_to_numpy(reference.GetPoints().GetData())),
            what + ": the points differ from the serial mesh's")
    T.check(np.array_equal(T.cell_array(mesh, "Material"), T.cell_array(reference, "Material")),
            what + ": the materials differ from the serial mesh's")


references = {}
for name, gray in (("labels", None), ("gray", gray_vti)):
    stages = serial_chain(read(labels_vti), read(gray) if gray else None)
    stages[-1].Update()
    references[name] = stages[-1].GetOutput()
    T.check(references[name].GetNumberOfCells() > 1000, "the serial %s mesh" % name)
    references[name + " cut"] = stages[-2].GetOutput()  # MarchingSimplices'

if ranks == 1:
    # VTK-style: every stage asked for piece 1 of 2 gives an empty output without an error; the
    # same stages asked for piece 0 of 2 give the serial mesh.
    for name, gray in (("labels", None), ("gray", gray_vti)):
        stages = serial_chain(read(labels_vti), read(gray) if gray else None)
        collectors = [T.ErrorCollector(stage) for stage in stages]
        for piece in (1, 0):
            stages[-1].UpdatePiece(piece, 2, 0)
            for stage, collector in zip(stages, collectors):
                T.check(not collector.errors, "%s, piece %d of 2: %s: %r" % (
                    name, piece, stage.GetClassName(), collector.errors))
                if piece == 1:
                    T.check_equal(stage.GetOutputDataObject(0).GetNumberOfCells(), 0,
                                  "%s, piece 1 of 2: %s's cells" % (name, stage.GetClassName()))
        check_same_mesh(stages[-1].GetOutput(), references[name], name + ", piece 0 of 2")
    # A later piece that has cells is a mesh distributed by other means: refused, clearly.
    snap = spacetreemesh.stmVertexSnap()
    snap.SetInputData(references["labels"])
    collector = T.ErrorCollector(snap)
    snap.UpdatePiece(1, 2, 0)
    T.check(any("piece by piece only from ImageToSpacetree" in e for e in collector.errors),
            "a later piece with cells: %r" % collector.errors)
    T.check_equal(snap.GetOutput().GetNumberOfCells(), 0, "the refused piece's cells")
else:
    def update_without_errors(stages, what):
        """Updates the proxies' pipeline; their VTK objects, which must report no error."""
        objects = [stage.GetClientSideObject() for stage in stages]
        collectors = [T.ErrorCollector(obj) for obj in objects]
        stages[-1].UpdatePipeline()
        for obj, collector in zip(objects, collectors):
            T.check(not collector.errors, "rank %d, %s: %s: %r" % (
                rank, what, obj.GetClassName(), collector.errors))
        return objects

    # Under MPI: the readers that split (.vti) and those that cannot (NIfTI), and a gray image
    # read in pieces as the separating function's second input.
    chains = {
        "vti": (simple.XMLImageDataReader(FileName=[labels_vti]), None, "labels"),
        "nifti": (NIfTIReaderSpacetreeMesh(FileName=labels_nii), None, "labels"),  # noqa: F821
        "gray": (simple.XMLImageDataReader(FileName=[labels_vti]),
                 simple.XMLImageDataReader(FileName=[gray_vti]), "gray"),
    }
    for name, (source, gray, reference) in chains.items():
        stages = [ImageToSpacetree(Input=source)]  # noqa: F821
        stages.append(SpacetreeBalance(Input=stages[-1]))  # noqa: F821
        stages.append(SpacetreeTessellate(Input=stages[-1]))  # noqa: F821
        if gray is not None:
            stages.append(SeparatingFunction(Input=stages[-1], GrayImage=gray,  # noqa: F821
                                             Mode="Gray Image", Threshold=0.0))
        stages.append(VertexSnap(Input=stages[-1]))  # noqa: F821
        stages.append(MarchingSimplices(Input=stages[-1]))  # noqa: F821
        stages.append(BoundarySmooth(Input=stages[-1]))  # noqa: F821
        objects = update_without_errors(stages, name)
        mesh = objects[-1].GetOutputDataObject(0)
        if rank == 0:
            check_same_mesh(mesh, references[reference], "%s, rank 0 of %d" % (name, ranks))
        else:
            T.check_equal(mesh.GetNumberOfCells(), 0, "%s, rank %d's cells" % (name, rank))
        # The union over the ranks is the serial mesh, no more.
        from vtkmodules.vtkCommonCore import vtkIdTypeArray
        local, total = vtkIdTypeArray(), vtkIdTypeArray()
        local.InsertNextValue(mesh.GetNumberOfCells())
        controller.AllReduce(local, total, 2)  # vtkCommunicator.SUM_OP
        T.check_equal(total.GetValue(0), references[reference].GetNumberOfCells(),
                      "%s: cells over the %d ranks" % (name, ranks))
    # Split Into Pieces: every rank meshes its own root cells and a ghost layer; the cells the
    # ranks own are the serial mesh's (TestSplitPieces.py compares them point for point), and
    # smoothing keeps them (it holds the ghost cells' points).
    from vtkmodules.vtkCommonCore import vtkDoubleArray, vtkIdTypeArray
    from vtkmodules.vtkCommonDataModel import vtkDataSetAttributes

    def check_ghost_copies(cut, smoothed, what):
        """After the smoothing's pass over the shared points (stmPieceBorder.h) every point of
        a rank's ghost cells is where the rank that owns a cell at it put it, bit for bit:
        each point is named by its position in the cut (the smoothing's input, whose points
        come first in its output)."""
        count = cut.GetNumberOfPoints()
        before = vtk_to_numpy(cut.GetPoints().GetData()).astype(np.float64)
        after = vtk_to_numpy(smoothed.GetPoints().GetData()).astype(np.float64)
        corners = smoothed.GetCells().GetConnectivityArray()
        cells = vtk_to_numpy(corners).reshape(smoothed.GetNumberOfCells(), -1)
        ghost = vtk_to_numpy(
            smoothed.GetCellData().GetArray(vtkDataSetAttributes.GhostArrayName())) != 0
        own = np.unique(cells[~ghost])
        own = own[own < count]
        copies = np.setdiff1d(np.unique(cells[ghost]), own)
        send, received = vtkDoubleArray(), vtkDoubleArray()
        for value in np.hstack([before[own], after[own]]).ravel():
            send.InsertNextValue(value)
        controller.AllGatherV(send, received)
        rows = vtk_to_numpy(received).reshape(-1, 6)
        owners = {tuple(row[:3]): tuple(row[3:]) for row in rows}
        T.check(len(copies) > 0, "%s: rank %d has no ghost points" % (what, rank))
        stale = sum(1 for p in copies if owners.get(tuple(before[p])) != tuple(after[p]))
        T.check_equal(stale, 0, "%s: rank %d's ghost points unlike their owners' (of %d)" % (
            what, rank, len(copies)))

    # The 2D slice: the ghost copies only (the serial references above are 3D).
    stages = [ImageToSpacetree(Input=simple.XMLImageDataReader(  # noqa: F821
        FileName=[slice_vti]), SplitIntoPieces=1)]
    for make in (SpacetreeBalance, SpacetreeTessellate, VertexSnap,  # noqa: F821
                 MarchingSimplices, BoundarySmooth):  # noqa: F821
        stages.append(make(Input=stages[-1]))
    objects = update_without_errors(stages, "split 2D slice")
    check_ghost_copies(objects[-2].GetOutputDataObject(0), objects[-1].GetOutputDataObject(0),
                       "split 2D slice")
    for name, source in (("vti", simple.XMLImageDataReader(FileName=[labels_vti])),
                         ("nifti", NIfTIReaderSpacetreeMesh(FileName=labels_nii))):  # noqa: F821
        stages = [ImageToSpacetree(Input=source, SplitIntoPieces=1)]  # noqa: F821
        for make in (SpacetreeBalance, SpacetreeTessellate, VertexSnap,  # noqa: F821
                     MarchingSimplices, BoundarySmooth):  # noqa: F821
            stages.append(make(Input=stages[-1]))
        objects = update_without_errors(stages, "split " + name)
        check_ghost_copies(objects[-2].GetOutputDataObject(0),
                           objects[-1].GetOutputDataObject(0), "split " + name)
        for index, what in ((-2, "cut"), (-1, "smoothed")):
            mesh = objects[index].GetOutputDataObject(0)
            ghosts = vtk_to_numpy(
                mesh.GetCellData().GetArray(vtkDataSetAttributes.GhostArrayName()))
            owned = int((ghosts == 0).sum())
            T.check(0 < owned < mesh.GetNumberOfCells(),
                    "rank %d, split %s, %s: %d owned of %d cells" % (
                        rank, name, what, owned, mesh.GetNumberOfCells()))
            local, total = vtkIdTypeArray(), vtkIdTypeArray()
            local.InsertNextValue(owned)
            controller.AllReduce(local, total, 2)  # vtkCommunicator.SUM_OP
            T.check_equal(total.GetValue(0), references["labels cut"].GetNumberOfCells(),
                          "split %s, %s: owned cells over the %d ranks" % (name, what, ranks))
print("rank %d of %d: pieces ok" % (rank, ranks))
