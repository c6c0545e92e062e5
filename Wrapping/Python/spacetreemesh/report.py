"""A visual quality report of a mesh: histograms of the element quality per material, the mesh
cut by a plane, and a page that shows them with the figures.

From pvpython, pvbatch or Debian's /usr/bin/python3 (with python3-paraview and
python3-matplotlib)::

    from spacetreemesh import report
    report.write_report("brain.vtu", "out")          # or a vtkUnstructuredGrid

On the command line (stmesh --report DIR runs this after writing the mesh)::

    python3 -m spacetreemesh.report brain.vtu out [--summary summary.json]

It writes into the directory:

- ``quality.json``: per material the element count, the smallest minimum dihedral angle, the
  largest condition number and the histograms' counts; the same over all elements;
- ``quality_histograms.png``: the histograms of the minimum dihedral angle (degrees) and of the
  condition number (VTK's vtkMeshQuality measures: MinAngle and Condition of the tetrahedra, or of
  the triangles of a planar mesh), stacked and coloured per material;
- ``cut.png``: the elements cut by the plane through the mesh's centre normal to Axis (default
  z), each piece coloured by its material and outlined, so that the interior shows;
- ``index.html``: the two pictures, the figures per material and, with a summary (stmesh's
  --summary JSON), its stage times.

Nothing here needs a display: the pictures are drawn by matplotlib's Agg backend.
"""
import argparse
import html
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402
from vtkmodules.util.numpy_support import vtk_to_numpy  # noqa: E402
from vtkmodules.vtkCommonDataModel import (  # noqa: E402
    VTK_TETRA,
    VTK_TRIANGLE,
    vtkPlane,
    vtkUnstructuredGrid,
)
from vtkmodules.vtkFiltersCore import vtkCutter  # noqa: E402
from vtkmodules.vtkFiltersVerdict import vtkMeshQuality  # noqa: E402

ANGLE_BINS = np.linspace(0.0, 90.0, 46)  # 2 degrees wide
CONDITION_BINS = np.linspace(1.0, 5.0, 41)  # 0.1 wide; larger values land in the last bin


def read_mesh(path):
    """A vtkUnstructuredGrid from a .vtu (inline binary, as stmesh writes it) or legacy .vtk."""
    if path.endswith(".vtu"):
        from vtkmodules.vtkIOXML import vtkXMLUnstructuredGridReader as Reader
    elif path.endswith(".vtk"):
        from vtkmodules.vtkIOLegacy import vtkUnstructuredGridReader as Reader
    else:
        raise ValueError("the report reads .vtu or .vtk meshes, not %s" % path)
    reader = Reader()
    reader.SetFileName(path)
    reader.Update()
    grid = reader.GetOutput()
    if grid is None or grid.GetNumberOfCells() == 0:
        raise ValueError("%s holds no cells" % path)
    return grid


def material_colours(materials):
    """A colour per material, the same in every picture: light grey for the background (0),
    tab20's for up to 20 other materials, else hues spread by the golden ratio."""
    others = [m for m in materials if m != 0]
    if len(others) <= 20:
        palette = plt.get_cmap("tab20")
        colours = {m: palette(i % 20) for i, m in enumerate(others)}
    else:
        palette = plt.get_cmap("hsv")
        colours = {m: palette((i * 0.618034) % 1.0) for i, m in enumerate(others)}
    colours[0] = (0.85, 0.85, 0.85, 1.0)
    return colours


