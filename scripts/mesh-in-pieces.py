"""Meshes a label image in pieces, one per MPI rank (ImageToSpacetree's SplitIntoPieces), with the
default pipeline, and prints each rank's time, cells and peak memory; with an output path,
writes the pieces as one .pvtu (inline binary, ghost cells marked vtkGhostType).

    mpiexec -n 2 pvbatch --symmetric scripts/mesh-in-pieces.py aal.nii.gz [out.pvtu]

A .vti image is read with VTK's XML reader, a NIfTI image with the plugin's reader; both give
sub-extents, so each rank reads only its ghost box grown by one voxel (the ranks classify the
thin parts together) and prints how many voxels it read.

Run by pvbatch or pvpython with the plugin built in ./build (or STM_PLUGIN naming it). Under
pvpython there is one rank: the whole image in one piece, for comparison.
"""
import os
import resource
import sys
import time

from paraview import simple

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
plugin = os.environ.get("STM_PLUGIN") or os.path.join(
    root, "build", "lib", "paraview-5.11", "plugins", "SpacetreeMesh", "SpacetreeMesh.so")
# The package "spacetreemesh" beside the plugin (lib/python3.X/dist-packages of the build).
site = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(plugin)))),
                    "python3.%d" % sys.version_info.minor, "dist-packages")
if os.path.isdir(site):
    sys.path.insert(0, site)
simple.LoadPlugin(plugin, ns=globals())
import spacetreemesh  # noqa: E402 (the plugin's module, once loaded)
from vtkmodules.util.numpy_support import vtk_to_numpy  # noqa: E402
from vtkmodules.vtkCommonDataModel import vtkDataSetAttributes  # noqa: E402
from vtkmodules.vtkIOParallelXML import vtkXMLPUnstructuredGridWriter  # noqa: E402
from vtkmodules.vtkParallelCore import vtkMultiProcessController  # noqa: E402

if len(sys.argv) not in (2, 3):
    sys.exit(__doc__)
controller = vtkMultiProcessController.GetGlobalController()
ranks = controller.GetNumberOfProcesses() if controller else 1
rank = controller.GetLocalProcessId() if controller else 0

start = time.time()
if sys.argv[1].endswith(".vti"):
    from vtkmodules.vtkIOXML import vtkXMLImageDataReader  # noqa: E402

    reader = vtkXMLImageDataReader()
else:
    reader = spacetreemesh.stmNIFTIImageReader()
reader.SetFileName(sys.argv[1])
stages = [spacetreemesh.stmImageToSpacetree()]
stages[0].SetInputConnection(reader.GetOutputPort())
stages[0].SetSplitIntoPieces(True)
for make in (spacetreemesh.stmSpacetreeBalance, spacetreemesh.stmSpacetreeTessellate,
             spacetreemesh.stmVertexSnap, spacetreemesh.stmMarchingSimplices,
             spacetreemesh.stmBoundarySmooth):
    stages.append(make())
    stages[-1].SetInputConnection(stages[-2].GetOutputPort())
# Each stage's output is freed once the next has run, as stmesh does between its stages (the
# reader's after the voxels read are counted).
read = []
stages[0].AddObserver("StartEvent", lambda caller, event: read.append(
    reader.GetOutputDataObject(0).GetNumberOfPoints()))
reader.ReleaseDataFlagOn()
for stage in stages[:-1]:
    stage.ReleaseDataFlagOn()
if not stages[-1].UpdatePiece(rank, ranks, 0):
    sys.exit("rank %d: meshing failed" % rank)
mesh = stages[-1].GetOutput()
ghosts = mesh.GetCellData().GetArray(vtkDataSetAttributes.GhostArrayName())
owned = mesh.GetNumberOfCells() - (int((vtk_to_numpy(ghosts) != 0).sum()) if ghosts else 0)
print("rank %d of %d: %.2f s, %d voxels read, %d cells, %d of them its own, peak RSS %.0f MiB" % (
    rank, ranks, time.time() - start, read[0] if read else -1, mesh.GetNumberOfCells(), owned,
    resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0), flush=True)

if len(sys.argv) == 3:
    writer = vtkXMLPUnstructuredGridWriter()
    writer.SetInputData(mesh)
    writer.SetFileName(sys.argv[2])
    writer.SetNumberOfPieces(ranks)
    writer.SetStartPiece(rank)
    writer.SetEndPiece(rank)
    writer.SetDataModeToBinary()  # inline: Debian's expat fails on appended data
    if controller:
        writer.SetController(controller)
    if not writer.Write():
        sys.exit("rank %d: writing %s failed" % (rank, sys.argv[2]))
