"""The documented region-refinement example (docs/examples/refine_region_box.py) runs as printed
and does what it says: on the AAL atlas, leaves of half a voxel inside its box and nowhere far
from it, with the exact voxel volume of every label (run by pvpython)."""
import os
import runpy
import sys

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkFiltersVerdict import vtkCellSizeFilter
from vtkmodules.vtkIOImage import vtkNIFTIImageReader
from vtkmodules.vtkIOXML import vtkXMLUnstructuredGridReader

import stmtesting as T

EXAMPLE = os.path.join(T.env("STM_SOURCE_DIR"), "docs", "examples", "refine_region_box.py")
OUTPUT = T.temp_path("aal-box.vtu")
BOX_LOW = np.array([80.0, 100.0, 60.0])
BOX_HIGH = BOX_LOW + 30.0

sys.argv = [EXAMPLE, T.env("STM_PLUGIN"), OUTPUT]
runpy.run_path(EXAMPLE, run_name="__main__")

reader = vtkXMLUnstructuredGridReader()
reader.SetFileName(OUTPUT)
reader.Update()
mesh = reader.GetOutput()
T.check(mesh.GetNumberOfCells() > 4650454,
        "the box refinement must add tetrahedra to the 4,650,454 of the default pipeline, got %d"
        % mesh.GetNumberOfCells())

points = vtk_to_numpy(mesh.GetPoints().GetData())
tets = vtk_to_numpy(mesh.GetCells().GetConnectivityArray()).reshape(-1, 4)
corners = points[tets]
edges = [np.linalg.norm(corners[:, a] - corners[:, b], axis=1) for a in range(4) for b in range(a + 1, 4)]
shortest = np.min(edges, axis=0)
centroids = corners.mean(axis=1)
inside = np.all((centroids > BOX_LOW) & (centroids < BOX_HIGH), axis=1)
far = np.any((centroids < BOX_LOW - 3.0) | (centroids > BOX_HIGH + 3.0), axis=1)
T.check(inside.sum() > 0, "no tetrahedron inside the box")
T.check_close(shortest[inside].min(), 0.5, 1e-9, "shortest edge inside the box (half a voxel)")
T.check(shortest[far].min() >= 1.0 - 1e-9,
        "far from the box no edge may be shorter than a voxel, found %r" % shortest[far].min())

# Exact volume per label: voxel counts of the atlas times 1 mm^3.
atlas = vtkNIFTIImageReader()
atlas.SetFileName(T.env("STM_AAL"))
atlas.Update()
counts = np.bincount(vtk_to_numpy(atlas.GetOutput().GetPointData().GetScalars()).astype(np.int64))
sizes = vtkCellSizeFilter()
sizes.SetInputData(mesh)
sizes.Update()
volumes = vtk_to_numpy(sizes.GetOutput().GetCellData().GetArray("Volume"))
T.check(volumes.min() > 0, "non-positive tetrahedron volume %r" % volumes.min())
labels = vtk_to_numpy(mesh.GetCellData().GetArray("Material")).astype(np.int64)
per_label = np.bincount(labels, weights=volumes, minlength=len(counts))
for label in range(1, len(counts)):
    if counts[label]:
        T.check_close(per_label[label], float(counts[label]), 1e-9, "volume of label %d" % label)
print("refine_region_box example: %d tetrahedra, %d inside the box, shortest edge %.3f"
      % (mesh.GetNumberOfCells(), inside.sum(), shortest[inside].min()))
