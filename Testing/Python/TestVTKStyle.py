"""The wrapped classes of the package "spacetreemesh" in a plain VTK pipeline (run by pvpython).

- aal.nii.gz through vtkNIFTIImageReader and the three filters: only tetrahedra, Material values
  equal to the non-zero labels, volume per material = voxel count x voxel volume.
- Two nested boxes (label 2 inside label 1) in a 20^3 point-data image with spacing
  (0.5, 1, 2) and origin (10, 20, 30): the spacetree reproduces every voxel's label; the mesh
  bounds are exactly the voxel model's (a point-data voxel is centred on its point), volumes
  per label exact, every tetrahedron positive (numpy, vtkCellSizeFilter and vtkMeshQuality),
  the mesh conforming (its boundary area equals the voxel model's surface area), for both cell
  templates, balanced or not, with and without the background.
- The same voxels as cell data give the same mesh; a rotated direction matrix is respected.
- BalanceLevel 1..3, with and without FaceBalanceOnly, on a tree with level jumps of 5: adjacent
  leaves differ by at most BalanceLevel levels, and balancing only refines.
- A 2D image in the XZ plane gives positively oriented triangles with exact areas.
"""
import numpy as np

import spacetreemesh
from vtkmodules.vtkCommonDataModel import VTK_TETRA, VTK_TRIANGLE
from vtkmodules.vtkFiltersVerdict import vtkMeshQuality
from vtkmodules.vtkIOImage import vtkNIFTIImageReader
from vtkmodules.util.numpy_support import vtk_to_numpy

import stmtesting as T

AAL = T.env("STM_AAL")


def pipeline(source, balance=True, balance_level=1, face_only=False, template=None,
             background=False, max_cell_size=None, pattern=None):
    """(tree filter, balance filter or None, tessellate filter), updated."""
    tree = spacetreemesh.stmImageToSpacetree()
    # Staircase meshes on the voxel lattice: no leaves below a voxel for thin parts.
    tree.SetThinPartRefinement(tree.NO_THIN_PARTS)
    if hasattr(source, "GetOutputPort"):
        tree.SetInputConnection(source.GetOutputPort())
    else:
        tree.SetInputData(source)
    if max_cell_size is not None:
        tree.SetMaxCellSize(max_cell_size)
    if pattern is not None:
        tree.SetRefinementPattern(pattern)
    last = tree
    balancer = None
    if balance:
        balancer = spacetreemesh.stmSpacetreeBalance()
        balancer.SetInputConnection(tree.GetOutputPort())
        balancer.SetBalanceLevel(balance_level)
        balancer.SetFaceBalanceOnly(face_only)
        last = balancer
    mesher = spacetreemesh.stmSpacetreeTessellate()
    mesher.SetSeparatingFunction(mesher.NO_FUNCTION)  # the staircase mesh
    mesher.SetInputConnection(last.GetOutputPort())
    if template is not None:
        mesher.SetCellTemplate(template)
    mesher.SetIncludeBackground(background)
    mesher.Update()
    return tree, balancer, mesher


# --- aal.nii.gz ---------------------------------------------------------------------------------
reader = vtkNIFTIImageReader()
reader.SetFileName(AAL)
reader.Update()
aal = reader.GetOutput()
T.check_equal(aal.GetDimensions(), (181, 217, 181), "AAL dimensions")
aal_counts = T.voxel_counts(T.image_labels(aal))
_, _, aal_mesher = pipeline(reader)
aal_mesh = aal_mesher.GetOutput()
T.check(bool(np.all(T.cell_types(aal_mesh) == VTK_TETRA)), "AAL mesh: not only tetrahedra")
T.check_measures(aal_mesh, aal_counts, float(np.prod(aal.GetSpacing())), 1e-6, "AAL (VTK-style)")
aal_cells = aal_mesh.GetNumberOfCells()
del aal_mesh, aal_mesher, aal

# --- nested boxes, point data -------------------------------------------------------------------
SPACING = (0.5, 1.0, 2.0)
ORIGIN = (10.0, 20.0, 30.0)
VOXEL = SPACING[0] * SPACING[1] * SPACING[2]
OUTER = ((2, 15), (4, 17), (3, 12))  # inclusive voxel index ranges along x, y, z
INNER = ((6, 10), (8, 13), (5, 9))
labels = np.zeros((20, 20, 20), dtype=np.uint8)  # [z, y, x]
labels[OUTER[2][0]:OUTER[2][1] + 1, OUTER[1][0]:OUTER[1][1] + 1, OUTER[0][0]:OUTER[0][1] + 1] = 1
labels[INNER[2][0]:INNER[2][1] + 1, INNER[1][0]:INNER[1][1] + 1, INNER[0][0]:INNER[0][1] + 1] = 2
counts = T.voxel_counts(labels)
T.check_equal(counts, {1: 14 * 14 * 10 - 5 * 6 * 5, 2: 5 * 6 * 5}, "nested box voxel counts")
body_surface = T.voxel_boundary_measure(labels > 0, SPACING)
# Physical corners of voxel i along an axis: ORIGIN + (i -/+ 0.5) * SPACING.
LATTICE_ORIGIN = tuple(o - 0.5 * s for o, s in zip(ORIGIN, SPACING))


