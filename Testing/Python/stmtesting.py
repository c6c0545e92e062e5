"""Shared helpers of the SpacetreeMesh Python tests (plain VTK + numpy, no paraview.simple).

Every test script imports this module; it is found through PYTHONPATH (set by CTest).
"""
import os
import sys
import traceback

import numpy as np

from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy
from vtkmodules.vtkCommonCore import vtkCommand
from vtkmodules.vtkCommonDataModel import (
    VTK_HEXAHEDRON,
    VTK_QUAD,
    VTK_TETRA,
    VTK_TRIANGLE,
    vtkDataSetAttributes,
    vtkImageData,
)

VTK_STRING_CALLDATA = 13  # vtkmodules.util.vtkConstants.VTK_STRING


def env(name):
    """An environment variable CTest must set; fails clearly when it is missing."""
    value = os.environ.get(name)
    assert value, "environment variable %s is not set (run the test through ctest)" % name
    return value


def temp_path(file_name):
    return os.path.join(env("STM_TEMP_DIR"), file_name)


def exit_all_ranks_on_failure(ranks):
    """Under mpiexec with several ranks: an uncaught exception (a failed check) prints its
    traceback and ends this process at once with exit code 1, which makes mpiexec stop the other
    ranks. Otherwise they would wait at their next collective call until ctest's timeout."""
    if ranks <= 1:
        return

    def print_and_exit(kind, value, trace):
        traceback.print_exception(kind, value, trace)
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(1)

    sys.excepthook = print_and_exit


def mpi_pieces_run():
    """A test under `mpiexec -n P pvbatch --symmetric` with P > 1, every rank asking for its own
    piece: (controller, rank, ranks, temp), a failed check ending every rank
    (exit_all_ranks_on_failure), temp the folder STM_TEMP_DIR names (made), else ".". """
    from vtkmodules.vtkParallelCore import vtkMultiProcessController

    controller = vtkMultiProcessController.GetGlobalController()
    rank, ranks = controller.GetLocalProcessId(), controller.GetNumberOfProcesses()
    check(ranks > 1, "run under mpiexec with several ranks, not %d" % ranks)
    exit_all_ranks_on_failure(ranks)
    temp = os.environ.get("STM_TEMP_DIR", ".")
    os.makedirs(temp, exist_ok=True)
    return controller, rank, ranks, temp


def check(condition, message):
    """Like assert, but survives python -O and always carries a message."""
    if not condition:
        raise AssertionError(message)


def check_equal(actual, expected, what):
    check(actual == expected, "%s: expected %r, got %r" % (what, expected, actual))


def check_close(actual, expected, rel, what):
    check(
        abs(actual - expected) <= rel * abs(expected),
        "%s: expected %r (relative tolerance %g), got %r" % (what, expected, rel, actual),
    )


# ------------------------------------------------------------------------------------------------
# Images

def make_image(labels, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0), cell_data=False,
               name="labels", direction=None):
    """A vtkImageData holding the numpy array labels (indexed [z, y, x]) as its active scalars.

    With cell_data=False a voxel is a point (dimensions = labels.shape reversed); with
    cell_data=True it is a cell (one more point per axis of more than one voxel).
    """
    labels = np.ascontiguousarray(labels)
    assert labels.ndim == 3
    voxels = (labels.shape[2], labels.shape[1], labels.shape[0])
    image = vtkImageData()
    if cell_data:
        image.SetDimensions(*[n + 1 if n > 1 else 1 for n in voxels])
    else:
        image.SetDimensions(*voxels)
    image.SetSpacing(*spacing)
    image.SetOrigin(*origin)
    if direction is not None:
        image.SetDirectionMatrix(*direction)
    array = numpy_to_vtk(labels.ravel(), deep=True)
    array.SetName(name)
    attributes = image.GetCellData() if cell_data else image.GetPointData()
    attributes.SetScalars(array)
    return image


def image_labels(image):
    """The active point scalars (or else cell scalars) of an image, as a flat numpy array."""
    scalars = image.GetPointData().GetScalars() or image.GetCellData().GetScalars()
    check(scalars is not None, "the image has no scalars")
    return vtk_to_numpy(scalars)


