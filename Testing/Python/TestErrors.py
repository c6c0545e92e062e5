"""Bad inputs make the filters report a specific error, fail the request, keep an empty output
and recover on good input (run by pvpython).

Each case runs on a filter that has just produced a non-empty output from a good input, so an
output left over from the previous run would be noticed. The filter's ErrorEvent observer
receives the filter's message (asserted by substring); the executive's "returned failure"
message, which tells that RequestData returned 0, is caught with a vtkStringOutputWindow.
"""
import math

import numpy as np

import spacetreemesh
from vtkmodules.util.numpy_support import numpy_to_vtk
from vtkmodules.vtkCommonCore import (
    vtkIdList,
    vtkIntArray,
    vtkLogger,
    vtkOutputWindow,
    vtkPoints,
    vtkStringOutputWindow,
    vtkUnsignedCharArray,
)
from vtkmodules.vtkCommonDataModel import (
    VTK_HEXAHEDRON,
    vtkDataObject,
    vtkDataSetAttributes,
    vtkImageData,
    vtkUnstructuredGrid,
)
from vtkmodules.vtkFiltersCore import vtkExtractCells

import stmtesting as T

# The expected errors are caught by observers and a string output window; keep vtkLogger from
# echoing them on stderr as well (pvpython prints through the output window, not the logger).
vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_OFF)

# A good 3D image: label 2 inside label 1, and a good spacetree of it.
good_labels = np.zeros((8, 9, 10), dtype=np.uint8)
good_labels[1:7, 2:8, 1:9] = 1
good_labels[3:5, 4:6, 3:6] = 2
GOOD_IMAGE = T.make_image(good_labels)


def good_tree():
    """A fresh unbalanced spacetree dataset of GOOD_IMAGE."""
    f = spacetreemesh.stmImageToSpacetree()
    f.SetInputData(GOOD_IMAGE)
    f.Update()
    tree = vtkUnstructuredGrid()
    tree.DeepCopy(f.GetOutput())
    T.check(tree.GetNumberOfCells() > 8, "the good spacetree has %d leaves" % tree.GetNumberOfCells())
    return tree


GOOD_TREE = good_tree()


class Run:
    """Updates a filter while collecting its errors and the executive's messages."""

    def __init__(self, algorithm):
        self.algorithm = algorithm
        self.collector = T.ErrorCollector(algorithm)

    def update(self):
        """Modified() and Update(); returns what the executive and others printed meanwhile."""
        self.collector.clear()
        window = vtkStringOutputWindow()
        previous = vtkOutputWindow.GetInstance()
        vtkOutputWindow.SetInstance(window)
        try:
            self.algorithm.Modified()
            self.algorithm.Update()
        finally:
            vtkOutputWindow.SetInstance(previous)
        return window.GetOutput() or ""


def set_input(algorithm, data):
    algorithm.SetInputData(data)


def expect_good(run, data, what):
    set_input(run.algorithm, data)
    messages = run.update()
    out = run.algorithm.GetOutput()
    T.check(not run.collector.errors, "%s: unexpected errors %r" % (what, run.collector.errors))
    T.check("returned failure" not in messages, "%s: the request failed: %s" % (what, messages))
    T.check(out.GetNumberOfCells() > 0, "%s: empty output on good input" % what)


def expect_error(run, data, substrings, what):
    """The filter fails with an error containing every substring and leaves an empty output."""
    set_input(run.algorithm, data)
    messages = run.update()
    errors = run.collector.errors
    T.check(len(errors) > 0, "%s: no error was reported (executive said %r)" % (what, messages))
    for substring in substrings:
        T.check(any(substring in e for e in errors),
                "%s: no error mentions %r; errors: %r" % (what, substring, errors))
    T.check("returned failure" in messages,
            "%s: the request did not fail (executive said %r)" % (what, messages))
    out = run.algorithm.GetOutput()
    T.check(out.GetNumberOfCells() == 0 and out.GetNumberOfPoints() == 0,
            "%s: the output is not empty (%d cells, %d points)"
            % (what, out.GetNumberOfCells(), out.GetNumberOfPoints()))
    T.check(out.GetCellData().GetNumberOfArrays() == 0 and out.GetPointData().GetNumberOfArrays() == 0,
            "%s: the output keeps cell or point arrays" % what)
    # Not checked: field data. The executive copies the input's field data to the output before
    # RequestData; Balance and Tessellate clear it on most failures but not when the geometry
    # field arrays are invalid.


cases = 0

# ------------------------------------------------------------------------------------------------
# ImageToSpacetree
tree_run = Run(spacetreemesh.stmImageToSpacetree())
expect_good(tree_run, GOOD_IMAGE, "good image")


