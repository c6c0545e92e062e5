"""The smoothing under MPI moves every point as the whole mesh's does (stmBoundarySmooth with
Split Into Pieces, every rank asking for its own piece: `mpiexec -n P pvbatch --symmetric`).
Each point is moved by the piece that owns the root cell of its block, and the pieces exchange
the roles, the Taubin targets and, after every colour of root cells, the positions of the points
they share; the volume restoration sums the volumes and its weights exactly over all pieces, and
the quality improvement moves its candidates in root blocks, the small parts are joined across
pieces, and the edge splits are made on the union of the cells around all pieces' bad cells.
With every part on, the owned cells of the P pieces are the serial mesh's cells bit for bit: 3D
nested ellipsoids with a one-voxel layer to MultiMaterialCut (volume targets from its
OriginalMaterialVolumes, and from the cells' OriginalMaterial with bounds tight enough that the
improvement moves points; with noise at the centre, where the serial run splits edges, to
MultiMaterialCut), a ball cut, snapped and smoothed onto an ellipsoid (vtkQuadric: the snap's
projections within each point's cells, the smoothing's with the whole mesh's mean edge), and a
2D image to MarchingSimplices. And an abort on rank 1 halfway through the exchanged smoothing,
in the exchanged snap before and during its rounds, or in MultiMaterialCut before and during
its steps' exchanged snaps, stops every rank.
"""
import os

import numpy as np

import spacetreemesh
import stmtesting as T
from vtkmodules.vtkCommonDataModel import vtkDataObject, vtkQuadric
from vtkmodules.vtkCommonExecutionModel import vtkTrivialProducer
from vtkmodules.vtkFiltersGeneral import vtkPassArrays

controller, rank, ranks, temp = T.mpi_pieces_run()


def chain(image, cut, targets="field"):
    """targets "cells": the volume targets from the cells' OriginalMaterial, and bounds tight
    enough that the quality improvement moves points."""
    producer = vtkTrivialProducer()
    producer.SetOutput(image)
    tree, balance, tessellate = T.spacetree_chain(producer)
    tree.SetSplitIntoPieces(True)
    stages = [producer, tree, balance, tessellate]
    if cut == "materials":
        tree.SetThinPartRefinement(spacetreemesh.stmImageToSpacetree.THIN_MATERIAL_PARTS)
        T.append_stages(stages, spacetreemesh.stmMultiMaterialCut)
        if targets == "cells":
            # Without the cut's field arrays the targets are the volumes per OriginalMaterial.
            remove = T.append_stages(stages, vtkPassArrays)
            remove.RemoveArraysOn()
            remove.AddArray(vtkDataObject.FIELD, "OriginalMaterialVolumes")
            remove.AddArray(vtkDataObject.FIELD, "OriginalMaterialVolumeParts")
    elif cut == "function":
        # The ellipsoid separates, the snap projects onto it and the smoothing too.
        function = T.append_stages(stages, spacetreemesh.stmSeparatingFunction)
        function.SetImplicitFunction(ELLIPSOID)
        snap = T.append_stages(stages, spacetreemesh.stmVertexSnap)
        snap.SetProjection(spacetreemesh.stmVertexSnap.FUNCTION)
        snap.SetImplicitFunction(ELLIPSOID)
        T.append_stages(stages, spacetreemesh.stmMarchingSimplices)
    else:
        T.append_stages(stages, spacetreemesh.stmVertexSnap, spacetreemesh.stmMarchingSimplices)
    smooth = T.append_stages(stages, spacetreemesh.stmBoundarySmooth)
    smooth.SetRestoreOriginalVolumes(cut == "materials")
    if cut == "function":
        smooth.SetProjectToFunction(True)
        smooth.SetImplicitFunction(ELLIPSOID)
    if targets == "cells":
        smooth.SetMaxConditionNumber(2.0)
        smooth.SetMinDihedralAngle(25.0)
    return stages


