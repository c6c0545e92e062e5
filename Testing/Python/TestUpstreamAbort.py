"""Aborting an upstream filter makes the downstream spacetree filters skip quietly.

ImageToSpacetree -> SpacetreeBalance -> SpacetreeTessellate on a small image; a ProgressEvent
observer on one filter calls SetAbortExecuteAndUpdateTime() (what an interactive abort does);
then Update() of the last filter. Expected: the aborted filter's output is empty and flagged
vtkAlgorithm::ABORTED, and the filters after it produce empty outputs without any error.
"""
import numpy as np

import spacetreemesh
from vtkmodules.vtkCommonCore import vtkCommand
from vtkmodules.vtkCommonExecutionModel import vtkAlgorithm

import stmtesting as T

labels = np.zeros((30, 30, 30), dtype=np.uint8)
labels[3:20, 4:25, 5:27] = 1
labels[8:12, 9:14, 10:20] = 2
failures = []
for victim_index in (0, 1):
    tree = spacetreemesh.stmImageToSpacetree()
    tree.SetInputData(T.make_image(labels))
    balance = spacetreemesh.stmSpacetreeBalance()
    balance.SetInputConnection(tree.GetOutputPort())
    mesher = spacetreemesh.stmSpacetreeTessellate()
    mesher.SetSeparatingFunction(mesher.NO_FUNCTION)
    mesher.SetInputConnection(balance.GetOutputPort())
    filters = (tree, balance, mesher)
    victim = filters[victim_index]
    collectors = [T.ErrorCollector(f) for f in filters]
    victim.AddObserver(vtkCommand.ProgressEvent, lambda caller, event: caller.SetAbortExecuteAndUpdateTime())
    mesher.Update()
    what = "abort of %s" % victim.GetClassName()
    if not victim.GetOutputInformation(0).Get(vtkAlgorithm.ABORTED()):
        failures.append("%s: its output is not flagged ABORTED" % what)
    for f, collector in zip(filters, collectors):
        if collector.errors:
            failures.append("%s: %s reported %s" % (what, f.GetClassName(),
                                                     [e.split("): ", 1)[-1].strip() for e in collector.errors]))
        if filters.index(f) >= victim_index and f.GetOutput().GetNumberOfCells() != 0:
            failures.append("%s: %s output not empty" % (what, f.GetClassName()))
T.check(not failures, "\n".join(failures))
print("upstream abort: downstream filters skip quietly")