def image_case(data, substrings, what, setup=None):
    global cases
    f = tree_run.algorithm
    expect_good(tree_run, GOOD_IMAGE, "good image before: " + what)
    if setup:
        setup(f)
    expect_error(tree_run, data, substrings, what)
    # Undo the settings; the same filter must work again.
    f.RemoveAllBodyLabels()
    f.SetBackgroundLabel(0)
    f.SetInputArrayToProcess(0, 0, 0, vtkDataObject.FIELD_ASSOCIATION_POINTS_THEN_CELLS,
                             vtkDataSetAttributes.SCALARS)
    expect_good(tree_run, GOOD_IMAGE, "good image after: " + what)
    cases += 1


image_case(T.make_image(good_labels.astype(np.float32)), ["is of type float", "integer labels"],
           "float scalars")
image_case(T.make_image(good_labels.astype(np.float64)), ["is of type double", "integer labels"],
           "double scalars")

no_scalars = vtkImageData()
no_scalars.SetDimensions(10, 9, 8)
image_case(no_scalars, ["No label array"], "image without scalars")

two_components = vtkImageData()
two_components.SetDimensions(10, 9, 8)
pairs = vtkUnsignedCharArray()
pairs.SetName("pairs")
pairs.SetNumberOfComponents(2)
pairs.SetNumberOfTuples(10 * 9 * 8)
pairs.Fill(1)
two_components.GetPointData().SetScalars(pairs)
image_case(two_components, ['"pairs" has 2 components'], "two-component labels")

image_case(T.make_image(np.ones((1, 1, 1), dtype=np.uint8)),
           ["1 x 1 x 1 voxels", "needs a 2D or 3D image"], "1x1x1 image")
image_case(T.make_image(np.ones((1, 1, 10), dtype=np.uint8)),
           ["10 x 1 x 1 voxels", "needs a 2D or 3D image"], "1D image")
image_case(T.make_image(good_labels, spacing=(1.0, 0.0, 1.0)),
           ["spacing (1, 0, 1) must be positive and finite"], "zero spacing")
image_case(T.make_image(good_labels, spacing=(1.0, 1.0, -2.0)),
           ["spacing (1, 1, -2) must be positive and finite"], "negative spacing")
image_case(T.make_image(good_labels, spacing=(math.nan, 1.0, 1.0)),
           ["must be positive and finite"], "NaN spacing")
image_case(T.make_image(good_labels, spacing=(math.inf, 1.0, 1.0)),
           ["must be positive and finite"], "infinite spacing")
image_case(GOOD_IMAGE, ["Body label 7 does not occur", '"labels"'], "absent body label",
           setup=lambda f: (f.AddBodyLabel(1), f.AddBodyLabel(7)))
image_case(T.make_image(np.zeros((8, 9, 10), dtype=np.uint8)),
           ["body of interest is empty", "background label 0"], "all-background image")
image_case(T.make_image(np.full((8, 9, 10), 5, dtype=np.int16)),
           ["body of interest is empty", "background label 5"], "image of the background label only",
           setup=lambda f: f.SetBackgroundLabel(5))
image_case(GOOD_IMAGE, ["Body label 1 equals the background label"], "body label = background label",
           setup=lambda f: (f.AddBodyLabel(2), f.AddBodyLabel(1), f.SetBackgroundLabel(1)))
image_case(GOOD_IMAGE, ["Body label 0 equals the background label"], "body label 0 with background 0",
           setup=lambda f: f.AddBodyLabel(0))

huge = T.make_image(good_labels.astype(np.int64))
huge_array = huge.GetPointData().GetScalars()
huge_array.SetValue(5, 1 << 40)
image_case(huge, ["outside the 32-bit integer range"], "labels beyond int32")

many = T.make_image(np.arange(250 * 300, dtype=np.int32).reshape(1, 250, 300))
image_case(many, ["74999 labels", "at most 65535"], "too many body labels")

short_cells = vtkImageData()
short_cells.SetDimensions(11, 10, 9)
short_array = numpy_to_vtk(np.ones(10, dtype=np.uint8), deep=True)
short_array.SetName("short")
short_cells.GetCellData().AddArray(short_array)
image_case(short_cells, ["does not have one value per voxel"], "cell labels of the wrong length",
           setup=lambda f: f.SetInputArrayToProcess(0, 0, 0, vtkDataObject.FIELD_ASSOCIATION_CELLS,
                                                    "short"))

image_case(GOOD_IMAGE, ["has no array named \"missing\""], "label array name that does not exist",
           setup=lambda f: f.SetInputArrayToProcess(0, 0, 0, vtkDataObject.FIELD_ASSOCIATION_POINTS,
                                                    "missing"))