def _histogram(values, weights=None):
    """(labels, sums) over the distinct values of an integer array: counts, or sums of weights."""
    values = np.asarray(values).ravel()
    if values.size and values.dtype.kind in "iu" and values.min() >= 0 and values.max() < 1 << 20:
        sums = np.bincount(values.astype(np.int64), weights=weights)
        present = np.bincount(values.astype(np.int64)) > 0
        labels = np.nonzero(present)[0]
        return labels, sums[labels]
    labels, inverse = np.unique(values, return_inverse=True)
    return labels, np.bincount(inverse, weights=weights, minlength=len(labels))


def voxel_counts(labels, background=0):
    """{label: number of voxels} for every label except background."""
    values, counts = _histogram(labels)
    return {int(v): int(c) for v, c in zip(values, counts) if int(v) != background}


def distinct(values):
    """The sorted distinct values of an integer array, as a list of int."""
    return [int(v) for v in _histogram(values)[0]]


# ------------------------------------------------------------------------------------------------
# Meshes

def cell_types(grid):
    return vtk_to_numpy(grid.GetCellTypesArray()) if grid.GetNumberOfCells() else np.zeros(0)


def cell_array(grid, name):
    array = grid.GetCellData().GetArray(name)
    check(array is not None, "the output lacks the cell array %r" % name)
    return vtk_to_numpy(array)


def connectivity(grid, nodes):
    """The connectivity of a grid whose cells all have `nodes` points, as an (M, nodes) array."""
    cells = grid.GetCells()
    offsets = vtk_to_numpy(cells.GetOffsetsArray())
    conn = vtk_to_numpy(cells.GetConnectivityArray())
    check(
        np.array_equal(offsets, np.arange(grid.GetNumberOfCells() + 1) * nodes),
        "not every cell has %d points" % nodes,
    )
    return conn.reshape(-1, nodes)


def points(grid):
    return vtk_to_numpy(grid.GetPoints().GetData()).astype(np.float64)


