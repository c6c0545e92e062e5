"""SpacetreeMesh: spacetree-based meshing of segmented images, as VTK filters.

Needs ParaView's ``vtkmodules`` (pvpython, pvbatch, or Debian's /usr/bin/python3 with
python3-paraview). Example::

    import spacetreemesh
    tree = spacetreemesh.stmImageToSpacetree()
    tree.SetInputConnection(reader.GetOutputPort())
    balance = spacetreemesh.stmSpacetreeBalance()
    balance.SetInputConnection(tree.GetOutputPort())
    mesh = spacetreemesh.stmSpacetreeTessellate()
    mesh.SetInputConnection(balance.GetOutputPort())
    mesh.Update()
"""
from .SpacetreeMeshFilters import *  # noqa: F401,F403