def element_quality(grid):
    """(cell types, materials, minimum dihedral angle in degrees, condition number) per cell;
    NaN for cells that are neither tetrahedra nor triangles."""
    measures = {}
    for name, tet, triangle in (("angle", "SetTetQualityMeasureToMinAngle",
                                 "SetTriangleQualityMeasureToMinAngle"),
                                ("condition", "SetTetQualityMeasureToCondition",
                                 "SetTriangleQualityMeasureToCondition")):
        quality = vtkMeshQuality()
        quality.SetInputData(grid)
        getattr(quality, tet)()
        getattr(quality, triangle)()
        quality.Update()
        measures[name] = vtk_to_numpy(
            quality.GetOutput().GetCellData().GetArray("Quality")).astype(float)
    types = vtk_to_numpy(grid.GetCellTypesArray())
    simplex = (types == VTK_TETRA) | (types == VTK_TRIANGLE)
    array = grid.GetCellData().GetArray("Material")
    materials = (vtk_to_numpy(array).astype(np.int64) if array is not None
                 else np.ones(grid.GetNumberOfCells(), dtype=np.int64))
    angle = np.where(simplex, measures["angle"], np.nan)
    condition = np.where(simplex, measures["condition"], np.nan)
    return types, materials, angle, condition


def histogram_figures(materials, angle, condition):
    """The per-material and overall figures (quality.json): one pass over the elements, each
    counted into its (material, bin) by np.bincount."""
    labels, index = np.unique(materials, return_inverse=True)
    valid = ~np.isnan(angle)
    figures = {"materials": [], "angle_bins": ANGLE_BINS.tolist(),
               "condition_bins": CONDITION_BINS.tolist()}

    def counts(values, bins):
        slot = np.clip(np.searchsorted(bins, values[valid], side="right") - 1, 0, len(bins) - 2)
        return np.bincount(index[valid] * (len(bins) - 1) + slot,
                           minlength=len(labels) * (len(bins) - 1)).reshape(len(labels), -1)

    angle_counts = counts(np.clip(angle, 0, 90), ANGLE_BINS)
    condition_counts = counts(np.clip(condition, 1, 5), CONDITION_BINS)
    elements = np.bincount(index, minlength=len(labels))
    measured = np.bincount(index[valid], minlength=len(labels))
    smallest = np.full(len(labels), np.inf)
    largest = np.full(len(labels), -np.inf)
    np.minimum.at(smallest, index[valid], angle[valid])
    np.maximum.at(largest, index[valid], condition[valid])

    def entry(i):
        count = int(measured[i])
        return {"material": int(labels[i]), "elements": int(elements[i]),
                "measured_elements": count,
                "min_dihedral_angle": float(smallest[i]) if count else None,
                "max_condition_number": float(largest[i]) if count else None,
                "angle_histogram": angle_counts[i].tolist(),
                "condition_histogram": condition_counts[i].tolist()}

    figures["materials"] = [entry(i) for i in range(len(labels))]
    total = int(valid.sum())
    figures["all"] = {"elements": int(len(materials)), "measured_elements": total,
                      "min_dihedral_angle": float(angle[valid].min()) if total else None,
                      "max_condition_number": float(condition[valid].max()) if total else None,
                      "angle_histogram": angle_counts.sum(axis=0).tolist(),
                      "condition_histogram": condition_counts.sum(axis=0).tolist()}
    return figures