def check(labels, nodes, cut, what, targets="field", must_split=False):
    image = T.make_image(labels)
    stages = chain(image, cut, targets)
    errors = [T.ErrorCollector(stage) for stage in stages[1:]]
    T.check(stages[-1].UpdatePiece(rank, ranks, 0) == 1, "%s: rank %d failed" % (what, rank))
    # Nor a warning: the smoothing warns of points its pieces do not share (cracks).
    T.check(not any(e.errors or e.warnings for e in errors), "%s: rank %d: %r" % (
        what, rank, [e.errors + e.warnings for e in errors]))
    own = T.owned_cell_rows(stages[-1].GetOutput(), nodes)
    T.check(len(own) > 0, "%s: rank %d owns no cell" % (what, rank))
    path = os.path.join(temp, "exact_%d_%d.npy" % (ranks, rank))
    np.save(path, own)
    smooth = stages[-1]
    errors_path = os.path.join(temp, "errors_%d_%d.npy" % (ranks, rank))
    np.save(errors_path, [smooth.GetLargestVolumeErrorBefore(), smooth.GetLargestVolumeErrorAfter(),
                          smooth.GetNumberOfImprovedPoints(), smooth.GetNumberOfSplitEdges()])
    controller.Barrier()
    if rank == 0:
        serial = chain(image, cut, targets)
        serial[-1].Update()
        expected = T.owned_cell_rows(serial[-1].GetOutput(), nodes)
        together = np.concatenate([np.load(os.path.join(temp, "exact_%d_%d.npy" % (ranks, r)))
                                   for r in range(ranks)])
        together = together[np.lexsort(together.T[::-1])]
        T.check(together.shape == expected.shape, "%s, %d ranks: %d owned cells, serial %d" % (
            what, ranks, len(together), len(expected)))
        # The restoration's volumes are the whole mesh's in every piece.
        serial_errors = [serial[-1].GetLargestVolumeErrorBefore(),
                         serial[-1].GetLargestVolumeErrorAfter()]
        improved = 0
        splits = []
        for r in range(ranks):
            piece = list(np.load(os.path.join(temp, "errors_%d_%d.npy" % (ranks, r))))
            T.check(piece[:2] == serial_errors, "%s, %d ranks: rank %d's volume errors %r, "
                    "serial %r" % (what, ranks, r, piece[:2], serial_errors))
            improved += piece[2]
            splits.append(int(piece[3]))
        T.check(cut != "materials" or serial_errors[0] > serial_errors[1] > 0.0,
                "%s: the restoration did not restore: %r" % (what, serial_errors))
        # Each improved point counted by the piece that moves it.
        serial_improved = serial[-1].GetNumberOfImprovedPoints()
        T.check(improved == serial_improved, "%s, %d ranks: %d points improved, serial %d"
                % (what, ranks, improved, serial_improved))
        serial_splits = serial[-1].GetNumberOfSplitEdges()
        T.check(targets != "cells" or serial_improved > 0, "%s: nothing improved" % what)
        T.check(not must_split or serial_splits > 0, "%s: no edge split" % what)
        # A piece counts the split edges whose new point it holds: at least the serial count
        # together, more where the pieces share a split edge.
        T.check(sum(splits) >= serial_splits, "%s, %d ranks: the pieces split %r edges, serial "
                "%d" % (what, ranks, splits, serial_splits))
        print("%s: volume errors %r, %d points improved, %d edges split (the pieces: %r), "
              "%d kept" % (what, serial_errors, serial_improved, serial_splits, splits,
                           serial[-1].GetNumberOfKeptPoints()))
        differing = np.count_nonzero(np.any(together != expected, axis=1))
        T.check(differing == 0, "%s, %d ranks: %d of %d cells differ from the serial mesh's"
                % (what, ranks, differing, len(expected)))
        print("%s, %d ranks: %d cells, the serial mesh's bit for bit" % (what, ranks,
                                                                       len(expected)))
    controller.Barrier()


three_d = T.nested_ellipsoids((40, 36, 44))
check(three_d, 4, "materials", "3D to MultiMaterialCut, smoothed")
check(three_d, 4, "materials", "3D to MultiMaterialCut, smoothed to the cells' volumes and "
      "improved to tight bounds", "cells")
