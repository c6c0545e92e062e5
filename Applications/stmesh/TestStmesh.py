#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-3-Clause
"""Command-line tests of stmesh; one ctest per case (stmesh.<case>).

Usage: TestStmesh.py --stmesh EXE --helper EXE --aal AAL.nii.gz --work DIR CASE

Each case runs stmesh in a fresh DIR and checks the exit code, the messages and the files
written; meshes are read back with stmeshTestHelper (VTK readers), which also writes the small
label images used for the format and error cases. The cases of --elements, --templates,
--cell-template and --boundary-layer write their own label images and read the meshes back with
the VTK Python modules (Debian's python3 sees them; CMake runs this script with it). Exits 0 when
the case passes. The cut cases (--separating, --output-mode, --keep, --iso) do the same and
also read surfaces back; the cases that check the staircase tessellation pass --separating none.
"""

import argparse
import gzip
import json
import math
import os
import random
import re
import shutil
import struct
import subprocess
import sys

ERROR_PREFIX = "stmesh: error:"
TRIANGLE, QUAD, TETRA, HEXAHEDRON, PYRAMID = 5, 9, 10, 12, 14
CELL_TYPE_NAMES = {TRIANGLE: "triangle", QUAD: "quad", TETRA: "tetra", HEXAHEDRON: "hexahedron",
                   PYRAMID: "pyramid"}
STAGES_TESSELLATE = ["read", "spacetree", "balance", "tessellate", "write"]
# --stop-after cut: no smooth stage.
STAGES_CUT = ["read", "spacetree", "balance", "tessellate", "snap", "cut", "write"]
# The default pipeline with a separating function: snap before the cut, smooth after it.
STAGES_ALL = ["read", "spacetree", "balance", "tessellate", "snap", "cut", "smooth", "write"]
# The staircase mesh of the voxels, as before the cut stage existed: the cases that check exact
# tessellation counts, stages or volumes per label give this.
STAIRCASE = ["--separating", "none"]
# The spacetree parameters of the summary when none of their options is given.
DEFAULT_SPACETREE_PARAMETERS = {
    "pattern": "auto", "root_cell_size": None, "max_cell_size_labels": {},
    "refine_region": None, "grading": None, "sizing_array": None, "balance_labels": {},
    "balance_region": None}
# The tessellation parameters of the summary when none of their options is given.
DEFAULT_TESSELLATE_PARAMETERS = {
    "elements": "simplicial", "templates": "regular", "cell_template": "checkerboard",
    "boundary_layers": 0}
# The cut parameters of the summary when none of their options is given, and with STAIRCASE.
DEFAULT_CUT_PARAMETERS = {"separating": "labels", "materials": "merged", "thin_parts": "refine",
                          "output_mode": "volume",
                          "keep": "both",
                          "iso": 0, "alpha": 1.0 / 3.0, "snap": "quality",
                          "smooth_iterations": 20, "smooth_method": "taubin"}
STAIRCASE_CUT_PARAMETERS = dict(DEFAULT_CUT_PARAMETERS, separating="none")
# The label merging and structure report parameters of the summary when none of their options
# is given.
DEFAULT_LABEL_PARAMETERS = {"merge": [], "min_component_voxels": 1, "interfaces": None,
                            "background": "keep", "msh_format": "ascii"}


class CaseFailed(Exception):
    pass


def check(condition, message):
    if not condition:
        raise CaseFailed(message)


class Context:
    def __init__(self, arguments):
        self.stmesh = arguments.stmesh
        self.helper = arguments.helper
        self.aal = arguments.aal
        self.work = arguments.work

    def path(self, name):
        return os.path.join(self.work, name)

    def run(self, arguments, env_changes=None, cwd=None):
        """Run stmesh; returns (exit code, stdout, stderr)."""
        env = dict(os.environ)
        # The tests choose these themselves.
        env.pop("VTK_SMP_BACKEND_IN_USE", None)
        env.pop("VTK_SMP_MAX_THREADS", None)
        env.pop("GLIBC_TUNABLES", None)
        env.update(env_changes or {})
        completed = subprocess.run([self.stmesh] + arguments, capture_output=True, text=True,
                                   env=env, cwd=cwd or self.work, timeout=280)
        print("$ stmesh " + " ".join(arguments))
        print(completed.stdout, end="")
        print(completed.stderr, end="", file=sys.stderr)
        check(completed.returncode >= 0,
              "stmesh was killed by signal %d (crash?)" % -completed.returncode)
        return completed.returncode, completed.stdout, completed.stderr

    def run_ok(self, arguments, **keywords):
        code, out, err = self.run(arguments, **keywords)
        check(code == 0, "expected exit code 0, got %d" % code)
        check(ERROR_PREFIX not in err, "unexpected error message on stderr")
        return out, err

    def run_failing(self, arguments, expected_code, expected_text=None, output=None, **keywords):
        """Run stmesh expecting a clean failure: the exit code, an error line on stderr (with
        expected_text if given), nothing on stdout that looks like a finished table, and no
        output file (nor a temporary one) left behind."""
        code, out, err = self.run(arguments, **keywords)
        check(code == expected_code,
              "expected exit code %d, got %d" % (expected_code, code))
        error_lines = [line for line in err.splitlines() if line.startswith(ERROR_PREFIX)]
        check(error_lines, "no line starting with '%s' on stderr" % ERROR_PREFIX)
        if expected_text is not None:
            check(any(expected_text in line for line in error_lines),
                  "stderr does not mention %r" % expected_text)
        check("\ntotal " not in out, "stdout shows a total line although the run failed")
        if output is not None:
            check(not os.path.exists(output), "%s was created although the run failed" % output)
        leftovers = [name for name in os.listdir(self.work) if ".tmp-" in name]
        check(not leftovers, "temporary files left behind: %s" % leftovers)
        return err

    def read_back(self, mesh, geometry=False):
        """The helper's read-back; with geometry also the measures and edges per material."""
        completed = subprocess.run([self.helper, "readback", mesh] +
                                   (["geometry"] if geometry else []), capture_output=True,
                                   text=True, timeout=100)
        check(completed.returncode == 0,
              "cannot read back %s: %s" % (mesh, completed.stderr.strip()))
        return json.loads(completed.stdout)

    def make_image(self, name, scalar_type="uint8", variant=None):
        # VTK's writers choose the layout by lower-case extension (vtkMetaImageWriter turns
        # "x.MHA" into "x.mhd" + "x.raw"), so write "x.mha" and rename it for upper-case tests.
        path = self.path(name)
        written = self.path(name.lower())
        completed = subprocess.run([self.helper, "make-image", written, scalar_type] +
                                   ([variant] if variant else []),
                                   capture_output=True, text=True, timeout=100)
        check(completed.returncode == 0,
              "cannot write test image %s: %s" % (name, completed.stderr.strip()))
        os.rename(written, path)
        return path

    def decompressed_aal(self):
        path = self.path("aal.nii")
        with gzip.open(self.aal, "rb") as source, open(path, "wb") as target:
            shutil.copyfileobj(source, target)
        return path


def load_summary(path):
    # Exactly the validity check of the specification, then the parse used for the checks.
    completed = subprocess.run(
        ["/usr/bin/python3", "-c", "import json,sys; json.load(open(sys.argv[1]))", path],
        capture_output=True, text=True)
    check(completed.returncode == 0, "%s is not valid JSON: %s" % (path, completed.stderr))
    with open(path) as summary_file:
        return json.load(summary_file)


def smooth_line(smooth):
    """The smooth stage's figures as stmesh prints them."""
    line = "smooth: %d moved points, %d rejected moves" % (smooth["moved_points"],
                                                          smooth["rejected_moves"])
    if smooth["improved_points"] > 0:
        line += ", %d quality improvement moves" % smooth["improved_points"]
    if smooth["split_edges"] > 0:
        line += ", %d split edges" % smooth["split_edges"]
    if smooth["kept_points"] > 0:
        line += ", %d points kept for small parts" % smooth["kept_points"]
    return line


def stage(summary, name):
    matches = [entry for entry in summary["stages"] if entry["name"] == name]
    check(len(matches) == 1, "summary has %d stages named %s" % (len(matches), name))
    return matches[0]


def check_table(out, stages):
    """The per-stage table: a header, one line per stage, a total line."""
    lines = out.splitlines()
    header = [i for i, line in enumerate(lines) if line.startswith("stage ")]
    check(len(header) == 1, "no table header in stdout")
    rows = lines[header[0] + 1:header[0] + 2 + len(stages)]
    check([row.split()[0] for row in rows] == stages + ["total"],
          "table rows are %s, expected %s" % ([r.split()[0] for r in rows], stages + ["total"]))
    for row in rows:
        seconds = row.split()[1]
        check(seconds == "-" or (len(seconds.split(".")[-1]) == 3 and float(seconds) >= 0),
              "bad seconds column in %r" % row)


def check_mesh_against_summary(mesh, summary, cell_type, key):
    data = mesh
    check(data["cell_types"] == [cell_type],
          "cell types %s, expected [%d]" % (data["cell_types"], cell_type))
    check("Material" in data["cell_arrays"], "no cell array Material")
    last = [entry for entry in summary["stages"] if entry["name"] != "write" and
            not entry["skipped"]][-1]
    check(data["cells"] == last["cells"],
          "read back %d cells, summary says %d" % (data["cells"], last["cells"]))
    check(data["points"] == last["points"],
          "read back %d points, summary says %d" % (data["points"], last["points"]))
    counts = summary[key]
    check(counts == data["material_counts"], "per-material counts differ from the file")
    check(sum(counts.values()) == data["cells"], "per-material counts do not add up")


# ------------------------------------------------------------------------------------------------
# Cases.

def case_help_and_version(c):
    out, _ = c.run_ok(["--help"])
    check(out.startswith("Usage: stmesh [INPUT]"), "help does not start with the usage")
    for option in ["-o OUTPUT", "--labels", "--max-cell-size", "--balance", "--stop-after",
                   "--threads", "--summary", "--version", "--pattern P",
                   "--root-cell-size X,Y,Z", "--max-cell-size-label L:S", "--refine-region",
                   "box:X0,Y0,Z0,X1,Y1,Z1", "sphere:CX,CY,CZ,R", "cylinder:CX,CY,CZ,AX,AY,AZ,R",
                   "slab:PX,PY,PZ,NX,NY,NZ,W", "--grading G", "--sizing-array NAME",
                   "--balance-label L:LEVEL", "--balance-region REGION:LEVEL",
                   "--elements simplicial|hybrid|leaves", "--templates midpoint|regular|extended",
                   "--cell-template checkerboard|kuhn", "--boundary-layer N",
                   "--separating labels|smooth:SIGMA|gray:FILE:ISO|sphere:CX,CY,CZ,R|none",
                   "--output-mode volume|surface", "--keep both|inside|outside", "--iso V",
                   "--alpha A", "--snap threshold|quality|none", "--smooth-iterations N",
                   "--smooth-method taubin|laplacian",
                   "--stop-after spacetree|balance|tessellate|snap|cut|smooth",
                   "--labels 1,2,5|all", "--merge S1,S2,...:T", "--merge 1,2,3:10 --merge 5,6:11",
                   "--min-component-voxels N", "--interfaces FILE",
                   "--keep-memory auto|yes|no"]:
        check(option in out, "help does not mention %s" % option)
    out, _ = c.run_ok(["-h"])
    check(out.startswith("Usage: stmesh"), "-h does not print the usage")
    out, _ = c.run_ok(["--version"])
    check(out.startswith("stmesh (SpacetreeMesh) "), "bad --version output %r" % out)


def case_default_input_vtu(c):
    output, summary_path = c.path("aal.vtu"), c.path("aal.json")
    out, _ = c.run_ok(["-o", output, "--summary", summary_path] + STAIRCASE)
    check("no INPUT given; meshing the default image " + c.aal in out,
          "no line saying the default image is meshed")
    check_table(out, STAGES_TESSELLATE)
    summary = load_summary(summary_path)
    check(summary["default_input"] is True and summary["input"] == c.aal, "bad input in summary")
    check(summary["output"] == output, "bad output in summary")
    check(summary["parameters"] == dict(
        {"labels": [], "all_labels": True, "max_cell_size": 16, "balance": 1,
         "stop_after": "tessellate", "compressor": "lz4"}, **DEFAULT_SPACETREE_PARAMETERS,
        **DEFAULT_TESSELLATE_PARAMETERS, **STAIRCASE_CUT_PARAMETERS,
        **DEFAULT_LABEL_PARAMETERS),
        "bad parameters %s" % summary["parameters"])
    # 1 mm voxels, MaxCellSize 16: cubes of 16 down to 1 voxel.
    check(summary["voxel_subdivision"] == [1, 1, 1], "bad voxel subdivision")
    check(summary["cell_sizes_voxels"] == [[16, 16, 16], [8, 8, 8], [4, 4, 4], [2, 2, 2],
                                           [1, 1, 1]],
          "bad cell sizes %s" % summary["cell_sizes_voxels"])
    check([entry["name"] for entry in summary["stages"]] == STAGES_TESSELLATE, "bad stages")
    check(summary["image"]["dimensions"] == [181, 217, 181], "bad image dimensions")
    check(stage(summary, "write")["file_bytes"] == os.path.getsize(output), "bad file size")
    check(stage(summary, "balance")["leaves"] >= stage(summary, "spacetree")["leaves"],
          "balancing removed leaves")
    tessellate = stage(summary, "tessellate")
    check(str(tessellate["cells"]) in out, "the table does not show the cell count")
    mesh = c.read_back(output)
    check_mesh_against_summary(mesh, summary, TETRA, "tetrahedra_per_material")
    # AAL has 116 regions; every one is in the body by default.
    check(len(summary["tetrahedra_per_material"]) == 116,
          "%d materials, expected the 116 AAL regions" % len(summary["tetrahedra_per_material"]))
    with open(output, "rb") as mesh_file:
        content = mesh_file.read()
    head = content[:4096]
    check(b'format="binary"' in head and b'format="appended"' not in content
          and b"<AppendedData" not in content, "the .vtu is not in inline binary mode")
    check(b'compressor="vtkLZ4DataCompressor"' in head, "the .vtu is not LZ4-compressed (the default)")


def case_legacy_vtk(c):
    output, summary_path = c.path("aal_1_2.vtk"), c.path("aal_1_2.json")
    out, _ = c.run_ok([c.aal, "-o", output, "--labels", "1,2", "--threads", "2",
                       "--summary", summary_path] + STAIRCASE)
    check_table(out, STAGES_TESSELLATE)
    summary = load_summary(summary_path)
    check(summary["threads"] == 2, "--threads 2 gave %s threads" % summary["threads"])
    check(summary["parameters"]["labels"] == [1, 2], "bad labels in summary")
    with open(output, "rb") as mesh_file:
        head = mesh_file.read(256)
    check(head.startswith(b"# vtk DataFile Version") and b"\nBINARY\n" in head,
          "not a binary legacy VTK file")
    mesh = c.read_back(output)
    check_mesh_against_summary(mesh, summary, TETRA, "tetrahedra_per_material")
    check(sorted(mesh["material_counts"]) == ["1", "2"], "materials other than 1 and 2")


def case_stop_after_spacetree(c):
    output, summary_path = c.path("tree.vtu"), c.path("tree.json")
    # Two regions keep the file small; the background leaves still fill the whole root grid.
    out, _ = c.run_ok([c.aal, "-o", output, "--stop-after", "spacetree", "--labels", "3,4",
                       "--summary", summary_path])
    check_table(out, ["read", "spacetree", "write"])
    summary = load_summary(summary_path)
    spacetree = stage(summary, "spacetree")
    check(spacetree["leaves"] == spacetree["cells"] > 0, "bad leaf count")
    check(str(spacetree["leaves"]) + " leaves" in out, "the table does not show the leaves")
    mesh = c.read_back(output)
    check_mesh_against_summary(mesh, summary, HEXAHEDRON, "leaves_per_material")
    check("Level" in mesh["cell_arrays"], "the spacetree has no Level array")


def case_stop_after_balance_unbalanced(c):
    image = c.make_image("labels.vti")
    tree, tree_summary = c.path("tree.vtu"), c.path("tree.json")
    c.run_ok([image, "-o", tree, "--stop-after", "spacetree", "--max-cell-size", "8",
              "--summary", tree_summary])
    output, summary_path = c.path("unbalanced.vtk"), c.path("unbalanced.json")
    out, _ = c.run_ok([image, "-o", output, "--stop-after", "balance", "--balance", "0",
                       "--max-cell-size", "8", "--summary", summary_path])
    check_table(out, ["read", "spacetree", "balance", "write"])
    check("skipped" in out, "the table does not say balancing was skipped")
    summary = load_summary(summary_path)
    check(stage(summary, "balance")["skipped"] is True, "balance not marked skipped")
    mesh = c.read_back(output)
    check_mesh_against_summary(mesh, summary, HEXAHEDRON, "leaves_per_material")
    check(mesh["cells"] == c.read_back(tree)["cells"],
          "--balance 0 changed the spacetree")
    balanced, balanced_summary = c.path("balanced.vtu"), c.path("balanced.json")
    c.run_ok([image, "-o", balanced, "--stop-after", "balance", "--balance", "1",
              "--max-cell-size", "8", "--summary", balanced_summary])
    check(load_summary(balanced_summary)["stages"][2]["skipped"] is False, "balance skipped")


def case_input_formats(c):
    reference = None
    for name, scalar_type in [("labels.vti", "uint8"), ("labels.mha", "int16"),
                              ("labels.mhd", "uint8"), ("labels.nrrd", "int16"),
                              ("labels.nii", "uint8"), ("labels.nii.gz", "int16"),
                              ("UPPER.NII.GZ", "uint8"), ("Upper.MHA", "uint8")]:
        image = c.make_image(name, scalar_type)
        output = c.path(name.replace(".", "_") + ".vtu")
        summary_path = output + ".json"
        c.run_ok([image, "-o", output, "--summary", summary_path] + STAIRCASE)
        summary = load_summary(summary_path)
        mesh = c.read_back(output)
        check_mesh_against_summary(mesh, summary, TETRA, "tetrahedra_per_material")
        check(sorted(mesh["material_counts"]) == ["1", "2", "7"],
              "%s: materials %s" % (name, sorted(mesh["material_counts"])))
        if reference is None:
            reference = mesh
        check(mesh == reference, "%s gives a different mesh than labels.vti" % name)

    # Every compressor writes the same mesh; each file names its compressor.
    image = c.make_image("compressors.vti", "uint8")
    for compressor, marker in [("lz4", b'compressor="vtkLZ4DataCompressor"'),
                               ("zlib", b'compressor="vtkZLibDataCompressor"'),
                               ("none", None)]:
        output = c.path("compressor_%s.vtu" % compressor)
        c.run_ok([image, "-o", output, "--compressor", compressor] + STAIRCASE)
        with open(output, "rb") as mesh_file:
            head = mesh_file.read(4096)
        if marker:
            check(marker in head, "--compressor %s: %s missing" % (compressor, marker))
        else:
            check(b"compressor=" not in head, "--compressor none: the file names a compressor")
        check(c.read_back(output) == reference, "--compressor %s changes the mesh" % compressor)


def case_default_output_name(c):
    image = c.make_image("phantom.nii.gz")
    c.run_ok([image])
    check(os.path.exists(c.path("phantom.vtu")), "phantom.vtu not written in the cwd")
    check(c.read_back(c.path("phantom.vtu"))["cell_types"] == [TETRA], "not a tetra mesh")
    subdirectory = c.path("sub")
    os.mkdir(subdirectory)
    image = c.make_image("Other.MHD")
    c.run_ok([image], cwd=subdirectory)
    check(os.listdir(subdirectory) == ["Other.vtu"],
          "expected only Other.vtu in the cwd, found %s" % os.listdir(subdirectory))


def case_threads_and_environment(c):
    image = c.make_image("labels.nrrd")
    results = {}
    for label, arguments, env in [
            ("one", ["--threads", "1"], {}),
            ("two", ["--threads", "2"], {}),
            ("env_max", [], {"VTK_SMP_MAX_THREADS": "1"}),
            ("env_backend", [], {"VTK_SMP_BACKEND_IN_USE": "Sequential"}),
            ("default", [], {}),
            ("glibc_defaults", [], {"GLIBC_TUNABLES": ""}),
            ("own_tunables", [], {"GLIBC_TUNABLES": "glibc.malloc.tcache_count=0"})]:
        output, summary_path = c.path(label + ".vtu"), c.path(label + ".json")
        c.run_ok([image, "-o", output, "--summary", summary_path] + arguments, env_changes=env)
        results[label] = (load_summary(summary_path), c.read_back(output))
    check(results["one"][0]["threads"] == 1, "--threads 1 not honoured")
    check(results["two"][0]["threads"] == 2, "--threads 2 not honoured")
    check(results["env_max"][0]["threads"] == 1, "VTK_SMP_MAX_THREADS not honoured")
    check(results["env_backend"][0]["smp_backend"] == "Sequential",
          "VTK_SMP_BACKEND_IN_USE not honoured")
    check(results["default"][0]["smp_backend"] == "STDThread", "STDThread not the default")
    # stmesh keeps glibc's allocator as the environment sets it (docs/performance.md).
    check(results["default"][0]["malloc_tunables"] == "",
          "malloc tunables without GLIBC_TUNABLES: %s" % results["default"][0]["malloc_tunables"])
    check(results["glibc_defaults"][0]["malloc_tunables"] == "",
          "an empty GLIBC_TUNABLES not kept")
    check(results["own_tunables"][0]["malloc_tunables"] == "glibc.malloc.tcache_count=0",
          "the user's GLIBC_TUNABLES not kept")
    cores = sorted(os.sched_getaffinity(0))
    check(results["default"][0]["threads"] == len(cores),
          "default threads %d, cores %d" % (results["default"][0]["threads"], len(cores)))
    if len(cores) > 1:
        # A process bound to one core (taskset; the child inherits the binding) runs one thread.
        os.sched_setaffinity(0, cores[:1])
        try:
            c.run_ok([image, "-o", c.path("bound.vtu"), "--summary", c.path("bound.json")])
        finally:
            os.sched_setaffinity(0, cores)
        results["bound"] = (load_summary(c.path("bound.json")), c.read_back(c.path("bound.vtu")))
        check(results["bound"][0]["threads"] == 1,
              "bound to one core: %d threads" % results["bound"][0]["threads"])
    meshes = [mesh for _, mesh in results.values()]
    check(all(mesh == meshes[0] for mesh in meshes), "the mesh depends on the threads")
    c.run_failing([image, "-o", c.path("bad_env.vtu")], 1, "VTK_SMP_MAX_THREADS",
                  output=c.path("bad_env.vtu"), env_changes={"VTK_SMP_MAX_THREADS": "many"})


def case_summary_json(c):
    image = c.make_image("labels.mha", "int16")
    output, summary_path = c.path("mesh.vtu"), c.path("summary.json")
    c.run_ok([image, "-o", output, "--labels", "2,7", "--max-cell-size", "4", "--balance", "2",
              "--summary", summary_path] + STAIRCASE)
    summary = load_summary(summary_path)
    for key in ["input", "output", "parameters", "threads", "stages", "total_seconds",
                "tetrahedra_per_material"]:
        check(key in summary, "summary lacks %s" % key)
    check(summary["parameters"] == dict(
        {"labels": [2, 7], "all_labels": False, "max_cell_size": 4, "balance": 2,
         "stop_after": "tessellate", "compressor": "lz4"}, **DEFAULT_SPACETREE_PARAMETERS,
        **DEFAULT_TESSELLATE_PARAMETERS, **STAIRCASE_CUT_PARAMETERS,
        **DEFAULT_LABEL_PARAMETERS),
        "bad parameters %s" % summary["parameters"])
    check(summary["spacetree_axes"] == [0, 1, 2], "bad spacetree axes")
    check(summary["voxel_subdivision"] == [1, 1, 1], "bad voxel subdivision")
    check(summary["cell_sizes_voxels"] == [[4, 4, 4], [2, 2, 2], [1, 1, 1]],
          "bad cell sizes %s" % summary["cell_sizes_voxels"])
    for entry in summary["stages"]:
        for key in ["name", "seconds", "cells", "points", "leaves", "peak_rss_mib"]:
            check(key in entry, "stage %s lacks %s" % (entry.get("name"), key))
        check(entry["peak_rss_mib"] > 0, "no peak memory for %s" % entry["name"])
        faults = entry["minor_page_faults"]
        check(faults is None if entry["skipped"] else isinstance(faults, int) and faults >= 0,
              "bad minor_page_faults %s for %s" % (faults, entry["name"]))
    check(sum(e["minor_page_faults"] or 0 for e in summary["stages"]) > 0,
          "the stages report no page faults")
    check(summary["total_seconds"] >= sum(e["seconds"] for e in summary["stages"]) * 0.99,
          "total shorter than the stages")
    check(sorted(summary["tetrahedra_per_material"]) == ["2", "7"], "bad materials")
    check_mesh_against_summary(c.read_back(output), summary, TETRA, "tetrahedra_per_material")
    # The tessellate stage's own figures; the volume share of hexahedra only for hybrid and
    # leaves output.
    tessellate = stage(summary, "tessellate")
    check(tessellate["cells_by_type"] == {"tetra": tessellate["cells"]},
          "bad cells_by_type %s" % tessellate["cells_by_type"])
    check(isinstance(tessellate["inserted_points"], int) and
          0 < tessellate["inserted_points"] < tessellate["points"],
          "bad inserted_points %s" % tessellate["inserted_points"])
    check("hexahedron_volume_fraction" not in tessellate,
          "hexahedron_volume_fraction in a simplicial run")
    check(tessellate["boundary_layers"] == 0,
          "boundary_layers %s without a separating function" % tessellate["boundary_layers"])
    for entry in summary["stages"]:
        if entry["name"] != "tessellate":
            check("inserted_points" not in entry and "cells_by_type" not in entry,
                  "stage %s has tessellation figures" % entry["name"])
        check("split_cells" not in entry, "stage %s has cut figures" % entry["name"])
    c.run_failing([image, "-o", c.path("same.vtu"), "--summary", c.path("same.vtu")], 1,
                  "same file", output=c.path("same.vtu"))
    # An unwritable summary fails before any meshing.
    c.run_failing([image, "-o", c.path("m2.vtu"), "--summary", c.path("no/such/dir/s.json")], 1,
                  "does not exist", output=c.path("m2.vtu"))


def case_error_missing_input(c):
    c.run_failing([c.path("missing.nii.gz"), "-o", c.path("out.vtu")], 1,
                  "No such file or directory", output=c.path("out.vtu"))


def case_error_unsupported_extension(c):
    path = c.path("labels.png")
    with open(path, "wb") as image_file:
        image_file.write(b"\x89PNG\r\n\x1a\n" + bytes(100))
    c.run_failing([path, "-o", c.path("out.vtu")], 1, "unsupported extension",
                  output=c.path("out.vtu"))


def case_error_corrupt_nii_gz(c):
    path = c.path("bad.nii.gz")
    with open(path, "wb") as image_file:
        image_file.write(random.Random(20240611).randbytes(64))
    c.run_failing([path, "-o", c.path("out.vtu")], 1, "bad.nii.gz", output=c.path("out.vtu"))
    # The default output name must not appear either.
    check(not os.path.exists(c.path("bad.vtu")), "bad.vtu created")
    c.run_failing([path], 1, "bad.nii.gz", output=c.path("bad.vtu"))


