"""Refines the AAL brain atlas to half-voxel size inside a box, as a planned cut would be.

    pvpython docs/examples/refine_region_box.py [PLUGIN] [OUTPUT.vtu]

PLUGIN defaults to the build tree's SpacetreeMesh.so, OUTPUT to aal-box.vtu. The atlas has 1 mm
voxels; inside the 30 mm box around (95, 115, 75) mm the leaves are at most 0.5 mm, which puts
the spacetree one level below the voxel there (and only there). Everything else is the default
pipeline (automatic pattern, balance level 1, checkerboard template), without the thin-part
refinement, which only a cut needs.
"""
import sys

from paraview.simple import *  # noqa: F401,F403 (LoadPlugin adds the filters to this namespace)

plugin = sys.argv[1] if len(sys.argv) > 1 else "build/lib/paraview-5.11/plugins/SpacetreeMesh/SpacetreeMesh.so"
output = sys.argv[2] if len(sys.argv) > 2 else "aal-box.vtu"
LoadPlugin(plugin, ns=globals())

image = OpenDataFile("/usr/share/mricron/templates/aal.nii.gz")
tree = ImageToSpacetree(Input=image)
tree.RefinementRegion = "Box"
tree.RefinementRegion.UseReferenceBounds = 0
tree.RefinementRegion.Position = [80.0, 100.0, 60.0]  # lower corner, mm
tree.RefinementRegion.Length = [30.0, 30.0, 30.0]
tree.RegionMaxCellSize = 0.5  # mm: half a voxel
# A staircase mesh keeps every voxel: no leaves below a voxel for thin parts outside the box.
tree.ThinPartRefinement = "No Thin Parts"
balanced = SpacetreeBalance(Input=tree, BalanceLevel=1)
mesh = SpacetreeTessellate(Input=balanced)
mesh.UpdatePipeline()
SaveData(output, proxy=mesh, DataMode="Binary", CompressorType="LZ4")
info = mesh.GetDataInformation()
print("%s: %d tetrahedra, %d points" % (output, info.GetNumberOfCells(), info.GetNumberOfPoints()))
