"""Thin-part refinement under MPI with a reader that reads sub-extents (`mpiexec -n P pvbatch
--symmetric`, Split Into Pieces, every rank asking for its own piece): each rank reads only its
ghost box grown by one voxel, never the whole image, and the ranks classify the thin parts
together (stm::ThinPartPiece), so that the owned cells of the P pieces are the serial mesh's bit
for bit. The image: the nested ellipsoids with their one-voxel layer, a bar two voxels wide along
x that is joined to a block at one end (only the block has voxel centres that keep the label, so
every part of the bar in a piece without the block is thin unless the pieces join it to the
block), noise at the centre and a line of three voxels outside the body; both thin-part modes
(body and materials), each with its cut, and the materials again with root cells of 4 voxels.
"""
import os

import numpy as np

import spacetreemesh
import stmtesting as T
from vtkmodules.vtkIOXML import vtkXMLImageDataReader, vtkXMLImageDataWriter

controller, rank, ranks, temp = T.mpi_pieces_run()

labels = T.nested_ellipsoids((32, 28, 128))  # [z, y, x]
labels[2:8, 2:8, 1:7] = 5
labels[4:6, 4:6, 1:127] = 5  # the bar, 2 x 2 voxels, through every piece
labels[11:21, 9:19, 59:69] = np.random.RandomState(4).randint(1, 6, size=(10, 10, 10))
labels[29, 3, 60:63] = 2  # a line of three voxels outside the body: thin in both modes
path = os.path.join(temp, "thin_parts_%d.vti" % ranks)
if rank == 0:
    writer = vtkXMLImageDataWriter()
    writer.SetInputData(T.make_image(labels))
    writer.SetFileName(path)
    writer.SetDataModeToBinary()  # inline: Debian's libexpat fails on appended data
    T.check(writer.Write() == 1, "writing %s" % path)
controller.Barrier()


def chain(mode, root, split=True):
    reader = vtkXMLImageDataReader()
    reader.SetFileName(path)
    tree, balance, tessellate = T.spacetree_chain(reader)
    tree.SetSplitIntoPieces(split)
    tree.SetThinPartRefinement(mode)
    tree.SetRootCellSize(root, root, root)
    stages = [reader, tree, balance, tessellate]
    if mode == spacetreemesh.stmImageToSpacetree.THIN_MATERIAL_PARTS:
        T.append_stages(stages, spacetreemesh.stmMultiMaterialCut)
    else:
        T.append_stages(stages, spacetreemesh.stmVertexSnap, spacetreemesh.stmMarchingSimplices)
    return stages


# Root cells of 4 voxels: the pieces keep 4 inner layers of ghost root cells and the outer one
# (stm::GhostRootLayersFor). With one, MultiMaterialCut's snapping decided other points than
# the whole mesh's before its steps' snaps exchanged; with the exchange, one layer gave the
# serial mesh too (4 ranks, an experiment).
cases = [(spacetreemesh.stmImageToSpacetree.THIN_BODY_PARTS, "body", 0),
         (spacetreemesh.stmImageToSpacetree.THIN_MATERIAL_PARTS, "materials", 0),
         (spacetreemesh.stmImageToSpacetree.THIN_MATERIAL_PARTS, "materials, root cells of 4", 4)]
for case, (mode, what, root) in enumerate(cases):
    stages = chain(mode, root)
    errors = [T.ErrorCollector(stage) for stage in stages[1:]]
    T.check(stages[-1].UpdatePiece(rank, ranks, 0) == 1, "%s: rank %d failed" % (what, rank))
    T.check(not any(e.errors for e in errors), "%s: rank %d: %r" % (
        what, rank, [e.errors for e in errors]))
    extent = stages[0].GetOutput().GetExtent()
    whole = (0, labels.shape[2] - 1, 0, labels.shape[1] - 1, 0, labels.shape[0] - 1)
    read = np.prod([extent[2 * a + 1] - extent[2 * a] + 1 for a in range(3)])
    T.check(root > 0 or read < labels.size, "%s: rank %d read the extent %r, the whole image is %r" % (
        what, rank, extent, whole))
    own = T.owned_cell_rows(stages[-1].GetOutput(), 4)
    T.check(len(own) > 0, "%s: rank %d owns no cell" % (what, rank))
    np.save(os.path.join(temp, "thin_%d_%d_%d.npy" % (case, ranks, rank)), own)
    np.save(os.path.join(temp, "read_%d_%d_%d.npy" % (case, ranks, rank)), [read])
    controller.Barrier()
    if rank == 0:
        # The serial run: one piece, the whole image, classified alone.
        serial = chain(mode, root, split=False)
        serial[-1].Update()
        thin_voxels = serial[1].GetNumberOfThinVoxels()
        T.check(thin_voxels > 0, "%s: the serial run found no thin voxel" % what)
        expected = T.owned_cell_rows(serial[-1].GetOutput(), 4)
        together = np.concatenate([np.load(os.path.join(temp, "thin_%d_%d_%d.npy" % (case, ranks, r)))
                                   for r in range(ranks)])
        together = together[np.lexsort(together.T[::-1])]
        T.check(together.shape == expected.shape, "%s, %d ranks: %d owned cells, serial %d" % (
            what, ranks, len(together), len(expected)))
        differing = np.count_nonzero(np.any(together != expected, axis=1))
        T.check(differing == 0, "%s, %d ranks: %d of %d cells differ from the serial mesh's"
                % (what, ranks, differing, len(expected)))
        reads = [int(np.load(os.path.join(temp, "read_%d_%d_%d.npy" % (case, ranks, r)))[0])
                 for r in range(ranks)]
        print("%s, %d ranks: %d thin voxels, %d cells, the serial mesh's bit for bit; the ranks "
              "read %r of %d voxels" % (what, ranks, thin_voxels, len(expected), reads,
                                        labels.size))
    controller.Barrier()