def signed_measures(grid, normal=(0.0, 0.0, 1.0)):
    """Signed volume of every tetrahedron, or signed area (seen along normal) of every triangle.

    The grid must hold only tetrahedra or only triangles. Computed with numpy, independently of
    VTK's cell-size filters, in chunks that stay in cache.
    """
    types = cell_types(grid)
    if len(types) and np.all(types == VTK_TETRA):
        nodes = 4
    elif len(types) and np.all(types == VTK_TRIANGLE):
        nodes = 3
    else:
        raise AssertionError("the mesh must consist only of tetrahedra or only of triangles; "
                             "types %s" % sorted(set(types.tolist())))
    xyz = vtk_to_numpy(grid.GetPoints().GetData()).astype(np.float64, copy=False)
    conn = connectivity(grid, nodes)
    n = np.asarray(normal, dtype=np.float64)
    n = n / np.linalg.norm(n)
    result = np.empty(len(conn))
    chunk = 1 << 18
    for start in range(0, len(conn), chunk):
        c = conn[start:start + chunk]
        p0 = xyz[c[:, 0]]
        a = xyz[c[:, 1]] - p0
        b = xyz[c[:, 2]] - p0
        cross = np.empty_like(a)
        cross[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
        cross[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
        cross[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
        if nodes == 4:
            d = xyz[c[:, 3]] - p0
            result[start:start + len(c)] = (cross * d).sum(axis=1) / 6.0
        else:
            result[start:start + len(c)] = 0.5 * (cross @ n)
    return result


def per_material(values, materials):
    """{material: sum of values over the cells of that material}."""
    labels, sums = _histogram(materials, weights=values)
    return {int(label): float(total) for label, total in zip(labels, sums)}


def vtk_measures(grid):
    """Volume of every tetrahedron (area of every triangle) by VTK's vtkCellSizeFilter."""
    from vtkmodules.vtkFiltersVerdict import vtkCellSizeFilter

    size = vtkCellSizeFilter()
    size.SetInputData(grid)
    size.ComputeVertexCountOff()
    size.ComputeLengthOff()
    size.Update()
    data = size.GetOutput().GetCellData()
    types = cell_types(grid)
    name = "Volume" if np.all(types == VTK_TETRA) else "Area"
    return vtk_to_numpy(data.GetArray(name)).astype(np.float64)


def check_measures(mesh, counts, voxel_measure, rel, what, normal=(0.0, 0.0, 1.0), exact=False):
    """Every simplex positive, and the measure of each material equal to its voxel count times
    voxel_measure; the set of materials equal to the set of labels of counts."""
    measures = signed_measures(mesh, normal)
    check(len(measures) > 0, "%s: the mesh is empty" % what)
    check(measures.min() > 0.0,
          "%s: %d simplices have a non-positive measure (min %r)"
          % (what, int((measures <= 0).sum()), measures.min()))
    totals = per_material(measures, cell_array(mesh, "Material"))
    check_equal(sorted(totals), sorted(counts), "%s: set of materials" % what)
    for label, count in sorted(counts.items()):
        if exact:
            check_equal(totals[label], count * voxel_measure, "%s: measure of label %d" % (what, label))
        else:
            check_close(totals[label], count * voxel_measure, rel,
                        "%s: measure of label %d" % (what, label))
    return totals


def boundary_measure(mesh):
    """(area of the facets that belong to one simplex only, largest number of simplices on a facet).

    For a conforming mesh every interior facet is shared by exactly two simplices, so the first
    value is the area (length in 2D) of the mesh's boundary; a hanging vertex leaves facets that
    belong to one simplex inside the body and makes the value larger.
    """
    types = cell_types(mesh)
    nodes = 4 if np.all(types == VTK_TETRA) else 3
    conn = connectivity(mesh, nodes)
    xyz = points(mesh)
    if nodes == 4:
        local = np.array([[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]])
    else:
        local = np.array([[0, 1], [0, 2], [1, 2]])
    facets = np.sort(conn[:, local].reshape(-1, local.shape[1]), axis=1)
    unique, counts = np.unique(facets, axis=0, return_counts=True)
    single = unique[counts == 1]
    if nodes == 4:
        p0 = xyz[single[:, 0]]
        cross = np.cross(xyz[single[:, 1]] - p0, xyz[single[:, 2]] - p0)
        measure = 0.5 * np.linalg.norm(cross, axis=1).sum()
    else:
        measure = np.linalg.norm(xyz[single[:, 1]] - xyz[single[:, 0]], axis=1).sum()
    return float(measure), int(counts.max())


def voxel_boundary_measure(mask, spacing):
    """Area (3D) or length (2D, mask of shape (1, ny, nx)) of the boundary of a voxel set."""
    mask = np.asarray(mask, dtype=bool)
    sx, sy, sz = spacing
    total = 0.0
    flat = mask.shape[0] == 1
    axes = ((2, sy * sz if not flat else sy), (1, sx * sz if not flat else sx), (0, sx * sy))
    for axis, face in axes:
        if flat and axis == 0:
            continue
        padded = np.pad(mask, [(1, 1) if a == axis else (0, 0) for a in range(3)])
        total += np.count_nonzero(np.diff(padded.astype(np.int8), axis=axis)) * face
    return total


def leaf_boxes(tree, lattice_origin, spacing):
    """Integer lattice boxes [lo, hi) of the leaves of a 3D spacetree dataset (axis-aligned image).

    Checks that every leaf corner lies exactly on the lattice of voxel corners.
    """
    nodes = 8 if np.all(cell_types(tree) == VTK_HEXAHEDRON) else 4
    corners = points(tree)[connectivity(tree, nodes)]
    lattice = (corners - np.asarray(lattice_origin)) / np.asarray(spacing)
    rounded = np.rint(lattice)
    check(np.array_equal(lattice, rounded),
          "leaf corners off the voxel lattice by up to %g" % np.abs(lattice - rounded).max())
    rounded = rounded.astype(np.int64)
    return rounded.min(axis=1), rounded.max(axis=1)


def paint(tree, lattice_origin, spacing, shape_xyz):
    """(material, level) of every lattice voxel [x, y, z] in shape_xyz, from the spacetree leaves.

    Voxels covered by no leaf get -1; voxels covered twice make the check fail.
    """
    lo, hi = leaf_boxes(tree, lattice_origin, spacing)
    material = np.full(shape_xyz, -1, dtype=np.int64)
    level = np.full(shape_xyz, -1, dtype=np.int64)
    cover = np.zeros(shape_xyz, dtype=np.int64)
    materials = cell_array(tree, "Material")
    levels = cell_array(tree, "Level")
    for leaf in range(len(lo)):
        box = tuple(slice(max(lo[leaf][a], 0), max(min(hi[leaf][a], shape_xyz[a]), 0)) for a in range(3))
        material[box] = materials[leaf]
        level[box] = levels[leaf]
        cover[box] += 1
    check(cover.max() <= 1, "spacetree leaves overlap")
    return material, level


def max_level_difference(lo, hi, levels, face_only=False):
    """Largest level difference between two adjacent leaves (boxes [lo, hi]).

    Adjacent: the closed boxes intersect (share at least a vertex), or with face_only they share
    a facet (touch along one axis and overlap with positive length along the others).
    """
    levels = np.asarray(levels, dtype=np.int64)
    dimension = lo.shape[1]
    best = 0
    for start in range(0, len(lo), 256):
        a_lo, a_hi = lo[start:start + 256, None, :], hi[start:start + 256, None, :]
        touch = np.all((a_lo <= hi[None]) & (lo[None] <= a_hi), axis=2)
        if face_only:
            overlap = np.minimum(a_hi, hi[None]) - np.maximum(a_lo, lo[None])
            touch &= np.count_nonzero(overlap > 0, axis=2) == dimension - 1
        difference = np.abs(levels[start:start + 256, None] - levels[None])
        if touch.any():
            best = max(best, int(difference[touch].max()))
    return best


# ------------------------------------------------------------------------------------------------
# ParaView pipelines

def proxies_by_xml_name(sources):
    """{XML name: [proxy]} of the proxies of paraview.simple.GetSources() given as `sources`."""
    found = {}
    for proxy in sources.values():
        found.setdefault(proxy.GetXMLName(), []).append(proxy)
    return found


# ------------------------------------------------------------------------------------------------
# Screenshots

def screenshot_coverage(path):
    """(the share of pixels that differ from the corner pixel's colour, the distinct colours) of
    a PNG screenshot, over every seventh pixel: a blank picture gives (0, 1)."""
    from vtkmodules.vtkIOImage import vtkPNGReader
    reader = vtkPNGReader()
    reader.SetFileName(path)
    reader.Update()
    pixels = reader.GetOutput().GetPointData().GetScalars()
    sample = [pixels.GetTuple(i) for i in range(0, pixels.GetNumberOfTuples(), 7)]
    background = pixels.GetTuple(0)
    covered = sum(1 for pixel in sample if pixel != background)
    return covered / len(sample), len(set(sample))


# ------------------------------------------------------------------------------------------------
# Events

class ErrorCollector:
    """Collects the messages of ErrorEvent (and WarningEvent) of one VTK object.

    With an observer on ErrorEvent, vtkErrorMacro hands the message to it instead of printing.
    """

    def __init__(self, obj):
        self.errors = []
        self.warnings = []
        self.tags = [
            obj.AddObserver(vtkCommand.ErrorEvent, self._on_error),
            obj.AddObserver(vtkCommand.WarningEvent, self._on_warning),
        ]
        self.obj = obj

    def _on_error(self, caller, event, message):
        self.errors.append(message)

    _on_error.CallDataType = VTK_STRING_CALLDATA

    def _on_warning(self, caller, event, message):
        self.warnings.append(message)

    _on_warning.CallDataType = VTK_STRING_CALLDATA

    def clear(self):
        del self.errors[:]
        del self.warnings[:]

    def remove(self):
        for tag in self.tags:
            self.obj.RemoveObserver(tag)


def is_hexahedral_spacetree(grid, dimension=3):
    types = cell_types(grid)
    expected = VTK_HEXAHEDRON if dimension == 3 else VTK_QUAD
    return len(types) > 0 and bool(np.all(types == expected))


def spacetree_chain(source):
    """ImageToSpacetree, SpacetreeBalance and SpacetreeTessellate after the image algorithm
    source, connected, all at their defaults and not yet updated. The package is imported here,
    not at the top, so that a test can load the plugin first."""
    import spacetreemesh

    tree = spacetreemesh.stmImageToSpacetree()
    tree.SetInputConnection(source.GetOutputPort())
    balance = spacetreemesh.stmSpacetreeBalance()
    balance.SetInputConnection(tree.GetOutputPort())
    tessellate = spacetreemesh.stmSpacetreeTessellate()
    tessellate.SetInputConnection(balance.GetOutputPort())
    return tree, balance, tessellate


def append_stages(stages, *classes):
    """Appends to the list `stages` a new object of each vtkAlgorithm class, each fed by the one
    before it; returns the last."""
    for cls in classes:
        stage = cls()
        stage.SetInputConnection(stages[-1].GetOutputPort())
        stages.append(stage)
    return stages[-1]


def gray_separating_function(upstream, gray_port, threshold):
    """stmSeparatingFunction after the algorithm upstream, in GRAY_IMAGE mode at `threshold`,
    sampling the image at the algorithm output gray_port; not yet updated."""
    import spacetreemesh

    function = spacetreemesh.stmSeparatingFunction()
    function.SetInputConnection(upstream.GetOutputPort())
    function.SetGrayImageConnection(gray_port)
    function.SetMode(spacetreemesh.stmSeparatingFunction.GRAY_IMAGE)
    function.SetThreshold(threshold)
    return function


def atlas_chain(path):
    """The reader of the NIfTI image at path and spacetree_chain after it."""
    from vtkmodules.vtkIOImage import vtkNIFTIImageReader

    reader = vtkNIFTIImageReader()
    reader.SetFileName(path)
    return (reader,) + spacetree_chain(reader)


def nested_ellipsoids(shape):
    """Nested ellipsoids (labels 1..3) in a [z, y, x] array, and a one-voxel layer of label 4."""
    z, y, x = np.meshgrid(*[np.arange(n) + 0.5 for n in shape], indexing="ij")
    centre = [n / 2.0 for n in shape]
    r = np.sqrt(sum(((c - m) / (0.45 * n)) ** 2 for c, m, n in zip((z, y, x), centre, shape)))
    labels = np.zeros(shape, dtype=np.uint8)
    labels[r < 1.0] = 1
    labels[r < 0.7] = 2
    labels[r < 0.4] = 3
    labels[(r >= 0.55) & (r < 0.55 + 1.0 / max(shape))] = 4
    return labels


def owned_cell_rows(mesh, nodes):
    """The cells with vtkGhostType 0, as sorted rows of their points' coordinates and material."""
    if mesh.GetNumberOfCells() == 0:
        return np.zeros((0, 3 * nodes + 1))
    coordinates = points(mesh)
    if mesh.IsA("vtkPolyData"):  # InterfaceSurface's facets
        cellsOf = mesh.GetPolys() if nodes == 3 else mesh.GetLines()
        conn = vtk_to_numpy(cellsOf.GetConnectivityArray()).reshape(-1, nodes)
    else:
        conn = connectivity(mesh, nodes)
    ghosts = mesh.GetCellData().GetArray(vtkDataSetAttributes.GhostArrayName())
    own = np.ones(len(conn), dtype=bool) if ghosts is None else vtk_to_numpy(ghosts) == 0
    if not own.any():
        return np.zeros((0, 3 * nodes + 1))
    corners = coordinates[conn[own]]  # (m, nodes, 3)
    order = np.lexsort((corners[:, :, 2], corners[:, :, 1], corners[:, :, 0]), axis=1)
    corners = np.take_along_axis(corners, order[:, :, None], axis=1).reshape(len(corners), -1)
    label = "BoundaryLabels" if mesh.GetCellData().GetArray("BoundaryLabels") else (
        "OriginalMaterial" if mesh.IsA("vtkPolyData") else "Material")
    columns = [corners, cell_array(mesh, label)[own]]
    if mesh.GetCellData().GetArray("RootColour") is not None:
        columns.append(cell_array(mesh, "RootColour")[own])
    rows = np.column_stack(columns)
    return rows[np.lexsort(rows.T[::-1])]
