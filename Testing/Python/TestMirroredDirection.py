"""An image whose direction matrix is a reflection (determinant -1, common for LPS/RAS-flipped
medical images) still gives positively oriented tetrahedra.

Input: the 20^3 nested-box image of TestVTKStyle.py with direction diag(-1, 1, 1). Expected:
every tetrahedron has a positive signed volume, and the per-material volumes equal the voxel
volumes, as with the identity or a rotation.
"""
import numpy as np

import spacetreemesh

import stmtesting as T

labels = np.zeros((20, 20, 20), dtype=np.uint8)
labels[3:13, 4:18, 2:16] = 1
labels[5:10, 8:14, 6:11] = 2
counts = T.voxel_counts(labels)
failures = []
for name, direction in (("identity", None),
                        ("rotation", (0, -1, 0, 1, 0, 0, 0, 0, 1)),
                        ("reflection of x", (-1, 0, 0, 0, 1, 0, 0, 0, 1)),
                        ("reflection of z", (1, 0, 0, 0, 1, 0, 0, 0, -1))):
    image = T.make_image(labels, (0.5, 1.0, 2.0), (10.0, 20.0, 30.0), direction=direction)
    tree = spacetreemesh.stmImageToSpacetree()
    tree.SetInputData(image)
    mesher = spacetreemesh.stmSpacetreeTessellate()
    mesher.SetSeparatingFunction(mesher.NO_FUNCTION)  # the staircase mesh
    mesher.SetInputConnection(tree.GetOutputPort())
    mesher.Update()
    try:
        T.check_measures(mesher.GetOutput(), counts, 1.0, 1e-12, "direction %s" % name)
    except AssertionError as error:
        failures.append(str(error))
T.check(not failures, "\n".join(failures))
print("mirrored direction: all tetrahedra positive")
