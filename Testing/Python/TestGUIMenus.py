"""Run in the ParaView GUI's Python shell at the end of TestGUIMenus.xml, which made a pipeline of
every filter of the plugin from the Filters > Spacetree Mesh menu and applied each with the
Properties panel (test python.gui_menus, RunGUITest.sh).

Checks that the menu made one proxy of each filter, that each applied output equals what the same
filter with its XML defaults makes from Python (so the panel's widgets pushed the defaults
unchanged), and that a screenshot of the view shows the meshes. Writes the marker file
STM_GUI_MARKER on success: ParaView's playback does not fail on a Python exception.
"""
import os
import sys

import numpy as np
import paraview.simple as simple
from paraview import servermanager
from paraview.simple import (FindSource, GetActiveViewOrCreate, GetSources, Render,
                             SaveScreenshot, SetActiveSource)
from vtkmodules.util.numpy_support import vtk_to_numpy

import stmtesting as T

MENU_FILTERS = ["stmImageToSpacetree", "stmSpacetreeBalance", "stmSpacetreeTessellate",
                "stmVertexSnap", "stmMarchingSimplices", "stmBoundarySmooth",
                "stmSeparatingFunction", "stmMultiMaterialCut", "stmInterfaceSurface"]


def report(text):
    """Prints on ParaView's standard output, not in the shell's console."""
    sys.__stdout__.write(text + "\n")
    sys.__stdout__.flush()


def mesh_arrays(proxy):
    """(points, connectivity, cell types) of a proxy's output (an unstructured grid, or the
    polygons of a polydata), fetched to the client."""
    data = servermanager.Fetch(proxy)
    if data.IsA("vtkUnstructuredGrid"):
        cells, types = data.GetCells(), T.cell_types(data)
    else:
        cells = data.GetPolys()
        types = np.array([data.GetCellType(cell) for cell in range(data.GetNumberOfCells())])
    return T.points(data), vtk_to_numpy(cells.GetConnectivityArray()), types


def main():
    gui = T.proxies_by_xml_name(GetSources())
    counts = {name: len(proxies) for name, proxies in gui.items()}
    expected = dict({name: 1 for name in MENU_FILTERS}, stmNIFTIReader=1, ExtractGrid=1)
    assert counts == expected, "the GUI's pipeline objects: %r" % counts

    # The same pipeline from Python, every property at its default.
    def make(filter_function, source):
        # paraview.simple of ParaView 5.11 takes the array defaults from the active source, not
        # from the Input given: make the input active first, as the GUI's menu does.
        SetActiveSource(source)
        return filter_function(Input=source)

    block = FindSource("ExtractSubset1")
    tree = make(simple.ImageToSpacetree, block)
    balanced = make(simple.SpacetreeBalance, tree)
    tessellated = make(simple.SpacetreeTessellate, balanced)
    snapped = make(simple.VertexSnap, tessellated)
    cut = make(simple.MarchingSimplices, snapped)
    smoothed = make(simple.BoundarySmooth, cut)
    function = make(simple.SeparatingFunction, tessellated)
    regions = make(simple.MultiMaterialCut, tessellated)
    interfaces = make(simple.InterfaceSurface, regions)
    reference = dict(zip(MENU_FILTERS, [tree, balanced, tessellated, snapped, cut, smoothed,
                                        function, regions, interfaces]))
    for name in MENU_FILTERS:
        made = gui[name][0]
        made_input = made.GetProperty("Input").GetData().GetXMLName()
        reference_input = reference[name].GetProperty("Input").GetData().GetXMLName()
        assert made_input == reference_input, "%s's input: %s" % (name, made_input)
        gui_mesh = mesh_arrays(made)
        python_mesh = mesh_arrays(reference[name])
        assert len(gui_mesh[2]) > 0, "%s made an empty output in the GUI" % name
        for what, a, b in zip(("points", "connectivity", "cell types"), gui_mesh, python_mesh):
            assert a.shape == b.shape and np.array_equal(a, b), \
                "%s: the GUI's %s differ from Python's (%r vs %r)" % (name, what, a.shape, b.shape)
        report("GUI menu: %s applied, %d cells, the same as from Python" % (name, len(gui_mesh[2])))
    for proxy in reversed(list(reference.values())):
        simple.Delete(proxy)

    # The interfaces between the block's regions, alone in the view, coloured by the pair of
    # materials they separate.
    view = GetActiveViewOrCreate("RenderView")
    for proxies in gui.values():
        simple.Hide(proxies[0], view)
    display = simple.Show(gui["stmInterfaceSurface"][0], view)
    simple.ColorBy(display, ("CELLS", "BoundaryLabels", "Magnitude"))
    display.RescaleTransferFunctionToDataRange(True)
    view.ResetCamera(False)
    Render(view)
    screenshot = os.path.join(os.environ["STM_TEMP_DIR"], "gui_menus.png")
    SaveScreenshot(screenshot, view, ImageResolution=[800, 600])
    fraction, colours = T.screenshot_coverage(screenshot)
    assert fraction > 0.1, \
        "screenshot nearly blank: %.3f of pixels differ from the background" % fraction
    assert colours > 50, "screenshot has only %d colours" % colours
    report("GUI menus: %d filters made from Filters > Spacetree Mesh, screenshot %s "
           "(%.0f%% covered)" % (len(MENU_FILTERS), screenshot, 100 * fraction))
    with open(os.environ["STM_GUI_MARKER"], "w") as marker:
        marker.write("ok\n")


# The shell swallows exceptions: report them where RunGUITest.sh prints them.
try:
    main()
except Exception:
    import traceback
    with open(os.environ["STM_GUI_MARKER"] + ".failure", "w") as failure:
        traceback.print_exc(file=failure)