def box_bounds(box):
    result = []
    for axis, (first, last) in enumerate(box):
        result += [ORIGIN[axis] + (first - 0.5) * SPACING[axis],
                   ORIGIN[axis] + (last + 0.5) * SPACING[axis]]
    return tuple(result)


def check_box_mesh(mesh, what, background_box=None):
    types = T.cell_types(mesh)
    T.check(len(types) > 0 and bool(np.all(types == VTK_TETRA)), "%s: not only tetrahedra" % what)
    material = T.cell_array(mesh, "Material")
    if background_box is None:
        T.check_equal(mesh.GetBounds(), box_bounds(OUTER), "%s: mesh bounds" % what)
        T.check_measures(mesh, counts, VOXEL, 1e-12, what)
        area, most = T.boundary_measure(mesh)
        T.check_close(area, body_surface, 1e-12, "%s: boundary area (conformity)" % what)
    else:
        T.check_equal(mesh.GetBounds(), background_box, "%s: mesh bounds with background" % what)
        box_volume = np.prod([background_box[2 * a + 1] - background_box[2 * a] for a in range(3)])
        all_counts = dict(counts)
        all_counts[0] = int(round(box_volume / VOXEL)) - sum(counts.values())
        T.check_measures(mesh, all_counts, VOXEL, 1e-12, what)
        area, most = T.boundary_measure(mesh)
        box_area = 2 * sum(
            (background_box[2 * a + 1] - background_box[2 * a]) *
            (background_box[2 * b + 1] - background_box[2 * b])
            for a, b in ((0, 1), (0, 2), (1, 2)))
        T.check_close(area, box_area, 1e-12, "%s: boundary area (conformity)" % what)
    T.check(most <= 2, "%s: a facet is shared by %d tetrahedra" % (what, most))
    # The inner box exactly.
    inner_points = T.points(mesh)[np.unique(T.connectivity(mesh, 4)[material == 2])]
    inner = tuple(v for a in range(3) for v in (inner_points[:, a].min(), inner_points[:, a].max()))
    T.check_equal(inner, box_bounds(INNER), "%s: bounds of label 2" % what)


image = T.make_image(labels, SPACING, ORIGIN)
tree, balancer, mesher = pipeline(image)
box_mesh = mesher.GetOutput()
check_box_mesh(box_mesh, "nested boxes")

# The spacetree holds every voxel's label (the root grid beyond the image is background).
tree_data = tree.GetOutput()
T.check(T.is_hexahedral_spacetree(tree_data), "nested boxes: spacetree not all hexahedra")
tree_lo, tree_hi = T.leaf_boxes(tree_data, LATTICE_ORIGIN, SPACING)
T.check_equal(tuple(tree_lo.min(axis=0)), (0, 0, 0), "spacetree lattice origin")
root_extent = tuple(int(v) for v in tree_hi.max(axis=0))
T.check(all(e >= 20 for e in root_extent), "the root grid %r does not cover the image" % (root_extent,))
painted, _ = T.paint(tree_data, LATTICE_ORIGIN, SPACING, root_extent)
T.check(bool(np.all(painted >= 0)), "the spacetree leaves do not cover the root grid")
T.check(bool(np.array_equal(painted[:20, :20, :20], labels.transpose(2, 1, 0))),
        "the spacetree's materials differ from the voxel labels")
T.check(bool(np.all(painted[20:] == 0)) and bool(np.all(painted[:, 20:] == 0))
        and bool(np.all(painted[:, :, 20:] == 0)), "the padding of the root grid is not background")
root_box = tuple(v for a in range(3) for v in (LATTICE_ORIGIN[a],
                                                  LATTICE_ORIGIN[a] + root_extent[a] * SPACING[a]))

# Positive volumes by VTK's own filters too.
vtk_volumes = T.vtk_measures(box_mesh)
T.check(vtk_volumes.min() > 0, "vtkCellSizeFilter: non-positive volume %r" % vtk_volumes.min())
by_vtk = T.per_material(vtk_volumes, T.cell_array(box_mesh, "Material"))
for label, count in counts.items():
    T.check_close(by_vtk[label], count * VOXEL, 1e-12, "vtkCellSizeFilter volume of label %d" % label)
