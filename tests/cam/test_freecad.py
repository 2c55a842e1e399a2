"""The FreeCAD post-processor, run by FreeCAD itself (``freecadcmd``, headless).

One freecadcmd run (a module fixture) builds a document: a sphere as the model, a Path Job
with a tool controller (tool 1, 1000 rpm) and a Custom operation, the hemishell's finishing
pass (pole to equator, a G3 about the origin in G18), plus two loose Path objects (the same
arc driven the other way, and a G17 mill arc). It posts them through the post's ``export``
(loaded by path with importlib, and once more through FreeCAD's own post loader after
copying the file into the macro folder), with and without postproc options, and records
what ``export`` returned and what it printed to FreeCAD's console. The tests then read the
written programs back with postproc itself.

FreeCAD comes from the Debian package freecad (``scripts/test`` installs it). Without it
these tests fail rather than skip. User settings live in a temporary HOME, so a developer's
FreeCAD preferences (an inch unit schema, say) cannot change the result. The whole module
takes about 3 s on an idle machine: 1.6-2 s for the one freecadcmd run (FreeCAD starting,
nine exports, postproc run three times), the rest postproc reading the programs back.
"""

from __future__ import annotations

import csv
import io
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from support import REPO

FREECAD_REQUIRED = ("freecadcmd (Debian package freecad) is required for the FreeCAD post-processor test: "
                    "apt-get install -y --no-install-recommends freecad")
POST = REPO / "postproc" / "cam" / "freecad" / "postproc_fanuc_lathe_post.py"
POSTPROC = Path(sys.executable).with_name("postproc")  # the venv's console script, not FreeCAD's Python
RADIUS = 57.15  # the hemishell
FEED_MM_MIN = 100.0  # at 1000 rpm: 0.1 mm/rev

# Run by freecadcmd; the spec (a JSON file named by $POSTPROC_FREECAD_SPEC) says what to export.
SCRIPT = r'''
import importlib.util, json, os, shutil
import FreeCAD, Path
from PathScripts import PathCustom, PathJob, PathPost, PathPostProcessor, PathPreferences

spec = json.load(open(os.environ["POSTPROC_FREECAD_SPEC"]))
module_spec = importlib.util.spec_from_file_location("postproc_fanuc_lathe_post", spec["post"])
post = importlib.util.module_from_spec(module_spec)
module_spec.loader.exec_module(post)
R, F = spec["radius"], spec["feed_mm_s"]

doc = FreeCAD.newDocument("Hemishell")
sphere = doc.addObject("Part::Sphere", "Shell")
sphere.Radius = R
doc.recompute()
job = PathJob.Create("Job", [sphere])
job.Label = "Hemishell (outside)"
tc = job.Tools.Group[0]
tc.ToolNumber, tc.SpindleSpeed, tc.SpindleDir = 1, 1000, "Forward"
finish = PathCustom.Create("Finish", parentJob=job)
finish.CoolantMode = "Flood"
finish.Gcode = ["G18", "G0 X0 Z60", f"G1 Z{R} F{F!r}", f"G3 X{R} Z0 I0 K{-R}", f"G1 X{R + 1.85}", "G0 Z62"]
reverse = doc.addObject("Path::Feature", "Reverse")
reverse.Path = Path.Path([Path.Command(c) for c in
                          ("G18", f"G0 X{R} Z-2", f"G1 Z0 F{F!r}", f"G2 X0 Z{R} I{-R} K0", "G0 Z62")])
mill = doc.addObject("Path::Feature", "MillArc")
mill.Path = Path.Path([Path.Command(c) for c in ("G0 X10 Z1", f"G1 Z0 F{F!r}", "G2 X0 Z10 I-10 K0")])  # no G18
doc.recompute()

objects = {"job": PathPost.CommandPathPost().buildPostList(job)[0], "reverse": [tc, reverse], "mill": [tc, mill]}
result = {"post_list": [getattr(o, "Label", "") for o in objects["job"]], "exports": {}}

# FreeCAD's own reading of G2/G3 in G18: the same end points, each direction's bounding box.
for name in ("G2", "G3"):
    path = Path.Path([Path.Command(c) for c in ("G18", f"G0 X{R} Z0", f"{name} X0 Z{R} I{-R} K0")])
    box = path.BoundBox
    result[name] = [box.XMin, box.XMax, box.ZMin, box.ZMax]
box = finish.Path.BoundBox
result["finish"] = [box.XMin, box.XMax, box.ZMin, box.ZMax]

console = FreeCAD.Console
def export(module, run):
    said = {"errors": [], "warnings": [], "messages": []}
    originals = console.PrintError, console.PrintWarning, console.PrintMessage
    console.PrintError, console.PrintWarning, console.PrintMessage = (
        said["errors"].append, said["warnings"].append, said["messages"].append)
    try:
        said["returned"] = module.export(objects[run["objects"]], run["output"], run["args"])
    finally:
        console.PrintError, console.PrintWarning, console.PrintMessage = originals
    return said

for run in spec["exports"]:
    result["exports"][run["name"]] = export(post, run)

# Installed the way a user does: the file copied into the macro folder, loaded by FreeCAD.
shutil.copy(spec["post"], PathPreferences.searchPathsPost()[0])
result["available"] = PathPostProcessor.PostProcessor.exists("postproc_fanuc_lathe")
loaded = PathPostProcessor.PostProcessor.load("postproc_fanuc_lathe")
result["exports"]["loader"] = export(loaded.script, spec["loader"])
result["loader_units"] = loaded.units

json.dump(result, open(spec["result"], "w"))
'''


