"""Threads without setting anything (issue 8): Debian's VTK starts on its Sequential SMP backend,
and loading SpacetreeMesh's filters switches it to STDThread, unless VTK_SMP_BACKEND_IN_USE
chose a backend.

STM_LOAD=module imports the Python package, STM_LOAD=plugin loads the ParaView plugin (the way
the GUI gets the filters). Then:
- the backend is STDThread with one thread per core, or the one VTK_SMP_BACKEND_IN_USE names;
- the default chain (tree, balance, tessellate, MarchingSimplices) on the AAL atlas gives the
  same mesh, point for point and cell for cell, on STDThread and on Sequential.
"""
import os

import numpy as np

from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkCommonCore import vtkSMPTools

import stmtesting as T

LOAD = T.env("STM_LOAD")
AAL = T.env("STM_AAL")
CHOSEN = os.environ.get("VTK_SMP_BACKEND_IN_USE")

T.check_equal(vtkSMPTools.GetBackend(), CHOSEN or "Sequential", "backend before loading")
if LOAD == "plugin":
    from paraview.simple import LoadPlugin

    LoadPlugin(T.env("STM_PLUGIN"), ns=globals())
else:
    T.check_equal(LOAD, "module", "STM_LOAD")
import spacetreemesh  # noqa: E402 (the plugin's load must come first)

T.check_equal(vtkSMPTools.GetBackend(), CHOSEN or "STDThread", "backend after loading (%s)" % LOAD)
if not CHOSEN:
    T.check_equal(vtkSMPTools.GetEstimatedNumberOfThreads(), os.cpu_count(), "threads")


def default_chain_mesh():
    tessellate = T.atlas_chain(AAL)[3]
    cut = spacetreemesh.stmMarchingSimplices()
    cut.SetInputConnection(tessellate.GetOutputPort())
    cut.Update()
    mesh = cut.GetOutput()
    T.check(mesh.GetNumberOfCells() > 1000000, "the cut mesh has %d cells" % mesh.GetNumberOfCells())
    return (vtk_to_numpy(mesh.GetPoints().GetData()).copy(),
            vtk_to_numpy(mesh.GetCells().GetConnectivityArray()).copy(),
            vtk_to_numpy(mesh.GetCellData().GetArray("Material")).copy())


if not CHOSEN:
    threaded = default_chain_mesh()
    T.check(vtkSMPTools.SetBackend("Sequential"), "Sequential backend available")
    sequential = default_chain_mesh()
    for name, a, b in zip(("points", "connectivity", "Material"), threaded, sequential):
        T.check(a.shape == b.shape and np.array_equal(a, b),
                "%s differ between STDThread and Sequential (%r, %r)" % (name, a.shape, b.shape))
    print("threaded backend: STDThread with %d threads; %d points, %d cells as on Sequential"
          % (os.cpu_count(), threaded[0].shape[0], threaded[2].shape[0]))
