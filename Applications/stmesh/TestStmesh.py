#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-3-Clause
"""Command-line tests of stmesh; one ctest per case (stmesh.<case>).

Usage: TestStmesh.py --stmesh EXE --helper EXE --aal AAL.nii.gz --work DIR CASE

Each case runs stmesh in a fresh DIR and checks the exit code, the messages and the files
written; meshes are read back with stmeshTestHelper (VTK readers), which also writes the small
label images used for the format and error cases. Exits 0 when the case passes.
"""

import argparse
import gzip
import json
import os
import random
import shutil
import subprocess
import sys

ERROR_PREFIX = "stmesh: error:"
TETRA, HEXAHEDRON = 10, 12
STAGES_TESSELLATE = ["read", "spacetree", "balance", "tessellate", "write"]


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

    def read_back(self, mesh):
        completed = subprocess.run([self.helper, "readback", mesh], capture_output=True,
                                   text=True, timeout=100)
        check(completed.returncode == 0,
              "cannot read back %s: %s" % (mesh, completed.stderr.strip()))
        return json.loads(completed.stdout)

    def make_image(self, name, scalar_type="uint8"):
        # VTK's writers choose the layout by lower-case extension (vtkMetaImageWriter turns
        # "x.MHA" into "x.mhd" + "x.raw"), so write "x.mha" and rename it for upper-case tests.
        path = self.path(name)
        written = self.path(name.lower())
        completed = subprocess.run([self.helper, "make-image", written, scalar_type],
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
                   "--threads", "--summary", "--version"]:
        check(option in out, "help does not mention %s" % option)
    out, _ = c.run_ok(["-h"])
    check(out.startswith("Usage: stmesh"), "-h does not print the usage")
    out, _ = c.run_ok(["--version"])
    check(out.startswith("stmesh (SpacetreeMesh) "), "bad --version output %r" % out)


def case_default_input_vtu(c):
    output, summary_path = c.path("aal.vtu"), c.path("aal.json")
    out, _ = c.run_ok(["-o", output, "--summary", summary_path])
    check("no INPUT given; meshing the default image " + c.aal in out,
          "no line saying the default image is meshed")
    check_table(out, STAGES_TESSELLATE)
    summary = load_summary(summary_path)
    check(summary["default_input"] is True and summary["input"] == c.aal, "bad input in summary")
    check(summary["output"] == output, "bad output in summary")
    check(summary["parameters"] == {"labels": [], "all_labels": True, "max_cell_size": 16,
                                    "balance": 1, "stop_after": "tessellate", "compressor": "lz4"},
          "bad parameters %s" % summary["parameters"])
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
                       "--summary", summary_path])
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
        c.run_ok([image, "-o", output, "--summary", summary_path])
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
        c.run_ok([image, "-o", output, "--compressor", compressor])
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
            ("default", [], {})]:
        output, summary_path = c.path(label + ".vtu"), c.path(label + ".json")
        c.run_ok([image, "-o", output, "--summary", summary_path] + arguments, env_changes=env)
        results[label] = (load_summary(summary_path), c.read_back(output))
    check(results["one"][0]["threads"] == 1, "--threads 1 not honoured")
    check(results["two"][0]["threads"] == 2, "--threads 2 not honoured")
    check(results["env_max"][0]["threads"] == 1, "VTK_SMP_MAX_THREADS not honoured")
    check(results["env_backend"][0]["smp_backend"] == "Sequential",
          "VTK_SMP_BACKEND_IN_USE not honoured")
    check(results["default"][0]["smp_backend"] == "STDThread", "STDThread not the default")
    check(results["default"][0]["threads"] == os.cpu_count(),
          "default threads %d, cores %d" % (results["default"][0]["threads"], os.cpu_count()))
    meshes = [mesh for _, mesh in results.values()]
    check(all(mesh == meshes[0] for mesh in meshes), "the mesh depends on the threads")
    c.run_failing([image, "-o", c.path("bad_env.vtu")], 1, "VTK_SMP_MAX_THREADS",
                  output=c.path("bad_env.vtu"), env_changes={"VTK_SMP_MAX_THREADS": "many"})


def case_summary_json(c):
    image = c.make_image("labels.mha", "int16")
    output, summary_path = c.path("mesh.vtu"), c.path("summary.json")
    c.run_ok([image, "-o", output, "--labels", "2,7", "--max-cell-size", "4", "--balance", "2",
              "--summary", summary_path])
    summary = load_summary(summary_path)
    for key in ["input", "output", "parameters", "threads", "stages", "total_seconds",
                "tetrahedra_per_material"]:
        check(key in summary, "summary lacks %s" % key)
    check(summary["parameters"] == {"labels": [2, 7], "all_labels": False, "max_cell_size": 4,
                                    "balance": 2, "stop_after": "tessellate", "compressor": "lz4"},
          "bad parameters %s" % summary["parameters"])
    for entry in summary["stages"]:
        for key in ["name", "seconds", "cells", "points", "leaves", "peak_rss_mib"]:
            check(key in entry, "stage %s lacks %s" % (entry.get("name"), key))
        check(entry["peak_rss_mib"] > 0, "no peak memory for %s" % entry["name"])
    check(summary["total_seconds"] >= sum(e["seconds"] for e in summary["stages"]) * 0.99,
          "total shorter than the stages")
    check(sorted(summary["tetrahedra_per_material"]) == ["2", "7"], "bad materials")
    check_mesh_against_summary(c.read_back(output), summary, TETRA, "tetrahedra_per_material")
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


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--stmesh", required=True)
    parser.add_argument("--helper", required=True)
    parser.add_argument("--aal", required=True)
    parser.add_argument("--work", required=True)
    parser.add_argument("case")
    arguments = parser.parse_args()

    function = globals().get("case_" + arguments.case.replace(".", "_"))
    if function is None:
        print("unknown case %s" % arguments.case, file=sys.stderr)
        return 2
    if not os.path.exists(arguments.aal):
        print("%s is missing (Debian package mricron-data)" % arguments.aal, file=sys.stderr)
        return 1
    if os.path.isdir(arguments.work):
        shutil.rmtree(arguments.work)
    os.makedirs(arguments.work)
    try:
        function(Context(arguments))
    except CaseFailed as failure:
        print("FAILED: %s" % failure, file=sys.stderr)
        return 1
    print("PASSED: stmesh.%s" % arguments.case)
    return 0


if __name__ == "__main__":
    sys.exit(main())