def _trace(path: Path, step_deg: float) -> Path:
    """A CCW trace of the hemishell's radius reading +0.01 mm everywhere (docs/formats.md §4, processed form)."""
    rows = [f"{i * step_deg:.1f},0.01" for i in range(round(360 / step_deg))]
    path.write_text("# postproc ballbar 1\n# radius_mm = 57.15\n# direction = ccw\nangle_deg,deviation_mm\n"
                    + "\n".join(rows) + "\n")
    return path


@pytest.fixture(scope="module")
def freecad(tmp_path_factory):
    """Run the FreeCAD script once; returns (result, folder with the written programs, trace)."""
    freecadcmd = shutil.which("freecadcmd")
    if freecadcmd is None:
        pytest.fail(FREECAD_REQUIRED, pytrace=False)
    assert POSTPROC.is_file(), f"postproc's console script is not beside {sys.executable}"
    folder = tmp_path_factory.mktemp("freecad")
    (folder / "home").mkdir()
    trace = _trace(folder / "ccw.csv", 1.0)
    gappy = _trace(folder / "gappy.csv", 10.0)
    quiet = "--no-show-editor"
    compensation = f"--plugin ballbar-inverse --ballbar {trace}"
    exports = [
        ("plain", "job", quiet),
        ("inches", "job", f"{quiet} --inches"),
        ("reverse", "reverse", quiet),
        ("compensated", "job", f"{quiet} --postproc-exe {POSTPROC} {compensation}"),
        ("quoted", "job", f"{quiet} --postproc-exe {POSTPROC} --postproc '{compensation}'"),
        ("refused", "job", f"{quiet} --postproc-exe {POSTPROC} --plugin ballbar-inverse --ballbar {gappy}"),
        ("no-postproc", "job", f"{quiet} --postproc-exe {folder / 'missing'} {compensation}"),
        ("mill", "mill", quiet),
    ]
    spec = {
        "post": str(POST), "radius": RADIUS, "feed_mm_s": FEED_MM_MIN / 60, "result": str(folder / "result.json"),
        "exports": [{"name": name, "objects": objects, "args": args, "output": str(folder / f"{name}.nc")}
                    for name, objects, args in exports],
        "loader": {"objects": "job", "args": quiet, "output": str(folder / "loader.nc")},
    }
    (folder / "spec.json").write_text(json.dumps(spec))
    (folder / "script.py").write_text(SCRIPT)
    env = {**os.environ, "HOME": str(folder / "home"), "POSTPROC_FREECAD_SPEC": str(folder / "spec.json")}
    done = subprocess.run([freecadcmd, str(folder / "script.py")], env=env, capture_output=True, text=True,
                          timeout=300)
    if not (folder / "result.json").is_file():  # freecadcmd exits 0 even when the script raises
        pytest.fail(f"the FreeCAD script did not finish:\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}")
    return json.loads((folder / "result.json").read_text()), folder, trace


def _rows(run, program: Path) -> list[dict[str, str]]:
    result = run("path", str(program))
    assert result.exit_code == 0, result.stderr
    return list(csv.DictReader(io.StringIO(result.stdout)))


def _arcs(rows):
    return [row for row in rows if row["kind"] == "arc"]


def _close(row, **expected) -> bool:
    return all(abs(float(row[key]) - value) < 1e-6 for key, value in expected.items())


def _words(program: str) -> set[str]:
    """The G and M words of a program, comments removed."""
    return set(re.findall(r"[GM]\d+(?:\.\d)?", re.sub(r"\([^)]*\)", "", program)))


def test_freecad_turns_g2_in_g18_with_theta_increasing(freecad):
    result, _, _ = freecad
    # From (R, 0) to (0, R) about the origin: G2 sweeps the quarter through theta = 45 deg
    # (x and z positive), G3 the three quarters through theta = 180 and 270 deg.
    assert result["G2"][0] > -1e-6 and result["G2"][2] > -1e-6
    assert result["G3"][0] < -0.99 * RADIUS and result["G3"][2] < -0.99 * RADIUS  # FreeCAD bounds its chords
    # The finishing pass's G3 from the pole to the equator is the quarter arc, theta decreasing.
    assert result["finish"][0] > -1e-6 and result["finish"][2] > -1e-6