def case_error_truncated_nii(c):
    with open(c.decompressed_aal(), "rb") as complete:
        head = complete.read(200)
    path = c.path("truncated.nii")
    with open(path, "wb") as image_file:
        image_file.write(head)
    c.run_failing([path, "-o", c.path("out.vtu")], 1, "truncated.nii", output=c.path("out.vtu"))


def case_error_truncated_nii_data(c):
    # A complete header, but only half the voxels.
    with open(c.decompressed_aal(), "rb") as complete:
        data = complete.read()
    path = c.path("halfdata.nii")
    with open(path, "wb") as image_file:
        image_file.write(data[:len(data) // 2])
    c.run_failing([path, "-o", c.path("out.vtu")], 1, "halfdata.nii", output=c.path("out.vtu"))
    # The same for a compressed file cut in the middle of the stream.
    with open(c.aal, "rb") as complete:
        compressed = complete.read()
    path = c.path("halfdata.nii.gz")
    with open(path, "wb") as image_file:
        image_file.write(compressed[:len(compressed) // 2])
    c.run_failing([path, "-o", c.path("out.vtu")], 1, "halfdata.nii.gz",
                  output=c.path("out.vtu"))


def case_error_corrupt_nifti_header(c):
    # The AAL atlas's own header with a datatype NIfTI does not define, or a bitpix that does
    # not match it: vtkNIFTIImageReader indexed a table with the datatype and crashed (found by
    # FuzzImageReading); refused before it reads, for .nii and .nii.gz alike.
    with open(c.decompressed_aal(), "rb") as complete:
        data = bytearray(complete.read())
    for datatype, bitpix, expected in [
            (28261, 8, "the NIfTI header's datatype 28261 is not a NIfTI type"),
            (2, 16, "the NIfTI header's bitpix 16 does not match its datatype 2 (8 bits")]:
        struct.pack_into("<hh", data, 70, datatype, bitpix)
        path = c.path("datatype%d.nii" % datatype)
        with open(path, "wb") as image_file:
            image_file.write(bytes(data))
        c.run_failing([path, "-o", c.path("out.vtu")], 1, expected, output=c.path("out.vtu"))
        with gzip.open(path + ".gz", "wb") as compressed:
            compressed.write(bytes(data))
        c.run_failing([path + ".gz", "-o", c.path("out.vtu")], 1, expected,
                      output=c.path("out.vtu"))


def case_error_corrupt_other_formats(c):
    garbage = random.Random(7).randbytes(300)
    for name in ["bad.vti", "bad.mha", "bad.nrrd", "BAD.MHA"]:
        path = c.path(name)
        with open(path, "wb") as image_file:
            image_file.write(garbage)
        c.run_failing([path, "-o", c.path("out.vtu")], 1, name, output=c.path("out.vtu"))
    # Valid headers, cut data.
    for name in ["cut.vti", "cut.mha", "cut.nrrd"]:
        path = c.make_image(name)
        size = os.path.getsize(path)
        with open(path, "r+b") as image_file:
            image_file.truncate(size * 2 // 3)
        c.run_failing([path, "-o", c.path("out.vtu")], 1, name, output=c.path("out.vtu"))
    empty = c.path("empty.nii")
    open(empty, "wb").close()
    c.run_failing([empty, "-o", c.path("out.vtu")], 1, "empty", output=c.path("out.vtu"))
    c.run_failing([c.work, "-o", c.path("out.vtu")], 1, "unsupported extension",
                  output=c.path("out.vtu"))
    directory = c.path("folder.nii")
    os.mkdir(directory)
    c.run_failing([directory, "-o", c.path("out.vtu")], 1, "is a directory",
                  output=c.path("out.vtu"))
    # NRRD headers VTK's reader crashes on (dimension 1, 2 or above 4), misreads (a first axis
    # of fewer than 10 samples taken for components, negative sizes) or half reads (ASCII data
    # that is not numbers): refused before VTK reads them (found by FuzzImageReading).
    def nrrd(name, dimension, sizes, data, encoding="raw"):
        path = c.path(name)
        with open(path, "wb") as image_file:
            image_file.write(("NRRD0004\ntype: uint8\ndimension: %d\nsizes: %s\n"
                              "encoding: %s\n\n" % (dimension, sizes, encoding)).encode() + data)
        return path

    for dimension, sizes in [(1, "24"), (2, "12 2"), (5, "12 2 1 1 1")]:
        c.run_failing([nrrd("dim%d.nrrd" % dimension, dimension, sizes, bytes(24)), "-o",
                       c.path("out.vtu")], 1, "NRRD dimension %d; VTK's NRRD reader reads "
                      "dimension 3 (X Y Z) and 4 (components X Y Z) only" % dimension,
                      output=c.path("out.vtu"))
    c.run_failing([nrrd("narrow.nrrd", 3, "5 5 5", bytes(125)), "-o", c.path("out.vtu")], 1,
                  "the NRRD image's first axis has 5 samples", output=c.path("out.vtu"))
    c.run_failing([nrrd("negative.nrrd", 3, "12 -2 1", bytes(24)), "-o", c.path("out.vtu")], 1,
                  "sizes are not 3 positive numbers", output=c.path("out.vtu"))
    c.run_failing([nrrd("text.nrrd", 3, "12 2 1", b"1 2 x y", "ascii"), "-o",
                   c.path("out.vtu")], 1, "ASCII data holds 'x', not a number, after 2 values",
                  output=c.path("out.vtu"))
    c.run_failing([nrrd("few.nrrd", 3, "12 2 1", b"1 2 3", "ascii"), "-o", c.path("out.vtu")],
                  1, "holds 3 values for 24 voxels", output=c.path("out.vtu"))
    # A header cut off inside its last line: vtkNrrdReader never returned (found by
    # FuzzImageReading), for attached and detached data alike.
    cut_off = c.path("cut_off.nhdr")
    with open(cut_off, "wb") as image_file:
        image_file.write(b"NRRD0004\ntype: uint8\ndimension: 4\nsizes: 1 4 3 2\nencoding: raw")
    c.run_failing([cut_off, "-o", c.path("out.vtu")], 1,
                  "the NRRD header's last line 'encoding: raw' has no line end",
                  output=c.path("out.vtu"))
    # Headers that bend the format, on which vtkNrrdReader crashed (a field without a value, a
    # magic line with more after it, a space before a field's colon; found by FuzzImageReading).
    for name, header, expected in [
            ("empty.nhdr", b"NRRD0004\ntype: uint8\ndimension: 4\nsizes: 1 4 3 2\n"
             b"encoding: raw\ndata file: \n\n", "line 6 of the NRRD header gives the field "
             "'data file' no value"),
            ("magic.nrrd", b"NRRD0004]\ntype: uint8\n\n",
             "line 1 of the NRRD header is not a magic line NRRD0001 to NRRD0005"),
            ("colon.nrrd", b"NRRD0004\ntype: uint8\ndimension :3\n\n",
             "line 3 of the NRRD header is not a field 'name: value' of the format "
             "('dimension :3')"),
            # Fields VTK reads into vectors of the wrong length, a file pattern it would hand
            # to snprintf, and a first axis it would take for the components.
            ("twice.nrrd", b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 12 2 1\n"
             b"space directions: (1,0,0) (0,1,0) (0,0,1)\n"
             b"space directions: (1,0,0) (0,1,0) (0,0,1)\n\n",
             "line 6 of the NRRD header gives the field 'space directions' a second time"),
            ("early.nrrd", b"NRRD0004\ntype: uint8\nsizes: 12 2 1\ndimension: 3\n\n",
             "line 3 of the NRRD header gives 'sizes' before 'dimension'"),
            ("space.nrrd", b"NRRD0004\ntype: uint8\ndimension: 4\nspace: RAS\n"
             b"sizes: 1 12 2 1\n\n", "line 5 of the NRRD header gives 4 sizes where VTK's "
             "NRRD reader reads 3"),
            ("pattern.nhdr", b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 12 2 1\n"
             b"encoding: raw\ndata file: slice%s.raw 1 2 1\n\n", "line 6 of the NRRD header "
             "gives the data file pattern 'slice%s.raw 1 2 1', not 'format min max step'"),
            ("flat.nrrd", b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 12 2 1\n"
             b"space directions: none (0,1,0) (0,0,1)\nencoding: raw\n\n",
             "the NRRD image's first axis has no spacing (0 or none)")]:
        with open(c.path(name), "wb") as image_file:
            image_file.write(header + bytes(24))
        c.run_failing([c.path(name), "-o", c.path("out.vtu")], 1, expected,
                      output=c.path("out.vtu"))
    # The same sizes as dimension 4 with one component are read.
    four = nrrd("four.nrrd", 4, "1 5 5 5", bytes([0] * 62 + [1] + [0] * 62))
    code, out, err = c.run([four, "-o", c.path("four.vtu"), "--stop-after", "spacetree"])
    check(code == 0 and "5 x 5 x 5 voxels" in out, "a 4D NRRD of one component failed: " + err)
    # A MetaImage header with a negative size made MetaIO throw std::bad_alloc, reported as
    # "out of memory".
    negative = c.path("negative.mha")
    with open(negative, "wb") as image_file:
        image_file.write(b"ObjectType = Image\nNDims = 3\nDimSize = 4 -3 2\n"
                         b"ElementType = MET_UCHAR\nElementDataFile = LOCAL\n" + bytes(24))
    c.run_failing([negative, "-o", c.path("out.vtu")], 1,
                  "the MetaImage header's DimSize = 4 -3 2 is not 3 positive integers",
                  output=c.path("out.vtu"))
    # Sizing keys that disagree made MetaIO write past VTK's buffer (found by
    # FuzzImageReading): a key given twice, more sizes than NDims, several channels.
    for name, header, expected in [
            ("twice.mha", b"NDims = 3\nNDims = 1\nDimSize = 4 3 2\n",
             "the MetaImage header gives NDims a second time"),
            ("sizes.mha", b"NDims = 1\nDimSize = 24 1 1\n",
             "the MetaImage header's DimSize = 24 1 1 is not 1 positive integers"),
            ("channels.mha", b"NDims = 3\nElementNumberOfChannels = 3\nDimSize = 4 3 2\n",
             "ElementNumberOfChannels = 3; stmesh reads one value per voxel")]:
        with open(c.path(name), "wb") as image_file:
            image_file.write(b"ObjectType = Image\n" + header +
                             b"ElementType = MET_UCHAR\nElementDataFile = LOCAL\n" + bytes(72))
        c.run_failing([c.path(name), "-o", c.path("out.vtu")], 1, expected,
                      output=c.path("out.vtu"))
    # A MetaImage of 4 dimensions made MetaIO write past VTK's buffer (a heap overflow under
    # AddressSanitizer), and a detached header whose data file is missing made it leak: both
    # refused before VTK reads them (found by FuzzImageReading).
    four_axes = c.path("four_axes.mha")
    with open(four_axes, "wb") as image_file:
        image_file.write(b"ObjectType = Image\nNDims = 4\nDimSize = 2 2 2 2\n"
                         b"ElementType = MET_UCHAR\nElementDataFile = LOCAL\n" + bytes(16))
    c.run_failing([four_axes, "-o", c.path("out.vtu")], 1,
                  "MetaImage NDims = 4; VTK's MetaImage reader reads 1 to 3 dimensions",
                  output=c.path("out.vtu"))
    detached = c.path("detached.mhd")
    with open(detached, "wb") as image_file:
        image_file.write(b"ObjectType = Image\nNDims = 3\nDimSize = 4 3 2\n"
                         b"ElementType = MET_UCHAR\nElementDataFile = nowhere.raw\n")
    c.run_failing([detached, "-o", c.path("out.vtu")], 1,
                  "the MetaImage header's data file '%s' cannot be read" % c.path("nowhere.raw"),
                  output=c.path("out.vtu"))
    # Several data files (LIST, a pattern): MetaIO freed what it never allocated on a corrupt
    # list (found by FuzzImageReading).
    listed = c.path("listed.mhd")
    with open(listed, "wb") as image_file:
        image_file.write(b"ObjectType = Image\nNDims = 3\nDimSize = 4 3 2\n"
                         b"ElementType = MET_UCHAR\nElementDataFile = LIST\nslice0.raw\n")
    c.run_failing([listed, "-o", c.path("out.vtu")], 1,
                  "the MetaImage header's ElementDataFile = LIST names several files",
                  output=c.path("out.vtu"))


def case_error_float_image(c):
    for name in ["gray.vti", "gray.mha"]:
        path = c.make_image(name, "float")
        c.run_failing([path, "-o", c.path("out.vtu")], 1, "integer label image",
                      output=c.path("out.vtu"))


def case_error_absent_label(c):
    c.run_failing([c.aal, "-o", c.path("out.vtu"), "--labels", "1,9999"], 1, "9999",
                  output=c.path("out.vtu"))


def case_error_balance_negative(c):
    c.run_failing([c.aal, "-o", c.path("out.vtu"), "--balance", "-1"], 2, "--balance",
                  output=c.path("out.vtu"))


def case_error_max_cell_size_zero(c):
    c.run_failing([c.aal, "-o", c.path("out.vtu"), "--max-cell-size", "0"], 2,
                  "--max-cell-size", output=c.path("out.vtu"))


def case_error_threads_abc(c):
    c.run_failing([c.aal, "-o", c.path("out.vtu"), "--threads", "abc"], 2, "--threads",
                  output=c.path("out.vtu"))


def case_error_bad_values(c):
    output = c.path("out.vtu")
    for arguments, text in [
            (["--balance", "3x"], "'3x' is not an integer"),
            (["--balance", "21"], "out of range"),
            (["--balance", ""], "empty"),
            (["--balance", " 2"], "not an integer"),
            (["--max-cell-size", "-4"], "out of range"),
            (["--max-cell-size", "99999999999999999999"], "out of range"),
            (["--threads", "0"], "out of range"),
            (["--threads", "1.5"], "not an integer"),
            (["--labels", "1,,2"], "empty entry"),
            (["--labels", "1,a"], "not an integer"),
            (["--labels", "1,1"], "listed twice"),
            (["--labels", "0"], "background"),
            (["--stop-after", "mesh"], "not one of"),
            (["--compressor", "gzip"], "not one of lz4, zlib, none"),
            (["--bogus"], "unknown option"),
            (["--balance"], "needs a value"),
            (["--balance", "1", "--balance", "2"], "more than once"),
            (["second.nii"], "more than one INPUT")]:
        err = c.run_failing([c.aal, "-o", output] + arguments, 2, text, output=output)
        check("--help" in err, "usage errors should point to --help")
    # The --name=value form parses the same way.
    c.run_failing([c.aal, "-o", output, "--balance=-1"], 2, "out of range", output=output)


def case_error_output_extension(c):
    for name in ["mesh.stl", "mesh", "mesh.vtu.gz", ".vtu"]:
        c.run_failing([c.aal, "-o", c.path(name)], 2, "unsupported extension",
                      output=c.path(name))


def case_error_output_directory(c):
    image = c.make_image("labels.vti")
    c.run_failing([image, "-o", c.path("no/such/dir/out.vtu")], 1, "does not exist")
    os.mkdir(c.path("existing.vtu"))
    c.run_failing([image, "-o", c.path("existing.vtu")], 1, "is a directory")
    if os.geteuid() != 0:  # root may write anywhere
        locked = c.path("locked")
        os.mkdir(locked, 0o555)
        c.run_failing([image, "-o", os.path.join(locked, "out.vtu")], 1, "not writable",
                      output=os.path.join(locked, "out.vtu"))


# ------------------------------------------------------------------------------------------------
# The spacetree options (refinement pattern, root cell size, size criteria, balance levels).

def test_label(i, j, k):
    """The label of voxel (i, j, k) of the helper's 20 x 18 x 16 test image (TestLabel)."""
    if (i - 9) ** 2 + (j - 9) ** 2 + (k - 8) ** 2 <= 25:
        return 1
    if 13 <= i <= 18 and 2 <= j <= 8 and 4 <= k <= 11:
        return 2
    if 2 <= i <= 3 and 13 <= j <= 15 and 2 <= k <= 4:
        return 7
    return 0


def voxel_volumes(flat=False):
    """Voxels (1 mm^3 or 1 mm^2 each) per body label of the test image, or of its 2D slice."""
    counts = {}
    for k in ([8] if flat else range(16)):
        for j in range(18):
            for i in range(20):
                label = test_label(i, j, k)
                if label:
                    counts[str(label)] = counts.get(str(label), 0) + 1
    return counts


def check_volumes(mesh, flat=False):
    """The mesh invariants the read-back shows: positive simplices, and every material's volume
    (area in 2D) equal to its voxels' (the spacing is 1 mm)."""
    check(mesh["smallest_measure"] is not None and mesh["smallest_measure"] > 0,
          "a simplex has a non-positive measure: %s" % mesh["smallest_measure"])
    expected = voxel_volumes(flat)
    check(sorted(mesh["material_measures"]) == sorted(expected),
          "materials %s, expected %s" % (sorted(mesh["material_measures"]), sorted(expected)))
    for material, volume in expected.items():
        check(abs(mesh["material_measures"][material] - volume) <= 1e-6 * volume,
              "material %s measures %r, its voxels %d" %
              (material, mesh["material_measures"][material], volume))


def mesh_run(c, image, name, arguments, stop_after=None):
    """stmesh IMAGE -o NAME.vtu --summary NAME.json ARGUMENTS --separating none: the summary and
    the read-back of the staircase mesh, after checking that they agree."""
    output, summary_path = c.path(name + ".vtu"), c.path(name + ".json")
    extra = (["--stop-after", stop_after] if stop_after else []) + STAIRCASE
    out, err = c.run_ok([image, "-o", output, "--summary", summary_path] + extra + arguments)
    summary, mesh = load_summary(summary_path), c.read_back(output, geometry=True)
    if stop_after in (None, "tessellate"):
        cell_type = TRIANGLE if summary["spacetree_axes"] == [0, 1] else TETRA
        key = "triangles_per_material" if cell_type == TRIANGLE else "tetrahedra_per_material"
    else:
        cell_type, key = (QUAD if summary["spacetree_axes"] == [0, 1] else HEXAHEDRON,
                          "leaves_per_material")
    check_mesh_against_summary(mesh, summary, cell_type, key)
    summary["stderr"] = err
    return summary, mesh


def leaves(summary, stage_name):
    return stage(summary, stage_name)["leaves"]


def case_option_pattern(c):
    image = c.make_image("labels.vti")
    summary, mesh = mesh_run(c, image, "auto", [])
    check(summary["cell_sizes_voxels"] == [[16, 16, 16], [8, 8, 8], [4, 4, 4], [2, 2, 2],
                                           [1, 1, 1]],
          "auto: cell sizes %s" % summary["cell_sizes_voxels"])
    summary, mesh = mesh_run(c, image, "three", ["--pattern", "3x3x3"])
    check(summary["parameters"]["pattern"] == "3x3x3", "bad pattern in the parameters")
    # Powers of 3 up to --max-cell-size 16.
    check(summary["cell_sizes_voxels"] == [[9, 9, 9], [3, 3, 3], [1, 1, 1]],
          "3x3x3: cell sizes %s" % summary["cell_sizes_voxels"])
    check(summary["voxel_subdivision"] == [1, 1, 1], "3x3x3: bad voxel subdivision")
    check(max(mesh["longest_edges"].values()) <= 9, "3x3x3: a tetrahedron longer than 9 voxels")
    check_volumes(mesh)
    # Finest level first, the last entry repeating; blanks and upper case are accepted.
    summary, mesh = mesh_run(c, image, "mixed", ["--pattern", "2X2X1, 2x2x2"])
    check(summary["parameters"]["pattern"] == "2x2x1,2x2x2", "pattern not normalised")
    check(summary["cell_sizes_voxels"] == [[16, 16, 8], [8, 8, 4], [4, 4, 2], [2, 2, 1],
                                           [1, 1, 1]],
          "2x2x1,2x2x2: cell sizes %s" % summary["cell_sizes_voxels"])
    check_volumes(mesh)
    # A 2D image takes two counts per entry, or three with the flat axis ignored.
    flat = c.make_image("slice.vti", variant="2d")
    summary, mesh = mesh_run(c, flat, "flat", ["--pattern", "3x3"])
    check(summary["spacetree_axes"] == [0, 1], "the slice is not meshed in 2D")
    check(summary["cell_sizes_voxels"] == [[9, 9], [3, 3], [1, 1]],
          "2D 3x3: cell sizes %s" % summary["cell_sizes_voxels"])
    check_volumes(mesh, flat=True)
    _, same = mesh_run(c, flat, "flat3", ["--pattern", "3x3x1"])
    check(same == mesh, "--pattern 3x3x1 and 3x3 differ on a 2D image")
    # Two counts on a 3D image are a usage error.
    c.run_failing([image, "-o", c.path("out.vtu"), "--pattern", "2x2"], 2,
                  "give three split counts", output=c.path("out.vtu"))


def case_option_root_cell_size(c):
    image = c.make_image("labels.vti")
    summary, mesh = mesh_run(c, image, "root", ["--root-cell-size", "8,8,4"])
    check(summary["parameters"]["root_cell_size"] == [8, 8, 4], "bad root_cell_size parameter")
    check(summary["cell_sizes_voxels"][0] == [8, 8, 4],
          "root cells %s, expected [8, 8, 4]" % summary["cell_sizes_voxels"][0])
    check(summary["cell_sizes_voxels"][-1] == [1, 1, 1], "finest cells are not voxels")
    check(mesh["longest_edges"] and max(mesh["longest_edges"].values()) <= 8,
          "a tetrahedron longer than the root cell")
    check_volumes(mesh)
    # A root size the pattern reaches: 9 = 3 x 3.
    summary, _ = mesh_run(c, image, "root9", ["--root-cell-size", "9,9,9", "--pattern", "3x3x3"],
                          stop_after="spacetree")
    check(summary["cell_sizes_voxels"] == [[9, 9, 9], [3, 3, 3], [1, 1, 1]],
          "root 9 with 3x3x3: cell sizes %s" % summary["cell_sizes_voxels"])
    # Two sizes for a 2D image, along the two axes it spans; a third is ignored.
    flat = c.make_image("slice.vti", variant="2d")
    summary, mesh = mesh_run(c, flat, "flat", ["--root-cell-size", "6,4"])
    check(summary["cell_sizes_voxels"][0] == [6, 4] and
          summary["cell_sizes_voxels"][-1] == [1, 1],
          "2D root 6,4: cell sizes %s" % summary["cell_sizes_voxels"])
    check_volumes(mesh, flat=True)
    _, same = mesh_run(c, flat, "flat3", ["--root-cell-size", "6,4,1"])
    check(same == mesh, "--root-cell-size 6,4,1 and 6,4 differ on a 2D image")
    c.run_failing([image, "-o", c.path("out.vtu"), "--root-cell-size", "8,8"], 2,
                  "give three sizes", output=c.path("out.vtu"))


def case_option_max_cell_size_label(c):
    image = c.make_image("labels.vti")
    base, base_tree = mesh_run(c, image, "base_tree", [], stop_after="spacetree")
    sized, sized_tree = mesh_run(c, image, "sized_tree", ["--max-cell-size-label", "1:2"],
                                 stop_after="spacetree")
    check(sized["parameters"]["max_cell_size_labels"] == {"1": 2}, "bad parameter")
    # The ball of label 1 holds leaves of 4 voxels; the box of label 2 none above 2.
    check(base_tree["longest_edges"]["1"] == 4,
          "label 1's largest leaf is %s voxels without the option, expected 4" %
          base_tree["longest_edges"]["1"])
    check(sized_tree["longest_edges"]["1"] == 2,
          "label 1's largest leaf is %s voxels, expected 2" % sized_tree["longest_edges"]["1"])
    # Only label 1's leaves change.
    for material in ["0", "2", "7"]:
        check(sized["leaves_per_material"][material] == base["leaves_per_material"][material],
              "--max-cell-size-label 1:2 changed the leaves of label %s" % material)
    check(sized["leaves_per_material"]["1"] > base["leaves_per_material"]["1"],
          "label 1 has no more leaves")
    _, base_mesh = mesh_run(c, image, "base", [])
    summary, mesh = mesh_run(c, image, "sized", ["--max-cell-size-label", "2:1,1:1.5"])
    check(summary["parameters"]["max_cell_size_labels"] == {"2": 1, "1": 1.5}, "bad parameter")
    check(mesh["cells"] > base_mesh["cells"], "no more tetrahedra than without the option")
    for material in ["1", "2"]:
        check(mesh["material_counts"][material] > base_mesh["material_counts"][material],
              "label %s has no more tetrahedra" % material)
        check(mesh["longest_edges"][material] == 1,
              "a tetrahedron of label %s is longer than 1 voxel" % material)
    check_volumes(mesh)


def case_option_refine_region(c):
    image = c.make_image("labels.vti")
    base, base_mesh = mesh_run(c, image, "base", [])
    # A box inside the ball of label 1, refined to 0.5 mm on 1 mm voxels.
    box = "box:6.5,6.5,5.5,11.5,11.5,10.5:0.5"
    summary, mesh = mesh_run(c, image, "box", ["--refine-region", box])
    check(summary["parameters"]["refine_region"] ==
          {"type": "box", "values": [6.5, 6.5, 5.5, 11.5, 11.5, 10.5], "size": 0.5},
          "bad refine_region parameter %s" % summary["parameters"]["refine_region"])
    check(summary["voxel_subdivision"] == [2, 2, 2],
          "voxel subdivision %s, expected [2, 2, 2]" % summary["voxel_subdivision"])
    check(summary["cell_sizes_voxels"] == [[16, 16, 16], [8, 8, 8], [4, 4, 4], [2, 2, 2],
                                           [1, 1, 1], [0.5, 0.5, 0.5]],
          "cell sizes %s" % summary["cell_sizes_voxels"])
    check(mesh["cells"] > base_mesh["cells"], "the region adds no tetrahedra")
    check(mesh["material_counts"]["2"] == base_mesh["material_counts"]["2"] and
          mesh["material_counts"]["7"] == base_mesh["material_counts"]["7"],
          "the region changed the tetrahedra of labels far from it")
    check_volumes(mesh)
    _, tree = mesh_run(c, image, "box_tree", ["--refine-region", box], stop_after="spacetree")
    check(tree["shortest_edges"]["1"] == 0.5, "no 0.5 mm leaf in the box")
    check(tree["shortest_edges"]["2"] == 1, "leaves below the voxel outside the box")

    for name, region, subdivision in [("sphere", "sphere:9,9,8,3:0.5", 2),
                                      ("cylinder", "cylinder:9,9,8,0,0,1,2:1", 1),
                                      ("slab", "slab:9,9,8,0,0,1,2:0.5", 2)]:
        summary, mesh = mesh_run(c, image, name, ["--refine-region", region])
        check(summary["voxel_subdivision"] == [subdivision] * 3,
              "%s: voxel subdivision %s" % (name, summary["voxel_subdivision"]))
        check(mesh["cells"] > base_mesh["cells"], "%s: no more tetrahedra" % name)
        check_volumes(mesh)
        if name == "slab":
            # The normal's length does not matter: the width is in physical units.
            _, same = mesh_run(c, image, "slab_long_normal",
                               ["--refine-region", "slab:9,9,8,0,0,5,2:0.5"])
            check(same == mesh, "the slab depends on the length of its normal")
            # The band is |z - 8| <= 1: three voxel layers; a thinner one holds one layer.
            _, thin = mesh_run(c, image, "slab_thin", ["--refine-region", "slab:9,9,8,0,0,1,0.5:0.5"])
            check(base_mesh["cells"] < thin["cells"] < mesh["cells"],
                  "a thinner slab does not refine less")


def case_option_grading(c):
    image = c.make_image("labels.vti")
    base, _ = mesh_run(c, image, "base", [], stop_after="spacetree")
    graded, tree = mesh_run(c, image, "graded", ["--grading", "1.5"], stop_after="spacetree")
    loose, _ = mesh_run(c, image, "loose", ["--grading", "4"], stop_after="spacetree")
    check(graded["parameters"]["grading"] == 1.5, "bad grading parameter")
    check(leaves(base, "spacetree") < leaves(loose, "spacetree") < leaves(graded, "spacetree"),
          "leaves without grading %d, grading 4 %d, grading 1.5 %d: not increasing" %
          (leaves(base, "spacetree"), leaves(loose, "spacetree"), leaves(graded, "spacetree")))
    _, base_mesh = mesh_run(c, image, "base_mesh", [])
    _, mesh = mesh_run(c, image, "graded_mesh", ["--grading", "1.5"])
    check(mesh["cells"] > base_mesh["cells"], "grading adds no tetrahedra")
    check_volumes(mesh)


def case_option_sizing_array(c):
    image = c.make_image("sized.vti", variant="sizing")
    base, base_tree = mesh_run(c, image, "base", [], stop_after="spacetree")
    sized, tree = mesh_run(c, image, "sized", ["--sizing-array", "sizing"],
                           stop_after="spacetree")
    check(sized["parameters"]["sizing_array"] == "sizing", "bad sizing_array parameter")
    # The array asks for 2 mm in every voxel (the padding of the root grid beyond the image has
    # no size, so background leaves there stay larger).
    check(base_tree["longest_edges"]["1"] == 4, "label 1 has no leaf of 4 mm without the array")
    for material in ["1", "2", "7"]:
        check(tree["longest_edges"][material] <= 2,
              "a leaf of label %s is %s mm, the sizing array asks for 2" %
              (material, tree["longest_edges"][material]))
    check(tree["longest_edges"]["1"] == 2, "label 1 has no leaf of 2 mm")
    check(leaves(sized, "spacetree") > leaves(base, "spacetree"), "no more leaves")
    _, mesh = mesh_run(c, image, "sized_mesh", ["--sizing-array", "sizing"])
    check_volumes(mesh)
    # A missing array, one of the wrong association, one with a zero size.
    c.run_failing([image, "-o", c.path("out.vtu"), "--sizing-array", "missing"], 1,
                  "no point array named 'missing'", output=c.path("out.vtu"))
    c.run_failing([image, "-o", c.path("out.vtu"), "--sizing-array", "cell_sizing"], 1,
                  "needs the labels' association", output=c.path("out.vtu"))
    c.run_failing([image, "-o", c.path("out.vtu"), "--sizing-array", "bad_sizing"], 1,
                  "holds sizes that are not positive", output=c.path("out.vtu"))


def case_option_balance_label(c):
    image = c.make_image("labels.vti")
    three, _ = mesh_run(c, image, "three", ["--balance", "3"], stop_after="balance")
    one, _ = mesh_run(c, image, "one", ["--balance", "1"], stop_after="balance")
    labelled, _ = mesh_run(c, image, "labelled", ["--balance", "3", "--balance-label", "1:1"],
                           stop_after="balance")
    check(labelled["parameters"]["balance_labels"] == {"1": 1}, "bad balance_labels parameter")
    check(leaves(three, "balance") < leaves(labelled, "balance") < leaves(one, "balance"),
          "balance leaves: level 3 %d, label 1 at level 1 %d, level 1 %d: not increasing" %
          (leaves(three, "balance"), leaves(labelled, "balance"), leaves(one, "balance")))
    _, mesh = mesh_run(c, image, "mesh", ["--balance", "3", "--balance-label", "1:1,2:2"])
    check_volumes(mesh)
    c.run_failing([image, "-o", c.path("out.vtu"), "--balance-label", "9:1"], 1,
                  "LabelBalanceLevels names label 9", output=c.path("out.vtu"))


def case_option_balance_region(c):
    image = c.make_image("labels.vti")
    three, _ = mesh_run(c, image, "three", ["--balance", "3"], stop_after="balance")
    one, _ = mesh_run(c, image, "one", ["--balance", "1"], stop_after="balance")
    region, _ = mesh_run(c, image, "sphere", ["--balance", "3", "--balance-region",
                                              "sphere:9,9,8,6:1"], stop_after="balance")
    check(region["parameters"]["balance_region"] ==
          {"type": "sphere", "values": [9, 9, 8, 6], "level": 1},
          "bad balance_region parameter %s" % region["parameters"]["balance_region"])
    check(leaves(three, "balance") < leaves(region, "balance") < leaves(one, "balance"),
          "balance leaves: level 3 %d, sphere at level 1 %d, level 1 %d: not increasing" %
          (leaves(three, "balance"), leaves(region, "balance"), leaves(one, "balance")))
    # A region covering the whole image gives --balance 1.
    whole, _ = mesh_run(c, image, "whole", ["--balance", "3", "--balance-region",
                                            "box:-10,-10,-10,30,30,30:1"], stop_after="balance")
    check(whole["leaves_per_material"] == one["leaves_per_material"],
          "a region over the whole image differs from --balance 1")
    slab, _ = mesh_run(c, image, "slab", ["--balance", "3", "--balance-region",
                                          "slab:9,9,8,0,0,1,4:1"], stop_after="balance")
    check(leaves(three, "balance") < leaves(slab, "balance"), "the slab adds no leaves")
    _, mesh = mesh_run(c, image, "mesh", ["--balance", "3", "--balance-region",
                                          "cylinder:9,9,8,1,0,0,4:1"])
    check_volumes(mesh)
    # A region outside the image changes nothing, and says so.
    outside, _ = mesh_run(c, image, "outside", ["--balance", "3", "--balance-region",
                                                "sphere:100,100,100,5:1"], stop_after="balance")
    check("stmesh: warning: --balance-region contains no leaf centre" in outside["stderr"],
          "no warning about a balance region outside the image")
    check(outside["leaves_per_material"] == three["leaves_per_material"],
          "a balance region outside the image changed the tree")


def case_error_spacetree_option_values(c):
    image = c.make_image("labels.vti")
    output = c.path("out.vtu")
    for arguments, text in [
            (["--pattern", ""], "needs a value"),
            (["--pattern", "cubes"], "is not auto or split counts"),
            (["--pattern", "3x3x"], "empty entry"),
            (["--pattern", "3x9x3"], "out of range (1 to 8)"),
            (["--pattern", "3x0x3"], "out of range (1 to 8)"),
            (["--pattern", "1x1x1"], "splits no axis"),
            (["--pattern", "2x2x2x2"], "4 split counts"),
            (["--pattern", "2x2,2x2x2"], "different numbers of split counts"),
            (["--root-cell-size", "8,8,8,8"], "4 sizes"),
            (["--root-cell-size", "8"], "1 sizes"),
            (["--root-cell-size", "8,0,8"], "out of range"),
            (["--root-cell-size", "8,-8,8"], "out of range"),
            (["--root-cell-size", "8,x,8"], "not an integer"),
            (["--root-cell-size", "8,8,4", "--max-cell-size", "8"], "exclude each other"),
            (["--max-cell-size-label", "3"], "is not LABEL:VALUE"),
            (["--max-cell-size-label", "3:2:1"], "is not LABEL:VALUE"),
            (["--max-cell-size-label", "3:0"], "must be positive"),
            (["--max-cell-size-label", "3:-2"], "must be positive"),
            (["--max-cell-size-label", "3:0.5"], "below one voxel"),
            (["--max-cell-size-label", "3:two"], "not a number"),
            (["--max-cell-size-label", "3:2,3:4"], "listed twice"),
            (["--max-cell-size-label", "0:2"], "background"),
            (["--max-cell-size-label", "x:2"], "not an integer"),
            (["--max-cell-size-label", "3:2,"], "empty entry"),
            (["--refine-region", "cone:0,0,0,1:1"], "unknown region type 'cone'"),
            (["--refine-region", "sphere:0,0,0,5"], "is not REGION:SIZE"),
            (["--refine-region", "sphere:0,0,5:1"], "needs 4 numbers, got 3"),
            (["--refine-region", "box:0,0,0,1,1,1,1:1"], "needs 6 numbers, got 7"),
            (["--refine-region", "sphere:0,0,0,5:0"], "SIZE must be positive"),
            (["--refine-region", "sphere:0,0,0,5:-1"], "SIZE must be positive"),
            (["--refine-region", "sphere:0,0,0,5:inf"], "not a number"),
            (["--refine-region", "sphere:0,0,a,5:1"], "not a number"),
            (["--refine-region", "sphere:0,0,0,0:1"], "radius must be positive"),
            (["--refine-region", "box:0,0,0,10,0,10:1"], "degenerate box"),
            (["--refine-region", "box:5,0,0,1,10,10:1"], "degenerate box"),
            (["--refine-region", "cylinder:0,0,0,0,0,0,3:1"], "axis AX,AY,AZ is zero"),
            (["--refine-region", "cylinder:0,0,0,0,0,1,-3:1"], "radius must be positive"),
            (["--refine-region", "slab:0,0,0,0,0,1,0:1"], "width must be positive"),
            (["--refine-region", "slab:0,0,0,0,0,0,2:1"], "normal NX,NY,NZ is zero"),
            (["--refine-region", "sphere:0,0,0,5:1", "--refine-region", "sphere:1,1,1,5:1"],
             "more than once"),
            (["--grading", "1.2"], "at least 1.5"),
            (["--grading", "0"], "at least 1.5"),
            (["--grading", "-2"], "at least 1.5"),
            (["--grading", "1.5x"], "not a number"),
            (["--sizing-array", ""], "needs an array name"),
            (["--balance-label", "1:0"], "out of range (1 to 20)"),
            (["--balance-label", "1:21"], "out of range (1 to 20)"),
            (["--balance-label", "1:1.5"], "not an integer"),
            (["--balance-label", "1"], "is not LABEL:VALUE"),
            (["--balance-label", "1:1,1:2"], "listed twice"),
            (["--balance-region", "sphere:0,0,0,5:0"], "out of range (1 to 20)"),
            (["--balance-region", "sphere:0,0,0,5:21"], "out of range (1 to 20)"),
            (["--balance-region", "sphere:0,0,0,5:0.5"], "not an integer"),
            (["--balance-region", "sphere:0,0,0,5"], "is not REGION:LEVEL"),
            (["--balance-region", "ring:0,0,0,5:1"], "unknown region type"),
            (["--balance-region", "box:0,0,0,0,1,1:1"], "degenerate box"),
            (["--balance-region", "slab:0,0,0,1,0,0,-1:1"], "width must be positive"),
            (["--balance", "0", "--balance-label", "1:1"], "cannot be combined with --balance 0"),
            (["--balance", "0", "--balance-region", "sphere:0,0,0,5:1"],
             "cannot be combined with --balance 0"),
            # Checked against the image: a 3D image needs three numbers.
            (["--root-cell-size", "8,8"], "give three sizes"),
            (["--pattern", "2x2,2x2"], "give three split counts")]:
        err = c.run_failing([image, "-o", output] + arguments, 2, text, output=output)
        error_lines = [line for line in err.splitlines() if line.startswith(ERROR_PREFIX)]
        check(len(error_lines) == 1, "expected one error line, got %s" % error_lines)
        check("--help" in err, "usage errors should point to --help")
    # The --name=value form parses the same way.
    c.run_failing([image, "-o", output, "--grading=1"], 2, "at least 1.5", output=output)


def case_error_spacetree_filter_errors(c):
    image = c.make_image("labels.vti")
    output = c.path("out.vtu")
    for arguments, text in [
            # The voxel centres are at integer coordinates 0..19, 0..17, 0..15.
            (["--refine-region", "box:100,100,100,110,110,110:0.5"],
             "The refinement region contains no voxel centre of the image"),
            (["--refine-region", "slab:0,0,8.5,0,0,1,0.5:0.5"],
             "The refinement region contains no voxel centre of the image"),
            (["--pattern", "3x3x3", "--root-cell-size", "8,8,8"],
             "is not reachable with the refinement pattern"),
            (["--root-cell-size", "32,16,16"], "is larger than the image (20 voxels)"),
            (["--max-cell-size-label", "9:2"],
             "LabelMaxCellSizes names label 9, which is not in the body of interest"),
            (["--labels", "1", "--max-cell-size-label", "2:2"],
             "LabelMaxCellSizes names label 2, which is not in the body of interest"),
            (["--balance-label", "9:1"], "LabelBalanceLevels names label 9")]:
        err = c.run_failing([image, "-o", output] + arguments, 1, text, output=output)
        check("--help" not in err, "a filter error should not point to --help")
        check(any(line.startswith(ERROR_PREFIX + " building the spacetree:") or
                  line.startswith(ERROR_PREFIX + " balancing the spacetree:")
                  for line in err.splitlines()),
              "the message does not name the stage")


# ------------------------------------------------------------------------------------------------
# The tessellation options (--elements, --templates, --cell-template, --boundary-layer), on label
# images written here; the meshes are read back with VTK's readers through its Python modules.

def vtk_modules():
    """The VTK classes these cases use; Debian's /usr/bin/python3 sees ParaView's vtkmodules."""
    try:
        from vtkmodules.vtkCommonCore import vtkCommand
        from vtkmodules.vtkCommonDataModel import vtkImageData
        from vtkmodules.vtkFiltersVerdict import vtkCellSizeFilter
        from vtkmodules.vtkIOImage import vtkNIFTIImageWriter
        from vtkmodules.vtkIOLegacy import vtkUnstructuredGridReader
        from vtkmodules.vtkIOXML import vtkXMLImageDataWriter, vtkXMLUnstructuredGridReader
    except ImportError as error:
        raise CaseFailed("%s cannot import the VTK Python modules (%s); run this script with "
                         "Debian's /usr/bin/python3" % (sys.executable, error))
    return dict(vtkCommand=vtkCommand, vtkImageData=vtkImageData,
                vtkCellSizeFilter=vtkCellSizeFilter, vtkNIFTIImageWriter=vtkNIFTIImageWriter,
                vtkUnstructuredGridReader=vtkUnstructuredGridReader,
                vtkXMLImageDataWriter=vtkXMLImageDataWriter,
                vtkXMLUnstructuredGridReader=vtkXMLUnstructuredGridReader)


def watched(algorithm, errors):
    vtk = vtk_modules()
    algorithm.AddObserver(vtk["vtkCommand"].ErrorEvent,
                          lambda caller, event: errors.append("%s failed" % caller.GetClassName()))
    return algorithm


def write_label_image(c, name, dimensions, label):
    """A uint8 label image of 1 mm voxels, one voxel per point, label(i, j, k) each, as .vti
    (inline binary) or .nii; returns its path and the voxels per non-zero label."""
    vtk = vtk_modules()
    image = vtk["vtkImageData"]()
    image.SetDimensions(*dimensions)
    image.AllocateScalars(3, 1)  # VTK_UNSIGNED_CHAR
    scalars = image.GetPointData().GetScalars()
    scalars.SetName("labels")
    voxels = {}
    index = 0
    for k in range(dimensions[2]):
        for j in range(dimensions[1]):
            for i in range(dimensions[0]):
                value = label(i, j, k)
                scalars.SetValue(index, value)
                if value:
                    voxels[str(value)] = voxels.get(str(value), 0) + 1
                index += 1
    path = c.path(name)
    errors = []
    if name.endswith(".vti"):
        writer = watched(vtk["vtkXMLImageDataWriter"](), errors)
        writer.SetDataModeToBinary()  # inline: Debian 12's libexpat fails on appended data
    else:
        writer = watched(vtk["vtkNIFTIImageWriter"](), errors)
    writer.SetInputData(image)
    writer.SetFileName(path)
    writer.Write()
    check(not errors and os.path.getsize(path) > 0, "cannot write %s: %s" % (name, errors))
    return path, voxels


def two_boxes(i, j, k):
    """Labels 1 and 2: two touching boxes of 4 x 6 x 6 and 3 x 6 x 6 voxels in 12 x 10 x 8."""
    if 1 <= j <= 6 and 1 <= k <= 6:
        if 2 <= i <= 5:
            return 1
        if 6 <= i <= 8:
            return 2
    return 0


def ball(i, j, k):
    """Label 1: a ball of radius 5 voxels, label 3: a small box inside it, in 16 x 15 x 14."""
    if 6 <= i <= 8 and 6 <= j <= 7 and 5 <= k <= 8:
        return 3
    return 1 if (i - 7) ** 2 + (j - 7) ** 2 + (k - 6) ** 2 <= 25 else 0


def read_grid(path):
    """The unstructured grid of a .vtu (checked to be inline binary XML: Debian's expat cannot
    read appended data) or legacy .vtk file: (VTK modules, grid, the error list of readers)."""
    vtk = vtk_modules()
    errors = []
    if path.endswith(".vtu"):
        with open(path, "rb") as mesh_file:
            content = mesh_file.read()
        check(b'format="binary"' in content[:4096] and b"<AppendedData" not in content,
              "%s is not inline binary XML" % path)
        reader = watched(vtk["vtkXMLUnstructuredGridReader"](), errors)
    else:
        reader = watched(vtk["vtkUnstructuredGridReader"](), errors)
    reader.SetFileName(path)
    reader.Update()
    grid = reader.GetOutput()
    check(not errors and grid is not None, "cannot read back %s: %s" % (path, errors))
    return vtk, grid, errors


def read_mesh(path):
    """The mesh of a .vtu (XML, inline binary) or legacy .vtk file, read by VTK's readers, as a
    dict: cells, points, cell types (VTK numbers) per cell, Material per cell, the volume (area
    of a 2D mesh) of every cell by vtkCellSizeFilter, the point array HangingNode (None
    without it) and the points in quarter millimetres (exact for the 1 mm voxels used here)."""
    vtk, grid, errors = read_grid(path)
    check(grid.GetNumberOfCells() > 0, "%s has no cells" % path)
    sizes = watched(vtk["vtkCellSizeFilter"](), errors)
    sizes.SetInputData(grid)
    sizes.Update()
    check(not errors, "vtkCellSizeFilter failed on %s" % path)
    cell_data = sizes.GetOutput().GetCellData()
    materials = grid.GetCellData().GetArray("Material")
    check(materials is not None, "%s has no cell array Material" % path)
    cells = grid.GetNumberOfCells()
    types = [grid.GetCellType(cell) for cell in range(cells)]
    measure_arrays = [cell_data.GetArray(name) for name in ("Volume", "Area")]
    measures = []
    for cell in range(cells):
        array = measure_arrays[0] if types[cell] in (TETRA, PYRAMID, HEXAHEDRON) else measure_arrays[1]
        measures.append(array.GetValue(cell))
    hanging = grid.GetPointData().GetArray("HangingNode")
    return {"cells": cells, "points": grid.GetNumberOfPoints(), "types": types,
            "materials": [int(materials.GetTuple1(cell)) for cell in range(cells)],
            "measures": measures,
            "quarter_mm_points": [tuple(int(round(4 * x)) for x in grid.GetPoint(point))
                                  for point in range(grid.GetNumberOfPoints())],
            "hanging": None if hanging is None else
            [int(hanging.GetTuple1(point)) for point in range(grid.GetNumberOfPoints())]}


def count_by_type(mesh):
    counts = {}
    for cell_type in mesh["types"]:
        name = CELL_TYPE_NAMES.get(cell_type, "type_%d" % cell_type)
        counts[name] = counts.get(name, 0) + 1
    return counts


def count_by_material(mesh):
    counts = {}
    for material in mesh["materials"]:
        counts[str(material)] = counts.get(str(material), 0) + 1
    return counts


def volume_by_material(mesh):
    volumes = {}
    for material, measure in zip(mesh["materials"], mesh["measures"]):
        volumes[str(material)] = volumes.get(str(material), 0.0) + measure
    return volumes


def check_volume_equals_voxels(mesh, voxels, what):
    """Every cell has a positive measure and every body material's volume is its voxels'."""
    check(min(mesh["measures"]) > 0, "%s: a cell has measure %r" % (what, min(mesh["measures"])))
    volumes = volume_by_material(mesh)
    volumes.pop("0", None)
    check(sorted(volumes) == sorted(voxels),
          "%s: materials %s, voxels of %s" % (what, sorted(volumes), sorted(voxels)))
    for material, count in voxels.items():
        check(abs(volumes[material] - count) <= 1e-9 * count,
              "%s: material %s measures %r, its voxels %d" % (what, material, volumes[material],
                                                             count))


def spacetree_corners(c, image, arguments=()):
    """The corners of all leaves (body and background) of the balanced spacetree, in quarter
    millimetres."""
    mesh_run(c, image, "tree", list(arguments), stop_after="balance")
    return set(read_mesh(c.path("tree.vtu"))["quarter_mm_points"])


def check_inserted_points(tessellate, mesh, corners, what):
    """inserted_points counts the mesh points that are no spacetree vertex (face and cell
    centres)."""
    new = sum(1 for point in mesh["quarter_mm_points"] if point not in corners)
    check(tessellate["inserted_points"] == new,
          "%s: inserted_points %d, but %d points of the mesh are no leaf corner" %
          (what, tessellate["inserted_points"], new))


def tessellate_run(c, image, name, arguments, extension=".vtu"):
    """stmesh IMAGE -o NAME.vtu --summary NAME.json ARGUMENTS --separating none: the summary,
    the tessellate stage, the read-back staircase mesh and stderr, after checking that the
    summary agrees with the file: cells, points, cells per type and per material, and the
    hexahedron volume share."""
    output, summary_path = c.path(name + extension), c.path(name + ".json")
    out, err = c.run_ok([image, "-o", output, "--summary", summary_path] + arguments + STAIRCASE)
    summary, mesh = load_summary(summary_path), read_mesh(output)
    tessellate = stage(summary, "tessellate")
    check(tessellate["cells"] == mesh["cells"] and tessellate["points"] == mesh["points"],
          "%s: the summary says %d cells, %d points, the file has %d, %d" %
          (name, tessellate["cells"], tessellate["points"], mesh["cells"], mesh["points"]))
    check(tessellate["cells_by_type"] == count_by_type(mesh),
          "%s: cells_by_type %s, the file has %s" % (name, tessellate["cells_by_type"],
                                                     count_by_type(mesh)))
    elements = summary["parameters"]["elements"]
    key = "cells_per_material" if elements != "simplicial" else \
        "triangles_per_material" if TRIANGLE in mesh["types"] else "tetrahedra_per_material"
    check(summary.get(key) == count_by_material(mesh),
          "%s: %s %s, the file has %s" % (name, key, summary.get(key), count_by_material(mesh)))
    # The printed line below the table.
    line = "tessellate: " + ", ".join("%d %s" % (count, type_name) for type_name, count in
                                      tessellate["cells_by_type"].items())
    line += "; %d inserted points" % tessellate["inserted_points"]
    if elements == "simplicial":
        check("hexahedron_volume_fraction" not in tessellate,
              "%s: hexahedron_volume_fraction in simplicial output" % name)
    else:
        boxes = sum(m for t, m in zip(mesh["types"], mesh["measures"]) if t in (HEXAHEDRON, QUAD))
        fraction = boxes / sum(mesh["measures"])
        check(abs(tessellate["hexahedron_volume_fraction"] - fraction) <= 1e-9,
              "%s: hexahedron_volume_fraction %r, the file's cells give %r" %
              (name, tessellate["hexahedron_volume_fraction"], fraction))
        line += "; %s fraction %.4f" % ("quad area" if QUAD in mesh["types"] or
                                        TRIANGLE in mesh["types"] else "hexahedron volume",
                                        tessellate["hexahedron_volume_fraction"])
    check(line in out.splitlines(), "%s: stdout lacks the line %r" % (name, line))
    return summary, tessellate, mesh, err


def case_option_elements_hybrid_uniform(c):
    # --max-cell-size 1: every leaf is a voxel, so no face has an extra vertex: the hybrid mesh
    # is the voxels themselves, the simplicial one their checkerboard templates.
    for name in ["boxes.vti", "boxes.nii"]:
        image, voxels = write_label_image(c, name, (12, 10, 8), two_boxes)
        check(voxels == {"1": 144, "2": 108}, "bad test image: %s" % voxels)
        stem = name.replace(".", "_")
        summary, tessellate, mesh, _ = tessellate_run(
            c, image, stem + "_hybrid", ["--elements", "hybrid", "--max-cell-size", "1"])
        check(summary["parameters"] == dict(
            {"labels": [], "all_labels": True, "max_cell_size": 1, "balance": 1,
             "stop_after": "tessellate", "compressor": "lz4"}, **DEFAULT_SPACETREE_PARAMETERS,
            **dict(DEFAULT_TESSELLATE_PARAMETERS, elements="hybrid"),
            **STAIRCASE_CUT_PARAMETERS, **DEFAULT_LABEL_PARAMETERS),
            "bad parameters %s" % summary["parameters"])
        check(tessellate["cells_by_type"] == {"hexahedron": 252},
              "%s: cells %s, expected 252 hexahedra" % (name, tessellate["cells_by_type"]))
        check(summary["cells_per_material"] == voxels, "%s: hexahedra per material %s" %
              (name, summary["cells_per_material"]))
        check(tessellate["inserted_points"] == 0, "%s: inserted points in a uniform tree" % name)
        check(tessellate["hexahedron_volume_fraction"] == 1, "%s: hexahedron volume fraction %r"
              % (name, tessellate["hexahedron_volume_fraction"]))
        # (7 x 7 x 7) corners of the 7 x 6 x 6 voxel block.
        check(mesh["points"] == 8 * 7 * 7, "%s: %d points" % (name, mesh["points"]))
        check(mesh["hanging"] is None, "%s: hybrid output has a HangingNode array" % name)
        check_volume_equals_voxels(mesh, voxels, name + " hybrid")
    # The same in legacy VTK.
    _, _, legacy, _ = tessellate_run(c, image, "boxes_hybrid_legacy",
                                     ["--elements", "hybrid", "--max-cell-size", "1"], ".vtk")
    check(legacy["types"] == mesh["types"] and legacy["materials"] == mesh["materials"],
          "the .vtk and .vtu hybrid meshes differ")


def case_option_cell_template(c):
    image, voxels = write_label_image(c, "boxes.vti", (12, 10, 8), two_boxes)
    for arguments, per_voxel in [([], 5), (["--cell-template", "checkerboard"], 5),
                                 (["--cell-template", "kuhn"], 6),
                                 (["--cell-template=kuhn", "--templates", "midpoint"], None)]:
        name = "_".join(a.strip("-").replace("=", "_") for a in arguments) or "default"
        summary, tessellate, mesh, _ = tessellate_run(c, image, name,
                                                      ["--max-cell-size", "1"] + arguments)
        check(summary["parameters"]["cell_template"] == ("kuhn" if per_voxel != 5 else
                                                        "checkerboard"),
              "%s: cell_template %s" % (name, summary["parameters"]["cell_template"]))
        if per_voxel:
            check(tessellate["cells_by_type"] == {"tetra": per_voxel * 252},
                  "%s: %s, expected %d tetrahedra per voxel" %
                  (name, tessellate["cells_by_type"], per_voxel))
            check(tessellate["inserted_points"] == 0, "%s: inserted points" % name)
            check(summary["tetrahedra_per_material"] ==
                  {m: per_voxel * n for m, n in voxels.items()}, "%s: per material" % name)
        else:
            # The midpoint rule splits every face and voxel at its centre: 12 tetrahedra per
            # face, 6 faces, and the template no longer matters.
            check(tessellate["cells_by_type"] == {"tetra": 24 * 252},
                  "%s: %s, expected 24 tetrahedra per voxel" % (name, tessellate["cells_by_type"]))
            check(tessellate["inserted_points"] > 0, "%s: no inserted points" % name)
        check_volume_equals_voxels(mesh, voxels, name)


def case_option_elements_hybrid(c):
    image, voxels = write_label_image(c, "ball.vti", (16, 15, 14), ball)
    _, leaves_stage, leaves_mesh, _ = tessellate_run(c, image, "leaves", ["--elements", "leaves"])
    summary, tessellate, mesh, _ = tessellate_run(c, image, "hybrid", ["--elements", "hybrid"])
    counts = tessellate["cells_by_type"]
    check(sorted(counts) == ["hexahedron", "pyramid", "tetra"] and min(counts.values()) > 0,
          "hybrid cells %s: expected hexahedra, pyramids and tetrahedra" % counts)
    check(0 < tessellate["hexahedron_volume_fraction"] < 1,
          "hexahedron volume fraction %r" % tessellate["hexahedron_volume_fraction"])
    check_volume_equals_voxels(mesh, voxels, "hybrid")
    check(abs(sum(mesh["measures"]) - sum(voxels.values())) <= 1e-9 * sum(voxels.values()),
          "the hybrid mesh measures %r, the body's voxels %d" %
          (sum(mesh["measures"]), sum(voxels.values())))
    # The points are spacetree vertices or the inserted face and cell centres; the leaves
    # output has only the corners of the body's leaves.
    corners = spacetree_corners(c, image)
    check(tessellate["inserted_points"] > 0, "no inserted points")
    check_inserted_points(tessellate, mesh, corners, "hybrid")
    check_inserted_points(leaves_stage, leaves_mesh, corners, "leaves")
    check(leaves_stage["inserted_points"] == 0, "leaves output inserted points")
    # --templates and --cell-template do not apply to hybrid output: a warning, the same mesh.
    _, _, same, err = tessellate_run(c, image, "hybrid_templates",
                                     ["--elements", "hybrid", "--templates", "midpoint",
                                      "--cell-template", "kuhn"])
    for option in ["--templates", "--cell-template"]:
        check("stmesh: warning: %s applies to simplicial output only; ignored with --elements "
              "hybrid" % option in err, "no warning that %s is ignored" % option)
    check(same == mesh, "--templates or --cell-template changed the hybrid mesh")
    # A 2D image: quads and triangles, the quads' area share.
    flat = c.make_image("slice.vti", variant="2d")
    summary, tessellate, mesh, _ = tessellate_run(c, flat, "flat", ["--elements", "hybrid"])
    check(sorted(tessellate["cells_by_type"]) == ["quad", "triangle"],
          "2D hybrid cells %s" % tessellate["cells_by_type"])
    check(0 < tessellate["hexahedron_volume_fraction"] < 1,
          "2D quad area fraction %r" % tessellate["hexahedron_volume_fraction"])
    check_volume_equals_voxels(mesh, voxel_volumes(flat=True), "2D hybrid")


def case_option_elements_leaves(c):
    image, voxels = write_label_image(c, "ball.vti", (16, 15, 14), ball)
    tree, _ = mesh_run(c, image, "tree", [], stop_after="balance")
    body_leaves = {m: n for m, n in tree["leaves_per_material"].items() if m != "0"}
    summary, tessellate, mesh, _ = tessellate_run(c, image, "leaves", ["--elements", "leaves"])
    check(tessellate["cells_by_type"] == {"hexahedron": sum(body_leaves.values())},
          "%s, expected one hexahedron per body leaf (%d)" % (tessellate["cells_by_type"],
                                                              sum(body_leaves.values())))
    check(summary["cells_per_material"] == body_leaves,
          "hexahedra per material %s, body leaves %s" % (summary["cells_per_material"],
                                                         body_leaves))
    check(tessellate["inserted_points"] == 0, "leaves output inserted points")
    check(tessellate["hexahedron_volume_fraction"] == 1, "hexahedron volume fraction %r" %
          tessellate["hexahedron_volume_fraction"])
    check_volume_equals_voxels(mesh, voxels, "leaves")
    # Hanging nodes: the balanced tree has leaves of different sizes side by side.
    check(mesh["hanging"] is not None, "no point array HangingNode")
    check(set(mesh["hanging"]) == {0, 1}, "HangingNode values %s" % sorted(set(mesh["hanging"])))
    # A uniform tree has none.
    boxes, box_voxels = write_label_image(c, "boxes.vti", (12, 10, 8), two_boxes)
    _, tessellate, mesh, _ = tessellate_run(c, boxes, "uniform",
                                            ["--elements", "leaves", "--max-cell-size", "1"])
    check(tessellate["cells_by_type"] == {"hexahedron": 252}, "uniform leaves %s" %
          tessellate["cells_by_type"])
    check(mesh["hanging"] is not None and set(mesh["hanging"]) == {0},
          "hanging nodes in a uniform tree")
    check_volume_equals_voxels(mesh, box_voxels, "uniform leaves")


def case_option_templates(c):
    image, voxels = write_label_image(c, "ball.vti", (16, 15, 14), ball)
    corners = spacetree_corners(c, image)
    inserted = {}
    for rule in ["midpoint", "regular", "extended"]:
        summary, tessellate, mesh, _ = tessellate_run(c, image, rule, ["--templates", rule])
        check_inserted_points(tessellate, mesh, corners, rule)
        check(summary["parameters"]["templates"] == rule, "bad templates parameter")
        check(list(tessellate["cells_by_type"]) == ["tetra"], "%s: cells %s" %
              (rule, tessellate["cells_by_type"]))
        check_volume_equals_voxels(mesh, voxels, rule)
        inserted[rule] = tessellate["inserted_points"]
    check(inserted["extended"] < inserted["regular"] < inserted["midpoint"],
          "inserted points: extended %(extended)d, regular %(regular)d, midpoint %(midpoint)d; "
          "expected decreasing" % inserted)
    # regular is the default.
    _, default, _, _ = tessellate_run(c, image, "default", [])
    check(default["inserted_points"] == inserted["regular"], "regular is not the default")


def case_option_boundary_layer(c):
    image, voxels = write_label_image(c, "ball.vti", (16, 15, 14), ball)
    background = {}
    for elements in ["simplicial", "hybrid", "leaves"]:
        runs = {}
        for layers in [0, 1, 2]:
            name = "%s_%d" % (elements, layers)
            summary, _, mesh, _ = tessellate_run(
                c, image, name, ["--elements", elements, "--boundary-layer=%d" % layers])
            check(summary["parameters"]["boundary_layers"] == layers,
                  "%s: boundary_layers %s" % (name, summary["parameters"]["boundary_layers"]))
            check_volume_equals_voxels(mesh, voxels, name)
            runs[layers] = mesh
        materials = [count_by_material(runs[layers]) for layers in [0, 1, 2]]
        check("0" not in materials[0], "%s: background cells without --boundary-layer" % elements)
        check(0 < materials[1].get("0", 0) < materials[2].get("0", 0),
              "%s: background cells %s with 1 and 2 layers" %
              (elements, [m.get("0") for m in materials]))
        # The body's cells do not change; the layers only add background cells.
        for layers in [1, 2]:
            body = {m: n for m, n in materials[layers].items() if m != "0"}
            check(body == materials[0], "%s: %d layers change the body's cells" %
                  (elements, layers))
        background[elements] = volume_by_material(runs[1])["0"]
    # One layer is the same region of background leaves in every output type.
    check(abs(background["hybrid"] - background["simplicial"]) <= 1e-9 * background["simplicial"]
          and abs(background["leaves"] - background["simplicial"]) <=
          1e-9 * background["simplicial"],
          "the first background layer measures %s" % background)
    _, _, wide, _ = tessellate_run(c, image, "wide", ["--boundary-layer", "100"])
    check(count_by_material(wide).get("0", 0) > 0, "--boundary-layer 100 adds no cells")


def case_error_tessellate_option_values(c):
    image, _ = write_label_image(c, "boxes.vti", (12, 10, 8), two_boxes)
    output = c.path("out.vtu")
    for arguments, text in [
            (["--elements", "foo"], "--elements: 'foo' is not one of simplicial, hybrid, leaves"),
            (["--elements", "Hybrid"],
             "--elements: 'Hybrid' is not one of simplicial, hybrid, leaves"),
            (["--elements", ""], "--elements: '' is not one of simplicial, hybrid, leaves"),
            (["--elements=tetra"], "--elements: 'tetra' is not one of simplicial, hybrid, leaves"),
            (["--elements", "hybrid", "--elements", "leaves"], "--elements given more than once"),
            (["--elements"], "--elements needs a value"),
            (["--templates", "x"], "--templates: 'x' is not one of midpoint, regular, extended"),
            (["--cell-template", "y"], "--cell-template: 'y' is not one of checkerboard, kuhn"),
            (["--boundary-layer", "-1"], "--boundary-layer: -1 is out of range (0 to 100)"),
            (["--boundary-layer", "101"], "--boundary-layer: 101 is out of range (0 to 100)"),
            (["--boundary-layer=101"], "--boundary-layer: 101 is out of range (0 to 100)"),
            (["--boundary-layer", "1.5"], "--boundary-layer: '1.5' is not an integer"),
            (["--boundary-layer", ""], "--boundary-layer needs an integer value"),
            (["--boundary-layers", "1"], "unknown option '--boundary-layers'")]:
        err = c.run_failing([image, "-o", output] + arguments, 2, text, output=output)
        error_lines = [line for line in err.splitlines() if line.startswith(ERROR_PREFIX)]
        check(len(error_lines) == 1 and error_lines[0].startswith(ERROR_PREFIX + " " + text),
              "expected one error line starting with %r, got %s" % (text, error_lines))
        check("--help" in err, "usage errors should point to --help")


# ------------------------------------------------------------------------------------------------
# The cut stage (--separating, --output-mode, --keep, --iso): stmMarchingSimplices on the
# tetrahedra, at the labels' function or one of stmSeparatingFunction.

def cut_vtk_modules():
    """The VTK classes of the cut cases, besides vtk_modules()."""
    try:
        from vtkmodules.vtkIOImage import vtkMetaImageWriter
        from vtkmodules.vtkIOLegacy import vtkPolyDataReader
        from vtkmodules.vtkIOXML import vtkXMLPolyDataReader
    except ImportError as error:
        raise CaseFailed("%s cannot import the VTK Python modules (%s); run this script with "
                         "Debian's /usr/bin/python3" % (sys.executable, error))
    return dict(vtk_modules(), vtkMetaImageWriter=vtkMetaImageWriter,
                vtkPolyDataReader=vtkPolyDataReader, vtkXMLPolyDataReader=vtkXMLPolyDataReader)


def big_ball(i, j, k):
    """Label 1: a ball of radius 8 voxels around (12, 12, 12) in 25 x 25 x 25."""
    return 1 if (i - 12) ** 2 + (j - 12) ** 2 + (k - 12) ** 2 <= 64 else 0


def ball_volume(radius):
    return 4.0 / 3.0 * 3.141592653589793 * radius ** 3


def filled_image(vtk, dimensions, vtk_type, name, value):
    """A vtkImageData of `dimensions` points with the scalar array `name` of `vtk_type`, holding
    value(i, j, k) at each point (i fastest)."""
    image = vtk["vtkImageData"]()
    image.SetDimensions(*dimensions)
    image.AllocateScalars(vtk_type, 1)
    scalars = image.GetPointData().GetScalars()
    scalars.SetName(name)
    index = 0
    for k in range(dimensions[2]):
        for j in range(dimensions[1]):
            for i in range(dimensions[0]):
                scalars.SetValue(index, value(i, j, k))
                index += 1
    return image


def write_gray_image(c, name, dimensions, gray):
    """A float gray image of 1 mm voxels with gray(i, j, k) at each voxel, as .mha or .vti."""
    vtk = cut_vtk_modules()
    image = filled_image(vtk, dimensions, 10, "gray", gray)  # VTK_FLOAT
    path = c.path(name)
    errors = []
    if name.endswith(".vti"):
        writer = watched(vtk["vtkXMLImageDataWriter"](), errors)
        writer.SetDataModeToBinary()
    else:
        writer = watched(vtk["vtkMetaImageWriter"](), errors)
        writer.SetCompression(False)
    writer.SetInputData(image)
    writer.SetFileName(path)
    writer.Write()
    check(not errors and os.path.getsize(path) > 0, "cannot write %s: %s" % (name, errors))
    return path


def read_cut(path):
    """The volume mesh of a cut run (.vtu or .vtk) as a dict: cells, points, the set of cell
    types, Material and OriginalMaterial per cell (None without them), the measure (volume, or
    area in 2D) of every cell and the names of the point and cell arrays."""
    vtk, grid, errors = read_grid(path)
    cells = grid.GetNumberOfCells()
    types = set(grid.GetCellType(cell) for cell in range(cells))
    measures = []
    if cells:
        sizes = watched(vtk["vtkCellSizeFilter"](), errors)
        sizes.SetInputData(grid)
        sizes.Update()
        check(not errors, "vtkCellSizeFilter failed on %s" % path)
        array = sizes.GetOutput().GetCellData().GetArray("Area" if TRIANGLE in types else "Volume")
        measures = [array.GetValue(cell) for cell in range(cells)]
    cell_data, point_data = grid.GetCellData(), grid.GetPointData()

    def values(name):
        array = cell_data.GetArray(name)
        return None if array is None else [int(array.GetTuple1(cell)) for cell in range(cells)]

    return {"cells": cells, "points": grid.GetNumberOfPoints(), "types": types,
            "materials": values("Material"), "original": values("OriginalMaterial"),
            "measures": measures,
            "point_arrays": sorted(point_data.GetArrayName(i)
                                   for i in range(point_data.GetNumberOfArrays())),
            "cell_arrays": sorted(cell_data.GetArrayName(i)
                                  for i in range(cell_data.GetNumberOfArrays()))}


def material_volumes(mesh):
    volumes = {}
    for material, measure in zip(mesh["materials"], mesh["measures"]):
        volumes[material] = volumes.get(material, 0.0) + measure
    return volumes


def close(value, reference, relative=1e-9):
    return abs(value - reference) <= relative * abs(reference)


def read_surface(path):
    """The surface of a cut run (.vtp or .vtk): points, cells (point id lists), cell types,
    OriginalMaterial per cell and the cell array names."""
    vtk = cut_vtk_modules()
    errors = []
    if path.endswith(".vtp"):
        with open(path, "rb") as surface_file:
            content = surface_file.read()
        check(b'type="PolyData"' in content[:4096] and b'format="binary"' in content[:4096] and
              b"<AppendedData" not in content, "%s is not inline binary XML polydata" % path)
        reader = watched(vtk["vtkXMLPolyDataReader"](), errors)
    else:
        with open(path, "rb") as surface_file:
            head = surface_file.read(256)
        check(b"\nBINARY\n" in head and b"POLYDATA" in head,
              "%s is not binary legacy VTK polydata" % path)
        reader = watched(vtk["vtkPolyDataReader"](), errors)
    reader.SetFileName(path)
    reader.Update()
    surface = reader.GetOutput()
    check(not errors and surface is not None, "cannot read back %s: %s" % (path, errors))
    cells = []
    for cell in range(surface.GetNumberOfCells()):
        ids = surface.GetCell(cell).GetPointIds()
        cells.append([ids.GetId(i) for i in range(ids.GetNumberOfIds())])
    cell_data = surface.GetCellData()
    original = cell_data.GetArray("OriginalMaterial")
    pairs = cell_data.GetArray("BoundaryLabels")
    return {"points": [surface.GetPoint(point) for point in range(surface.GetNumberOfPoints())],
            "cells": cells,
            "types": set(surface.GetCellType(cell) for cell in range(surface.GetNumberOfCells())),
            "original": None if original is None else
            [int(original.GetTuple1(cell)) for cell in range(surface.GetNumberOfCells())],
            "boundary_labels": None if pairs is None else
            [tuple(int(value) for value in pairs.GetTuple2(cell))
             for cell in range(surface.GetNumberOfCells())],
            "cell_arrays": sorted(cell_data.GetArrayName(i)
                                  for i in range(cell_data.GetNumberOfArrays()))}


def check_closed_and_oriented(surface, what):
    """Every edge of the surface (triangles, or the points of 2D lines) is shared by exactly two
    of its cells, in opposite directions: a closed, consistently oriented surface."""
    check(surface["cells"], "%s: the surface is empty" % what)
    directed = {}
    for ids in surface["cells"]:
        for a, b in zip(ids, ids[1:] + ids[:1]) if len(ids) == 3 else [tuple(ids)]:
            directed[(a, b)] = directed.get((a, b), 0) + 1
    check(max(directed.values()) == 1, "%s: a directed edge occurs twice" % what)
    if all(len(ids) == 3 for ids in surface["cells"]):
        unmatched = [edge for edge in directed if (edge[1], edge[0]) not in directed]
        check(not unmatched, "%s: %d edges have only one triangle (or two of the same "
              "orientation), e.g. %s" % (what, len(unmatched), unmatched[:3]))
    else:
        starts = sorted(a for a, _ in directed)
        ends = sorted(b for _, b in directed)
        check(starts == ends and len(set(starts)) == len(starts),
              "%s: the lines do not form closed curves" % what)


def enclosed_volume(surface):
    """The volume a closed triangle surface encloses, positive for outward normals."""
    points = surface["points"]
    total = 0.0
    for a, b, c in surface["cells"]:
        p, q, r = points[a], points[b], points[c]
        total += (p[0] * (q[1] * r[2] - q[2] * r[1]) - p[1] * (q[0] * r[2] - q[2] * r[0]) +
                  p[2] * (q[0] * r[1] - q[1] * r[0])) / 6.0
    return total


def option_value(arguments, name, default):
    """The value of --name in an argument list, or the default."""
    return arguments[arguments.index(name) + 1] if name in arguments else default


def plain_run(c, image, name, arguments):
    """stmesh IMAGE -o NAME.vtu --summary NAME.json ARGUMENTS: the summary and the read-back
    mesh (read_cut), for runs that cut_run's binary checks do not fit (several materials)."""
    output, summary_path = c.path(name + ".vtu"), c.path(name + ".json")
    c.run_ok([image, "-o", output, "--summary", summary_path] + arguments)
    return load_summary(summary_path), read_cut(output)


def cut_run(c, image, name, arguments, inside=1, extension=".vtu"):
    """stmesh IMAGE -o NAME.vtu --summary NAME.json ARGUMENTS with a cut stage (volume output):
    the summary, its tessellate and cut stages, the read-back mesh, stdout and stderr, after
    checking that they agree: the stages (snap, cut and smooth unless --stop-after cut), the
    cells and points, the cells inside (Material INSIDE) and outside (0), the per-material
    counts and the lines below the table. With smoothing the cut keeps both sides and --keep
    acts after the smoothing, so the file's sides are the cut's, or one of them."""
    output, summary_path = c.path(name + extension), c.path(name + ".json")
    out, err = c.run_ok([image, "-o", output, "--summary", summary_path] + arguments)
    summary, mesh = load_summary(summary_path), read_cut(output)
    stop_after = option_value(arguments, "--stop-after", "smooth")
    stages = STAGES_CUT if stop_after == "cut" else STAGES_ALL
    check([entry["name"] for entry in summary["stages"]] == stages,
          "%s: stages %s" % (name, [entry["name"] for entry in summary["stages"]]))
    check_table(out, stages)
    check(summary["parameters"]["stop_after"] == stop_after, "%s: stop_after %s" %
          (name, summary["parameters"]["stop_after"]))
    tessellate, cut = stage(summary, "tessellate"), stage(summary, "cut")
    smooth = stage(summary, "smooth") if stop_after == "smooth" else None
    smoothed = smooth is not None and not smooth["skipped"]
    last = smooth if smoothed else cut
    check(last["cells"] == mesh["cells"] and last["points"] == mesh["points"],
          "%s: the summary says %d cells, %d points, the file has %d, %d" %
          (name, last["cells"], last["points"], mesh["cells"], mesh["points"]))
    check(mesh["materials"] is not None and mesh["original"] is not None,
          "%s: no Material or OriginalMaterial" % name)
    check(set(mesh["materials"]) <= {inside, 0},
          "%s: Material values %s, expected %d inside and 0 outside" %
          (name, sorted(set(mesh["materials"])), inside))
    inside_cells = mesh["materials"].count(inside)
    keep = option_value(arguments, "--keep", "both")
    expected = (cut["inside_cells"], cut["outside_cells"])
    if smoothed:
        expected = (expected[0] if keep != "outside" else 0,
                    expected[1] if keep != "inside" else 0)
    check(expected == (inside_cells, mesh["cells"] - inside_cells),
          "%s: inside_cells %s, outside_cells %s (--keep %s); the file has %d and %d" %
          (name, cut["inside_cells"], cut["outside_cells"], keep, inside_cells,
           mesh["cells"] - inside_cells))
    key = "triangles_per_material" if TRIANGLE in mesh["types"] else "tetrahedra_per_material"
    counts = {}
    for material in mesh["materials"]:
        counts[str(material)] = counts.get(str(material), 0) + 1
    check(summary.get(key) == counts, "%s: %s %s, the file has %s" %
          (name, key, summary.get(key), counts))
    for figure in ["split_cells", "cut_points"]:
        check(isinstance(cut[figure], int) and cut[figure] >= 0, "%s: bad %s %s" %
              (name, figure, cut[figure]))
    line = "cut: %d split cells, %d cut points; %d inside cells, %d outside cells" % (
        cut["split_cells"], cut["cut_points"], cut["inside_cells"], cut["outside_cells"])
    check(line in out.splitlines(), "%s: stdout lacks the line %r" % (name, line))
    snap = stage(summary, "snap")
    if not snap["skipped"]:
        check(isinstance(snap["snapped_points"], int) and snap["snapped_points"] >= 0 and
              isinstance(snap["refused_snaps"], int) and snap["refused_snaps"] >= 0,
              "%s: bad snap figures %s" % (name, snap))
        # Snapping moves points; it adds and removes none.
        check(snap["points"] == tessellate["points"] and snap["cells"] == tessellate["cells"],
              "%s: the snap stage changed the mesh's size" % name)
        line = "snap: %d snapped points, %d refused snaps" % (snap["snapped_points"],
                                                              snap["refused_snaps"])
        check(line in out.splitlines(), "%s: stdout lacks the line %r" % (name, line))
    if smoothed:
        check(isinstance(smooth["moved_points"], int) and smooth["moved_points"] >= 0 and
              isinstance(smooth["rejected_moves"], int) and smooth["rejected_moves"] >= 0 and
              isinstance(smooth["improved_points"], int) and smooth["improved_points"] >= 0,
              "%s: bad smooth figures %s" % (name, smooth))
        line = smooth_line(smooth)
        check(line in out.splitlines(), "%s: stdout lacks the line %r" % (name, line))
    layers = tessellate["boundary_layers"]
    check(("; %d boundary layer%s" % (layers, "" if layers == 1 else "s")) in out,
          "%s: stdout does not show the %d boundary layers" % (name, layers))
    if mesh["cells"]:
        check(min(mesh["measures"]) > 0, "%s: a cell has measure %r" %
              (name, min(mesh["measures"])))
    return summary, tessellate, cut, mesh, out, err


def staircase_volume(c, image, name, layers, arguments=None):
    """The total volume (area) of the staircase mesh with LAYERS background layers: the
    tessellation of a run with `arguments` (the labels function's spacetree has leaves of one
    voxel at convex corners, which --separating none's has not), or of --separating none's."""
    output = c.path(name + ".vtu")
    if arguments is None:
        c.run_ok([image, "-o", output, "--boundary-layer", str(layers)] + STAIRCASE)
    else:
        c.run_ok([image, "-o", output, "--boundary-layer", str(layers), "--stop-after",
                  "tessellate"] + arguments)
    return sum(read_cut(output)["measures"])


def case_cut_default(c):
    image, voxels = write_label_image(c, "ball.vti", (16, 15, 14), ball)
    summary, tessellate, cut, mesh, out, _ = cut_run(c, image, "default", [])
    # Snapping and smoothing are part of the default pipeline, which now stops after smooth.
    check(summary["parameters"] == dict(
        {"labels": [], "all_labels": True, "max_cell_size": 16, "balance": 1,
         "stop_after": "smooth", "compressor": "lz4"}, **DEFAULT_SPACETREE_PARAMETERS,
        **DEFAULT_TESSELLATE_PARAMETERS, **DEFAULT_CUT_PARAMETERS, **DEFAULT_LABEL_PARAMETERS),
        "bad parameters %s" % summary["parameters"])
    check(mesh["types"] == {TETRA}, "cell types %s, expected tetrahedra" % mesh["types"])
    # Every label of the body is inside: Material 1; the tessellation's labels are kept.
    check(set(mesh["materials"]) == {1, 0}, "Material values %s" % sorted(set(mesh["materials"])))
    check(set(mesh["original"]) == {0, 1, 3},
          "OriginalMaterial values %s" % sorted(set(mesh["original"])))
    check("SeparatingFunction" in mesh["point_arrays"], "no point array SeparatingFunction")
    # The labels' function brings one background layer; the cut splits cells and adds points
    # on their edges, keeping every tessellation point.
    check(tessellate["boundary_layers"] == 1, "boundary_layers %s" % tessellate["boundary_layers"])
    check(cut["split_cells"] > 0 and cut["cut_points"] > 0, "nothing was cut")
    check(cut["points"] == tessellate["points"] + cut["cut_points"],
          "the cut has %d points, the tessellation %d plus %d cut points" %
          (cut["points"], tessellate["points"], cut["cut_points"]))
    check(cut["cells"] > tessellate["cells"], "the cut has no more cells than the tessellation")
    for entry in summary["stages"]:
        if entry["name"] != "cut":
            check("split_cells" not in entry, "stage %s has cut figures" % entry["name"])
    # Volume conservation: snapping and smoothing move only points inside the domain, and the
    # cut covers exactly the domain of the staircase mesh with one background layer.
    total = sum(mesh["measures"])
    staircase = staircase_volume(c, image, "staircase", 1, [])
    check(close(total, staircase), "the cut mesh measures %r, the staircase mesh with one "
          "layer %r" % (total, staircase))
    # The surface lies within half a voxel of the voxels' boundary.
    inside = material_volumes(mesh)[1]
    body = sum(voxels.values())
    check(0.75 * body < inside < 1.1 * body,
          "the inside measures %r, the body's voxels %d" % (inside, body))
    # One label selected: it is the inside Material; several merged: 1; several without
    # --materials: each its own material, as --materials separate makes them.
    _, _, _, single, _, _ = cut_run(c, image, "label3", ["--labels", "3"], inside=3)
    check(set(single["materials"]) == {3, 0}, "--labels 3: Material values %s" %
          sorted(set(single["materials"])))
    _, _, _, both, _, _ = cut_run(c, image, "labels13", ["--labels", "3,1", "--materials",
                                                         "merged"])
    check(set(both["materials"]) == {1, 0}, "--labels 3,1 --materials merged: Material values %s"
          % sorted(set(both["materials"])))
    summary, several = plain_run(c, image, "labels13_separate", ["--labels", "3,1"])
    _, separate = plain_run(c, image, "labels13_explicit",
                            ["--labels", "3,1", "--materials", "separate"])
    check(summary["parameters"]["materials"] == "separate" and several == separate,
          "--labels 3,1 is not --materials separate: %s" % summary["parameters"]["materials"])
    check({1, 3} <= set(several["materials"]), "--labels 3,1: Material values %s" %
          sorted(set(several["materials"])))
    # Legacy VTK output and an explicit --stop-after smooth give the same mesh.
    _, _, _, legacy, _, _ = cut_run(c, image, "legacy", ["--stop-after", "smooth"],
                                    extension=".vtk")
    check(legacy == mesh, "the .vtk cut mesh differs from the .vtu")
    # --stop-after tessellate writes the tessellation with the function and its layer.
    output, summary_path = c.path("tessellation.vtu"), c.path("tessellation.json")
    out, _ = c.run_ok([image, "-o", output, "--summary", summary_path, "--stop-after",
                       "tessellate"])
    check_table(out, STAGES_TESSELLATE)
    tessellation = read_cut(output)
    check("SeparatingFunction" in tessellation["point_arrays"],
          "--stop-after tessellate: no point array SeparatingFunction")
    check(set(tessellation["materials"]) == {0, 1, 3},
          "--stop-after tessellate: Material values %s" % sorted(set(tessellation["materials"])))
    check(tessellation["cells"] == tessellate["cells"], "--stop-after tessellate changes the "
          "tessellation")


def case_cut_keep(c):
    image, _ = write_label_image(c, "ball.vti", (16, 15, 14), ball)
    _, _, _, both, _, _ = cut_run(c, image, "both", ["--keep", "both"])
    summary, _, cut, inside, _, _ = cut_run(c, image, "inside", ["--keep", "inside"])
    check(summary["parameters"]["keep"] == "inside", "bad keep parameter")
    check(set(inside["materials"]) == {1}, "--keep inside: Material values %s" %
          sorted(set(inside["materials"])))
    # With smoothing (the default) the cut keeps both sides and the outside goes after the
    # smoothing; without it, the cut keeps only the inside.
    check(cut["outside_cells"] > 0, "--keep inside: outside_cells %s" % cut["outside_cells"])
    _, _, unsmoothed, _, _, _ = cut_run(c, image, "inside_cut", ["--keep", "inside",
                                                                 "--stop-after", "cut"])
    check(unsmoothed["outside_cells"] == 0 and unsmoothed["inside_cells"] == cut["inside_cells"],
          "--keep inside --stop-after cut: inside_cells %s, outside_cells %s" %
          (unsmoothed["inside_cells"], unsmoothed["outside_cells"]))
    _, _, _, outside, _, _ = cut_run(c, image, "outside", ["--keep", "outside"])
    check(set(outside["materials"]) == {0}, "--keep outside: Material values %s" %
          sorted(set(outside["materials"])))
    for name, mesh in [("inside", inside), ("outside", outside)]:
        check(mesh["points"] < both["points"], "--keep %s: %d points, both sides %d" %
              (name, mesh["points"], both["points"]))
    check(inside["cells"] + outside["cells"] == both["cells"],
          "the sides have %d + %d cells, both %d" % (inside["cells"], outside["cells"],
                                                    both["cells"]))
    volumes = material_volumes(both)
    check(close(sum(inside["measures"]), volumes[1]) and
          close(sum(outside["measures"]), volumes[0]),
          "the kept sides measure %r and %r, both sides' %s" %
          (sum(inside["measures"]), sum(outside["measures"]), volumes))
    # --iso moves the surface: a negative iso-value shrinks the inside.
    _, _, _, shrunk, _, _ = cut_run(c, image, "iso", ["--iso", "-0.5", "--keep", "inside"])
    check(0 < sum(shrunk["measures"]) < sum(inside["measures"]),
          "--iso -0.5: the inside measures %r, at 0 %r" % (sum(shrunk["measures"]),
                                                           sum(inside["measures"])))


def case_cut_surface(c):
    image, _ = write_label_image(c, "ball.vti", (16, 15, 14), ball)
    _, _, _, volume, _, _ = cut_run(c, image, "volume", [])
    output, summary_path = c.path("surface.vtp"), c.path("surface.json")
    out, _ = c.run_ok([image, "-o", output, "--summary", summary_path, "--output-mode",
                       "surface"])
    check_table(out, STAGES_ALL)
    summary = load_summary(summary_path)
    check(summary["parameters"]["output_mode"] == "surface", "bad output_mode parameter")
    surface = read_surface(output)
    # With smoothing (the default) the cut keeps both sides in volume mode, and the smooth
    # stage takes the surface from the smoothed mesh: its figures describe the surface.
    cut, smooth = stage(summary, "cut"), stage(summary, "smooth")
    check(surface["types"] == {TRIANGLE}, "surface cell types %s" % surface["types"])
    check(smooth["cells"] == len(surface["cells"]) and smooth["points"] == len(surface["points"]),
          "the summary says %d cells, %d points, the file has %d, %d" %
          (smooth["cells"], smooth["points"], len(surface["cells"]), len(surface["points"])))
    check(smooth["surface_cells"] == smooth["cells"], "bad surface_cells %s" % smooth)
    check(cut["inside_cells"] > 0 and cut["outside_cells"] > 0 and cut["split_cells"] > 0,
          "bad cut figures %s" % cut)
    check("Normals" in surface["cell_arrays"], "the surface has no Normals")
    counts = {}
    for material in surface["original"]:
        counts[str(material)] = counts.get(str(material), 0) + 1
    check(summary.get("triangles_per_original_material") == counts,
          "triangles_per_original_material %s, the file has %s" %
          (summary.get("triangles_per_original_material"), counts))
    check(smooth_line(smooth) + "; a surface of %d triangles" % smooth["cells"]
          in out.splitlines(), "stdout lacks the smooth line")
    check_closed_and_oriented(surface, "surface.vtp")
    # Oriented outward, it encloses exactly the inside of the (smoothed) volume output: the
    # surface is the smoothed interface, not a new cut.
    check(smooth["moved_points"] > 0, "smoothing moved no point")
    enclosed, inside = enclosed_volume(surface), material_volumes(volume)[1]
    check(close(enclosed, inside), "the surface encloses %r, the volume output's inside "
          "measures %r" % (enclosed, inside))
    # Without smoothing the cut writes the surface itself, as before the smooth stage existed.
    unsmoothed, unsmoothed_summary = c.path("unsmoothed.vtp"), c.path("unsmoothed.json")
    out, _ = c.run_ok([image, "-o", unsmoothed, "--summary", unsmoothed_summary,
                       "--output-mode", "surface", "--stop-after", "cut"])
    check_table(out, STAGES_CUT)
    cut = stage(load_summary(unsmoothed_summary), "cut")
    unsmoothed_surface = read_surface(unsmoothed)
    check(cut["cells"] == len(unsmoothed_surface["cells"]) and "inside_cells" not in cut,
          "bad cut figures %s" % cut)
    check("cut: %d split cells, %d cut points; a surface of %d triangles" %
          (cut["split_cells"], cut["cut_points"], cut["cells"]) in out.splitlines(),
          "stdout lacks the cut line")
    check_closed_and_oriented(unsmoothed_surface, "unsmoothed.vtp")
    # Smoothing moves points, never adds or removes facets.
    check(len(unsmoothed_surface["cells"]) == len(surface["cells"]),
          "the smoothed surface has %d triangles, the unsmoothed %d" %
          (len(surface["cells"]), len(unsmoothed_surface["cells"])))
    # Legacy VTK polydata: the same surface.
    c.run_ok([image, "-o", c.path("surface.vtk"), "--output-mode", "surface"])
    legacy = read_surface(c.path("surface.vtk"))
    check(legacy["cells"] == surface["cells"] and legacy["original"] == surface["original"],
          "the .vtk surface differs from the .vtp")
    # The default output name of a surface ends in .vtp.
    subdirectory = c.path("sub")
    os.mkdir(subdirectory)
    c.run_ok([image, "--output-mode", "surface"], cwd=subdirectory)
    check(os.listdir(subdirectory) == ["ball.vtp"],
          "expected only ball.vtp in the cwd, found %s" % os.listdir(subdirectory))


def case_cut_sphere(c):
    image, _ = write_label_image(c, "big_ball.vti", (25, 25, 25), big_ball)
    radius = 6.5
    summary, _, _, mesh, _, _ = cut_run(
        c, image, "sphere", ["--separating", "sphere:12,12,12,%g" % radius, "--max-cell-size",
                             "2"])
    check(summary["parameters"]["separating"] == "sphere:12,12,12,6.5",
          "bad separating parameter %s" % summary["parameters"]["separating"])
    check("SeparatingFunction" in mesh["point_arrays"], "no point array SeparatingFunction")
    # The linear interpolant of the convex |x - c|^2 - R^2 lies above it: the inside is a
    # polyhedron inscribed in the ball, a little smaller.
    inside, analytic = material_volumes(mesh)[1], ball_volume(radius)
    check(0.97 * analytic < inside <= analytic,
          "the inside measures %r, the ball of radius %g %r" % (inside, radius, analytic))
    total = sum(mesh["measures"])
    staircase = staircase_volume(c, image, "staircase", 1)
    check(close(total, staircase), "the cut mesh measures %r, the staircase mesh with one "
          "layer %r" % (total, staircase))
    # The tessellation's labels are kept: the sphere lies inside label 1.
    check(set(mesh["original"]) == {0, 1}, "OriginalMaterial values %s" %
          sorted(set(mesh["original"])))


def case_cut_smooth(c):
    image, _ = write_label_image(c, "ball.vti", (16, 15, 14), ball)
    _, labels_tessellate, _, labels, _, _ = cut_run(c, image, "labels", [])
    summary, tessellate, _, mesh, out, _ = cut_run(c, image, "smooth",
                                                  ["--separating", "smooth:1.5"])
    check(summary["parameters"]["separating"] == "smooth:1.5", "bad separating parameter")
    # 1 + ceil(3 sigma / voxel) = 1 + ceil(4.5) layers for the smoothed function's zero set.
    check(tessellate["boundary_layers"] == 6 > labels_tessellate["boundary_layers"],
          "boundary_layers %s with smooth:1.5, %s with labels" %
          (tessellate["boundary_layers"], labels_tessellate["boundary_layers"]))
    check("; 6 boundary layers" in out, "stdout does not report 6 boundary layers")
    check(mesh["cells"] > labels["cells"], "smooth:1.5 has no more cells than labels")
    check(set(mesh["materials"]) == {0, 1}, "Material values %s" % sorted(set(mesh["materials"])))
    total = sum(mesh["measures"])
    staircase = staircase_volume(c, image, "staircase", 6)
    check(close(total, staircase), "the cut mesh measures %r, the staircase mesh with six "
          "layers %r" % (total, staircase))
    # --boundary-layer above the function's need wins.
    _, wide, _, _, _, _ = cut_run(c, image, "wide", ["--separating", "smooth:1.5",
                                                     "--boundary-layer", "8"])
    check(wide["boundary_layers"] == 8, "--boundary-layer 8: %s layers" % wide["boundary_layers"])


def case_cut_gray(c):
    image, _ = write_label_image(c, "big_ball.vti", (25, 25, 25), big_ball)

    def gray(i, j, k):
        # Bright in the centre, 10 gray values darker per mm: 35 at 6.5 mm.
        return 100.0 - 10.0 * ((i - 12) ** 2 + (j - 12) ** 2 + (k - 12) ** 2) ** 0.5

    meshes = {}
    for name in ["gray.mha", "gray.vti"]:
        path = write_gray_image(c, name, (25, 25, 25), gray)
        summary, _, _, mesh, _, _ = cut_run(
            c, image, name.replace(".", "_"), ["--separating", "gray:%s:35" % path])
        check(summary["parameters"]["separating"] == "gray:%s:35" % path,
              "bad separating parameter %s" % summary["parameters"]["separating"])
        meshes[name] = mesh
    check(meshes["gray.mha"] == meshes["gray.vti"], "the .mha and .vti gray images differ")
    # The gray values are concave in space; their trilinear interpolation in the image and the
    # linear one on the tetrahedra are averages that lie below them (Jensen): the inside is a
    # little smaller than the ball where the gray value exceeds 35.
    mesh = meshes["gray.mha"]
    inside, analytic = material_volumes(mesh)[1], ball_volume(6.5)
    check(0.92 * analytic < inside <= analytic,
          "the inside measures %r, the ball of radius 6.5 %r" % (inside, analytic))
    total = sum(mesh["measures"])
    staircase = staircase_volume(c, image, "staircase", 1)
    check(close(total, staircase), "the cut mesh measures %r, the staircase mesh with one "
          "layer %r" % (total, staircase))
    # --iso -10 cuts at the gray value 45 (f = 35 - gray): a ball of radius 5.5.
    _, _, _, smaller, _, _ = cut_run(c, image, "iso", ["--separating",
                                                       "gray:%s:35" % c.path("gray.mha"),
                                                       "--iso", "-10", "--keep", "inside"])
    inside, analytic = sum(smaller["measures"]), ball_volume(5.5)
    check(0.92 * analytic < inside <= analytic,
          "--iso -10: the inside measures %r, the ball of radius 5.5 %r" % (inside, analytic))
    # An integer image works as a gray image too.
    _, _, cut, _, _, _ = cut_run(c, image, "labels_as_gray",
                                 ["--separating", "gray:%s:0.5" % image])
    check(cut["inside_cells"] > 0, "the label image as gray image: no inside cells")


def case_cut_two_dimensional(c):
    flat = c.make_image("slice.vti", variant="2d")
    summary, tessellate, _, mesh, _, _ = cut_run(c, flat, "flat", [])
    check(mesh["types"] == {TRIANGLE}, "2D cut cell types %s" % mesh["types"])
    check("triangles_per_material" in summary, "no triangles_per_material")
    total = sum(mesh["measures"])
    staircase = staircase_volume(c, flat, "staircase", 1, [])
    check(close(total, staircase), "the 2D cut mesh measures %r, the staircase mesh with one "
          "layer %r" % (total, staircase))
    output, summary_path = c.path("flat_surface.vtp"), c.path("flat_surface.json")
    out, _ = c.run_ok([flat, "-o", output, "--output-mode", "surface", "--summary",
                       summary_path])
    curve = read_surface(output)
    check(curve["types"] == {3}, "2D surface cell types %s, expected lines" % curve["types"])
    check_closed_and_oriented(curve, "flat_surface.vtp")
    # The smooth stage (default) takes the surface from the smoothed mesh.
    smooth = stage(load_summary(summary_path), "smooth")
    check(smooth["cells"] == len(curve["cells"]) and
          "a surface of %d lines" % smooth["cells"] in out, "stdout does not count the lines")
    check("lines_per_original_material" in load_summary(summary_path),
          "no lines_per_original_material")


def case_cut_warnings(c):
    image, _ = write_label_image(c, "ball.vti", (16, 15, 14), ball)
    # The cut options do nothing without a cut stage, and say so.
    plain = c.path("plain.vtu")
    c.run_ok([image, "-o", plain] + STAIRCASE)
    ignored = c.path("ignored.vtu")
    _, err = c.run_ok([image, "-o", ignored, "--output-mode", "volume", "--keep", "inside",
                       "--iso", "1"] + STAIRCASE)
    for option in ["--output-mode", "--keep", "--iso"]:
        check("stmesh: warning: %s applies to the cut stage only; ignored with --separating none"
              % option in err, "no warning that %s is ignored" % option)
    check(read_cut(ignored) == read_cut(plain), "ignored cut options changed the mesh")
    _, err = c.run_ok([image, "-o", c.path("early.vtu"), "--stop-after", "tessellate", "--keep",
                       "inside"])
    check("stmesh: warning: --keep applies to the cut stage only; ignored with --stop-after "
          "tessellate" in err, "no warning that --keep is ignored with --stop-after tessellate")
    _, err = c.run_ok([image, "-o", c.path("surface.vtp"), "--output-mode", "surface", "--keep",
                       "inside"])
    check("stmesh: warning: --keep applies to volume output only; ignored with --output-mode "
          "surface" in err, "no warning that --keep is ignored with surface output")
    # A separating function that the run stops before.
    for arguments, text in [
            (["--separating", "sphere:9,9,8,3", "--stop-after", "tessellate"],
             "stmesh: warning: --separating sphere:9,9,8,3 is ignored with --stop-after "
             "tessellate (the tessellation carries the labels' function)"),
            (["--separating", "smooth:1", "--stop-after", "balance"],
             "stmesh: warning: --separating smooth:1 is ignored with --stop-after balance")]:
        _, err = c.run_ok([image, "-o", c.path("stopped.vtu")] + arguments)
        check(text in err, "no warning %r" % text)
    _, err = c.run_ok([image, "-o", c.path("stopped.vtu"), "--separating", "smooth:1",
                       "--stop-after", "tessellate"])
    check("warning" not in err, "unexpected warning %r" % err)
    # No warning in a plain run.
    _, err = c.run_ok([image, "-o", c.path("default.vtu")])
    check("warning" not in err, "unexpected warning %r" % err)
    # A sphere that misses the mesh: an empty inside, and a warning.
    _, _, cut, _, _, err = cut_run(c, image, "missed", ["--separating", "sphere:100,100,100,2"])
    check(cut["inside_cells"] == 0, "a sphere outside the mesh has inside cells")
    check("stmesh: warning: the separating surface (--separating sphere:100,100,100,2) encloses "
          "no part of the mesh" in err, "no warning about an empty inside")
    # The snap and smooth options without their stage.
    for arguments, texts in [
            (["--alpha", "0.2", "--snap", "quality", "--smooth-iterations", "5",
              "--smooth-method", "laplacian"] + STAIRCASE,
             ["--alpha applies to the snap stage only; ignored with --separating none",
              "--snap applies to the snap stage only; ignored with --separating none",
              "--smooth-iterations applies to the smooth stage only; ignored with "
              "--separating none",
              "--smooth-method applies to the smooth stage only; ignored with "
              "--separating none"]),
            (["--alpha", "0.2", "--stop-after", "tessellate"],
             ["--alpha applies to the snap stage only; ignored with --stop-after tessellate"]),
            (["--smooth-method", "laplacian", "--stop-after", "cut"],
             ["--smooth-method applies to the smooth stage only; ignored with --stop-after cut"]),
            (["--alpha", "0.2", "--snap", "none"], ["--alpha is ignored with --snap none"]),
            (["--alpha", "0.2", "--snap", "quality"],
             ["--alpha is ignored with --snap quality"]),
            (["--smooth-method", "laplacian", "--smooth-iterations", "0"],
             ["--smooth-method is ignored with --smooth-iterations 0"])]:
        _, err = c.run_ok([image, "-o", c.path("ignored_stage.vtu")] + arguments)
        for text in texts:
            check("stmesh: warning: " + text in err, "no warning %r" % text)
        check(err.count("warning") == len(texts), "unexpected warnings in %r" % err)
    # Non-simplicial elements are fine when the run stops before the cut.
    c.run_ok([image, "-o", c.path("hybrid.vtu"), "--elements", "hybrid", "--stop-after",
              "tessellate"])


# ------------------------------------------------------------------------------------------------
# The snap stage (--alpha, --snap: stmVertexSnap before the cut) and the smooth stage
# (--smooth-iterations, --smooth-method: stmBoundarySmooth after it).

def case_snap_smooth_default(c):
    image, _ = write_label_image(c, "ball.vti", (16, 15, 14), ball)
    summary, tessellate, cut, mesh, out, _ = cut_run(c, image, "default", [])
    snap, smooth = stage(summary, "snap"), stage(summary, "smooth")
    check(not snap["skipped"] and not smooth["skipped"], "a stage was skipped by default")
    params = summary["parameters"]
    check((params["alpha"], params["snap"], params["smooth_iterations"],
           params["smooth_method"]) == (1.0 / 3.0, "quality", 20, "taubin"),
          "bad snap and smooth parameters %s" % params)
    # The labels' function takes steps of 1/4 at the voxel corners, so cuts close to a point
    # are common: the default (quality-driven) rule snaps points, and every snap removes at
    # least the cut edge next to the point.
    check(snap["snapped_points"] > 0, "the default snapped no point")
    _, _, unsnapped_cut, _, _, _ = cut_run(c, image, "unsnapped", ["--snap", "none"])
    check(cut["cut_points"] < unsnapped_cut["cut_points"],
          "snapping %d points left %d cut edges, without snapping %d" %
          (snap["snapped_points"], cut["cut_points"], unsnapped_cut["cut_points"]))
    # Smoothing moves points and keeps the cells: the smooth stage has the cut's cells and
    # points, and "SmoothingDisplacement" and "Snapped" arrive in the output.
    check(smooth["moved_points"] > 0, "smoothing moved no point")
    check(smooth["cells"] == cut["cells"] and smooth["points"] == cut["points"],
          "smoothing changed the mesh's size")
    for array in ["Snapped", "SmoothingDisplacement", "SeparatingFunction"]:
        check(array in mesh["point_arrays"], "no point array %s in %s" %
              (array, mesh["point_arrays"]))
    # The seconds of every stage, like the others.
    for entry in (snap, smooth):
        check(entry["seconds"] >= 0 and entry["peak_rss_mib"] > 0, "bad stage %s" % entry)


def case_snap_alpha_zero_and_none(c):
    image, _ = write_label_image(c, "ball.vti", (16, 15, 14), ball)
    # Alpha 0 runs the snap stage and snaps nothing: the cut is the cut without a snap stage.
    summary, _, cut, mesh, _, _ = cut_run(c, image, "alpha0", ["--alpha", "0",
                                                              "--stop-after", "cut"])
    snap = stage(summary, "snap")
    check(summary["parameters"]["alpha"] == 0, "bad alpha %s" % summary["parameters"]["alpha"])
    # --alpha alone selects the threshold rule, whose parameter it is.
    check(summary["parameters"]["snap"] == "threshold",
          "--alpha 0 snapped by rule %s" % summary["parameters"]["snap"])
    check(not snap["skipped"] and snap["snapped_points"] == 0 and snap["refused_snaps"] == 0,
          "--alpha 0: snap figures %s" % snap)
    summary, _, none_cut, none_mesh, out, _ = cut_run(c, image, "none",
                                                      ["--snap", "none", "--stop-after", "cut"])
    snap = stage(summary, "snap")
    check(snap["skipped"] and "snapped_points" not in snap, "--snap none: snap stage %s" % snap)
    check(summary["parameters"]["snap"] == "none", "bad snap parameter")
    check("skipped (--snap none)" in out, "the table does not say the snap was skipped")
    check(cut["cut_points"] == none_cut["cut_points"] and cut["split_cells"] ==
          none_cut["split_cells"], "--alpha 0 and --snap none cut differently")
    without_arrays = lambda m: dict(m, point_arrays=None)
    check(without_arrays(mesh) == without_arrays(none_mesh),
          "--alpha 0 and --snap none give different meshes")
    check("Snapped" in mesh["point_arrays"] and "Snapped" not in none_mesh["point_arrays"],
          "point arrays %s and %s" % (mesh["point_arrays"], none_mesh["point_arrays"]))
    # Alpha 0.5 snaps every cut edge's nearer end, so that nothing is left to cut.
    summary, _, cut, _, _, _ = cut_run(c, image, "alpha05", ["--alpha", "0.5"])
    check(stage(summary, "snap")["snapped_points"] > 0, "--alpha 0.5 snapped nothing")
    check(cut["cut_points"] < none_cut["cut_points"], "--alpha 0.5 cut %d edges, no snapping %d"
          % (cut["cut_points"], none_cut["cut_points"]))


def worst_condition(path):
    """The largest Verdict condition number of the cells of a mesh file (vtkMeshQuality)."""
    try:
        from vtkmodules.vtkFiltersVerdict import vtkMeshQuality
    except ImportError as error:
        raise CaseFailed("cannot import vtkMeshQuality (%s)" % error)
    _, grid, errors = read_grid(path)
    quality = watched(vtkMeshQuality(), errors)
    quality.SetInputData(grid)
    quality.SetTetQualityMeasureToCondition()
    quality.SetTriangleQualityMeasureToCondition()
    quality.Update()
    check(not errors, "vtkMeshQuality failed on %s" % path)
    return quality.GetOutput().GetCellData().GetArray("Quality").GetRange()[1]


def case_snap_quality(c):
    image, _ = write_label_image(c, "ball.vti", (16, 15, 14), ball)
    summary, _, _, mesh, _, _ = cut_run(c, image, "quality", ["--snap", "quality"])
    check(summary["parameters"]["snap"] == "quality", "bad snap parameter")
    check(stage(summary, "snap")["snapped_points"] > 0, "--snap quality snapped nothing")
    total = sum(mesh["measures"])
    staircase = staircase_volume(c, image, "staircase", 1, [])
    check(close(total, staircase), "the mesh measures %r, the staircase mesh with one layer %r"
          % (total, staircase))
    # The quality-driven rule snaps only where the cut's elements get no worse: the worst
    # element of its cut is no worse than without snapping.
    worst = {}
    for rule in ["quality", "none"]:
        output = c.path("cut_%s.vtu" % rule)
        c.run_ok([image, "-o", output, "--snap", rule, "--stop-after", "cut"])
        worst[rule] = worst_condition(output)
    check(worst["quality"] <= worst["none"] * (1 + 1e-9),
          "--snap quality: worst condition number %r, without snapping %r" %
          (worst["quality"], worst["none"]))
    # The analytic sphere: points move along its gradient onto it.
    big, _ = write_label_image(c, "big_ball.vti", (25, 25, 25), big_ball)
    for rule in ["threshold", "quality"]:
        summary, _, _, sphere, _, _ = cut_run(
            c, big, "sphere_" + rule, ["--separating", "sphere:12,12,12,6.5", "--snap", rule,
                                       "--max-cell-size", "2"])
        check(stage(summary, "snap")["snapped_points"] > 0, "%s: nothing snapped" % rule)
        inside, analytic = material_volumes(sphere)[1], ball_volume(6.5)
        check(0.97 * analytic < inside <= analytic * (1 + 1e-9),
              "%s: the inside measures %r, the ball %r" % (rule, inside, analytic))


def case_smooth_iterations(c):
    image, _ = write_label_image(c, "ball.vti", (16, 15, 14), ball)
    # No smoothing is the cut as it is: --smooth-iterations 0 writes what --stop-after cut does.
    summary, _, _, zero, out, _ = cut_run(c, image, "zero", ["--smooth-iterations", "0"])
    smooth = stage(summary, "smooth")
    check(smooth["skipped"] and "moved_points" not in smooth, "smooth stage %s" % smooth)
    check("skipped (--smooth-iterations 0)" in out, "the table does not say it was skipped")
    _, _, _, cut, _, _ = cut_run(c, image, "cut", ["--stop-after", "cut"])
    check(zero == cut, "--smooth-iterations 0 differs from --stop-after cut")
    for keep in ["inside", "outside"]:
        _, _, _, zero_side, _, _ = cut_run(c, image, "zero_" + keep,
                                           ["--smooth-iterations", "0", "--keep", keep])
        _, _, _, cut_side, _, _ = cut_run(c, image, "cut_" + keep,
                                          ["--stop-after", "cut", "--keep", keep])
        check(zero_side == cut_side, "--keep %s: --smooth-iterations 0 differs from "
              "--stop-after cut" % keep)
    # Smoothing keeps the cells and the domain (points on the mesh boundary stay), moves the
    # inside's volume a little, and Laplacian differs from Taubin.
    volumes = {}
    for method in ["taubin", "laplacian"]:
        summary, _, _, mesh, _, _ = cut_run(c, image, method, ["--smooth-method", method,
                                                               "--smooth-iterations", "20"])
        check(summary["parameters"]["smooth_method"] == method, "bad smooth_method")
        check(mesh["cells"] == cut["cells"] and mesh["materials"] == cut["materials"],
              "%s: smoothing changed the cells" % method)
        check(close(sum(mesh["measures"]), sum(cut["measures"])),
              "%s: the domain measures %r, before smoothing %r" %
              (method, sum(mesh["measures"]), sum(cut["measures"])))
        volumes[method] = material_volumes(mesh)[1]
    # Taubin's lambda|mu steps keep the ball's volume; Laplacian smoothing shrinks it (the
    # paper's section 3.4), strongly on a ball of only 5 voxels' radius.
    before = material_volumes(cut)[1]
    check(abs(volumes["taubin"] / before - 1) < 0.05 and volumes["laplacian"] < 0.95 * before,
          "the inside measures %r with Taubin, %r with Laplacian, %r before smoothing" %
          (volumes["taubin"], volumes["laplacian"], before))
    # One side after smoothing is that side of the smoothed mesh of both sides.
    _, _, _, both, _, _ = cut_run(c, image, "both", [])
    _, _, _, inside, _, _ = cut_run(c, image, "inside", ["--keep", "inside"])
    _, _, _, outside, _, _ = cut_run(c, image, "outside", ["--keep", "outside"])
    check(inside["cells"] + outside["cells"] == both["cells"] and
          sorted(inside["measures"] + outside["measures"]) == sorted(both["measures"]),
          "the smoothed sides are not the smoothed mesh's")


def case_stop_after_snap_and_smooth(c):
    image, _ = write_label_image(c, "ball.vti", (16, 15, 14), ball)
    output, summary_path = c.path("snapped.vtu"), c.path("snapped.json")
    out, _ = c.run_ok([image, "-o", output, "--summary", summary_path, "--stop-after", "snap"])
    check_table(out, ["read", "spacetree", "balance", "tessellate", "snap", "write"])
    summary = load_summary(summary_path)
    check(summary["parameters"]["stop_after"] == "snap", "bad stop_after")
    snap, tessellate = stage(summary, "snap"), stage(summary, "tessellate")
    snapped = read_cut(output)
    check(snapped["cells"] == snap["cells"] == tessellate["cells"] and
          snapped["points"] == snap["points"] == tessellate["points"],
          "the snapped mesh has %d cells and %d points, the tessellation %d and %d" %
          (snapped["cells"], snapped["points"], tessellate["cells"], tessellate["points"]))
    check("Snapped" in snapped["point_arrays"], "no point array Snapped")
    check(snap["snapped_points"] > 0, "nothing snapped")
    # Snapping moves points inside the domain: its volume stays.
    check(close(sum(snapped["measures"]), staircase_volume(c, image, "staircase", 1, [])),
          "snapping changed the domain")
    # --stop-after smooth is the default.
    _, _, _, explicit, _, _ = cut_run(c, image, "explicit", ["--stop-after", "smooth"])
    _, _, _, default, _, _ = cut_run(c, image, "default", [])
    check(explicit == default, "--stop-after smooth differs from the default")
    # --stop-after snap with --snap none writes the tessellation.
    output = c.path("unsnapped.vtu")
    out, _ = c.run_ok([image, "-o", output, "--stop-after", "snap", "--snap", "none"])
    check("skipped (--snap none)" in out, "the table does not say the snap was skipped")
    tessellation = c.path("tessellation.vtu")
    c.run_ok([image, "-o", tessellation, "--stop-after", "tessellate"])
    check(read_cut(output) == read_cut(tessellation), "--stop-after snap --snap none is not the "
          "tessellation")


def case_error_snap_smooth_option_values(c):
    image, _ = write_label_image(c, "ball.vti", (16, 15, 14), ball)
    output = c.path("out.vtu")
    for arguments, text in [
            (["--alpha", "0.6"], "--alpha: A must be between 0 and 0.5, got 0.6"),
            (["--alpha", "-0.1"], "--alpha: A must be between 0 and 0.5, got -0.1"),
            (["--alpha", "abc"], "--alpha: 'abc' is not a number"),
            (["--alpha", ""], "--alpha needs a number"),
            (["--alpha", "nan"], "--alpha: 'nan' is not a number"),
            (["--snap", "edge"], "--snap: 'edge' is not one of threshold, quality, none"),
            (["--snap", "Quality"], "--snap: 'Quality' is not one of threshold, quality, none"),
            (["--smooth-iterations", "-1"],
             "--smooth-iterations: -1 is out of range (0 to 1000)"),
            (["--smooth-iterations", "2.5"], "--smooth-iterations: '2.5' is not an integer"),
            (["--smooth-iterations", "1001"],
             "--smooth-iterations: 1001 is out of range (0 to 1000)"),
            (["--smooth-method", "gauss"], "--smooth-method: 'gauss' is not one of taubin, "
             "laplacian"),
            (["--alpha", "0.1", "--alpha", "0.2"], "--alpha given more than once"),
            (["--stop-after", "snap", "--separating", "none"],
             "--stop-after snap needs a separating function, but --separating is none"),
            (["--stop-after", "smooth", "--separating", "none"],
             "--stop-after smooth needs a separating function, but --separating is none")]:
        err = c.run_failing([image, "-o", output] + arguments, 2, text, output=output)
        error_lines = [line for line in err.splitlines() if line.startswith(ERROR_PREFIX)]
        check(len(error_lines) == 1 and error_lines[0].startswith(ERROR_PREFIX + " " + text),
              "expected one error line starting with %r, got %s" % (text, error_lines))
        check("--help" in err, "usage errors should point to --help")


def case_error_cut_option_values(c):
    image, _ = write_label_image(c, "ball.vti", (16, 15, 14), ball)
    output = c.path("out.vtu")
    for arguments, text in [
            (["--separating", "foo"], "--separating: 'foo' is not one of labels, smooth:SIGMA, "
             "gray:FILE:ISO, sphere:CX,CY,CZ,R or none"),
            (["--separating", ""], "--separating: '' is not one of"),
            (["--separating", "labels:2"], "--separating: 'labels:2' is not one of"),
            (["--separating", "Labels"], "--separating: 'Labels' is not one of"),
            (["--separating", "smooth"], "--separating: smooth needs the Gaussian's sigma"),
            (["--separating", "smooth:-1"], "--separating: smooth SIGMA must be positive, got -1"),
            (["--separating", "smooth:0"], "--separating: smooth SIGMA must be positive, got 0"),
            (["--separating", "smooth:abc"], "--separating: smooth SIGMA: 'abc' is not a number"),
            (["--separating", "smooth:"], "--separating: smooth SIGMA needs a number"),
            (["--separating", "smooth:nan"], "--separating: smooth SIGMA: 'nan' is not a number"),
            (["--separating", "smooth:2000"], "--separating: smooth SIGMA 2000 is out of range"),
            (["--separating", "sphere"], "--separating: sphere needs its centre and radius"),
            (["--separating", "sphere:1,2"], "--separating: sphere:CX,CY,CZ,R needs 4 numbers, "
             "got 2"),
            (["--separating", "sphere:1,2,3,4,5"], "--separating: sphere:CX,CY,CZ,R needs 4 "
             "numbers, got 5"),
            (["--separating", "sphere:1,2,x,4"], "--separating: sphere: 'x' is not a number"),
            (["--separating", "sphere:1,,3,4"], "--separating: sphere: empty entry"),
            (["--separating", "sphere:1,2,3,0"], "--separating: the sphere radius must be "
             "positive, got 0"),
            (["--separating", "gray"], "--separating: 'gray' is not gray:FILE:ISO"),
            (["--separating", "gray:t1.mha"], "--separating: 'gray:t1.mha' is not gray:FILE:ISO"),
            (["--separating", "gray::3"], "--separating: gray:FILE:ISO needs a file name"),
            (["--separating", "gray:t1.mha:x"], "--separating: gray ISO: 'x' is not a number"),
            (["--separating", "none", "--separating", "labels"],
             "--separating given more than once"),
            (["--separating"], "--separating needs a value"),
            (["--output-mode", "both"], "--output-mode: 'both' is not one of volume, surface"),
            (["--keep", "all"], "--keep: 'all' is not one of both, inside, outside"),
            (["--iso", "abc"], "--iso: 'abc' is not a number"),
            (["--iso", "inf"], "--iso: 'inf' is not a number"),
            (["--iso", ""], "--iso needs a number"),
            (["--stop-after", "cutting"], "--stop-after: 'cutting' is not one of spacetree, "
             "balance, tessellate, snap, cut, smooth"),
            (["--stop-after", "cut", "--separating", "none"],
             "--stop-after cut needs a separating function"),
            (["--elements", "hybrid"], "--elements hybrid: cutting at the separating function "
             "(--separating labels) needs simplicial elements; give --separating none"),
            (["--elements", "leaves", "--separating", "smooth:1"],
             "--elements leaves: cutting at the separating function (--separating smooth:1) "
             "needs simplicial elements"),
            (["--elements", "hybrid", "--stop-after", "cut"],
             "--elements hybrid: cutting at the separating function")]:
        err = c.run_failing([image, "-o", output] + arguments, 2, text, output=output)
        error_lines = [line for line in err.splitlines() if line.startswith(ERROR_PREFIX)]
        check(len(error_lines) == 1 and error_lines[0].startswith(ERROR_PREFIX + " " + text),
              "expected one error line starting with %r, got %s" % (text, error_lines))
        check("--help" in err, "usage errors should point to --help")
    # The output's extension must fit the output mode.
    for name, arguments, text in [
            ("x.vtu", ["--output-mode", "surface"], "--output-mode surface writes a surface "
             "(polydata), not an unstructured grid; use .vtp (VTK XML polydata) or .vtk"),
            ("x.stl", ["--output-mode", "surface"], "unsupported extension; use .vtp (VTK XML "
             "polydata) or .vtk (legacy VTK) for --output-mode surface"),
            ("x.vtp", [], ".vtp holds polydata, but the output is an unstructured grid; use .vtu"),
            ("x.vtp", ["--output-mode", "surface"] + STAIRCASE,
             "(--output-mode surface is ignored with --separating none)"),
            ("x.vtp", ["--output-mode", "surface", "--stop-after", "tessellate"],
             "(--output-mode surface is ignored with --stop-after tessellate)")]:
        err = c.run_failing([image, "-o", c.path(name)] + arguments, 2, text,
                            output=c.path(name))
        check("--help" in err, "usage errors should point to --help")
    # The --name=value form parses the same way.
    c.run_failing([image, "-o", output, "--separating=smooth:-1"], 2,
                  "--separating: smooth SIGMA must be positive", output=output)


def case_error_cut_files(c):
    image, _ = write_label_image(c, "ball.vti", (16, 15, 14), ball)
    output = c.path("out.vtu")
    for separating, text in [
            ("gray:%s:3" % c.path("missing.mha"),
             "--separating: cannot read gray image '%s': No such file or directory" %
             c.path("missing.mha")),
            ("gray:%s:3" % c.path("gray.png"), "--separating: gray image '%s' has an "
             "unsupported extension" % c.path("gray.png"))]:
        err = c.run_failing([image, "-o", output, "--separating", separating], 1, text,
                            output=output)
        check("--help" not in err, "a file error should not point to --help")
    # A corrupt gray image fails when it is read, before the cut, naming the file.
    corrupt = c.path("corrupt.mha")
    with open(corrupt, "wb") as image_file:
        image_file.write(random.Random(11).randbytes(300))
    c.run_failing([image, "-o", output, "--separating", "gray:%s:3" % corrupt], 1, "corrupt.mha",
                  output=output)
    # A gray image of several components.
    vtk = cut_vtk_modules()
    colour = vtk["vtkImageData"]()
    colour.SetDimensions(16, 15, 14)
    colour.AllocateScalars(10, 3)
    errors = []
    writer = watched(vtk["vtkXMLImageDataWriter"](), errors)
    writer.SetDataModeToBinary()
    writer.SetInputData(colour)
    writer.SetFileName(c.path("colour.vti"))
    writer.Write()
    check(not errors, "cannot write colour.vti")
    c.run_failing([image, "-o", output, "--separating", "gray:%s:3" % c.path("colour.vti")], 1,
                  "3 components per voxel; stmesh needs one gray value per voxel", output=output)


# ------------------------------------------------------------------------------------------------
# --labels all, --merge and the structure report ("materials" in the summary, the "materials:"
# line).

def merge_labels(i, j, k):
    """Labels 1, 2, 3 and 5 in boxes of 12 x 10 x 8: 1 and 2 touch, 3 and 5 stand apart."""
    if 1 <= j <= 4 and 1 <= k <= 3:
        if 1 <= i <= 3:
            return 1
        if 4 <= i <= 6:
            return 2
    if 6 <= j <= 8 and 4 <= k <= 6:
        if 1 <= i <= 4:
            return 3
        if 7 <= i <= 10:
            return 5
    return 0


def report_labels(i, j, k):
    """two_boxes and one more voxel of label 2 at (9, 7, 3), which touches the box of label 2
    only along an edge: a second component of 2 under 6-connectivity."""
    return 2 if (i, j, k) == (9, 7, 3) else two_boxes(i, j, k)


def flat_labels(i, j, k):
    """A 2D image (16 x 15 x 1): label 1 in a 4 x 4 square and at the two voxels (8, 8) and
    (9, 9), which touch each other and nothing else only at a corner; label 4 in a 3 x 2
    rectangle."""
    if 2 <= i <= 5 and 2 <= j <= 5 or (i, j) in ((8, 8), (9, 9)):
        return 1
    if 10 <= i <= 12 and 2 <= j <= 3:
        return 4
    return 0


def report_line(materials):
    """The printed line the summary's materials give: the body materials (not 0) only."""
    body = [entry for entry in materials if entry["material"] != 0]
    lost = sum(entry["lost_components"] for entry in body)
    components = sum(entry["image_components"] for entry in body)
    line = "materials: %d material%s, %d lost component%s (of %d), largest volume error " % (
        len(body), "" if len(body) == 1 else "s", lost, "" if lost == 1 else "s", components)
    errors = [entry for entry in body if entry["volume_error"] is not None]
    if not errors:
        return line + "n/a"
    worst = max(errors, key=lambda entry: abs(entry["volume_error"]))
    percent = 100.0 * worst["volume_error"]
    if abs(percent) < 0.005:
        percent = 0.0
    return line + "%.2f%% (material %d)" % (percent, worst["material"])


def check_report(summary, out, voxels, what, components=None, mesh_volumes=None):
    """The staircase report: one entry per material, ascending, with the image's voxels, the
    mesh volume equal to the voxel volume (1 mm voxels) unless mesh_volumes gives it, no lost
    component and, if given, the components per material; the printed line agrees."""
    materials = summary["materials"]
    check(isinstance(materials, list), "%s: materials is %r" % (what, materials))
    check([entry["material"] for entry in materials] == sorted(int(m) for m in voxels),
          "%s: materials %s, expected %s" % (what, [e["material"] for e in materials],
                                             sorted(int(m) for m in voxels)))
    for entry in materials:
        count = voxels[str(entry["material"])]
        check(entry["voxels"] == count and entry["voxel_volume"] == count,
              "%s: material %d has %s voxels, volume %s; expected %d" %
              (what, entry["material"], entry["voxels"], entry["voxel_volume"], count))
        volume = (mesh_volumes or {}).get(str(entry["material"]), count)
        check(close(entry["mesh_volume"], volume),
              "%s: material %d: mesh volume %r, expected %d" %
              (what, entry["material"], entry["mesh_volume"], volume))
        check(abs(entry["volume_error"] - (volume - count) / count) <= 1e-9,
              "%s: volume_error %r" % (what, entry["volume_error"]))
        check(entry["lost_components"] == 0,
              "%s: material %d lost %d components" % (what, entry["material"],
                                                      entry["lost_components"]))
        if components is not None:
            check(entry["image_components"] == components[str(entry["material"])],
                  "%s: material %d has %d components, expected %d" %
                  (what, entry["material"], entry["image_components"],
                   components[str(entry["material"])]))
    check(isinstance(summary["report_seconds"], float) and summary["report_seconds"] >= 0,
          "%s: bad report_seconds %r" % (what, summary.get("report_seconds")))
    check(report_line(materials) in out.splitlines(),
          "%s: stdout lacks the line %r" % (what, report_line(materials)))


def pair_areas(surface):
    """The total area of the triangles of an interface surface per BoundaryLabels pair."""
    areas = {}
    for cell, pair in zip(surface["cells"], surface["boundary_labels"]):
        a, b, c = (surface["points"][i] for i in cell)
        u = [b[k] - a[k] for k in range(3)]
        v = [c[k] - a[k] for k in range(3)]
        n = (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
        areas[pair] = areas.get(pair, 0.0) + 0.5 * math.sqrt(sum(x * x for x in n))
    return areas


def case_option_interfaces(c):
    image, _ = write_label_image(c, "ball.vti", (16, 15, 14), ball)
    # The staircase of the labels: per pair, the facets measure the voxel faces between them
    # (1 mm voxels); the outside of the mesh (the background, no cells here) is -1.
    faces = c.path("faces.vtp")
    summary_path = c.path("faces.json")
    out, _ = c.run_ok([image, "-o", c.path("stair.vtu"), "--separating", "none",
                       "--interfaces", faces, "--summary", summary_path])
    summary = load_summary(summary_path)
    check([entry["name"] for entry in summary["stages"]] == STAGES_TESSELLATE + ["interfaces"],
          "stages %s" % [entry["name"] for entry in summary["stages"]])
    check(summary["parameters"]["interfaces"] == faces, "bad interfaces parameter")
    surface = read_surface(faces)
    interfaces = stage(summary, "interfaces")
    check(interfaces["cells"] == len(surface["cells"]) and
          interfaces["file_bytes"] == os.path.getsize(faces), "interfaces stage %s" % interfaces)
    check(("%d facets" % len(surface["cells"])) in out, "the table does not show the facets")
    check("BoundaryLabels" in surface["cell_arrays"] and "CellId" in surface["cell_arrays"],
          "cell arrays %s" % surface["cell_arrays"])
    expected = {}
    for k in range(14):
        for j in range(15):
            for i in range(16):
                own = ball(i, j, k)
                for di, dj, dk in ((1, 0, 0), (0, 1, 0), (0, 0, 1)):
                    ni, nj, nk = i + di, j + dj, k + dk
                    other = ball(ni, nj, nk) if ni < 16 and nj < 15 and nk < 14 else 0
                    if own == other:
                        continue
                    key = ((max(own, other), -1) if 0 in (own, other)
                           else (min(own, other), max(own, other)))
                    expected[key] = expected.get(key, 0) + 1
    measured = pair_areas(surface)
    check(sorted(measured) == sorted(expected), "pairs %s, voxel faces %s"
          % (sorted(measured), sorted(expected)))
    for key, count in expected.items():
        check(close(measured[key], count), "pair %s measures %r, %d voxel faces"
              % (key, measured[key], count))
    # The default pipeline (cut and smoothed): the interface between outside (0) and inside (1)
    # only, the background box being left out; legacy .vtk works too.
    legacy = c.path("cut_faces.vtk")
    c.run_ok([image, "-o", c.path("cut.vtu"), "--interfaces", legacy])
    cut_surface = read_surface(legacy)
    check(set(cut_surface["boundary_labels"]) == {(0, 1)},
          "pairs of the cut %s" % sorted(set(cut_surface["boundary_labels"])))
    # What cannot have interfaces.
    for arguments, text in [
            (["--interfaces", c.path("i.vtu")], "use .vtp"),
            (["--interfaces", c.path("i.vtp"), "--output-mode", "surface", "-o",
              c.path("s.vtp")], "--output-mode surface"),
            (["--interfaces", c.path("i.vtp"), "--stop-after", "balance"], "--stop-after balance"),
            (["--interfaces", c.path("i.vtp"), "--separating", "none", "--elements", "hybrid"],
             "--elements hybrid"),
            (["--interfaces="], "--interfaces needs a file name")]:
        arguments = [image] + (["-o", c.path("x.vtu")] if "-o" not in arguments else []) + arguments
        c.run_failing(arguments, 2, text)


def case_option_labels_all(c):
    # --labels all is the default spelled out: the same parameters and the same mesh.
    image, _ = write_label_image(c, "boxes.vti", (12, 10, 8), two_boxes)
    results = {}
    for name, arguments in [("default", []), ("all", ["--labels", "all"]),
                            ("all_inline", ["--labels=all"])]:
        summary, tessellate, mesh, _ = tessellate_run(c, image, name, arguments)
        results[name] = (summary["parameters"], tessellate["cells"], mesh["cells"])
    check(results["default"][0]["labels"] == [] and results["default"][0]["all_labels"] is True,
          "bad default labels %s" % results["default"][0])
    check(results["all"] == results["default"] == results["all_inline"],
          "--labels all differs from the default: %s" % results)
    # With the cut, the default body is one material, and --labels all asks for every label as
    # a material: --materials separate (the atlas's regions in an FE export).
    ball_image, _ = write_label_image(c, "ball.vti", (16, 15, 14), ball)
    default, _, _, _, _, _ = cut_run(c, ball_image, "cut_default", [])
    check(default["parameters"]["materials"] == "merged", "default materials %s" %
          default["parameters"]["materials"])
    explicit, explicit_mesh = plain_run(c, image, "cut_all", ["--labels", "all"])
    separate, separate_mesh = plain_run(c, image, "cut_separate", ["--materials", "separate"])
    check(explicit["parameters"] == separate["parameters"], "--labels all: parameters %s" %
          explicit["parameters"])
    check(explicit_mesh == separate_mesh, "--labels all: %d cells, --materials separate %d" %
          (explicit_mesh["cells"], separate_mesh["cells"]))
    merged, _, _, merged_mesh, _, _ = cut_run(c, image, "cut_merged", ["--labels", "all",
                                                                       "--materials", "merged"])
    check(merged["parameters"]["materials"] == "merged" and
          set(merged_mesh["materials"]) <= {0, 1}, "--labels all --materials merged: %s" %
          sorted(set(merged_mesh["materials"])))
    # "all" is a whole value, not a list entry.
    c.run_failing([image, "-o", c.path("x.vtu"), "--labels", "all,2"], 2, "--labels",
                  output=c.path("x.vtu"))


def case_option_merge(c):
    image, voxels = write_label_image(c, "labels.vti", (12, 10, 8), merge_labels)
    check(voxels == {"1": 36, "2": 36, "3": 36, "5": 36}, "bad test image: %s" % voxels)
    for name, arguments, expected, merge in [
            ("new_target", ["--merge", "1,2:10"], {"10": 72, "3": 36, "5": 36},
             [{"sources": [1, 2], "target": 10}]),
            ("source_target", ["--merge", "2,3:3"], {"1": 36, "3": 72, "5": 36},
             [{"sources": [2, 3], "target": 3}]),
            ("two_groups", ["--merge", "1,2:10", "--merge=5,3:11"], {"10": 72, "11": 72},
             [{"sources": [1, 2], "target": 10}, {"sources": [5, 3], "target": 11}]),
            # A target beyond the uint8 labels widens the merged copy.
            ("wide_target", ["--merge", "1,2,3,5:300"], {"300": 144},
             [{"sources": [1, 2, 3, 5], "target": 300}]),
            # --labels names the merged labels.
            ("merged_body", ["--merge", "1,2:10", "--labels", "10"], {"10": 72},
             [{"sources": [1, 2], "target": 10}])]:
        summary, _, mesh, _ = tessellate_run(c, image, name, arguments)
        check(summary["parameters"]["merge"] == merge,
              "%s: parameters.merge %s" % (name, summary["parameters"]["merge"]))
        check(summary["parameters"]["labels"] == ([10] if name == "merged_body" else []),
              "%s: labels %s" % (name, summary["parameters"]["labels"]))
        check(summary["image"]["scalar_type"] == "unsigned char",
              "%s: scalar type %s" % (name, summary["image"]["scalar_type"]))
        # The staircase mesh: every merged material measures exactly its sources' voxels.
        check_volume_equals_voxels(mesh, expected, name)
        check(sorted(summary["tetrahedra_per_material"]) == sorted(expected),
              "%s: materials %s" % (name, sorted(summary["tetrahedra_per_material"])))
        check([entry["material"] for entry in summary["materials"]] ==
              sorted(int(m) for m in expected), "%s: report materials %s" %
              (name, [entry["material"] for entry in summary["materials"]]))
        for entry in summary["materials"]:
            check(entry["voxels"] == expected[str(entry["material"])] and
                  close(entry["mesh_volume"], entry["voxel_volume"]),
                  "%s: report %s" % (name, entry))
    # A merged-away label is no longer in the image.
    output = c.path("gone.vtu")
    c.run_failing([image, "-o", output, "--merge", "1,2:10", "--labels", "1"] + STAIRCASE, 1,
                  "Body label 1 does not occur", output=output)


def case_materials_separate(c):
    # Every label its own material: the ball (label 1) around a small box (label 3), and two
    # touching boxes (labels 1, 2) meeting the background along triple lines.
    image, voxels = write_label_image(c, "ball.vti", (16, 15, 14), ball)
    output, summary_path = c.path("ball.vtu"), c.path("ball.json")
    out, _ = c.run_ok([image, "-o", output, "--summary", summary_path, "--materials", "separate"])
    summary = load_summary(summary_path)
    check([entry["name"] for entry in summary["stages"]] == STAGES_ALL,
          "stages %s" % [entry["name"] for entry in summary["stages"]])
    check(summary["parameters"]["materials"] == "separate",
          "parameters.materials %s" % summary["parameters"]["materials"])
    check(stage(summary, "snap")["skipped"] and "in the cut stage (--materials separate)" in out,
          "the snap stage is not shown as done by the cut")
    check(re.search(r"117 materials, [1-9][0-9]* snaps", out) is None and
          re.search(r"3 materials, [1-9][0-9]* snaps", out) is not None,
          "the cut stage does not show its snaps")
    mesh = read_cut(output)
    check(set(mesh["materials"]) == {0, 1, 3}, "Material values %s" % sorted(set(mesh["materials"])))
    check(min(mesh["measures"]) > 0, "a cell has measure %r" % min(mesh["measures"]))
    # The small box (3 x 2 x 4 voxels) keeps less than half its volume: the labels function
    # rounds its edges as the binary cut of it alone would.
    volumes = material_volumes(mesh)
    check(abs(volumes[1] - voxels["1"]) <= 0.1 * voxels["1"],
          "label 1 measures %r, its voxels %d" % (volumes[1], voxels["1"]))
    check(0.3 * voxels["3"] < volumes[3] < voxels["3"],
          "label 3 measures %r, its voxels %d" % (volumes[3], voxels["3"]))
    entries = {entry["material"]: entry for entry in summary["materials"]}
    check(sorted(entries) == [0, 1, 3], "report materials %s" % sorted(entries))
    check(entries[1]["voxels"] == voxels["1"] and entries[3]["voxels"] == voxels["3"] and
          entries[1]["lost_components"] == 0 and entries[3]["lost_components"] == 0,
          "report %s" % entries)
    check(close(entries[3]["mesh_volume"], volumes[3]), "report volume of 3 %r, the file's %r"
          % (entries[3]["mesh_volume"], volumes[3]))
    # The cut alone: the tessellation's domain, every piece inside one of its cells.
    boxes, box_voxels = write_label_image(c, "boxes.vti", (12, 10, 8), two_boxes)
    output, summary_path = c.path("boxes.vtu"), c.path("boxes.json")
    out, _ = c.run_ok([boxes, "-o", output, "--summary", summary_path, "--materials", "separate",
                       "--stop-after", "cut"])
    summary = load_summary(summary_path)
    check([entry["name"] for entry in summary["stages"]] == STAGES_CUT,
          "stages %s" % [entry["name"] for entry in summary["stages"]])
    cut = stage(summary, "cut")
    mesh = read_cut(output)
    check(set(mesh["materials"]) == {0, 1, 2}, "Material values %s" % sorted(set(mesh["materials"])))
    check(set(mesh["original"]) == {0, 1, 2}, "OriginalMaterial values %s" %
          sorted(set(mesh["original"])))
    check(cut["split_cells"] > 0 and cut["points"] == stage(summary, "tessellate")["points"] +
          cut["cut_points"], "cut figures %s" % cut)
    check(cut["inside_cells"] == sum(1 for m in mesh["materials"] if m != 0),
          "inside_cells %s" % cut["inside_cells"])
    check(close(sum(mesh["measures"]), staircase_volume(c, boxes, "staircase", 1, ["--materials", "separate"])),
          "the cut does not cover the staircase with one background layer")
    volumes = material_volumes(mesh)
    for label in ("1", "2"):
        check(abs(volumes[int(label)] - box_voxels[label]) <= 0.2 * box_voxels[label],
              "label %s measures %r, its voxels %d" % (label, volumes[int(label)],
                                                       box_voxels[label]))
    # What does not apply to several materials.
    for arguments, text in [
            (["--output-mode", "surface", "-o", c.path("s.vtp")], "applies to one body"),
            (["--keep", "inside"], "--keep applies to one body"),
            (["--iso", "0.5"], "--iso applies to one body"),
            (["--separating", "smooth:1"], "--materials separate cuts at the interfaces"),
            (["--separating", "sphere:8,7,6,4"], "--materials separate cuts at the interfaces")]:
        arguments = ([boxes, "--materials", "separate"] +
                     (["-o", c.path("x.vtu")] if "-o" not in arguments else []) + arguments)
        c.run_failing(arguments, 2, text)
    c.run_failing([boxes, "-o", c.path("x.vtu"), "--materials", "bogus"], 2,
                  "--materials: 'bogus' is not one of merged, separate")
    # Ignored, with a warning.
    _, err = c.run_ok([boxes, "-o", c.path("w1.vtu"), "--materials", "separate"] + STAIRCASE)
    check("--materials applies to the cut stage only" in err, "no warning for --separating none")
    _, err = c.run_ok([boxes, "-o", c.path("w2.vtu"), "--materials", "separate", "--snap",
                       "threshold", "--stop-after", "cut"])
    check("--snap is ignored with --materials separate" in err, "no warning for --snap")
    # --snap none: no snapping in the cut stage.
    output, summary_path = c.path("plain.vtu"), c.path("plain.json")
    out, _ = c.run_ok([boxes, "-o", output, "--summary", summary_path, "--materials", "separate",
                       "--snap", "none", "--stop-after", "cut"])
    check("skipped (--snap none)" in out and re.search(r"materials, [0-9]+ snaps", out) is None,
          "--snap none: the cut stage snapped")


def specks(i, j, k):
    """Labels 1 (a box), 2 (single voxels in it and a one-voxel line), 3 (single voxels in the
    background) in 14 x 12 x 10."""
    if (i, j, k) in ((1, 1, 1), (9, 8, 6), (12, 10, 8)):
        return 3
    if 4 <= i <= 9 and 3 <= j <= 8 and 2 <= k <= 7:
        if (i, j, k) in ((6, 5, 4), (8, 7, 3)) or (j == 6 and k == 5 and i >= 5):
            return 2
        return 1
    return 0


def case_thin_parts(c):
    # Specks and a one-voxel line: the cut at the labels function loses them at voxel size; the
    # thin parts refined to half a voxel keep every component, for each material and for the
    # body.
    image, _ = write_label_image(c, "specks.vti", (14, 12, 10), specks)
    results = {}
    for name, arguments in [("separate", ["--materials", "separate"]),
                            ("separate_ignored", ["--materials", "separate", "--thin-parts",
                                                  "ignore"]),
                            ("merged", []), ("merged_ignored", ["--thin-parts", "ignore"])]:
        output, summary_path = c.path(name + ".vtu"), c.path(name + ".json")
        out, _ = c.run_ok([image, "-o", output, "--summary", summary_path, "--stop-after", "cut"] +
                          arguments)
        summary = load_summary(summary_path)
        check(summary["parameters"]["thin_parts"] ==
              ("ignore" if name.endswith("ignored") else "refine"),
              "%s: parameters.thin_parts %s" % (name, summary["parameters"]["thin_parts"]))
        thin = stage(summary, "spacetree")["thin_voxels"]
        check((("%d thin voxels refined" % thin) in out) == (thin > 0),
              "%s: the table does not show the %d thin voxels" % (name, thin))
        results[name] = (thin,
                         sum(entry["lost_components"] for entry in summary["materials"]
                             if entry["material"] != 0))
        check(min(read_cut(output)["measures"]) > 0, "%s: a cell is not positive" % name)
    check(results["separate"][0] > 0 and results["separate"][1] == 0,
          "--materials separate: %d thin voxels, %d components lost" % results["separate"])
    check(results["separate_ignored"][0] == 0 and results["separate_ignored"][1] > 0,
          "--thin-parts ignore: %d thin voxels, %d components lost" % results["separate_ignored"])
    # The body (1, 2 and 3 merged): only the specks of 3 in the background are thin.
    check(results["merged"][0] > 0 and results["merged"][1] == 0,
          "merged: %d thin voxels, %d components lost" % results["merged"])
    check(results["merged_ignored"][1] > 0,
          "merged, --thin-parts ignore: %d components lost" % results["merged_ignored"][1])
    # No cut at the labels function: nothing to refine, and a warning when asked for.
    _, err = c.run_ok([image, "-o", c.path("stair.vtu"), "--thin-parts", "refine"] + STAIRCASE)
    check("--thin-parts applies to a cut at the labels function only" in err,
          "no warning for --thin-parts with --separating none")
    c.run_failing([image, "-o", c.path("x.vtu"), "--thin-parts", "maybe"], 2,
                  "--thin-parts: 'maybe' is not one of refine, ignore")


def case_error_merge_values(c):
    image, _ = write_label_image(c, "labels.vti", (12, 10, 8), merge_labels)
    output = c.path("out.vtu")
    for arguments, text in [
            (["--merge", "0,1:5"], "--merge: 0 is the background label and cannot be merged"),
            (["--merge", "1,2:0"], "--merge: the target of '1,2:0' is 0, the background label"),
            (["--merge", "1,2,1:7"], "--merge: label 1 is listed twice in '1,2,1:7'"),
            (["--merge", "1,2:7", "--merge", "3,2:8"],
             "--merge: label 2 is a source of both '1,2:7' and '3,2:8'"),
            (["--merge", "1:2", "--merge", "2,3:4"],
             "--merge: label 2 is the target of '1:2' and a source of '2,3:4'"),
            (["--merge", "1,2"], "--merge: '1,2' is not SOURCES:TARGET"),
            (["--merge", "1,,2:3"], "--merge: empty entry in '1,,2'"),
            (["--merge", "a:3"], "--merge source: 'a' is not an integer"),
            (["--merge", "1:99999999999"], "--merge target: 99999999999 is out of range"),
            (["--min-component-voxels", "0"], "--min-component-voxels: 0 is out of range"),
            (["--min-component-voxels", "x"], "--min-component-voxels: 'x' is not an integer"),
            (["--min-component-voxels", "2", "--min-component-voxels", "3"],
             "--min-component-voxels given more than once")]:
        err = c.run_failing([image, "-o", output] + arguments, 2, text, output=output)
        check("--help" in err, "usage errors should point to --help")
    # A source the image does not hold fails like an absent --labels label (exit code 1).
    for arguments, text in [
            (["--merge", "1,9:10"], "--merge: source label 9 does not occur in the image"),
            (["--merge", "1,2:10", "--merge", "4,6:11"],
             "--merge: source labels 4, 6 do not occur in the image")]:
        err = c.run_failing([image, "-o", output] + arguments + STAIRCASE, 1, text, output=output)
        check("--help" not in err, "an absent label is no usage error")


def case_report_staircase(c):
    image, voxels = write_label_image(c, "labels.vti", (12, 10, 8), report_labels)
    check(voxels == {"1": 144, "2": 109}, "bad test image: %s" % voxels)
    output, summary_path = c.path("mesh.vtu"), c.path("mesh.json")
    out, _ = c.run_ok([image, "-o", output, "--summary", summary_path] + STAIRCASE)
    summary = load_summary(summary_path)
    check_report(summary, out, voxels, "staircase", {"1": 1, "2": 2})
    check(summary["parameters"]["min_component_voxels"] == 1, "bad min_component_voxels")
    # The one-voxel component is left out with --min-component-voxels 2; all else stays.
    output, summary_path = c.path("min2.vtu"), c.path("min2.json")
    out, _ = c.run_ok([image, "-o", output, "--summary", summary_path,
                       "--min-component-voxels", "2"] + STAIRCASE)
    summary = load_summary(summary_path)
    check(summary["parameters"]["min_component_voxels"] == 2, "bad min_component_voxels")
    check_report(summary, out, voxels, "--min-component-voxels 2", {"1": 1, "2": 1})
    # Larger than every component: none is counted.
    output, summary_path = c.path("min200.vtu"), c.path("min200.json")
    out, _ = c.run_ok([image, "-o", output, "--summary", summary_path,
                       "--min-component-voxels", "200"] + STAIRCASE)
    check_report(load_summary(summary_path), out, voxels, "--min-component-voxels 200",
                 {"1": 0, "2": 0})
    # Other staircase outputs: hexahedra (leaves, hybrid, with --labels restricting the body:
    # label 1 becomes background), the spacetree and the balanced tree, whose background
    # leaves fill the root grid: 3 x 3 x 2 roots of 4 voxels, 12 x 12 x 8 voxels, the image
    # padded by 2 rows of background.
    background = 12 * 10 * 8 - 144 - 109
    padded = 12 * 12 * 8 - 144 - 109
    for name, arguments, expected, components in [
            ("leaves", ["--elements", "leaves"], voxels, {"1": 1, "2": 2}),
            ("hybrid", ["--elements", "hybrid", "--labels", "2"], {"2": 109}, {"2": 2}),
            ("spacetree", ["--stop-after", "spacetree", "--max-cell-size", "4",
                           "--pattern", "2x2x2"], dict(voxels, **{"0": background}),
             {"0": 1, "1": 1, "2": 2}),
            ("balance", ["--stop-after", "balance", "--max-cell-size", "4",
                         "--pattern", "2x2x2"], dict(voxels, **{"0": background}),
             {"0": 1, "1": 1, "2": 2})]:
        output, summary_path = c.path(name + ".vtu"), c.path(name + ".json")
        out, _ = c.run_ok([image, "-o", output, "--summary", summary_path] + arguments +
                          STAIRCASE)
        check_report(load_summary(summary_path), out, expected, name, components,
                     {"0": padded})
    # With boundary layers the background is in the mesh but covers only the layers: listed,
    # and left out of the printed line.
    output, summary_path = c.path("layers.vtu"), c.path("layers.json")
    out, _ = c.run_ok([image, "-o", output, "--summary", summary_path, "--boundary-layer", "1"]
                      + STAIRCASE)
    summary = load_summary(summary_path)
    check([entry["material"] for entry in summary["materials"]] == [0, 1, 2],
          "boundary layers: materials %s" % [e["material"] for e in summary["materials"]])
    zero = summary["materials"][0]
    check(zero["voxels"] == background and 0 < zero["mesh_volume"] < background,
          "boundary layers: background entry %s" % zero)
    check(report_line(summary["materials"]) in out.splitlines(),
          "boundary layers: stdout lacks %r" % report_line(summary["materials"]))
    # A 2D image: 4-connected components; the two diagonal voxels are two components.
    flat, flat_voxels = write_label_image(c, "flat.vti", (16, 15, 1), flat_labels)
    check(flat_voxels == {"1": 18, "4": 6}, "bad 2D test image: %s" % flat_voxels)
    output, summary_path = c.path("flat.vtu"), c.path("flat.json")
    out, _ = c.run_ok([flat, "-o", output, "--summary", summary_path] + STAIRCASE)
    check_report(load_summary(summary_path), out, flat_voxels, "2D", {"1": 3, "4": 1})


def case_report_cut(c):
    image, voxels = write_label_image(c, "ball.vti", (25, 25, 25), big_ball)
    body = voxels["1"]
    background = 25 ** 3 - body
    summary, _, _, mesh, out, _ = cut_run(c, image, "default", [])
    materials = summary["materials"]
    check([entry["material"] for entry in materials] == [0, 1],
          "materials %s" % [entry["material"] for entry in materials])
    zero, one = materials
    check(one["voxels"] == body and one["voxel_volume"] == body, "material 1: %s" % one)
    check(abs(one["volume_error"]) <= 0.05, "material 1: volume error %r" % one["volume_error"])
    check(close(one["volume_error"], (one["mesh_volume"] - body) / body),
          "material 1: volume_error %r does not fit its volumes" % one["volume_error"])
    check(close(one["mesh_volume"], material_volumes(mesh)[1]),
          "material 1: mesh_volume %r, the file's cells %r" % (one["mesh_volume"],
                                                              material_volumes(mesh)[1]))
    check(one["image_components"] == 1 and one["lost_components"] == 0, "material 1: %s" % one)
    check(zero["voxels"] == background and close(zero["mesh_volume"], material_volumes(mesh)[0]),
          "material 0: %s" % zero)
    check(report_line(materials) in out.splitlines(), "stdout lacks %r" % report_line(materials))
    check(report_line(materials).startswith("materials: 1 material, 0 lost components (of 1), "
                                             "largest volume error "), report_line(materials))
    # --keep inside: the mesh has no background, so only the body is listed.
    summary, _, _, _, out, _ = cut_run(c, image, "inside", ["--keep", "inside"])
    check([entry["material"] for entry in summary["materials"]] == [1],
          "--keep inside: materials %s" % [e["material"] for e in summary["materials"]])
    check(summary["materials"][0]["lost_components"] == 0, "--keep inside lost the body")
    # --keep outside: the body is in the image but not in the mesh: listed, with volume 0 and
    # its component lost.
    summary, _, _, _, out, _ = cut_run(c, image, "outside", ["--keep", "outside"])
    check([entry["material"] for entry in summary["materials"]] == [0, 1],
          "--keep outside: materials %s" % [e["material"] for e in summary["materials"]])
    one = summary["materials"][1]
    check(one["voxels"] == body and one["mesh_volume"] == 0 and one["volume_error"] == -1 and
          one["image_components"] == 1 and one["lost_components"] == 1,
          "--keep outside: material 1: %s" % one)
    check("materials: 1 material, 1 lost component (of 1), largest volume error -100.00% "
          "(material 1)" in out.splitlines(), "--keep outside: bad materials line")
    # The lost component is listed, with its first voxel (in memory order: x fastest).
    first = next([i, j, k] for k in range(25) for j in range(25) for i in range(25)
                 if big_ball(i, j, k) == 1)
    check(summary["lost_components"] == [{"material": 1, "voxels": body, "first_voxel": first}],
          "--keep outside: lost_components %s, expected material 1 from %s" %
          (summary["lost_components"], first))
    check(("lost: material 1, %d voxels from voxel (%d, %d, %d)" % ((body,) + tuple(first)))
          in out.splitlines(), "--keep outside: stdout does not list the lost component")
    summary, _, _, _, _, _ = cut_run(c, image, "inside-list", ["--keep", "inside"])
    check(summary["lost_components"] == [], "--keep inside: lost_components %s" %
          summary["lost_components"])
    # One label as the body: it is the inside material, and the other labels map to 0.
    two, two_voxels = write_label_image(c, "two.vti", (16, 15, 14), ball)
    summary, _, _, _, _, _ = cut_run(c, two, "label3", ["--labels", "3"], inside=3)
    entries = {entry["material"]: entry for entry in summary["materials"]}
    check(sorted(entries) == [0, 3], "--labels 3: materials %s" % sorted(entries))
    check(entries[3]["voxels"] == two_voxels["3"] and
          entries[0]["voxels"] == 16 * 15 * 14 - two_voxels["3"],
          "--labels 3: voxels %s" % entries)
    # A surface has no volume to report.
    output, summary_path = c.path("surface.vtp"), c.path("surface.json")
    out, _ = c.run_ok([image, "-o", output, "--summary", summary_path, "--output-mode",
                       "surface"])
    check(load_summary(summary_path)["materials"] is None, "surface output has a report")
    check(not any(line.startswith("materials:") for line in out.splitlines()),
          "surface output prints a materials line")


# ------------------------------------------------------------------------------------------------
# Finite-element outputs (.msh, .mesh, .inp, .feb), read back by independent readers: Gmsh itself
# (Debian's gmsh and python3-gmsh), meshio (python3-meshio) and, for FEBio's XML, ElementTree.

FE_EXTENSIONS = [".msh", ".mesh", ".inp", ".feb", ".exo"]


def vtu_grid(path):
    """(points as tuples, cells as point-id tuples, VTK cell types, Material) of a .vtu."""
    _, grid, _ = read_grid(path)
    materials = grid.GetCellData().GetArray("Material")
    cells, types = [], []
    for cell in range(grid.GetNumberOfCells()):
        ids = grid.GetCell(cell).GetPointIds()
        cells.append(tuple(ids.GetId(k) for k in range(ids.GetNumberOfIds())))
        types.append(grid.GetCellType(cell))
    return ([grid.GetPoint(p) for p in range(grid.GetNumberOfPoints())], cells, types,
            [int(materials.GetTuple1(cell)) for cell in range(grid.GetNumberOfCells())])


def gmsh_check(c, path):
    """Gmsh's own reading and coherence check: no warning (a negative volume, a duplicate node
    or element) and no error."""
    completed = subprocess.run(["gmsh", "-check", path], capture_output=True, text=True,
                               timeout=250)
    print(completed.stdout[-2000:])
    check(completed.returncode == 0, "gmsh -check %s exited with %d" % (path,
                                                                         completed.returncode))
    problems = [line for line in (completed.stdout + completed.stderr).splitlines()
                if line.startswith("Warning") or line.startswith("Error")]
    check(not problems, "gmsh -check %s: %s" % (path, problems[:5]))


def gmsh_groups(path):
    """{physical tag: (name, elements)} as Gmsh's Python API reads them."""
    import gmsh
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(path)
        groups = {}
        for dim, tag in gmsh.model.getPhysicalGroups():
            count = 0
            for entity in gmsh.model.getEntitiesForPhysicalGroup(dim, tag):
                _, element_tags, _ = gmsh.model.mesh.getElements(dim, entity)
                count += sum(len(tags) for tags in element_tags)
            groups[tag] = (gmsh.model.getPhysicalName(dim, tag), count)
        return groups
    finally:
        gmsh.finalize()


def meshio_counts(path, key):
    """(points, {tag: elements}) read by meshio; key: the cell data of the tags."""
    import meshio
    mesh = meshio.read(path)
    counts = {}
    for block in mesh.cell_data[key]:
        for tag in block:
            counts[int(tag)] = counts.get(int(tag), 0) + 1
    return mesh, counts


def febio_parts(path):
    """{part name: (element type, elements)}, nodes, domains {name: material} and material names
    of a .feb file."""
    import xml.etree.ElementTree as ET
    root = ET.parse(path).getroot()
    check(root.tag == "febio_spec" and root.get("version") == "4.0", "%s is no FEBio 4.0 file"
          % path)
    parts = {part.get("name"): (part.get("type"), len(part.findall("elem")))
             for part in root.find("Mesh").findall("Elements")}
    nodes = root.find("Mesh").find("Nodes").findall("node")
    domains = {domain.get("name"): domain.get("mat")
               for domain in root.find("MeshDomains").findall("SolidDomain")}
    materials = [material.get("name") for material in root.find("Material").findall("material")]
    return parts, nodes, domains, materials


def exodus_blocks(path):
    """{block id: (name, elements, the node ids of its points)} of an Exodus II file read by
    VTK's vtkExodusIIReader."""
    from vtkmodules.vtkIOExodus import vtkExodusIIReader
    reader = vtkExodusIIReader()
    reader.SetFileName(path)
    reader.UpdateInformation()
    count = reader.GetNumberOfObjects(reader.ELEM_BLOCK)
    for index in range(count):
        reader.SetObjectStatus(reader.ELEM_BLOCK, index, 1)
    reader.SetGenerateGlobalNodeIdArray(1)
    reader.Update()
    output = reader.GetOutput()
    blocks = {}
    iterator = output.NewIterator()
    iterator.InitTraversal()
    index = 0
    while not iterator.IsDoneWithTraversal():
        block = iterator.GetCurrentDataObject()
        node_ids = block.GetPointData().GetArray("GlobalNodeId")
        # Every element has a positive volume as VTK's Exodus reader orders its corners.
        sizes = vtk_modules()["vtkCellSizeFilter"]()
        sizes.SetInputData(block)
        sizes.Update()
        volumes = sizes.GetOutput().GetCellData().GetArray("Volume")
        smallest = min(volumes.GetValue(e) for e in range(volumes.GetNumberOfTuples()))
        check(smallest > 0, "Exodus: block %d has an element of volume %r" %
              (reader.GetObjectId(reader.ELEM_BLOCK, index), smallest))
        blocks[reader.GetObjectId(reader.ELEM_BLOCK, index)] = (
            reader.GetObjectName(reader.ELEM_BLOCK, index), block.GetNumberOfCells(),
            {int(node_ids.GetTuple1(p)) for p in range(node_ids.GetNumberOfTuples())})
        index += 1
        iterator.GoToNextItem()
    check(index == count, "Exodus: %d blocks read of %d" % (index, count))
    return blocks, reader.GetNumberOfNodesInFile()


def check_fe_outputs(c, image, name, arguments, names):
    """Writes the mesh of `arguments` as .vtu (--background drop, the reference) and in every
    finite-element format, and checks what each reader finds: the same points bit for bit, the
    same elements per material (tag = label) with the names of `names`, and Gmsh's check."""
    reference = c.path(name + ".vtu")
    c.run_ok([image, "-o", reference, "--background", "drop"] + arguments)
    points, cells, types, materials = vtu_grid(reference)
    check(0 not in materials, "--background drop left background cells")
    per_material = {}
    for material in materials:
        per_material[material] = per_material.get(material, 0) + 1
    for extension in FE_EXTENSIONS + [".binary.msh"]:
        output, summary_path = c.path(name + extension), c.path(name + extension + ".json")
        extra = ["--msh-format", "binary"] if extension == ".binary.msh" else []
        c.run_ok([image, "-o", output, "--summary", summary_path] + arguments + extra)
        summary = load_summary(summary_path)
        check(summary["parameters"]["background"] == "drop", "%s: background %s" %
              (extension, summary["parameters"]["background"]))
        check(stage(summary, "write")["file_bytes"] == os.path.getsize(output),
              "%s: the summary's file size" % extension)
        if extension.endswith(".msh"):
            gmsh_check(c, output)
            groups = gmsh_groups(output)
            check({tag: count for tag, (_, count) in groups.items()} == per_material,
                  "%s: Gmsh's groups %s, the .vtu's materials %s" % (extension, groups,
                                                                     per_material))
            for tag, (group_name, _) in groups.items():
                check(group_name == names.get(tag, "Material_%d" % tag),
                      "%s: group %d is named %r" % (extension, tag, group_name))
            mesh, counts = meshio_counts(output, "gmsh:physical")
        elif extension == ".mesh":
            mesh, counts = meshio_counts(output, "medit:ref")
        elif extension == ".inp":
            import meshio
            mesh = meshio.read(output)
            counts = {}
            # meshio keeps only the last *ELEMENT block of a set (pyramids and hexahedra are
            # both C3D8 blocks of it), so the sets are counted here, line by line.
            words = {re.sub("[^A-Za-z0-9]", "_", names.get(label, "Material_%d" % label)): label
                     for label in per_material}
            current = None
            with open(output) as abaqus_file:
                for line in abaqus_file:
                    if line.startswith("*"):
                        match = re.match(r"\*ELEMENT, TYPE=C3D[468], ELSET=(\w+)$", line.strip())
                        current = match.group(1) if match else None
                        check(current is None or current in words, "Abaqus: ELSET %s" % current)
                    elif current is not None:
                        counts[words[current]] = counts.get(words[current], 0) + 1
        if extension == ".exo":
            blocks, nodes_in_file = exodus_blocks(output)
            check(nodes_in_file == len(points), "Exodus: %d nodes in the file, the .vtu has %d "
                  "points" % (nodes_in_file, len(points)))
            counts = {}
            for block_id, (block_name, elements, _) in blocks.items():
                material = block_id if block_id in per_material else int(
                    next(label for label in per_material
                         if block_name.startswith(names.get(label, "Material_%d" % label) + "_")))
                counts[material] = counts.get(material, 0) + elements
                if block_id in per_material:
                    # Named after the material, with the element type where it has several.
                    expected = names.get(block_id, "Material_%d" % block_id)
                    check(block_name == expected or (len(set(types)) > 1 and
                                                     block_name.startswith(expected + "_")),
                          "Exodus: block %d is named %r" % (block_id, block_name))
            check(counts == per_material, "Exodus: elements per material %s, the .vtu's %s" %
                  (counts, per_material))
            # The blocks share their interface nodes, numbered as the .vtu's points + 1.
            used = set().union(*(nodes for _, _, nodes in blocks.values()))
            check(used == {p + 1 for cell in cells for p in cell},
                  "Exodus: the blocks' nodes are not the .vtu's points")
            check(len(blocks) < 2 or sum(len(nodes) for _, _, nodes in blocks.values()) >
                  len(used), "Exodus: no node is shared between blocks")
        elif extension != ".feb":
            check(counts == per_material, "%s: elements per material %s, the .vtu's %s" %
                  (extension, counts, per_material))
            check(len(mesh.points) == len(points) and all(
                tuple(float(x) for x in mesh.points[p]) == tuple(points[p])
                for p in range(len(points))), "%s: the points differ from the .vtu's" % extension)
            check(sum(len(block.data) for block in mesh.cells) == len(cells),
                  "%s: %d elements, the .vtu has %d" % (extension, sum(len(block.data)
                                                                       for block in mesh.cells),
                                                        len(cells)))
        else:
            parts, nodes, domains, materials_named = febio_parts(output)
            check(len(nodes) == len(points), "FEBio: %d nodes, the .vtu has %d" %
                  (len(nodes), len(points)))
            check(sum(count for _, count in parts.values()) == len(cells),
                  "FEBio: elements %s" % parts)
            check(sorted(domains) == sorted(parts) and
                  all(material in materials_named for material in domains.values()),
                  "FEBio: domains %s, parts %s, materials %s" % (domains, sorted(parts),
                                                                 materials_named))
    return per_material, types


def case_export_formats(c):
    # The ball (label 1) with a box inside (label 3), every label its own material, named by a
    # label table in MRIcron's format (label 3 in ITK-SNAP's quotes).
    image, _ = write_label_image(c, "ball.nii", (16, 15, 14), ball)
    table = c.path("names.txt")
    with open(table, "w") as names_file:
        names_file.write("# labels\n1 Ball 2001\n3 0 0 255 1 1 1 \"Inner box\"\n7 Absent\n")
    names = {1: "Ball", 3: "Inner box"}
    per_material, types = check_fe_outputs(c, image, "ball", ["--materials", "separate",
                                                              "--label-names", table], names)
    check(sorted(per_material) == [1, 3] and set(types) == {TETRA},
          "materials %s, types %s" % (per_material, set(types)))
    # The names also travel in the .vtu as field data.
    _, grid, _ = read_grid(c.path("ball.vtu"))
    field = grid.GetFieldData()
    names_array = field.GetAbstractArray("MaterialNames")
    labels_array = field.GetArray("MaterialNameLabels")
    check(names_array is not None and labels_array is not None and
          [names_array.GetValue(i) for i in range(names_array.GetNumberOfValues())] ==
          ["Ball", "Inner box", "Absent"] and
          [int(labels_array.GetTuple1(i)) for i in range(3)] == [1, 3, 7],
          "the .vtu's label table")
    # A hybrid mesh (hexahedra, pyramids, tetrahedra): Gmsh finds no negative volume, so every
    # format's corner order is right; pyramids are collapsed C3D8 in Abaqus.
    boxes, _ = write_label_image(c, "boxes.nii", (12, 10, 8), two_boxes)
    per_material, types = check_fe_outputs(
        c, boxes, "hybrid", ["--elements", "hybrid", "--stop-after", "tessellate"], {})
    check(sorted(per_material) == [1, 2] and {TETRA, PYRAMID, HEXAHEDRON} <= set(types),
          "hybrid: materials %s, types %s" % (per_material, set(types)))
    import meshio
    abaqus = meshio.read(c.path("hybrid.inp"))
    check(sum(len(block.data) for block in abaqus.cells if block.type == "hexahedron") ==
          sum(1 for t in types if t in (HEXAHEDRON, PYRAMID)),
          "Abaqus: hexahedra and collapsed pyramids")
    # The background kept on request: its cells get the tag after the largest label.
    kept = c.path("kept.msh")
    c.run_ok([boxes, "-o", kept, "--background", "keep", "--stop-after", "tessellate",
              "--boundary-layer", "1"])
    groups = gmsh_groups(kept)
    check(sorted(groups) == [1, 2, 3] and groups[3][0] == "Material_0",
          "kept background: groups %s" % groups)


def case_export_two_dimensional(c):
    flat = c.make_image("slice.vti", variant="2d")
    output = c.path("slice.msh")
    c.run_ok([flat, "-o", output])
    gmsh_check(c, output)
    import meshio
    mesh = meshio.read(output)
    check({block.type for block in mesh.cells} == {"triangle"}, "2D cell types %s" %
          {block.type for block in mesh.cells})
    medit = c.path("slice.mesh")
    c.run_ok([flat, "-o", medit])
    check({block.type for block in meshio.read(medit).cells} == {"triangle"}, "Medit 2D")
    for extension, text in [(".inp", "the Abaqus export writes solid elements"),
                            (".feb", "the FEBio export writes solid elements")]:
        c.run_failing([flat, "-o", c.path("slice" + extension)], 1, text,
                      output=c.path("slice" + extension))


def case_error_export_options(c):
    image, _ = write_label_image(c, "ball.nii", (16, 15, 14), ball)
    bad_table = c.path("bad.txt")
    with open(bad_table, "w") as names_file:
        names_file.write("1 Ball\nthree Box\n")
    twice = c.path("twice.txt")
    with open(twice, "w") as names_file:
        names_file.write("1 Ball\n1 Box\n")
    for arguments, code, text in [
            (["--msh-format", "binary", "-o", c.path("x.vtu")], 2, "--msh-format applies to"),
            (["--msh-format", "big", "-o", c.path("x.msh")], 2, "not one of ascii, binary"),
            (["--background", "maybe", "-o", c.path("x.msh")], 2, "not one of keep, drop"),
            (["--output-mode", "surface", "-o", c.path("x.msh")], 2,
             "the finite-element formats hold volume meshes"),
            (["--label-names", c.path("missing.txt"), "--materials", "separate", "-o",
              c.path("x.msh")], 1, "cannot open the label table"),
            (["--label-names", bad_table, "--materials", "separate", "-o", c.path("x.msh")], 1,
             "line 2 of the label table does not start with an integer"),
            (["--label-names", twice, "--materials", "separate", "-o", c.path("x.msh")], 1,
             "label 1 is named twice"),
            (["--label-names", twice, "-o", c.path("x.msh")], 2,
             "the cut makes the body of several labels one material")]:
        c.run_failing([image] + arguments, code, text, output=c.path("x.msh"))


def png_pixels(path):
    """(width, height, distinct colours) of a PNG read by VTK's reader."""
    from vtkmodules.vtkIOImage import vtkPNGReader
    from vtkmodules.util.numpy_support import vtk_to_numpy
    check(os.path.getsize(path) > 0, "%s is empty" % path)
    reader = vtkPNGReader()
    check(reader.CanReadFile(path), "%s is no PNG" % path)
    reader.SetFileName(path)
    reader.Update()
    image = reader.GetOutput()
    pixels = vtk_to_numpy(image.GetPointData().GetScalars())
    width, height, _ = image.GetDimensions()
    return width, height, len({tuple(pixel[:3]) for pixel in pixels[::7]})


def case_report_directory(c):
    # The ball with its inner box, every label its own material, to Gmsh with a report.
    image, _ = write_label_image(c, "ball.nii", (16, 15, 14), ball)
    table = c.path("names.txt")
    with open(table, "w") as names_file:
        names_file.write("1 Ball\n3 Inner_box\n")
    output, report, summary_path = c.path("ball.msh"), c.path("report"), c.path("ball.json")
    out, _ = c.run_ok([image, "--materials", "separate", "--label-names", table, "-o", output,
                       "--report", report, "--summary", summary_path])
    check("report:  %s/index.html" % report in out, "no report line")
    summary = load_summary(summary_path)
    check(stage(summary, "report")["seconds"] > 0, "no report stage in the summary")
    copied = load_summary(os.path.join(report, "summary.json"))
    check(copied["output"] == summary["output"] and
          [s["name"] for s in copied["stages"]] == STAGES_ALL,
          "the report's summary.json: stages %s" % [s["name"] for s in copied["stages"]])
    # The mesh the report drew: the written one (as .vtu beside it, background left out).
    mesh = read_mesh(os.path.join(report, "mesh.vtu"))
    with open(os.path.join(report, "quality.json")) as quality_file:
        quality = json.load(quality_file)
    check(quality["all"]["elements"] == mesh["cells"] and
          quality["all"]["measured_elements"] == mesh["cells"],
          "quality.json counts %s, the mesh has %d cells" % (quality["all"]["elements"],
                                                             mesh["cells"]))
    per_material = count_by_material(mesh)
    check({str(entry["material"]): entry["elements"] for entry in quality["materials"]} ==
          per_material, "quality.json per material %s, the mesh's %s" %
          ([(e["material"], e["elements"]) for e in quality["materials"]], per_material))
    for entry in quality["materials"] + [quality["all"]]:
        check(sum(entry["angle_histogram"]) == entry["measured_elements"] ==
              sum(entry["condition_histogram"]), "histogram counts %s" % entry)
    # vtkMeshQuality's figures against stmesh's own measures of the same cells.
    check(abs(quality["all"]["max_condition_number"] - summary["quality"]["worst_condition"])
          < 1e-6 and abs(quality["all"]["min_dihedral_angle"] -
                         summary["quality"]["smallest_dihedral_degrees"]) < 0.01,
          "report figures %s / %s, stmesh's %s" % (quality["all"]["max_condition_number"],
                                                   quality["all"]["min_dihedral_angle"],
                                                   summary["quality"]))
    for picture, least_colours in (("quality_histograms.png", 3), ("cut.png", 4)):
        width, height, colours = png_pixels(os.path.join(report, picture))
        check(width >= 300 and height >= 300 and colours >= least_colours,
              "%s: %d x %d pixels, %d colours" % (picture, width, height, colours))
    with open(os.path.join(report, "index.html")) as page_file:
        page = page_file.read()
    for text in ('src="quality_histograms.png"', 'src="cut.png"', "Inner_box", "Ball",
                 'href="summary.json"', "<td>smooth</td>"):
        check(text in page, "index.html lacks %r" % text)
    # The report needs a volume mesh, and a python3 that can make it.
    c.run_failing([image, "--output-mode", "surface", "-o", c.path("s.vtp"), "--report",
                   c.path("r2")], 2, "--report needs a volume mesh")
    code, _, err = c.run([image, "-o", c.path("b.vtu"), "--report", c.path("r3")],
                         env_changes={"STMESH_PYTHON": "/nonexistent/python3"})
    check(code == 1 and "--report: /nonexistent/python3 -m spacetreemesh.report failed" in err,
          "a missing python3: exit %d" % code)


def case_export_label_table_beside(c):
    # An atlas's label table beside it (MRIcron: aal.nii.gz and aal.nii.txt) names the groups
    # without --label-names; --label-names none ignores it; a malformed one only warns.
    image, _ = write_label_image(c, "ball.nii", (16, 15, 14), ball)
    with open(image + ".txt", "w") as names_file:
        names_file.write("1 Ball\n3 Inner_box\n")
    output = c.path("named.msh")
    out, _ = c.run_ok([image, "--materials", "separate", "-o", output])
    check("names:   %s.txt (2 labels, found beside the input" % image in out, "no names line")
    check({tag: name for tag, (name, _) in gmsh_groups(output).items()} ==
          {1: "Ball", 3: "Inner_box"}, "groups %s" % gmsh_groups(output))
    unnamed = c.path("unnamed.msh")
    out, _ = c.run_ok([image, "--materials", "separate", "--label-names", "none", "-o", unnamed])
    check("names:" not in out and {name for name, _ in gmsh_groups(unnamed).values()} ==
          {"Material_1", "Material_3"}, "--label-names none")
    # The merged body (Material 1 for labels 1 and 3) is not named after label 1.
    merged = c.path("merged.msh")
    out, _ = c.run_ok([image, "-o", merged])
    check("names:" not in out and {name for name, _ in gmsh_groups(merged).values()} ==
          {"Material_1"}, "the merged body was named")
    with open(image + ".txt", "w") as names_file:
        names_file.write("1 Ball\none Box\n")
    _, err = c.run_ok([image, "--materials", "separate", "-o", c.path("warned.msh")])
    check("warning: the label table beside the input is ignored" in err, "no warning")



# ------------------------------------------------------------------------------------------------
# Degenerate and hostile inputs (issue 10, docs/reliability.md): each gives a clear error or a
# valid mesh that keeps every component of the image.

VTK_UNSIGNED_CHAR, VTK_INT, VTK_FLOAT = 3, 6, 10


def write_any_image(c, name, dimensions, value, vtk_type=VTK_UNSIGNED_CHAR, spacing=(1, 1, 1),
                    direction=None):
    """A .vti image (inline binary) of any scalar type, value(i, j, k) per voxel, with a spacing
    and a direction matrix (9 numbers, row-major) if given."""
    vtk = vtk_modules()
    image = filled_image(vtk, dimensions, vtk_type, "labels", value)
    image.SetSpacing(*spacing)
    if direction is not None:
        image.SetDirectionMatrix(*direction)
    errors = []
    writer = watched(vtk["vtkXMLImageDataWriter"](), errors)
    writer.SetDataModeToBinary()  # inline: Debian 12's libexpat fails on appended data
    writer.SetInputData(image)
    writer.SetFileName(c.path(name))
    writer.Write()
    check(not errors, "cannot write %s: %s" % (name, errors))
    return c.path(name)


def check_valid_mesh(path, dimension):
    """Conformity of a simplicial mesh read back: every facet in at most two cells, and every
    cell of positive measure. Returns the mesh as read_cut gives it."""
    vtk, grid, errors = read_grid(path)
    check(not errors, "%s: %s" % (path, errors))
    facets = {}
    ids = None
    for cell in range(grid.GetNumberOfCells()):
        points = grid.GetCell(cell).GetPointIds()
        ids = [points.GetId(k) for k in range(points.GetNumberOfIds())]
        check(len(ids) == dimension + 1, "%s: cell %d has %d points" % (path, cell, len(ids)))
        for skip in range(dimension + 1):
            facet = tuple(sorted(ids[:skip] + ids[skip + 1:]))
            facets[facet] = facets.get(facet, 0) + 1
    check(max(facets.values()) <= 2, "%s: a facet is shared by more than two cells" % path)
    mesh = read_cut(path)
    check(min(mesh["measures"]) > 0, "%s: a cell has no positive measure" % path)
    return mesh


def run_degenerate(c, image, name, arguments=(), dimension=3, volume_error=None):
    """Meshes an image with the default pipeline: exit 0, a valid mesh, no lost component and
    no inverted cell; returns the summary."""
    output, summary_path = c.path(name + ".vtu"), c.path(name + ".json")
    c.run_ok([image, "-o", output, "--summary", summary_path] + list(arguments))
    summary = load_summary(summary_path)
    check_valid_mesh(output, dimension)
    check(summary["quality"]["inverted_cells"] == 0, "%s: inverted cells" % name)
    for entry in summary["materials"]:
        check(entry["lost_components"] == 0, "%s: material %s lost a component" %
              (name, entry["material"]))
        if volume_error is not None and entry["material"] != 0:
            check(abs(entry["volume_error"]) <= volume_error, "%s: material %s volume error %s" %
                  (name, entry["material"], entry["volume_error"]))
    return summary


def case_degenerate_small_images(c):
    # One voxel: refused clearly. One voxel thick along any axis: a planar mesh in the image's
    # own plane, with its true area (the quality report measures it in that plane).
    single = write_any_image(c, "single.vti", (1, 1, 1), lambda i, j, k: 1)
    c.run_failing([single, "-o", c.path("single.vtu")], 1, "1 x 1 x 1", output=c.path("single.vtu"))
    for name, dimensions in [("yz", (1, 8, 8)), ("xz", (8, 1, 8)), ("xy", (8, 8, 1))]:
        image = write_any_image(c, name + ".vti", dimensions, lambda i, j, k: 1)
        summary = run_degenerate(c, image, name, dimension=2, volume_error=0.05)
        area = summary["quality"]["volume_per_material"]["1"]
        check(60 < area <= 64, "%s: area %s of the 8 x 8 plate" % (name, area))
    # A plate one voxel thick inside a 3D image: kept, and not pinched through.
    plate = write_any_image(c, "plate.vti", (8, 8, 5), lambda i, j, k: 1 if k == 2 else 0)
    run_degenerate(c, plate, "plate")


def case_degenerate_full_and_border(c):
    # Every voxel foreground, a shell on the image border, and a block filling one corner of the
    # image: one coarse leaf each, whose corners all lie where the body is a minority (the
    # image's border counts as background); leaves of one voxel there keep them.
    full = write_any_image(c, "full.vti", (10, 10, 10), lambda i, j, k: 1)
    run_degenerate(c, full, "full", volume_error=0.1)
    border = write_any_image(c, "border.vti", (10, 10, 10),
                             lambda i, j, k: 1 if min(i, j, k) == 0 or max(i, j, k) == 9 else 0)
    run_degenerate(c, border, "border", volume_error=0.2)
    block = write_any_image(c, "block.vti", (16, 16, 16),
                            lambda i, j, k: 1 if max(i, j, k) < 8 else 0)
    out, _ = c.run_ok([block, "-o", c.path("block_table.vtu")])
    check("80 corner voxels at voxel size" in out, "the table does not show the corner voxels")
    run_degenerate(c, block, "block", volume_error=0.1)
    square = write_any_image(c, "square.vti", (16, 16, 1),
                             lambda i, j, k: 1 if max(i, j) < 8 else 0)
    run_degenerate(c, square, "square", dimension=2, volume_error=0.05)


def case_degenerate_labels(c):
    # Labels at both ends of the 32-bit range, and 10^4 distinct labels, as materials.
    extremes = write_any_image(
        c, "extremes.vti", (12, 12, 12),
        lambda i, j, k: 2147483647 if (i - 5.5) ** 2 + (j - 5.5) ** 2 + (k - 5.5) ** 2 < 16 else
        (-5 if (i, j, k) == (0, 0, 0) else 0), VTK_INT)
    summary = run_degenerate(c, extremes, "extremes", ["--labels", "all"])
    check(sorted(entry["material"] for entry in summary["materials"]) == [-5, 0, 2147483647],
          "materials %s" % [entry["material"] for entry in summary["materials"]])
    many = write_any_image(c, "many.vti", (25, 25, 16),
                           lambda i, j, k: 1 + i + 25 * (j + 25 * k), VTK_INT)
    summary = run_degenerate(c, many, "many", ["--labels", "all"])
    check(len([e for e in summary["materials"] if e["material"] != 0]) == 10000,
          "%d materials, not 10000" % len(summary["materials"]))


def case_degenerate_gray_values(c):
    # NaN and Inf in a gray-value image: refused with the reason, no mesh.
    body = write_any_image(c, "body.vti", (10, 10, 10), lambda i, j, k: 1)
    for name, bad in [("nan", float("nan")), ("inf", float("inf"))]:
        gray = write_any_image(c, name + ".vti", (10, 10, 10),
                               lambda i, j, k: bad if (i, j, k) == (4, 4, 4) else 400.0 * (i < 6),
                               VTK_FLOAT)
        c.run_failing([body, "--separating", "gray:%s:200" % gray, "-o", c.path(name + ".vtu")],
                      1, "NaN or infinite", output=c.path(name + ".vtu"))


def case_degenerate_geometry(c):
    # A direction matrix that is not axis-aligned is respected: the mesh is the axis-aligned
    # one rotated. Spacings of 1e-6 and 1e6 give the same cut, scaled (docs/reliability.md: the
    # snap and the smoothing's quality tests decide a few points differently there).
    def ball(i, j, k):
        return 1 if (i - 5.5) ** 2 + (j - 5.5) ** 2 + (k - 5.5) ** 2 < 16 else 0
    angle = 0.3
    cosine, sine = math.cos(angle), math.sin(angle)
    plain = write_any_image(c, "plain.vti", (12, 12, 12), ball)
    rotated = write_any_image(c, "rotated.vti", (12, 12, 12), ball,
                              direction=(cosine, -sine, 0, sine, cosine, 0, 0, 0, 1))
    meshes = {}
    for name, image in [("plain", plain), ("rotated", rotated)]:
        # Without snapping and smoothing, whose quality tests round differently in rotated
        # coordinates, the cut depends on the function values alone.
        run_degenerate(c, image, name, ["--smooth-iterations", "0", "--snap", "none"])
        _, grid, _ = read_grid(c.path(name + ".vtu"))
        meshes[name] = [grid.GetPoint(p) for p in range(grid.GetNumberOfPoints())]
    check(len(meshes["plain"]) == len(meshes["rotated"]), "rotation changed the point count")
    for a, b in zip(meshes["plain"], meshes["rotated"]):
        expected = (cosine * a[0] - sine * a[1], sine * a[0] + cosine * a[1], a[2])
        check(all(abs(x - y) < 1e-9 for x, y in zip(expected, b)),
              "point %s is not the rotation of %s" % (b, a))
    counts = {}
    for name, spacing in [("unit", 1.0), ("tiny", 1e-6), ("huge", 1e6)]:
        image = write_any_image(c, name + ".vti", (12, 12, 12), ball,
                                spacing=(spacing, spacing, spacing))
        summary = run_degenerate(c, image, name, ["--smooth-iterations", "0", "--snap", "none"])
        counts[name] = (stage(summary, "cut")["cells"], stage(summary, "cut")["points"])
        volume = summary["quality"]["volume_per_material"]["1"] / spacing ** 3
        check(abs(volume - 280) < 0.15 * 280, "%s: volume %s voxels of 280" % (name, volume))
    check(counts["tiny"] == counts["unit"] == counts["huge"],
          "cells and points per spacing: %s" % counts)


def case_degenerate_memory(c):
    # A header that promises more voxels than memory holds is refused before reading, with the
    # estimate (VTK's reader would abort the process allocating them).
    with open(c.decompressed_aal(), "rb") as complete:
        head = bytearray(complete.read(352 + 1000))
    struct.pack_into("<8h", head, 40, 3, 30000, 30000, 30000, 1, 1, 1, 1)
    path = c.path("huge.nii")
    with open(path, "wb") as image_file:
        image_file.write(bytes(head))
    c.run_failing([path, "-o", c.path("huge.vtu")], 1, "30000 x 30000 x 30000 voxels",
                  output=c.path("huge.vtu"))
    code, _, err = c.run([path, "-o", c.path("huge.vtu")])
    check(re.search(r"needs at least [0-9.]+ GiB, and this machine has [0-9.]+ GiB", err),
          "no estimate in the message")
    # A header that fits in memory but promises more voxels than its file could hold, even
    # compressed 1032 to 1 (deflate's most): refused before the reader allocates them, with
    # the sizes (the fuzz target FuzzImageReading ran out of memory on such headers).
    struct.pack_into("<8h", head, 40, 3, 400, 400, 400, 1, 1, 1, 1)
    path = c.path("lying.nii")
    with open(path, "wb") as image_file:
        image_file.write(bytes(head))
    c.run_failing([path, "-o", c.path("lying.vtu")], 1,
                  "400 x 400 x 400 voxels (64000000 bytes), more than a file of 1352 bytes can "
                  "hold even compressed", output=c.path("lying.vtu"))
    with gzip.open(c.path("lying.nii.gz"), "wb") as compressed:
        compressed.write(bytes(head))
    code, _, err = c.run([c.path("lying.nii.gz"), "-o", c.path("lying.vtu")])
    check(code == 1 and "can hold even compressed" in err, "the .nii.gz was not refused: " + err)


def available_memory_bytes():
    with open("/proc/meminfo") as meminfo:
        for line in meminfo:
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) * 1024
    return 0


def case_keep_memory(c):
    # --keep-memory (docs/performance.md, "Memory kept in the process"): the choice the summary
    # records, and the same mesh whichever allocator setting made it.
    image = c.make_image("labels.nrrd")
    runs = {}
    for label, arguments, env in [
            ("default", [], {}),
            ("no", ["--keep-memory", "no"], {}),
            ("yes_over_tunables", ["--keep-memory=yes"],
             {"GLIBC_TUNABLES": "glibc.malloc.tcache_count=0"}),
            ("auto_with_tunables", ["--keep-memory", "auto"],
             {"GLIBC_TUNABLES": "glibc.malloc.tcache_count=0"})]:
        output, summary_path = c.path(label + ".vtu"), c.path(label + ".json")
        c.run_ok([image, "-o", output, "--summary", summary_path] + arguments, env_changes=env)
        runs[label] = (load_summary(summary_path)["keep_memory"], c.read_back(output))
    expected = {
        "default": ("auto", True, "auto: "),
        "no": ("no", False, "--keep-memory no"),
        "yes_over_tunables": ("yes", True, "--keep-memory yes"),
        "auto_with_tunables": ("auto", False, "auto: GLIBC_TUNABLES is set")}
    for label, (option, kept, reason) in expected.items():
        record = runs[label][0]
        check(record["option"] == option and record["kept"] == kept and
              record["reason"].startswith(reason), "%s: %s" % (label, record))
        check(runs[label][1] == runs["default"][1], "%s: another mesh" % label)
    check(" within a quarter of the available " in runs["default"][0]["reason"],
          "default: %s" % runs["default"][0]["reason"])
    # An image whose voxels times 400 bytes exceed a quarter of the available memory (a full
    # block of one label, uncompressed, up to the spacetree) is not kept under auto.
    sizes = (512, 512, 128)
    voxels = sizes[0] * sizes[1] * sizes[2]
    available = available_memory_bytes()
    with open(c.decompressed_aal(), "rb") as complete:
        head = bytearray(complete.read(352))
    struct.pack_into("<8h", head, 40, 3, sizes[0], sizes[1], sizes[2], 1, 1, 1, 1)
    path = c.path("block.nii")
    with open(path, "wb") as image_file:
        image_file.write(bytes(head))
        image_file.write(b"\x01" * voxels)
    summary_path = c.path("block.json")
    c.run_ok([path, "-o", c.path("block.vtu"), "--stop-after", "spacetree", "--summary",
              summary_path])
    record = load_summary(summary_path)["keep_memory"]
    if voxels * 400 > 1.25 * available / 4:
        check(not record["kept"] and " above a quarter of the available " in record["reason"],
              "block: %s" % record)
    else:
        print("block: %d MiB available, too close to the bound to check: %s" %
              (available // 1048576, record))
    # A value that is none of the three is a usage error.
    c.run_failing([image, "-o", c.path("bad.vtu"), "--keep-memory", "maybe"], 2,
                  "--keep-memory: 'maybe' is not one of auto, yes, no", output=c.path("bad.vtu"))


def run_case(case, work, make_context, test_prefix="stmesh."):
    """Runs case_<case> (dots as underscores) of the calling script in a fresh work folder;
    returns the exit code."""
    function = sys.modules["__main__"].__dict__.get("case_" + case.replace(".", "_"))
    if function is None:
        print("unknown case %s" % case, file=sys.stderr)
        return 2
    if os.path.isdir(work):
        shutil.rmtree(work)
    os.makedirs(work)
    try:
        function(make_context())
    except CaseFailed as failure:
        print("FAILED: %s" % failure, file=sys.stderr)
        return 1
    print("PASSED: %s%s" % (test_prefix, case))
    return 0


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--stmesh", required=True)
    parser.add_argument("--helper", required=True)
    parser.add_argument("--aal", required=True)
    parser.add_argument("--work", required=True)
    parser.add_argument("case")
    arguments = parser.parse_args()
    if not os.path.exists(arguments.aal):
        print("%s is missing (Debian package mricron-data)" % arguments.aal, file=sys.stderr)
        return 1
    return run_case(arguments.case, arguments.work, lambda: Context(arguments))


if __name__ == "__main__":
    sys.exit(main())
