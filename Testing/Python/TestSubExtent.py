"""Images that are part of a larger one (an extent that does not start at 0: ExtractSubset's
VOI, a streamed piece) are meshed where they are (run by pvpython).

Regression: ImageToSpacetree put the first voxel of such an image at the origin, and the gray
image of SeparatingFunction was sampled as if its extent started at 0. A sub-extent image must
give the same mesh, point for point, as the same voxels in an image of their own whose origin
is moved to where they are.
"""
import numpy as np

import spacetreemesh
import stmtesting as T
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkImagingCore import vtkExtractVOI

labels = np.zeros((14, 16, 18), dtype=np.uint8)  # [z, y, x]
labels[3:10, 4:12, 5:14] = 1
labels[5:8, 6:10, 7:12] = 2
whole = T.make_image(labels)
voi = vtkExtractVOI()
voi.SetInputData(whole)
voi.SetVOI(4, 15, 3, 13, 2, 12)
voi.Update()
part = voi.GetOutput()
T.check_equal(part.GetExtent(), (4, 15, 3, 13, 2, 12), "the sub-extent")
moved = T.make_image(np.ascontiguousarray(labels[2:13, 3:14, 4:16]), origin=(4.0, 3.0, 2.0))


def mesh(image, gray=None):
    tree = spacetreemesh.stmImageToSpacetree()
    tree.SetInputData(image)
    balance = spacetreemesh.stmSpacetreeBalance()
    balance.SetInputConnection(tree.GetOutputPort())
    tessellate = spacetreemesh.stmSpacetreeTessellate()
    tessellate.SetInputConnection(balance.GetOutputPort())
    last = tessellate
    if gray is not None:
        function = spacetreemesh.stmSeparatingFunction()
        function.SetInputConnection(tessellate.GetOutputPort())
        function.SetInputData(1, gray)
        function.SetMode(spacetreemesh.stmSeparatingFunction.GRAY_IMAGE)
        function.SetThreshold(0.5)
        last = function
    last.Update()
    return last.GetOutput()


a, b = mesh(part), mesh(moved)
T.check(a.GetNumberOfCells() > 0 and a.GetNumberOfCells() == b.GetNumberOfCells(),
        "cells %d and %d" % (a.GetNumberOfCells(), b.GetNumberOfCells()))
T.check(np.array_equal(vtk_to_numpy(a.GetPoints().GetData()), vtk_to_numpy(b.GetPoints().GetData())),
        "the sub-extent image's mesh is not where its voxels are: bounds %r against %r"
        % (a.GetBounds(), b.GetBounds()))
# A gray image given as a sub-extent samples the same values.
gray_whole = T.make_image(labels.astype(np.float32))
gray_voi = vtkExtractVOI()
gray_voi.SetInputData(gray_whole)
gray_voi.SetVOI(2, 17, 1, 15, 0, 13)
gray_voi.Update()
gray_moved = T.make_image(np.ascontiguousarray(labels[0:14, 1:16, 2:18].astype(np.float32)),
                          origin=(2.0, 1.0, 0.0))
fa = mesh(moved, gray_voi.GetOutput()).GetPointData().GetArray("SeparatingFunction")
fb = mesh(moved, gray_moved).GetPointData().GetArray("SeparatingFunction")
T.check(fa is not None and np.array_equal(vtk_to_numpy(fa), vtk_to_numpy(fb)),
        "the gray image's sub-extent is sampled elsewhere")
print("sub-extent: %d cells where the voxels are; the gray image sampled alike" % a.GetNumberOfCells())