# Noise of labels 1 to 4 in a box of 10 voxels at the centre, where the pieces meet.
noisy = three_d.copy()
noisy[15:25, 13:23, 17:27] = np.random.RandomState(2).randint(1, 5, size=(10, 10, 10))
check(noisy, 4, "materials", "3D with noise at the centre to MultiMaterialCut, smoothed and "
      "split", must_split=True)
# An ellipsoid x^2/17^2 + y^2/14^2 + z^2/19^2 - 1 about the centre of a ball of label 1: the
# pieces project their points onto it as the serial mesh does (the snap within each point's
# cells, the smoothing with the whole mesh's mean edge).
ELLIPSOID = vtkQuadric()
ELLIPSOID.SetCoefficients(1.0 / 17 ** 2, 1.0 / 14 ** 2, 1.0 / 19 ** 2, 0, 0, 0,
                          -2 * 20.2 / 17 ** 2, -2 * 18.1 / 14 ** 2, -2 * 22.3 / 19 ** 2,
                          20.2 ** 2 / 17 ** 2 + 18.1 ** 2 / 14 ** 2 + 22.3 ** 2 / 19 ** 2 - 1)
zz, yy, xx = np.mgrid[0:44, 0:36, 0:40] + 0.5
ball = ((xx - 20) ** 2 + (yy - 18) ** 2 + (zz - 22) ** 2 < 21 ** 2).astype(np.uint8)
check(ball, 4, "function", "3D ellipsoid function, snapped and smoothed onto it")
yy, xx = np.mgrid[0:70, 0:64]
two_d = ((xx - 30.5) ** 2 / 26.0 ** 2 + (yy - 36.0) ** 2 / 30.0 ** 2 < 1.0).astype(np.uint8)
two_d[(xx - 30.5) ** 2 + (yy - 30.0) ** 2 < 12.0 ** 2] = 2
check(two_d[np.newaxis], 3, "surface", "2D to MarchingSimplices, smoothed")


def abort_on_rank_1(stages, aborted, at, what):
    """Aborts the stage `aborted` of `stages` on rank 1 at progress `at`: every rank stops at the
    same agreement, none waits for the others or reports an error, and every rank's output of
    that stage is empty."""
    stopped = []

    def abort(caller, event):
        if rank == 1 and caller.GetProgress() >= at and not stopped:
            stopped.append(caller.GetProgress())
            caller.SetAbortExecute(1)

    aborted.AddObserver("ProgressEvent", abort)
    errors = [T.ErrorCollector(stage) for stage in stages[1:]]
    T.check(stages[-1].UpdatePiece(rank, ranks, 0) == 1, "%s abort: rank %d failed" % (what, rank))
    T.check(not any(e.errors for e in errors), "%s abort at %g: rank %d: %r" % (
        what, at, rank, [e.errors for e in errors]))
    T.check(rank != 1 or stopped, "%s abort: rank 1 never reached %g of it" % (what, at))
    T.check(aborted.GetOutput().GetNumberOfCells() == 0, "%s abort at %g: rank %d kept %d cells" % (
        what, at, rank, aborted.GetOutput().GetNumberOfCells()))
    controller.Barrier()
    if rank == 0:
        print("abort on rank 1 at %g of the exchanged %s: every rank stopped" % (at, what))


def stage_of(stages, class_name):
    return [stage for stage in stages if stage.IsA(class_name)][0]


# An abort on one rank during the exchanged smoothing (halfway): the smoothing agrees on each
# abort check while it exchanges. Before, rank 1 left the exchanges and the others waited.
stages = chain(T.make_image(three_d), "materials")
abort_on_rank_1(stages, stages[-1], 0.5, "smoothing")

# In the snap, before its rounds (progress 0.5) and during them: the pieces agree before every
# round while they exchange.
for at in (0.5, 0.7):
    stages = chain(T.make_image(ball), "function")
    abort_on_rank_1(stages, stage_of(stages, "stmVertexSnap"), at, "snap")

# In MultiMaterialCut, before its steps (progress 0.1, where no snap has begun) and during them
# (0.5): every rank stops at the next agreement of the steps' snaps, or at the cut's last one.
for at in (0.1, 0.5):
    stages = chain(T.make_image(noisy), "materials")
    abort_on_rank_1(stages, stage_of(stages, "stmMultiMaterialCut"), at, "multi-material cut")
