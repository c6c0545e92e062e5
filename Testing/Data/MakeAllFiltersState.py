"""Writes AllFilters.pvsm, the ParaView state that python.gui_state loads in the GUI: every
filter of the plugin on a 41 x 41 x 41 voxel block of the AAL atlas (run by pvpython; the state
is committed, this script remakes it: pvpython MakeAllFiltersState.py PLUGIN OUTPUT.pvsm)."""
import sys

from paraview.simple import (ExtractSubset, GetActiveViewOrCreate, LoadPlugin, OpenDataFile,
                             SaveState, Show)

LoadPlugin(sys.argv[1], ns=globals())
image = OpenDataFile("/usr/share/mricron/templates/aal.nii.gz")
block = ExtractSubset(Input=image, VOI=[70, 110, 80, 120, 60, 100])
tree = ImageToSpacetree(Input=block, ThinPartRefinement="Thin Body Parts")  # noqa: F821
balanced = SpacetreeBalance(Input=tree)  # noqa: F821
tessellated = SpacetreeTessellate(Input=balanced)  # noqa: F821
snapped = VertexSnap(Input=tessellated)  # noqa: F821
cut = MarchingSimplices(Input=snapped)  # noqa: F821
smoothed = BoundarySmooth(Input=cut)  # noqa: F821
ball = SeparatingFunction(Input=tessellated, ImplicitFunction="Sphere")  # noqa: F821
ball.ImplicitFunction.Center = [90, 100, 80]
ball.ImplicitFunction.Radius = 12
inside_ball = MarchingSimplices(Input=ball, KeepSide="Inside")  # noqa: F821
regions = MultiMaterialCut(Input=tessellated)  # noqa: F821
interfaces = InterfaceSurface(Input=regions)  # noqa: F821
view = GetActiveViewOrCreate("RenderView")
for proxy in (smoothed, interfaces):
    Show(proxy, view)
SaveState(sys.argv[2])
