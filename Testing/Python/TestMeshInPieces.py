"""scripts/mesh-in-pieces.py under `mpiexec -n 2 pvbatch --symmetric` on the AAL brain mask
(run by pvpython): the two ranks' pieces, written as one .pvtu and read back, are the serial
mesh once the ghost cells are removed and the shared points merged (tolerance 0): the same
number of cells and of points, so the smoothed pieces meet point on point.
"""
import os
import subprocess

import stmtesting as T
from vtkmodules.vtkFiltersCore import vtkStaticCleanUnstructuredGrid
from vtkmodules.vtkFiltersParallel import vtkRemoveGhosts
from vtkmodules.vtkIOXML import vtkXMLPUnstructuredGridReader

folder = T.env("STM_TEMP_DIR")
pieces = os.path.join(folder, "pieces.pvtu")
script = os.path.join(T.env("STM_SOURCE_DIR"), "scripts", "mesh-in-pieces.py")
# pvpython may have started MPI as a singleton: its OpenMPI variables would make mpiexec's ranks
# join it, so they stay out of the environment mpiexec gets.
environment = {key: value for key, value in os.environ.items()
               if not key.startswith(("OMPI_", "PMIX_", "OPAL_")) or key.startswith("OMPI_ALLOW")}
run = subprocess.run([T.env("STM_MPIEXEC"), "--oversubscribe", "-n", "2", T.env("STM_PVBATCH"),
                      "--symmetric", script, T.env("STM_AAL"), pieces],
                     capture_output=True, text=True, timeout=300, env=environment)
T.check(run.returncode == 0, "mpiexec failed (%d): %s %s" % (
    run.returncode, run.stdout[-1000:], run.stderr[-2000:]))
for rank in (0, 1):
    T.check("rank %d of 2:" % rank in run.stdout, "rank %d did not report: %r" % (rank, run.stdout))

reader = vtkXMLPUnstructuredGridReader()
reader.SetFileName(pieces)
owned = vtkRemoveGhosts()
owned.SetInputConnection(reader.GetOutputPort())
merged = vtkStaticCleanUnstructuredGrid()
merged.SetInputConnection(owned.GetOutputPort())
merged.SetTolerance(0.0)
merged.Update()
together = merged.GetOutput()
T.check(reader.GetOutput().GetNumberOfCells() > together.GetNumberOfCells(),
        "the pieces have no ghost cells")

# The serial mesh: one piece, by the same script under pvpython.
serial_path = os.path.join(folder, "serial.pvtu")
run = subprocess.run([T.env("STM_PVPYTHON"), script, T.env("STM_AAL"), serial_path],
                     capture_output=True, text=True, timeout=300, env=environment)
T.check(run.returncode == 0, "the serial run failed: %s" % run.stderr[-2000:])
serial = vtkXMLPUnstructuredGridReader()
serial.SetFileName(serial_path)
serial.Update()
reference = serial.GetOutput()
T.check_equal(together.GetNumberOfCells(), reference.GetNumberOfCells(), "owned cells")
T.check_equal(together.GetNumberOfPoints(), reference.GetNumberOfPoints(),
              "points once the pieces' shared points are merged")
print("mesh in pieces: OK (%d cells, %d points)" % (
    together.GetNumberOfCells(), together.GetNumberOfPoints()))
