"""The smoothing's steps under MPI move every point as the whole mesh's do (stmBoundarySmooth
with Split Into Pieces, every rank asking for its own piece: `mpiexec -n P pvbatch --symmetric`).
Each point is moved by the piece that owns the root cell of its block, and the pieces exchange
the roles, the Taubin targets and, after every colour of root cells, the positions of the points
they share. With the parts that are not exchanged yet turned off (the volume restoration, the
quality improvement, the small parts and the edge splits) the owned cells of the P pieces are
the serial mesh's cells bit for bit: 3D nested ellipsoids with a one-voxel layer to
MultiMaterialCut, and a 2D image to MarchingSimplices. With every part on, the pieces still
conform: as many cells as the serial mesh.
"""
import os

import numpy as np

import spacetreemesh
import stmtesting as T
from vtkmodules.vtkCommonExecutionModel import vtkTrivialProducer
from vtkmodules.vtkParallelCore import vtkMultiProcessController

controller = vtkMultiProcessController.GetGlobalController()
rank, ranks = controller.GetLocalProcessId(), controller.GetNumberOfProcesses()
T.check(ranks > 1, "run under mpiexec with several ranks, not %d" % ranks)
temp = os.environ.get("STM_TEMP_DIR", ".")


def chain(image, cut, exchanged_only):
    producer = vtkTrivialProducer()
    producer.SetOutput(image)
    tree, balance, tessellate = T.spacetree_chain(producer)
    tree.SetSplitIntoPieces(True)
    stages = [producer, tree, balance, tessellate]
    if cut == "materials":
        tree.SetThinPartRefinement(spacetreemesh.stmImageToSpacetree.THIN_MATERIAL_PARTS)
        T.append_stages(stages, spacetreemesh.stmMultiMaterialCut)
    else:
        T.append_stages(stages, spacetreemesh.stmVertexSnap, spacetreemesh.stmMarchingSimplices)
    smooth = T.append_stages(stages, spacetreemesh.stmBoundarySmooth)
    smooth.SetSplitInteriorEdges(False)
    if exchanged_only:
        smooth.SetNumberOfImprovementSweeps(0)
        smooth.SetSmallPartPoints(0)
        smooth.SetRestoreOriginalVolumes(False)
    return stages


def check(labels, nodes, cut, exchanged_only, what):
    image = T.make_image(labels)
    stages = chain(image, cut, exchanged_only)
    errors = [T.ErrorCollector(stage) for stage in stages[1:]]
    T.check(stages[-1].UpdatePiece(rank, ranks, 0) == 1, "%s: rank %d failed" % (what, rank))
    T.check(not any(e.errors for e in errors), "%s: rank %d: %r" % (
        what, rank, [e.errors for e in errors]))
    own = T.owned_cell_rows(stages[-1].GetOutput(), nodes)
    T.check(len(own) > 0, "%s: rank %d owns no cell" % (what, rank))
    path = os.path.join(temp, "exact_%d_%d.npy" % (ranks, rank))
    np.save(path, own)
    controller.Barrier()
    if rank == 0:
        serial = chain(image, cut, exchanged_only)
        serial[-1].Update()
        expected = T.owned_cell_rows(serial[-1].GetOutput(), nodes)
        together = np.concatenate([np.load(os.path.join(temp, "exact_%d_%d.npy" % (ranks, r)))
                                   for r in range(ranks)])
        together = together[np.lexsort(together.T[::-1])]
        T.check(together.shape == expected.shape, "%s, %d ranks: %d owned cells, serial %d" % (
            what, ranks, len(together), len(expected)))
        if exchanged_only:
            differing = np.count_nonzero(np.any(together != expected, axis=1))
            T.check(differing == 0, "%s, %d ranks: %d of %d cells differ from the serial mesh's"
                    % (what, ranks, differing, len(expected)))
        print("%s, %d ranks: %d cells%s" % (what, ranks, len(expected),
                                            ", the serial mesh's bit for bit" if exchanged_only
                                            else ""))
    controller.Barrier()


three_d = T.nested_ellipsoids((40, 36, 44))
check(three_d, 4, "materials", True, "3D to MultiMaterialCut, smoothed")
check(three_d, 4, "materials", False, "3D to MultiMaterialCut, smoothed with every part")
yy, xx = np.mgrid[0:70, 0:64]
two_d = ((xx - 30.5) ** 2 / 26.0 ** 2 + (yy - 36.0) ** 2 / 30.0 ** 2 < 1.0).astype(np.uint8)
two_d[(xx - 30.5) ** 2 + (yy - 30.0) ** 2 < 12.0 ** 2] = 2
check(two_d[np.newaxis], 3, "surface", True, "2D to MarchingSimplices, smoothed")
