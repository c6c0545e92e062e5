"""The plugin in the real ParaView GUI (run under Xvfb by RunGUITest.sh): the NIfTI reader and the
four filters run through the GUI's Python, the mesh is right, and a screenshot shows it.

ParaView's --script exits 0 even when the script raises, so success is reported by writing the
marker file named by STM_GUI_MARKER, which the wrapper checks.
"""
import os

from paraview.simple import (ColorBy, GetActiveViewOrCreate, LoadPlugin, OpenDataFile, Render,
                             SaveScreenshot, Show)

import stmtesting as T

LoadPlugin(os.environ["STM_PLUGIN"], ns=globals())
image = OpenDataFile(os.environ["STM_AAL"])
assert image.GetXMLName() == "stmNIFTIReader", image.GetXMLName()
tree = ImageToSpacetree(Input=image)  # noqa: F821 (defined by LoadPlugin)
balanced = SpacetreeBalance(Input=tree)  # noqa: F821
tessellated = SpacetreeTessellate(Input=balanced)  # noqa: F821
tessellated.UpdatePipeline()
cells = tessellated.GetDataInformation().GetNumberOfCells()
# AAL, MaxCellSize 16, thin body parts refined, BalanceLevel 1, checkerboard template, one
# automatic background layer for the default separating function: the tessellation stmesh's
# default run makes of the brain mask.
assert cells == 6635905, cells
cut = MarchingSimplices(Input=tessellated)  # noqa: F821
cut.UpdatePipeline()
cells = cut.GetDataInformation().GetNumberOfCells()
assert cells == 8118405, cells
mesh = MarchingSimplices(Input=tessellated, KeepSide="Inside")  # noqa: F821
mesh.UpdatePipeline()

view = GetActiveViewOrCreate("RenderView")
display = Show(mesh, view)
ColorBy(display, ("CELLS", "OriginalMaterial"))
display.RescaleTransferFunctionToDataRange(True)
view.CameraPosition = [90, -400, 300]
view.CameraFocalPoint = [90, 108, 90]
view.CameraViewUp = [0, 0, 1]
view.ResetCamera(False)
Render(view)
screenshot = os.path.join(os.environ["STM_TEMP_DIR"], "gui_aal_mesh.png")
SaveScreenshot(screenshot, view, ImageResolution=[800, 600])

# Not blank: the mesh covers a good part of the picture in many colours.
fraction, colours = T.screenshot_coverage(screenshot)
assert fraction > 0.1, "screenshot nearly blank: %.3f of pixels differ from the background" % fraction
assert colours > 50, "screenshot has only %d colours" % colours
print("GUI: %d tetrahedra, screenshot %s (%.0f%% covered, %d colours)" % (cells, screenshot, 100 * fraction, colours))
with open(os.environ["STM_GUI_MARKER"], "w") as marker:
    marker.write("ok\n")