# ------------------------------------------------------------------------------------------------
# Balance and Tessellate on what is not a spacetree


def copy_tree():
    tree = vtkUnstructuredGrid()
    tree.DeepCopy(GOOD_TREE)
    return tree


def replace_cell_array(tree, name, values):
    array = numpy_to_vtk(np.ascontiguousarray(values), deep=True)
    array.SetName(name)
    tree.GetCellData().RemoveArray(name)
    tree.GetCellData().AddArray(array)


def corrupt_level(value):
    tree = copy_tree()
    levels = T.cell_array(tree, "Level").copy()
    levels[3] = value
    replace_cell_array(tree, "Level", levels)
    return tree


def corrupt_field(name, values):
    tree = copy_tree()
    tree.GetFieldData().RemoveArray(name)
    if values is not None:
        array = vtkIntArray()
        array.SetName(name)
        for v in values:
            array.InsertNextValue(v)
        tree.GetFieldData().AddArray(array)
    return tree


def plain_grid():
    grid = vtkUnstructuredGrid()
    pts = vtkPoints()
    for corner in [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]:
        pts.InsertNextPoint(corner)
    grid.SetPoints(pts)
    ids = vtkIdList()
    for i in range(8):
        ids.InsertNextId(i)
    grid.InsertNextCell(VTK_HEXAHEDRON, ids)
    for name in ("Level", "Material"):
        a = vtkIntArray()
        a.SetName(name)
        a.InsertNextValue(0 if name == "Level" else 1)
        grid.GetCellData().AddArray(a)
    return grid


def without_one_leaf():
    keep = vtkIdList()
    for i in range(GOOD_TREE.GetNumberOfCells()):
        if i != 5:
            keep.InsertNextId(i)
    extract = vtkExtractCells()
    extract.SetInputData(GOOD_TREE)
    extract.SetCellList(keep)
    extract.Update()
    tree = vtkUnstructuredGrid()
    tree.DeepCopy(extract.GetOutput())
    T.check(tree.GetFieldData().GetArray("SpacetreeDimension") is not None,
            "vtkExtractCells dropped the field data")
    T.check(tree.GetCellData().GetArray("Level") is not None, "vtkExtractCells dropped Level")
    return tree


def empty_tree():
    tree = vtkUnstructuredGrid()
    tree.Allocate(0)
    tree.SetPoints(vtkPoints())
    tree.GetFieldData().ShallowCopy(GOOD_TREE.GetFieldData())
    for name in ("Level", "Material", "LatticeIndex"):
        source = GOOD_TREE.GetCellData().GetArray(name)
        array = source.NewInstance()
        array.SetName(name)
        array.SetNumberOfComponents(source.GetNumberOfComponents())
        tree.GetCellData().AddArray(array)
    return tree


def tet_mesh():
    f = spacetreemesh.stmSpacetreeTessellate()
    f.SetInputData(GOOD_TREE)
    f.Update()
    mesh = vtkUnstructuredGrid()
    mesh.DeepCopy(f.GetOutput())
    return mesh


levels = T.cell_array(GOOD_TREE, "Level")
leaf_with_room = int(np.nonzero(levels < levels.max())[0][0])
one_level_down = copy_tree()
shifted = T.cell_array(one_level_down, "Level").copy()
shifted[leaf_with_room] += 1
replace_cell_array(one_level_down, "Level", shifted)

other_material = copy_tree()
materials = T.cell_array(other_material, "Material").copy()
materials[2] = 55
replace_cell_array(other_material, "Material", materials)

fractional_level = copy_tree()
replace_cell_array(fractional_level, "Level",
                   np.where(np.arange(len(levels)) == 4, 0.5, levels).astype(np.float64))

moved_leaf = copy_tree()
indices = T.cell_array(moved_leaf, "LatticeIndex").copy()
indices[1] = indices[0]
replace_cell_array(moved_leaf, "LatticeIndex", indices)

no_lattice_index = copy_tree()
no_lattice_index.GetCellData().RemoveArray("LatticeIndex")