def draw_histograms(figures, colours, path, names):
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5), dpi=100)
    for ax, key, bins, label in ((axes[0], "angle_histogram", ANGLE_BINS,
                                  "minimum dihedral angle (degrees)"),
                                 (axes[1], "condition_histogram", CONDITION_BINS,
                                  "condition number (5 and above in the last bin)")):
        bottom = np.zeros(len(bins) - 1)
        for entry in figures["materials"]:
            top = bottom + np.array(entry[key], dtype=float)
            ax.stairs(top, bins, baseline=bottom, fill=True, color=colours[entry["material"]],
                      label=names.get(entry["material"], "Material %d" % entry["material"]))
            bottom = top
        ax.set_xlabel(label)
        ax.set_ylabel("elements")
        ax.set_yscale("symlog", linthresh=10)
    overall = figures["all"]
    fig.suptitle("%d elements: smallest dihedral angle %.2f degrees, worst condition number %.3f"
                 % (overall["measured_elements"], overall["min_dihedral_angle"] or float("nan"),
                    overall["max_condition_number"] or float("nan")))
    if len(figures["materials"]) <= 12:
        axes[1].legend(fontsize="small")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def draw_cut(grid, colours, path, axis=2, names=None):
    """The elements cut by the plane through the centre of the bounds, normal to `axis`."""
    bounds = grid.GetBounds()
    centre = [(bounds[2 * a] + bounds[2 * a + 1]) / 2 for a in range(3)]
    plane = vtkPlane()
    plane.SetOrigin(centre)
    normal = [0.0, 0.0, 0.0]
    normal[axis] = 1.0
    plane.SetNormal(normal)
    cutter = vtkCutter()
    cutter.SetInputData(grid)
    cutter.SetCutFunction(plane)
    cutter.GenerateTrianglesOff()
    cutter.Update()
    section = cutter.GetOutput()
    kept = [a for a in range(3) if a != axis]
    points = vtk_to_numpy(section.GetPoints().GetData())[:, kept] if section.GetNumberOfPoints() \
        else np.zeros((0, 2))
    array = section.GetCellData().GetArray("Material")
    polys = section.GetPolys()
    offsets = vtk_to_numpy(polys.GetOffsetsArray())
    connectivity = vtk_to_numpy(polys.GetConnectivityArray())
    polygons = np.split(points[connectivity], offsets[1:-1]) if len(offsets) > 1 else []
    labels = vtk_to_numpy(array).astype(np.int64) if array is not None else \
        np.ones(len(polygons), dtype=np.int64)
    faces = [colours.get(int(label), (0.5, 0.5, 0.5, 1)) for label in labels[:len(polygons)]]
    width = bounds[2 * kept[0] + 1] - bounds[2 * kept[0]]
    height = bounds[2 * kept[1] + 1] - bounds[2 * kept[1]]
    scale = 9.0 / max(width, height, 1e-30)
    fig, ax = plt.subplots(figsize=(max(3.0, width * scale), max(3.0, height * scale)), dpi=110)
    edge = 0.1 if len(polygons) > 20000 else 0.3
    ax.add_collection(PolyCollection(polygons, facecolors=faces, edgecolors="black",
                                     linewidths=edge))
    ax.set_xlim(bounds[2 * kept[0]], bounds[2 * kept[0] + 1])
    ax.set_ylim(bounds[2 * kept[1]], bounds[2 * kept[1] + 1])
    ax.set_aspect("equal")
    axis_names = "xyz"
    ax.set_xlabel(axis_names[kept[0]])
    ax.set_ylabel(axis_names[kept[1]])
    ax.set_title("the elements cut at %s = %.4g (%d pieces)" % (axis_names[axis], centre[axis],
                                                                len(polygons)))
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return len(polygons)


def material_names(grid):
    """{label: name} of the mesh's label table (stmLabelTable's field data), if any."""
    field = grid.GetFieldData()
    names = field.GetAbstractArray("MaterialNames")
    labels = field.GetArray("MaterialNameLabels")
    if names is None or labels is None:
        return {}
    return {int(labels.GetTuple1(i)): names.GetValue(i) for i in range(names.GetNumberOfValues())}


