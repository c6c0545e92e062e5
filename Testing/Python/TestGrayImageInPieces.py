"""A gray image as the separating function under MPI (`mpiexec -n P pvbatch --symmetric`, Split
Into Pieces, every rank asking for its own piece, .vti readers for the labels and for the gray
image): SeparatingFunction and VertexSnap (Projection Function) each read only the voxels around
their piece's points, never the whole gray image (stmGrayImagePieces: a first pass finds the
piece's bounds), and the owned cells of the P pieces, cut and smoothed, are the serial mesh's
bit for bit. The gray ellipsoid reaches beyond the image's z = 0 boundary, where the image is
closed (stm::ClosedVoxelField) inside the labels' box; the pieces read sub-extents of the gray
image both at that boundary and away from it.
"""
import os

import numpy as np

import spacetreemesh
import stmtesting as T
from vtkmodules.vtkIOXML import vtkXMLImageDataReader, vtkXMLImageDataWriter

controller, rank, ranks, temp = T.mpi_pieces_run()

shape = (192, 28, 32)  # [z, y, x]: the pieces are cut across z
labels = T.nested_ellipsoids(shape)
labels[0:100, 4:24, 4:28][labels[0:100, 4:24, 4:28] == 0] = 1  # a box from the z = 0 face
z, y, x = np.meshgrid(*[np.arange(n) + 0.0 for n in shape], indexing="ij")
gray = (1.0 - ((z - 10.0) / 70.0) ** 2 - ((y - 14.0) / 8.0) ** 2
        - ((x - 16.0) / 10.0) ** 2).astype(np.float32)
labels_path = os.path.join(temp, "gray_labels_%d.vti" % ranks)
gray_path = os.path.join(temp, "gray_%d.vti" % ranks)
if rank == 0:
    for path, image in ((labels_path, T.make_image(labels)),
                        (gray_path, T.make_image(gray, name="gray"))):
        writer = vtkXMLImageDataWriter()
        writer.SetInputData(image)
        writer.SetFileName(path)
        writer.SetDataModeToBinary()  # inline: Debian's libexpat fails on appended data
        T.check(writer.Write() == 1, "writing %s" % path)
controller.Barrier()


def reader_of(path):
    reader = vtkXMLImageDataReader()
    reader.SetFileName(path)
    return reader


def chain(split):
    """Labels -> tree -> balance -> tessellate -> gray function -> snap onto the gray surface ->
    cut -> smoothing; the function and the snap each with their own reader of the gray image."""
    labels_reader = reader_of(labels_path)
    tree, balance, tessellate = T.spacetree_chain(labels_reader)
    tree.SetSplitIntoPieces(split)
    function_reader, snap_reader = reader_of(gray_path), reader_of(gray_path)
    function = T.gray_separating_function(tessellate, function_reader.GetOutputPort(), 0.0)
    snap = spacetreemesh.stmVertexSnap()
    snap.SetInputConnection(function.GetOutputPort())
    snap.SetProjection(spacetreemesh.stmVertexSnap.FUNCTION)
    snap.SetGrayImageConnection(snap_reader.GetOutputPort())
    snap.SetThreshold(0.0)
    stages = [tree, balance, tessellate, function, snap]
    T.append_stages(stages, spacetreemesh.stmMarchingSimplices, spacetreemesh.stmBoundarySmooth)
    return stages, (function_reader, snap_reader)


def voxels(reader):
    extent = reader.GetOutput().GetExtent()
    return int(np.prod([extent[2 * a + 1] - extent[2 * a] + 1 for a in range(3)]))


stages, gray_readers = chain(True)
errors = [T.ErrorCollector(stage) for stage in stages]
T.check(stages[-1].UpdatePiece(rank, ranks, 0) == 1, "rank %d failed" % rank)
T.check(not any(e.errors for e in errors), "rank %d: %r" % (rank, [e.errors for e in errors]))
reads = [voxels(reader) for reader in gray_readers]
for what, read in zip(("SeparatingFunction", "VertexSnap"), reads):
    T.check(0 < read < gray.size, "rank %d: %s read %d of the gray image's %d voxels" % (
        rank, what, read, gray.size))
T.check(stages[4].GetNumberOfSnappedPoints() > 0, "rank %d snapped no point" % rank)
for index, what in ((-2, "cut"), (-1, "smoothed")):
    own = T.owned_cell_rows(stages[index].GetOutput(), 4)
    T.check(len(own) > 0, "%s: rank %d owns no cell" % (what, rank))
    np.save(os.path.join(temp, "gray_%s_%d_%d.npy" % (what, ranks, rank)), own)
np.save(os.path.join(temp, "gray_reads_%d_%d.npy" % (ranks, rank)), reads)
controller.Barrier()
if rank == 0:
    serial, serial_readers = chain(False)
    serial[-1].Update()
    T.check_equal(voxels(serial_readers[0]), gray.size, "the serial run's gray voxels")
    # The gray surface is cut inside the labels' box, also where it meets the z = 0 boundary.
    for index, what in ((-2, "cut"), (-1, "smoothed")):
        expected = T.owned_cell_rows(serial[index].GetOutput(), 4)
        together = np.concatenate([
            np.load(os.path.join(temp, "gray_%s_%d_%d.npy" % (what, ranks, r)))
            for r in range(ranks)])
        together = together[np.lexsort(together.T[::-1])]
        T.check(together.shape == expected.shape, "%s, %d ranks: %d owned cells, serial %d" % (
            what, ranks, len(together), len(expected)))
        differing = np.count_nonzero(np.any(together != expected, axis=1))
        T.check(differing == 0, "%s, %d ranks: %d of %d cells differ from the serial mesh's" % (
            what, ranks, differing, len(expected)))
        # Both materials, and inside cells at the z = 0 boundary.
        inside = expected[expected[:, 12] == 1]  # Material, after the 4 corners
        T.check(len(inside) > 0 and len(inside) < len(expected),
                "%s: %d inside cells of %d" % (what, len(inside), len(expected)))
        T.check(inside[:, 2:12:3].min() <= 0.0, "%s: the inside starts at z = %g" % (
            what, inside[:, 2:12:3].min()))
    reads = [np.load(os.path.join(temp, "gray_reads_%d_%d.npy" % (ranks, r))).tolist()
             for r in range(ranks)]
    print("gray image, %d ranks: %d cells, the serial mesh's bit for bit; the ranks read %r of "
          "%d gray voxels (separating function, snap)" % (
              ranks, len(expected), reads, gray.size))
controller.Barrier()