TREE_CASES = [
    (plain_grid(), ['lack a valid array "SpacetreeDimension"', "output of ImageToSpacetree"],
     "plain unstructured grid"),
    (vtkUnstructuredGrid(), ['lack a valid array "SpacetreeDimension"'], "empty unstructured grid"),
    # A mesh carries no spacetree field data (SpacetreeTessellate removes what the executive
    # passes on), so it is refused as not being a spacetree at all.
    (tet_mesh(), ['lack a valid array "SpacetreeDimension"', "is the input the output of ImageToSpacetree"],
     "a tessellated mesh"),
    (corrupt_level(99), ["leaf 3 has an invalid level"], "Level 99"),
    (one_level_down, ["invalid spacetree", "hole in the root grid"], "a leaf one level too fine"),
    (fractional_level, ["leaf 4 has an invalid level"], "a fractional level"),
    (other_material, ["leaf 2 ", "not in the material table"], "unknown material"),
    (moved_leaf, ["invalid spacetree", "leaf 1 overlaps another leaf"], "two leaves at one place"),
    (without_one_leaf(), ["invalid spacetree", "hole in the root grid"], "a missing leaf"),
    (no_lattice_index, ["lacks valid cell arrays Level, Material and LatticeIndex"], "no LatticeIndex"),
    (empty_tree(), ["has no leaves"], "no leaves"),
    (corrupt_field("SpacetreeDimension", [4]), ["dimension must be 2 or 3, got 4"], "dimension 4"),
    (corrupt_field("SpacetreeImageAxes", [2, 1, 0]), ["image axes must be increasing"],
     "decreasing image axes"),
    (corrupt_field("SpacetreeMaxLevel", [21]), ["MaxLevel must be between 0 and 20"], "MaxLevel 21"),
    (corrupt_field("SpacetreeRootGridDimensions", None),
     ['lack a valid array "SpacetreeRootGridDimensions"'], "no root grid dimensions"),
    (corrupt_field("SpacetreeBodyLabels", [1, 1, 2]), ["material labels are not distinct"],
     "repeated body labels"),
]

for algorithm, name in ((spacetreemesh.stmSpacetreeBalance(), "SpacetreeBalance"),
                        (spacetreemesh.stmSpacetreeTessellate(), "SpacetreeTessellate")):
    run = Run(algorithm)
    for data, substrings, what in TREE_CASES:
        label = "%s, %s" % (name, what)
        expect_good(run, GOOD_TREE, label + " (good tree before)")
        expect_error(run, data, [name] + substrings, label)
        cases += 1
    expect_good(run, GOOD_TREE, name + " (good tree at the end)")

# ------------------------------------------------------------------------------------------------
# Out-of-range parameters of SpacetreeTessellate are clamped (vtkSetClampMacro), not errors; the
# clamped values are used.
clamped = spacetreemesh.stmSpacetreeTessellate()
clamped.SetSeparatingFunction(clamped.NO_FUNCTION)  # no automatic boundary layer
for setter, value, getter, expected in [
        ("SetBoundaryLayers", -5, "GetBoundaryLayers", 0),
        ("SetBoundaryLayers", 101, "GetBoundaryLayers", 100),
        ("SetOutputType", 7, "GetOutputType", spacetreemesh.stmSpacetreeTessellate.LEAVES),
        ("SetOutputType", -1, "GetOutputType", spacetreemesh.stmSpacetreeTessellate.SIMPLICIAL),
        ("SetTemplateRule", 3, "GetTemplateRule", spacetreemesh.stmSpacetreeTessellate.EXTENDED),
        ("SetTemplateRule", -2, "GetTemplateRule",
         spacetreemesh.stmSpacetreeTessellate.MIDPOINT_EVERYWHERE),
        ("SetCellTemplate", 2, "GetCellTemplate", spacetreemesh.stmSpacetreeTessellate.KUHN)]:
    getattr(clamped, setter)(value)
    T.check(getattr(clamped, getter)() == expected,
            "%s(%d) gives %s() = %r, expected the clamped %d"
            % (setter, value, getter, getattr(clamped, getter)(), expected))
    cases += 1
T.check(clamped.GetBoundaryLayers() == 100 and clamped.GetOutputType() == 0,
        "the clamps do not stick")
clamped.SetBoundaryLayers(-5)
clamped.SetOutputType(7)
clamp_run = Run(clamped)
expect_good(clamp_run, GOOD_TREE, "SpacetreeTessellate with clamped BoundaryLayers and OutputType")
leaf_cells = clamped.GetOutput()
T.check({leaf_cells.GetCellType(i) for i in range(leaf_cells.GetNumberOfCells())} == {VTK_HEXAHEDRON},
        "OutputType 7 (clamped to LEAVES) does not output the leaves as hexahedra")
T.check(0 not in set(T.cell_array(leaf_cells, "Material")),
        "BoundaryLayers -5 (clamped to 0) outputs background leaves")
T.check(clamped.GetNumberOfInsertedPoints() == 0, "the leaves output inserted points")

print("errors: %d bad inputs reported, no crash, empty outputs" % cases)
