"""A saved ParaView state that uses every filter of the plugin (Testing/Data/AllFilters.pvsm, on
a block of the AAL atlas cut out by ExtractSubset), loaded under Xvfb by pvpython
(python.state_all_filters) and by the GUI (python.gui_state, RunGUITest.sh): every pipeline
object comes back and runs, each output is what its filter makes, and a screenshot of the
state's view shows the meshes. Success writes the marker file STM_GUI_MARKER.
"""
import os

from paraview.simple import GetActiveViewOrCreate, GetSources, LoadPlugin, LoadState, Render
from paraview.simple import SaveScreenshot

import stmtesting as T

LoadPlugin(os.environ["STM_PLUGIN"], ns=globals())
LoadState(os.environ["STM_STATE"])
sources = T.proxies_by_xml_name(GetSources())
expected = {"stmNIFTIReader": 1, "ExtractGrid": 1, "stmImageToSpacetree": 1,
            "stmSpacetreeBalance": 1, "stmSpacetreeTessellate": 1, "stmVertexSnap": 1,
            "stmMarchingSimplices": 2, "stmBoundarySmooth": 1, "stmSeparatingFunction": 1,
            "stmMultiMaterialCut": 1, "stmInterfaceSurface": 1}
found = {name: len(proxies) for name, proxies in sources.items()}
assert found == expected, "the state's pipeline objects: %r" % found

outputs = {}
for name, proxies in sources.items():
    for proxy in proxies:
        proxy.UpdatePipeline()
        info = proxy.GetDataInformation()
        assert info.GetNumberOfCells() > 0, "%s has an empty output" % name
        outputs.setdefault(name, []).append(proxy.GetClientSideObject().GetOutputDataObject(0))
# The leaves of the spacetree are hexahedra; every mesh after the tessellation has tetrahedra
# only; the interfaces are triangles; balancing only refines.
from vtkmodules.vtkCommonDataModel import VTK_HEXAHEDRON, VTK_TETRA, VTK_TRIANGLE  # noqa: E402


def types(data):
    return {data.GetCellType(c) for c in range(data.GetNumberOfCells())}


assert types(outputs["stmImageToSpacetree"][0]) == {VTK_HEXAHEDRON}
assert outputs["stmSpacetreeBalance"][0].GetNumberOfCells() >= \
    outputs["stmImageToSpacetree"][0].GetNumberOfCells()
for name in ("stmSpacetreeTessellate", "stmVertexSnap", "stmMarchingSimplices",
             "stmBoundarySmooth", "stmSeparatingFunction", "stmMultiMaterialCut"):
    for data in outputs[name]:
        assert types(data) == {VTK_TETRA}, "%s: cell types %r" % (name, types(data))
assert types(outputs["stmInterfaceSurface"][0]) == {VTK_TRIANGLE}
materials = outputs["stmMultiMaterialCut"][0].GetCellData().GetArray("Material")
distinct = {int(materials.GetTuple1(c)) for c in range(materials.GetNumberOfTuples())}
assert len(distinct) > 3, "the multi-material cut has materials %r" % distinct
# The ball cut keeps the inside of the sphere of radius 12 only: less than its volume.
from vtkmodules.vtkFiltersVerdict import vtkCellSizeFilter  # noqa: E402
sizes = vtkCellSizeFilter()
ball = [data for proxy, data in zip(sources["stmMarchingSimplices"], outputs["stmMarchingSimplices"])
        if proxy.KeepSide == "Inside"][0]
sizes.SetInputData(ball)
sizes.Update()
volume = sum(sizes.GetOutput().GetCellData().GetArray("Volume").GetValue(c)
             for c in range(ball.GetNumberOfCells()))
assert 0 < volume < 4.0 / 3.0 * 3.14159265 * 12 ** 3 * 1.05, "the ball cut measures %r" % volume

view = GetActiveViewOrCreate("RenderView")
view.ResetCamera(False)
Render(view)
screenshot = os.path.join(os.environ["STM_TEMP_DIR"], "gui_state.png")
SaveScreenshot(screenshot, view, ImageResolution=[800, 600])
fraction, _ = T.screenshot_coverage(screenshot)
assert fraction > 0.05, "screenshot nearly blank: %.3f of pixels differ from the background" % fraction
print("GUI state: %d pipeline objects ran, screenshot %s (%.0f%% covered)"
      % (sum(expected.values()), screenshot, 100 * fraction))
with open(os.environ["STM_GUI_MARKER"], "w") as marker:
    marker.write("ok\n")