quality = vtkMeshQuality()
quality.SetInputData(box_mesh)
quality.SetTetQualityMeasureToVolume()
quality.SaveCellQualityOn()
quality.Update()
signed = vtk_to_numpy(quality.GetOutput().GetCellData().GetArray("Quality"))
T.check(signed.min() > 0, "vtkMeshQuality: %d tetrahedra with non-positive signed volume"
        % int((signed <= 0).sum()))

# Both templates, balanced or not, with and without the background.
KUHN = spacetreemesh.stmSpacetreeTessellate.KUHN
CHECKERBOARD = spacetreemesh.stmSpacetreeTessellate.CHECKERBOARD
for template in (CHECKERBOARD, KUHN):
    for balance in (False, True):
        for background in (False, True):
            what = "nested boxes, template %d, balance %s, background %s" % (template, balance, background)
            _, _, m = pipeline(image, balance=balance, template=template, background=background)
            check_box_mesh(m.GetOutput(), what, root_box if background else None)
# With 2x2x2 refinement every regular cell takes its template: 6 tetrahedra (Kuhn) against 5.
# (The automatic pattern of these 0.5 x 1 x 2 voxels splits x alone at one level; the cells
# above it take the midpoint rule with the checkerboard template, see SpacetreeTessellation.h.)
kuhn_cells = pipeline(image, balance=False, template=KUHN, pattern="2x2x2")[2].GetOutput().GetNumberOfCells()
checker_cells = pipeline(image, balance=False, template=CHECKERBOARD,
                         pattern="2x2x2")[2].GetOutput().GetNumberOfCells()
T.check(kuhn_cells > checker_cells, "Kuhn (6 per cube) gave %d tetrahedra, checkerboard (5) %d"
        % (kuhn_cells, checker_cells))

# --- the same voxels as cell data ---------------------------------------------------------------
cell_image = T.make_image(labels, SPACING, LATTICE_ORIGIN, cell_data=True)
T.check_equal(cell_image.GetDimensions(), (21, 21, 21), "cell-data image dimensions")
cell_mesh = pipeline(cell_image)[2].GetOutput()
check_box_mesh(cell_mesh, "nested boxes as cell data")
T.check(bool(np.array_equal(T.points(cell_mesh), T.points(box_mesh))),
        "cell-data and point-data images give different points")
T.check(bool(np.array_equal(T.connectivity(cell_mesh, 4), T.connectivity(box_mesh, 4))),
        "cell-data and point-data images give different tetrahedra")
T.check(bool(np.array_equal(T.cell_array(cell_mesh, "Material"), T.cell_array(box_mesh, "Material"))),
        "cell-data and point-data images give different materials")

# --- a rotated image: index x along +y, index y along -x ----------------------------------------
ROTATION = (0, -1, 0, 1, 0, 0, 0, 0, 1)
rotated_mesh = pipeline(T.make_image(labels, SPACING, ORIGIN, direction=ROTATION))[2].GetOutput()
T.check_measures(rotated_mesh, counts, VOXEL, 1e-12, "rotated image")
(x0, x1, y0, y1, z0, z1) = box_bounds(OUTER)
# Physical = ORIGIN + R (index * spacing): x' = ORIGIN_x - (y - ORIGIN_y), y' = ORIGIN_y + (x - ORIGIN_x).
expected = (ORIGIN[0] - (y1 - ORIGIN[1]), ORIGIN[0] - (y0 - ORIGIN[1]),
            ORIGIN[1] + (x0 - ORIGIN[0]), ORIGIN[1] + (x1 - ORIGIN[0]), z0, z1)
T.check_equal(rotated_mesh.GetBounds(), expected, "rotated image: mesh bounds")

# --- balancing: a single voxel at the centre of a 64^3 root cell -----------------------------
jump = np.zeros((64, 64, 64), dtype=np.uint8)
jump[31, 31, 31] = 1
jump[44:60, 5:12, 40:50] = 2
jump_image = T.make_image(jump)
jump_origin = (-0.5, -0.5, -0.5)
unbalanced_filter = spacetreemesh.stmImageToSpacetree()
unbalanced_filter.SetInputData(jump_image)
unbalanced_filter.SetMaxCellSize(64)
unbalanced_filter.SetThinPartRefinement(unbalanced_filter.NO_THIN_PARTS)
unbalanced_filter.Update()
unbalanced = unbalanced_filter.GetOutput()
lo, hi = T.leaf_boxes(unbalanced, jump_origin, (1, 1, 1))
levels = T.cell_array(unbalanced, "Level")
T.check_equal(T.max_level_difference(lo, hi, levels), 5, "level jump of the unbalanced tree")
unbalanced_material, unbalanced_level = T.paint(unbalanced, jump_origin, (1, 1, 1), (64, 64, 64))
T.check(bool(np.array_equal(unbalanced_material, jump.transpose(2, 1, 0))),
        "unbalanced tree: materials differ from the voxels")