def write_page(directory, figures, names, summary, pieces, title):
    rows = []
    for entry in figures["materials"]:
        label = entry["material"]
        rows.append("<tr><td>%d</td><td>%s</td><td>%d</td><td>%s</td><td>%s</td></tr>" % (
            label, html.escape(names.get(label, "")), entry["elements"],
            "%.2f" % entry["min_dihedral_angle"] if entry["min_dihedral_angle"] is not None
            else "", "%.3f" % entry["max_condition_number"]
            if entry["max_condition_number"] is not None else ""))
    stages = ""
    if summary:
        stages = "<h2>Run</h2><table><tr><th>stage</th><th>seconds</th></tr>%s</table>" % "".join(
            "<tr><td>%s</td><td>%.3f</td></tr>" % (html.escape(stage["name"]), stage["seconds"])
            for stage in summary.get("stages", []) if not stage.get("skipped"))
        stages += "<p>total %.3f s; <a href=\"summary.json\">summary.json</a></p>" % summary.get(
            "total_seconds", float("nan"))
    overall = figures["all"]
    page = """<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>%(title)s</title>
<style>body{font-family:sans-serif;margin:2em}img{max-width:100%%;border:1px solid #ccc}
table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 8px;text-align:right}</style>
</head><body>
<h1>%(title)s</h1>
<p>%(elements)d elements; smallest minimum dihedral angle %(angle).2f degrees; worst condition
number %(condition).3f (vtkMeshQuality, over the tetrahedra or triangles).</p>
<h2>Element quality per material</h2>
<img src="quality_histograms.png" alt="histograms of the element quality">
<h2>The mesh cut by a plane</h2>
<img src="cut.png" alt="the elements cut by a plane, coloured per material">
<p>%(pieces)d cut elements.</p>
<h2>Materials</h2>
<table><tr><th>label</th><th>name</th><th>elements</th><th>smallest dihedral angle</th>
<th>worst condition number</th></tr>
%(rows)s
</table>
%(stages)s
<p>Figures: <a href="quality.json">quality.json</a>.</p>
</body></html>
""" % dict(title=html.escape(title), elements=overall["elements"],
           angle=overall["min_dihedral_angle"] or float("nan"),
           condition=overall["max_condition_number"] or float("nan"), rows="\n".join(rows),
           stages=stages, pieces=pieces)
    with open(os.path.join(directory, "index.html"), "w") as out:
        out.write(page)


def write_report(mesh, directory, summary=None, axis=2, title=None):
    """Writes the report of `mesh` (a vtkUnstructuredGrid or the path of a .vtu/.vtk file) into
    `directory` (made if needed). summary: stmesh's summary (a dict or the path of its JSON).
    Returns the figures written to quality.json."""
    path = mesh if isinstance(mesh, str) else None
    grid = read_mesh(mesh) if path else mesh
    if not isinstance(grid, vtkUnstructuredGrid) or grid.GetNumberOfCells() == 0:
        raise ValueError("the report needs an unstructured grid with cells")
    if isinstance(summary, str):
        with open(summary) as source:
            summary = json.load(source)
    os.makedirs(directory, exist_ok=True)
    names = material_names(grid)
    _, materials, angle, condition = element_quality(grid)
    figures = histogram_figures(materials, angle, condition)
    colours = material_colours([entry["material"] for entry in figures["materials"]])
    draw_histograms(figures, colours, os.path.join(directory, "quality_histograms.png"), names)
    pieces = draw_cut(grid, colours, os.path.join(directory, "cut.png"), axis, names)
    figures["cut_pieces"] = pieces
    with open(os.path.join(directory, "quality.json"), "w") as out:
        json.dump(figures, out, indent=1)
    write_page(directory, figures, names, summary, pieces,
               title or "Mesh report: %s" % (os.path.basename(path) if path else "mesh"))
    return figures


def main(arguments=None):
    parser = argparse.ArgumentParser(description="A visual quality report of a mesh.")
    parser.add_argument("mesh", help="the mesh (.vtu or .vtk)")
    parser.add_argument("directory", help="where the report goes")
    parser.add_argument("--summary", help="stmesh's summary JSON, shown on the page")
    parser.add_argument("--axis", type=int, default=2, choices=(0, 1, 2),
                        help="the axis the cut plane is normal to (default 2: z)")
    parser.add_argument("--title", help="the page's title")
    options = parser.parse_args(arguments)
    try:
        write_report(options.mesh, options.directory, options.summary, options.axis,
                     options.title)
    except (OSError, ValueError) as error:
        print("report: error: %s" % error, file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