def test_the_job_is_posted_as_a_fanuc_lathe_program(freecad):
    result, folder, _ = freecad
    assert result["post_list"] == ["G54", "TC: Default Tool", "Finish"]
    said = result["exports"]["plain"]
    program = (folder / "plain.nc").read_text()
    assert said["returned"] == program and said["errors"] == []
    lines = program.splitlines()
    assert lines[:2] == ["%", "O0001 (HEMISHELL OUTSIDE)"]
    assert lines[-4:] == ["M09", "M05", "M30", "%"]
    assert "G18 G21 G40 G99" in lines
    for block in ("T0101", "G97 S1000 M03", "M08", "G01 Z57.150 F0.1000", "G03 X114.300 Z0.000 I0.000 K-57.150"):
        assert block in lines
    assert not _words(program) & {"G17", "G54", "G49", "G80", "G90", "G43", "M6", "M06"}
    assert not any("plain.nc" in line.lower() for line in lines)  # no file name as a block
    for text in re.findall(r"\(([^\n]*)\)", program):
        assert text == text.upper() and "(" not in text and ")" not in text


def test_the_posted_program_is_the_hemishell_arc(freecad, run):
    _, folder, _ = freecad
    program = folder / "plain.nc"
    check = run("check", str(program))
    assert check.exit_code == 0, check.stderr
    assert ", 0 warnings" in check.stderr
    rows = _rows(run, program)
    (arc,) = _arcs(rows)
    assert _close(arc, x_start=0, z_start=RADIUS, x_end=RADIUS, z_end=0, x_center=0, z_center=0)
    assert arc["direction"] == "ccw"  # G03: theta from 90 down to 0 deg


def test_freecads_g2_is_written_g02(freecad, run):
    result, folder, _ = freecad
    assert result["exports"]["reverse"]["errors"] == []
    program = (folder / "reverse.nc").read_text()
    assert "G02 X0.000 Z57.150 I-57.150 K0.000" in program.splitlines()
    (arc,) = _arcs(_rows(run, folder / "reverse.nc"))
    assert _close(arc, x_start=RADIUS, z_start=0, x_end=0, z_end=RADIUS, x_center=0, z_center=0)
    assert arc["direction"] == "cw"


def test_inches_are_the_same_geometry(freecad, run):
    _, folder, _ = freecad
    program = (folder / "inches.nc").read_text().splitlines()
    assert "G18 G20 G40 G99" in program and "G03 X4.5000 Z0.0000 I0.0000 K-2.2500" in program
    assert "G01 Z2.2500 F0.00394" in program  # 0.1 mm/rev
    inches, mm = _rows(run, folder / "inches.nc"), _rows(run, folder / "plain.nc")
    assert [(row["line"], row["kind"], row["direction"]) for row in inches] == [
        (row["line"], row["kind"], row["direction"]) for row in mm]
    for inch_row, mm_row in zip(inches, mm):  # within half the last inch decimal, 0.00127 mm
        for key in ("x_start", "z_start", "x_end", "z_end", "x_center", "z_center"):
            assert (inch_row[key] == "") == (mm_row[key] == "")
            assert inch_row[key] == "" or abs(float(inch_row[key]) - float(mm_row[key])) < 0.0013


def test_with_postproc_options_the_written_program_is_the_compensated_one(freecad, run):
    result, folder, trace = freecad
    said = result["exports"]["compensated"]
    written = (folder / "compensated.nc").read_bytes()
    expected = run("compensate", str(folder / "plain.nc"), "--plugin", "ballbar-inverse", "--ballbar", str(trace))
    assert expected.exit_code == 0, expected.stderr
    assert written == expected.stdout_bytes
    assert said["returned"] == written.decode() and said["errors"] == []
    assert any("2 blocks replaced by 2" in message for message in said["messages"])
    # The trace says the path lies 0.01 mm outside: the arc is pulled in by as much.
    (arc,) = _arcs(_rows(run, folder / "compensated.nc"))
    assert _close(arc, x_start=0, z_start=RADIUS - 0.01, x_end=RADIUS - 0.01, z_end=0, x_center=0, z_center=0)
    assert arc["direction"] == "ccw"
    assert (folder / "quoted.nc").read_bytes() == written  # --postproc "ARGS" is the same request


def test_postprocs_refusal_reaches_the_freecad_user_and_nothing_is_written(freecad):
    result, folder, _ = freecad
    said = result["exports"]["refused"]
    assert said["returned"] is None
    assert not (folder / "refused.nc").exists()
    (error,) = said["errors"]
    assert "postproc compensate: bad input (exit 3); nothing was written" in error
    assert "gappy.csv: error: a gap of 10.0 deg in the trace" in error
    said = result["exports"]["no-postproc"]
    assert said["returned"] is None and not (folder / "no-postproc.nc").exists()
    assert "cannot run postproc" in said["errors"][0]


def test_a_mill_arc_is_refused(freecad):
    result, folder, _ = freecad
    said = result["exports"]["mill"]
    assert said["returned"] is None and not (folder / "mill.nc").exists()
    (error,) = said["errors"]
    assert "MillArc: G2" in error and "an arc in the G17 plane: lathe arcs lie in the XZ plane" in error


def test_copied_into_the_macro_folder_freecad_loads_it(freecad):
    result, folder, _ = freecad
    assert result["available"] and result["loader_units"] == "Metric"
    assert (folder / "loader.nc").read_text() == (folder / "plain.nc").read_text()