jump_counts = T.voxel_counts(jump)
leaf_counts = {}
for level in (1, 2, 3):
    for face_only in (False, True):
        what = "BalanceLevel %d, FaceBalanceOnly %s" % (level, face_only)
        balance = spacetreemesh.stmSpacetreeBalance()
        balance.SetInputConnection(unbalanced_filter.GetOutputPort())
        balance.SetBalanceLevel(level)
        balance.SetFaceBalanceOnly(face_only)
        balance.Update()
        balanced = balance.GetOutput()
        lo, hi = T.leaf_boxes(balanced, jump_origin, (1, 1, 1))
        levels = T.cell_array(balanced, "Level")
        difference = T.max_level_difference(lo, hi, levels, face_only=face_only)
        T.check(difference <= level, "%s: adjacent leaves differ by %d levels" % (what, difference))
        material, level_map = T.paint(balanced, jump_origin, (1, 1, 1), (64, 64, 64))
        T.check(bool(np.array_equal(material, unbalanced_material)), "%s: materials changed" % what)
        T.check(bool(np.all(level_map >= unbalanced_level)), "%s: a leaf was coarsened" % what)
        leaf_counts[(level, face_only)] = balanced.GetNumberOfCells()
        mesher = spacetreemesh.stmSpacetreeTessellate()
        mesher.SetSeparatingFunction(mesher.NO_FUNCTION)  # the staircase mesh
        mesher.SetInputConnection(balance.GetOutputPort())
        mesher.Update()
        T.check_measures(mesher.GetOutput(), jump_counts, 1.0, 1e-12, what)
        area, most = T.boundary_measure(mesher.GetOutput())
        T.check_close(area, T.voxel_boundary_measure(jump > 0, (1, 1, 1)), 1e-12,
                      "%s: boundary area (conformity)" % what)
for level in (1, 2, 3):
    T.check(leaf_counts[(level, True)] <= leaf_counts[(level, False)],
            "BalanceLevel %d: face balancing gave more leaves (%d) than vertex balancing (%d)"
            % (level, leaf_counts[(level, True)], leaf_counts[(level, False)]))
T.check(leaf_counts[(1, False)] > leaf_counts[(2, False)] > unbalanced.GetNumberOfCells(),
        "leaf counts should fall with BalanceLevel: %r, unbalanced %d"
        % (leaf_counts, unbalanced.GetNumberOfCells()))

# --- 2D in the XZ plane ------------------------------------------------------------------------
flat = np.zeros((30, 1, 40), dtype=np.int32)  # [z, y, x]
flat[5:20, 0, 3:30] = 4
flat[8:12, 0, 10:15] = 9
flat_counts = T.voxel_counts(flat)
flat_image = T.make_image(flat, (1.0, 1.0, 1.0), (0.0, 5.0, 0.0))
flat_tree, _, flat_mesher = pipeline(flat_image)
T.check(T.is_hexahedral_spacetree(flat_tree.GetOutput(), dimension=2), "XZ image: not only quads")
flat_mesh = flat_mesher.GetOutput()
T.check(bool(np.all(T.cell_types(flat_mesh) == VTK_TRIANGLE)), "XZ image: not only triangles")
T.check_equal(flat_mesh.GetBounds(), (2.5, 29.5, 5.0, 5.0, 4.5, 19.5), "XZ image: bounds")
# The lattice axes are x then z: positive orientation is counter-clockwise seen along x cross z = -y.
T.check_measures(flat_mesh, flat_counts, 1.0, 0.0, "XZ image areas", normal=(0.0, -1.0, 0.0), exact=True)
length, most = T.boundary_measure(flat_mesh)
T.check_equal(length, T.voxel_boundary_measure(flat.transpose(1, 0, 2) > 0, (1.0, 1.0, 1.0)),
              "XZ image: boundary length (conformity)")
T.check(most <= 2, "XZ image: an edge is shared by %d triangles" % most)

print("vtk_style: passed (AAL %d tetrahedra, nested boxes %d)" % (aal_cells, box_mesh.GetNumberOfCells()))
