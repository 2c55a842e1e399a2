"""Closing the loop on the machine: the probing program, its printout, and the verdict.

The written program is run here as a control would run it (:func:`run_on_control`): its macro
statements evaluated, each G31 stopped where a stylus moving along it first touches a known
surface (a perfect sphere, or the virtual lathe's cut surface through its own touch model),
#5061/#5062 latched and the DPRNT lines formatted with FANUC's digit rules. The printout goes
through ``probe-import`` and the probe file through ``inspect``.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, strategies as st

from postproc.diagnostics import OptionError, UsageError, EXIT_BAD_INPUT, EXIT_REFUSED, EXIT_USAGE, EXIT_WOULD_CHANGE
from postproc.measure.features import owners
from postproc.geometry import Profile, segment_of
from postproc.measure.readers.probe import read_probe
from postproc.onmachine.probe_cycle import RESERVED_M, Cycle, plan, stations
from postproc.onmachine.probe_route import Surfaces
from postproc.interpret.program import interpret_source
from postproc.simulator import cut, generator, load, nominal, read_program
from postproc.simulator.surface import Plane
from postproc.simulator.touch import Touch as SimTouch, run as sim_run
from postproc.syntax.source import Source
from support import SAMPLES
from support.control import Alarm, run_on_control, skips
from support.parts import TurnedProfile

HEMISHELL = str(SAMPLES / "programs" / "hemishell.nc")
MACHINE = str(SAMPLES / "machines" / "v40r-sim.toml")
R_PART = 57.15
STYLUS = 3.0
CLEARANCE = 1.0

# The hemishell's arc without the flat at its equator, so every touch from pole to equator is reachable.
DOME = """%
O1002 (DOME)
G18 G21 G40 G99
T0101
G00 X0. Z62.
G01 Z57.15 F0.08
G03 X114.3 Z0. I0. K-57.15
G00 X130.
G00 Z62.
M30
%
"""


def write(tmp_path: Path, name: str, text: str | bytes) -> str:
    path = tmp_path / name
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    return str(path)


# ---------------------------------------------------------------------------- a control, emulated


def sphere_latch(radius: float):
    """Where a stylus moving along each skip first touches a sphere of ``radius`` about the origin."""
    def latch(start, end):
        n = (end - start) / np.linalg.norm(end - start)
        reach = radius + STYLUS
        p = float(start @ n)
        t = -p - math.sqrt(p * p - float(start @ start) + reach * reach)
        return tuple(start + t * n)
    return latch


def plane_latch(point, normal):
    def latch(start, end):
        n = (end - start) / np.linalg.norm(end - start)
        gap = float((start - np.asarray(point)) @ np.asarray(normal)) - STYLUS
        return tuple(start + gap / float(-(n @ np.asarray(normal))) * n)
    return latch


def probe_program(run, tmp_path, program, *options) -> str:
    out = str(tmp_path / "probe.nc")
    result = run("probe-program", program, *options, "--tool", "T0909", "-o", out)
    assert result.exit_code == 0, result.stderr
    assert result.stdout == ""
    return Path(out).read_text()


# ---------------------------------------------------------------------------- the program


def test_written_program_passes_check(run, tmp_path):
    text = probe_program(run, tmp_path, HEMISHELL, "--from-line", "10", "--to-line", "10", "--points", "36",
                         "--inset", "3", "--datum-x", "95", "--datum-z", "10")
    path = str(tmp_path / "probe.nc")
    result = run("check", path)
    assert result.exit_code == 0, result.stderr
    assert re.fullmatch(rf"{re.escape(path)}: ok: {text.count(chr(10))} lines, \d+ moves, 0 warnings\n", result.stderr)
    assert text.startswith("%\nO8100 (") and text.endswith("M30\n%\n")
    assert "G18 G21 G40 G98\n" in text and "\nM05\n" in text and "\nT0909\n" in text
    assert text.index("POPEN") < text.index("DPRNT[") and text.rindex("DPRNT[END]") < text.index("PCLOS")
    assert text.count("G31 ") == 36 + 2 and text.count("THEN#3000=1(NO TOUCH AT") == 38
    assert "DPRNT[POINT*#1[40]*X#5061[44]*Z#5062[44]*I#2[15]*K#3[15]]" in text
    assert text.count("DPRNT[DATUM*BEFORE*") == 1 and text.count("DPRNT[DATUM*AFTER*") == 1
    for line in text.splitlines():
        if line.startswith(("G01", "G31")):
            assert " F" in line, line  # F on every feed and skip block
        assert "--" not in line and "+-" not in line, line  # no sign right after an operator


def test_skip_moves_follow_the_nominal_normals_and_nothing_enters_the_material(run, tmp_path):
    points, inset = 12, 3.0
    text = probe_program(run, tmp_path, HEMISHELL, "--from-line", "10", "--to-line", "10", "--points", str(points),
                         "--inset", str(inset), "--clearance", str(CLEARANCE))
    name, moves = read_program(HEMISHELL)
    profile_of = nominal(moves, 10, 10, program=name)
    targets, outward, _ = stations(profile_of, points, inset)
    found = skips(text)
    assert [record for _, _, record in found] == ["POINT"] * points
    surfaces = Surfaces(moves)  # the arc and the flat of line 11
    for (start, end, _), q, n in zip(found, targets, outward):
        direction = (end - start) / np.linalg.norm(end - start)
        assert np.degrees(math.acos(min(1.0, float(-direction @ n)))) < 0.05
        assert np.linalg.norm(start - (q + (STYLUS + CLEARANCE) * n)) < 1e-3  # from the clearance outside
        assert float((end - q) @ n) < STYLUS  # aims beyond the surface
        # approach and retract run on this line: the ball touches nothing before the surface
        way = start + np.linspace(0, 1, 50)[:, None] * (q + STYLUS * n - start)
        assert np.all(surfaces.distance(way) >= STYLUS - 1e-3)
    with Source.from_text(text, "probe.nc") as source:
        travel = [m for step in interpret_source(source) for m in step.moves
                  if dict(step.block.codes).get("G") != "31" and m.known]
    assert travel
    for move in travel:
        segment = segment_of(move)
        samples = segment.point_at(np.linspace(0, 1, max(2, int(segment.length / 0.05))))
        assert np.all(surfaces.distance(samples) >= STYLUS + CLEARANCE / 2 - 1e-3), move


def test_stations_without_inset_are_the_simulators():
    name, moves = read_program(HEMISHELL)
    profile_of = nominal(moves, 10, 10, program=name)
    mine, theirs = stations(profile_of, 9), profile_of.stations(9)
    for a, b in zip(mine, theirs):
        np.testing.assert_allclose(a, b, atol=1e-12)


def test_a_touch_that_would_meet_another_surface_is_refused(run, tmp_path):
    result = run("probe-program", HEMISHELL, "--from-line", "10", "--to-line", "10", "--points", "8",
                 "-o", str(tmp_path / "p.nc"))
    assert result.exit_code == EXIT_REFUSED
    assert result.stderr.startswith(f"{HEMISHELL}: error: point 8 (x 57.148 z 0.500): the stylus would meet the "
                                    "surface of line 11")
    assert "--inset" in result.stderr and not (tmp_path / "p.nc").exists()


def test_a_bore_is_left_along_z(run, tmp_path):
    bore = write(tmp_path, "bore.nc", "%\nO2001\nG18 G21 G40 G98\nG00 X40. Z5.\nG01 Z-30. F100.\nG01 X20.\n"
                                      "G00 Z5.\nG00 X200. Z50.\nM30\n%\n")
    text = probe_program(run, tmp_path, bore, "--points", "4", "--per-feature", "1", "--inset", "3", "--material",
                         "left", "--stylus-radius", "2")
    found = skips(text)
    assert [tuple(np.round((end - start) / np.linalg.norm(end - start), 6)) for start, end, _ in found] == \
        [(1.0, 0.0)] * 3 + [(0.0, -1.0)]
    assert run("check", str(tmp_path / "probe.nc")).exit_code == 0
    with Source.from_text(text, "probe.nc") as source:
        ends = [(m.x1, m.z1) for step in interpret_source(source) for m in step.moves if None not in (m.x1, m.z1)]
    inside = [x for x, z in ends if z < 5.0]
    assert inside and max(inside) <= 20.0 - 2.0 - 0.5  # in the bore: a stylus radius and half the clearance off
    assert min(x for x, _ in ends) >= 0.0  # never across the axis


def test_a_face_no_escape_line_reaches_is_refused(run, tmp_path):
    """The upper face of a groove inside a bore faces down: the stylus fits below it but cannot get there."""
    groove = write(tmp_path, "groove.nc", "%\nO2002\nG18 G21 G40 G98\nG00 X40. Z5.\nG01 Z-10. F100.\nG01 X60.\n"
                                          "G01 Z-25.\nG01 X40.\nG01 Z-40.\nG00 X30.\nG00 Z10.\nM30\n%\n")
    result = run("probe-program", groove, "--material", "left", "--from-line", "6", "--to-line", "6", "--points", "2",
                 "--per-feature", "2", "--inset", "2", "--stylus-radius", "2")
    assert result.exit_code == EXIT_REFUSED and result.stdout == ""
    assert result.stderr == (f"{groove}: error: no clear way in to point 1: neither along its normal nor along +Z or "
                             "+X does the stylus reach the space above or beyond the part; narrow the stretch "
                             "(--from-line/--to-line, --inset)\n")


def test_touches_go_to_every_feature_and_the_summary_says_how_many(run, tmp_path):
    shaft = TurnedProfile.drawn(31)
    program = write(tmp_path, "shaft.nc", shaft.program())
    out = str(tmp_path / "probe.nc")
    result = run("probe-program", program, "--points", "30", "--inset", "0.5", "--tool", "T0909", "-o", out)
    assert result.exit_code == 0, result.stderr
    name, moves = read_program(program)
    profile_of = nominal(moves, program=name)
    found = profile_of.features
    summary = result.stderr.splitlines()[1:]
    assert len(summary) == len(found)
    # each approach aims at a point of the feature it touches, from R + clearance out
    aims = np.array([start + (STYLUS + CLEARANCE) * (end - start) / np.linalg.norm(end - start)
                     for start, end, _ in skips(Path(out).read_text())])
    near = profile_of.profile.closest(aims)
    assert np.all(near.distance < 2e-3)
    touched = owners(found)[near.index]
    for number, (feature, line) in enumerate(zip(found, summary)):
        count = int(line.split(": ")[1].split()[0])
        assert line.startswith(f"  {feature.describe()}: {count} points, ") and count >= 3
        assert np.sum(touched == number) == count, feature.describe()
    # the taper and the face beyond it meet at a concave corner: the stylus keeps more than the inset from it
    taper, face = summary[-2], summary[-1]
    assert float(taper.split(" mm from its end")[0].split()[-1]) > 1.0
    assert float(face.split(" mm from its start")[0].split()[-1]) > 1.0


def test_a_feature_too_short_to_touch_is_named_and_too_few_points_are_refused(run, tmp_path):
    program = write(tmp_path, "shaft.nc", TurnedProfile.drawn(31).program())
    result = run("probe-program", program, "--points", "40", "--inset", "1.2", "-o", str(tmp_path / "p.nc"))
    assert result.exit_code == 0, result.stderr
    assert "warning: the taper on line 7 (1.626 mm) has no room for a touch clear of its ends: not probed " \
        "(omp-feedback leaves it as programmed)" in result.stderr
    assert "  the taper on line 7: 0 points\n" in result.stderr
    few = run("probe-program", program, "--points", "10", "-o", str(tmp_path / "q.nc"))
    assert few.exit_code == EXIT_BAD_INPUT and not (tmp_path / "q.nc").exists()
    assert ("--points 10: 10 touches cannot give each of the 8 features with room for them 3; give --points 24 or "
            "more, or fewer per feature (--per-feature)") in few.stderr


def test_gcode_system_b_and_soft_limits(run, tmp_path):
    system_b = write(tmp_path, "b.toml", 'gcode_system = "B"\n')
    text = probe_program(run, tmp_path, HEMISHELL, "--from-line", "10", "--to-line", "10", "--points", "5",
                         "--inset", "3", "--machine", system_b)
    assert "G18 G21 G40 G90 G94\n" in text
    assert run("check", str(tmp_path / "probe.nc"), "--machine", system_b).exit_code == 0
    tight = write(tmp_path, "tight.toml", "x_limits = [-5.0, 60.0]\nz_limits = [-450.0, 450.0]\n")
    result = run("probe-program", HEMISHELL, "--from-line", "10", "--to-line", "10", "--points", "5", "--inset", "3",
                 "--machine", tight)
    assert result.exit_code == EXIT_REFUSED and "outside the soft limits -5..60" in result.stderr
    assert result.stdout == ""


@pytest.mark.parametrize("options, code, message", [
    (["--datum-x", "95"], EXIT_USAGE, "give --datum-x and --datum-z together"),
    (["--points", "0"], EXIT_BAD_INPUT, "--points 0: must be a whole number, 1 or more"),
    (["--clearance", "0"], EXIT_BAD_INPUT, "--clearance 0: must be positive"),
    (["--tool", "T9X"], EXIT_BAD_INPUT, "--tool 9X: expected the digits of a T code"),
    (["--program-number", "10000"], EXIT_BAD_INPUT, "a FANUC program number is 1 to 9999"),
    (["--inset", "50"], EXIT_BAD_INPUT, "--inset 50 leaves nothing of the 89.771 mm profile"),
    (["--stylus-radius", "3000"], EXIT_BAD_INPUT, "--stylus-radius 3000: a stylus radius of 3000 mm is larger than any "
                                                  "probe's (balls of 0.3 to 25 mm): micrometres written as millimetres?"),
])
def test_bad_options(run, options, code, message):
    result = run("probe-program", HEMISHELL, "--from-line", "10", "--to-line", "10", *options)
    assert result.exit_code == code and message in result.stderr and result.stdout == ""


def test_without_a_tool_the_program_warns(run, tmp_path):
    result = run("probe-program", HEMISHELL, "--from-line", "10", "--to-line", "10", "--points", "3", "--inset", "3")
    assert result.exit_code == 0 and result.stdout.startswith("%\nO8100")
    assert "warning: no --tool: the probing program selects no tool" in result.stderr
    assert "\nT" not in result.stdout


# ---------------------------------------------------------------------------- the round trip


@pytest.mark.parametrize("padded, eol", [(True, "\r\n"), (False, "\n"), (True, "\r\r\n")])
def test_round_trip_on_a_perfect_oversize_part(run, tmp_path, padded, eol):
    """A part 10 um oversize: every point reads +10 um, the datum stands still."""
    points, inset = 12, 3.0
    text = probe_program(run, tmp_path, HEMISHELL, "--from-line", "10", "--to-line", "10", "--points", str(points),
                         "--inset", str(inset), "--datum-x", "95", "--datum-z", "10")
    sphere, face = sphere_latch(R_PART + 0.01), plane_latch((95.0, 10.0), (0.0, 1.0))
    latched = [(face if record.startswith("DATUM") else sphere)(start, end) for start, end, record in skips(text)]
    printout = write(tmp_path, "printout.txt", run_on_control(text, latched, padded, eol))
    probe_file = str(tmp_path / "points.csv")
    result = run("probe-import", printout, "-o", probe_file)
    assert result.exit_code == 0, result.stderr
    assert result.stderr == f"{printout}: {points} points, datum z\n" and result.stdout == ""

    probe = read_probe(probe_file)
    assert probe.stylus_radius == STYLUS and probe.repeatability == 0.003
    assert probe.datum_before == probe.datum_after == {"z": pytest.approx(13.0, abs=1e-4)}
    assert probe.extras["x-probing-program"] == "O8100"
    assert len(probe.centres) == points
    np.testing.assert_allclose(np.hypot(*probe.centres.T), R_PART + 0.01 + STYLUS, atol=1e-4)
    name, moves = read_program(HEMISHELL)
    _, outward, _ = stations(nominal(moves, 10, 10, program=name), points, inset)
    np.testing.assert_allclose(probe.approach, -outward, atol=1e-3)  # the grid tilts a 2 mm move by < 0.06 deg

    inside = run("inspect", HEMISHELL, "--probe", probe_file, "--band", "0.02", "--from-line", "10", "--to-line", "10")
    assert inside.exit_code == 0, inside.stderr
    lines = inside.stdout.splitlines()
    assert lines[0] == (f"{HEMISHELL}: {points} points of {probe_file} against lines 10-10 (89.771 mm of profile), "
                        "band +-0.02 mm")
    assert any("datum z stable: 13 before, 13 after (+0.0000 mm" in line for line in lines)
    assert lines[-3].startswith("cleaned: mean +10.0") and lines[-1] == "in tolerance"
    assert inside.stderr == f"{probe_file}: warning: no probe calibration given: the pretravel is taken as k = 0 " \
                           "(give --calibration)\n"

    outside = run("inspect", HEMISHELL, "--probe", probe_file, "--band", "0.005", "--from-line", "10", "--to-line",
                  "10")
    assert outside.exit_code == EXIT_WOULD_CHANGE
    assert outside.stdout.splitlines()[-2:] == [
        "re-cut with compensation",
        f"  postproc compensate {HEMISHELL} --plugin omp-feedback --probe {probe_file} "
        f"-o {HEMISHELL[:-3]}-omp.nc"]
    assert outside.stderr.endswith(f"{HEMISHELL}: re-cut with compensation: {points} of {points} points outside "
                                   "+-0.005 mm\n")


def test_round_trip_through_the_virtual_lathe_matches_simulate_probe(run, tmp_path):
    """The control runs the program on the virtual V40R: the imported file is simulate probe's."""
    dome = write(tmp_path, "dome.nc", DOME)
    points = 8
    simulated = str(tmp_path / "simulated.csv")
    assert run("simulate", "probe", dome, "--machine", MACHINE, "--points", str(points), "--inset", "0.5",
               "-o", simulated).exit_code == 0
    text = probe_program(run, tmp_path, dome, "--points", str(points), "--datum-x", "95", "--datum-z", "10",
                         "--datum-on", "both", "--machine", MACHINE)

    simulation, profile = load(MACHINE)
    name, moves = read_program(dome, profile)
    profile_of = nominal(moves, program=name)
    surface = cut(moves, profile_of, simulation)
    session = []
    for i, (start, end, record) in enumerate(skips(text)):
        n = (end - start) / np.linalg.norm(end - start)
        target = start + (STYLUS + simulation.probe.standoff_mm) * n  # so the virtual probe starts where G31 does
        if record.startswith("DATUM"):
            when = 0.0 if record.endswith("BEFORE") else 1.0
            touched = Plane((95.0, 10.0), (0.0, 1.0) if abs(n[1]) > 0.5 else (1.0, 0.0))
        else:
            when, touched = (i - 1) / (points + 1), surface  # i - 1: two datum touches came first
        session.append(SimTouch(touched, target, n, when, record))
    assert [t.name for t in session[:2]] == ["DATUM BEFORE"] * 2 and session[2].when == pytest.approx(1 / 9)
    reported = sim_run(session, simulation, generator(simulation.seed, "probe"), name)
    printout = write(tmp_path, "printout.txt", run_on_control(text, list(map(tuple, reported))))
    imported = str(tmp_path / "imported.csv")
    result = run("probe-import", printout, "-o", imported)
    assert result.exit_code == 0, result.stderr

    mine, theirs = read_probe(imported), read_probe(simulated)
    np.testing.assert_allclose(mine.centres, theirs.centres, atol=1e-3)
    # the printed approach is the direction of the skip move on the control's 0.001 mm grid: 2 mm long, so within 5e-4
    np.testing.assert_allclose(mine.approach, theirs.approach, atol=5e-4)
    assert set(mine.datum_before) == set(theirs.datum_before) == {"x", "z"}
    for axis in "xz":
        assert mine.datum_before[axis] == pytest.approx(theirs.datum_before[axis], abs=1e-4)
        assert mine.datum_after[axis] == pytest.approx(theirs.datum_after[axis], abs=1e-4)
    mine_json, theirs_json = (json.loads(run("inspect", dome, "--probe", path, "--band", "0.05", "--json").stdout)
                              for path in (imported, simulated))
    for key in ("mean_um", "std_um"):
        assert mine_json["figures_um"]["probed"][key] == pytest.approx(theirs_json["figures_um"]["probed"][key],
                                                                       abs=0.5)
    assert mine_json["dropped"][0]["kind"] == theirs_json["dropped"][0]["kind"] == "nub"


def test_a_missed_touch_stops_the_program(run, tmp_path):
    text = probe_program(run, tmp_path, HEMISHELL, "--from-line", "10", "--to-line", "10", "--points", "3",
                         "--inset", "3")
    latched = [sphere_latch(R_PART)(start, end) for start, end, _ in skips(text)]
    latched[1] = None  # no surface within reach: the latched position is the skip's end point
    with pytest.raises(Alarm, match=r"NO TOUCH AT POINT 2"):
        run_on_control(text, latched)


# ---------------------------------------------------------------------------- inspect


def test_inspect_json_and_the_datum_check(run, tmp_path):
    rows = [f"{(R_PART + STYLUS) * math.cos(t):.7f},{(R_PART + STYLUS) * math.sin(t):.7f},"
            f"{-math.cos(t):.9f},{-math.sin(t):.9f}" for t in np.radians(np.linspace(5, 85, 12))]
    header = "# postproc probe 1\n# stylus_radius_mm = 3\n# datum_before_z_mm = 13.0\n# datum_after_z_mm = {after}\n" \
             "# repeatability_mm = 0.003\nx_mm,z_mm,approach_x,approach_z\n"
    good = write(tmp_path, "good.csv", header.format(after="13.001") + "\n".join(rows) + "\n")
    result = run("inspect", HEMISHELL, "--probe", good, "--band", "0.001", "--to-line", "10", "--json")
    assert result.exit_code == 0, result.stderr
    data = json.loads(result.stdout)
    assert data["in_tolerance"] is True and data["verdict"] == "in tolerance" and data["command"] is None
    assert data["points"] == 12 and data["outside"] == 0 and data["lines"] == [10, 10]
    assert abs(data["figures_um"]["cleaned"]["rms_um"]) < 1e-3
    assert [d["row"] for d in data["deviations"]] == list(range(7, 19))

    moved = write(tmp_path, "moved.csv", header.format(after="13.010") + "\n".join(rows) + "\n")
    refused = run("inspect", HEMISHELL, "--probe", moved, "--band", "0.01", "--to-line", "10")
    assert refused.exit_code == EXIT_REFUSED and refused.stdout == ""
    assert refused.stderr.startswith(f"{moved}: error: the machine moved during the inspection")
    forced = run("inspect", HEMISHELL, "--probe", moved, "--band", "0.01", "--to-line", "10", "--force")
    assert forced.exit_code == 0 and "(used anyway, --force)" in forced.stdout
    bad = run("inspect", HEMISHELL, "--probe", good, "--band", "0")
    assert bad.exit_code == EXIT_BAD_INPUT and "--band 0: must be positive" in bad.stderr


def test_inspect_suggests_the_calibration_and_force(run, tmp_path):
    rows = [f"{(R_PART + 0.02 + STYLUS) * math.cos(t):.7f},{(R_PART + 0.02 + STYLUS) * math.sin(t):.7f},"
            f"{-math.cos(t):.9f},{-math.sin(t):.9f}" for t in np.radians(np.linspace(5, 85, 12))]
    probe_file = write(tmp_path, "p q.csv", "# postproc probe 1\n# stylus_radius_mm = 3\n"
                                            "x_mm,z_mm,approach_x,approach_z\n" + "\n".join(rows) + "\n")
    result = run("inspect", HEMISHELL, "--probe", probe_file, "--band", "0.01", "--to-line", "10",
                 "--calibration", str(SAMPLES / "probe" / "artifact-calibration.csv"), "--force", "--json")
    assert result.exit_code == EXIT_WOULD_CHANGE
    data = json.loads(result.stdout)
    assert data["verdict"] == "re-cut with compensation" and data["outside"] == 12
    assert data["command"] == (f"postproc compensate {HEMISHELL} --plugin omp-feedback --probe '{probe_file}' "
                               f"--calibration {SAMPLES / 'probe' / 'artifact-calibration.csv'} --force "
                               f"-o {HEMISHELL[:-3]}-omp.nc")
    assert any(note.startswith("pretravel model") for note in data["notes"])


def test_inspect_the_sample(run):
    """The sample pass 1 (20 um nub at the pole, tool set 8 um off): reported, and out of a 5 um band."""
    probe_file = str(SAMPLES / "probe" / "hemishell-pass1.csv")
    result = run("inspect", HEMISHELL, "--probe", probe_file, "--calibration",
                 str(SAMPLES / "probe" / "artifact-calibration.csv"), "--band", "0.005", "--from-line", "10",
                 "--to-line", "10")
    assert result.exit_code == EXIT_WOULD_CHANGE, result.stderr
    assert "dropped as the nub at the pole" in result.stdout
    assert "datum x stable" in result.stdout and "datum z stable" in result.stdout
    assert "pretravel model" in result.stdout and "of the candidates" not in result.stdout  # the ranking: --json only


# ---------------------------------------------------------------------------- printouts


HEADER = "POSTPROC PROBE V   1 O8100 G21 D 2 R   3.0000 N   2"
POINT1 = "POINT    1 X   6.4100 Z  60.0700 I -.05251 K -.99862"
POINT2 = "POINT    2 X 118.1000 Z   3.1000 I -.99865 K -.05200"


def test_printout_number_formats_and_units(run, tmp_path):
    text = ("\x00\x00%\r\n\x12%\r\n   " + HEADER + "   \r\n\r\n"
            "DATUM BEFORE X 190.0000 Z  13.0060 I    .00000 K- 1.00000\r\n"
            "POINT 1 X6.41 Z60.07 I-0.05251 K-0.99862\r\n"
            "POINT    2 X 118.1 Z 3.1000 I -.99865 K -.05200\r\n"
            "DATUM AFTER X 190. Z  13.0070 I +0. K -1\r\nEND\r\n\x14%\r\n")
    printout = write(tmp_path, "a.txt", text)
    out = str(tmp_path / "a.csv")
    result = run("probe-import", printout, "-o", out, "--repeatability", "0.005")
    assert result.exit_code == 0, result.stderr
    probe = read_probe(out)
    np.testing.assert_allclose(probe.centres, [[3.205, 60.07], [59.05, 3.1]])
    assert probe.datum_before == {"z": 13.006} and probe.datum_after == {"z": 13.007}
    assert probe.repeatability == 0.005
    inch = write(tmp_path, "inch.txt", "POSTPROC PROBE V1 O8100 G20 D1 R.1181 N1\nPOINT 1 X2. Z1. I-1. K0.\nEND\n")
    assert run("probe-import", inch, "-o", out, "--stylus-radius", "3").exit_code == 0
    probe = read_probe(out)
    np.testing.assert_allclose(probe.centres, [[50.8, 25.4]])
    assert probe.stylus_radius == 3.0 and "datum_before" not in probe.extras
    overridden = run("probe-import", printout, "--stylus-radius", "2.998")
    assert overridden.exit_code == 0 and "# stylus_radius_mm = 2.998\n" in overridden.stdout
    assert f"{printout}:3: warning: the probing program was written for a stylus radius of 3 mm; 2.998 mm is " \
           "used" in overridden.stderr


@pytest.mark.parametrize("lines, line, message", [
    ([HEADER, "POINT    1 X   6.4100 Z  60.0700 I -.05251", POINT2, "END"], 2,
     "a POINT line reads 'POINT <n> X <x> Z <z> I <approach x> K <approach z>'"),
    ([HEADER, POINT1.replace("6.4100", "6.41.00"), POINT2, "END"], 2, "cannot read this line"),
    ([HEADER, POINT1, "HELLO WORLD", POINT2, "END"], 3, "expected 'POSTPROC PROBE V 1"),
    ([POINT1, POINT2, "END"], 1, "the printout must start with the header line"),
    ([HEADER, POINT2, POINT1, "END"], 2, "point 2 where point 1 was expected: a point is missing before it"),
    ([HEADER, POINT1, POINT1, "END"], 3, "point 1 where point 2 was expected: out of order or repeated"),
    ([HEADER, POINT1, POINT2, "END", HEADER], 5, "more printout after END (line 4)"),
    ([HEADER, POINT1, HEADER, POINT2, "END"], 3, "a second run starts here (the first at line 1)"),
    ([HEADER, POINT1.replace("K -.99862", "K -.9"), POINT2, "END"], 2, "has length 0.901"),
    ([HEADER.replace("V   1", "V 2"), POINT1, POINT2, "END"], 1, "printout format V 2 is not known"),
    ([HEADER.replace("G21", "G71"), POINT1, POINT2, "END"], 1, "units G 71"),
    ([HEADER, "DATUM BEFORE X 190. Z 13. I 0. K -1.", POINT1, POINT2, "END"], 2,
     "the datum along Z has no DATUM AFTER touch"),
    ([HEADER, "DATUM BEFORE X 190. Z 13. I -.7071 K -.7071", POINT1, POINT2,
      "DATUM AFTER X 190. Z 13. I -.7071 K -.7071", "END"], 2, "a datum touch must run along X or Z"),
    ([HEADER, POINT1, "DATUM BEFORE X 190. Z 13. I 0. K -1.", POINT2, "END"], 3,
     "a DATUM BEFORE line after the first point (line 2)"),
    ([HEADER, POINT1, "END"], 3, "1 points printed but the header (line 1) announces 2"),
    ([HEADER, "POINT 1.5 X 1. Z 1. I 0. K -1.", "END"], 2, "a point's number must be a whole number"),
])
def test_malformed_printouts_are_refused_at_their_line(run, tmp_path, lines, line, message):
    printout = write(tmp_path, "bad.txt", "\r\n".join(lines) + "\r\n")
    out = tmp_path / "out.csv"
    result = run("probe-import", printout, "-o", str(out))
    assert result.exit_code == EXIT_BAD_INPUT
    assert result.stderr.startswith(f"{printout}:{line}: error: ") and message in result.stderr, result.stderr
    assert result.stdout == "" and not out.exists()


@pytest.mark.parametrize("data, message", [
    (b"", ": error: the printout is empty"),
    ((HEADER + "\n" + POINT1 + "\n").encode(), ":2: error: the printout ends here without END: the probing "
                                                "program did not finish (1 of 2 points printed)"),
    (b"\xd0\xcf\xd3\xd4", None),
])
def test_incomplete_or_garbled_printouts(run, tmp_path, data, message):
    printout = write(tmp_path, "bad.txt", data)
    result = run("probe-import", printout)
    assert result.exit_code == EXIT_BAD_INPUT and result.stdout == ""
    if message is None:
        assert result.stderr.startswith(f"{printout}:1: error: not an ASCII printout")
        assert "even parity" in result.stderr
    else:
        assert result.stderr == f"{printout}{message}\n"


def test_import_from_stdin(run):
    result = run("probe-import", "-", input=f"{HEADER}\n{POINT1}\n{POINT2}\nEND\n")
    assert result.exit_code == 0, result.stderr
    assert result.stdout.startswith("# postproc probe 1\n# stylus_radius_mm = 3\n")
    assert "# x-printout = <stdin>\n" in result.stdout and result.stderr == "<stdin>: 2 points, no datum\n"


def test_the_profile_probed_is_the_simulators(tmp_path):
    """probe-program and simulate probe read the same profile and material side of a program."""
    name, moves = read_program(HEMISHELL)
    profile_of = nominal(moves, 10, 10, program=name)
    planned = plan(moves, profile_of, Cycle(points=5, inset=3.0))
    assert planned.lines == (10, 10)
    assert isinstance(profile_of.profile, Profile)
    for touch, q in zip(planned.points, stations(profile_of, 5, 3.0)[0]):
        assert touch.target == pytest.approx(tuple(q))


# -- the probe's T and M codes: a code that selects no tool or means something else is refused ---------

GENERATORS = {"probe-program": [str(SAMPLES / "programs" / "hemishell.nc")],
              "artifact-program": ["--center-x", "80", "--center-z", "30", "--artifact-radius", "25.4"]}


@given(digits=st.text(alphabet="0123456789", min_size=1, max_size=8))
def test_a_t_code_that_selects_no_tool_or_cancels_the_offset_is_refused(digits):
    """Tool and offset, two digits each or one each: any other length, a tool 0 or an offset 0
    is refused, naming the code."""
    cycle = Cycle(tool=digits)
    half = len(digits) // 2
    selects = int(digits) != 0 and len(digits) in (2, 4) and int(digits[:half]) != 0 and int(digits[half:]) != 0
    if not selects:
        with pytest.raises(OptionError, match=rf"--tool T{digits}: (T0 selects no tool|tool 0+ is no tool|offset 0+ "
                                              r"cancels|a lathe's T code is the tool and its offset)"):
            cycle.check()
    else:
        cycle.check()


@given(code=st.integers(0, 199))
def test_an_m_code_the_control_gives_a_meaning_cannot_switch_the_probe(code):
    for cycle in (Cycle(probe_on=str(code), probe_off="none"), Cycle(probe_on="none", probe_off=f"{code:02d}")):
        if code in RESERVED_M:
            with pytest.raises(OptionError, match=rf"M{code:02d} .* on a FANUC control, it cannot switch the probe"):
                cycle.check()
        else:
            cycle.check()
    with pytest.raises(OptionError, match="one M code cannot switch the probe both on and off"):
        Cycle(probe_on=str(code + 200), probe_off=f"0{code + 200}").check()


@pytest.mark.parametrize("command", sorted(GENERATORS))
@pytest.mark.parametrize("option, value, said", [
    ("--tool", "T0", "--tool T0: T0 selects no tool and cancels the tool offset; give the probe's tool and offset, "
                     "e.g. T0909"),
    ("--tool", "t0900", "--tool T0900: offset 00 cancels the tool offset"),
    ("--probe-on", "M30", "--probe-on M30: M30 ends the program and rewinds it on a FANUC control"),
    ("--program-number", "0", "--program-number 0: a FANUC program number is 1 to 9999"),
])
def test_every_probing_program_generator_refuses_a_code_that_means_no_probe(run, tmp_path, command, option, value,
                                                                            said):
    target = tmp_path / "O8100.nc"
    result = run(command, *GENERATORS[command], option, value, "-o", str(target))
    assert result.exit_code == EXIT_BAD_INPUT
    assert result.stdout == ""
    assert result.stderr.startswith(f"postproc: error: {said}") and result.stderr.count("error:") == 1
    assert not target.exists()


# -- the probe's switches come in pairs: on without off leaves the probe on after the cycle ---------------

SWITCH = st.one_of(st.none(), st.sampled_from(["none", "NONE", "None"]), st.integers(10, 97).map(str))


@given(on=SWITCH, off=SWITCH)
def test_a_probe_switch_without_its_partner_is_refused(on, off):
    """Either switch given without the other is a usage error naming the missing option and the
    remedy; both (an M code, or none: the machine does it by itself) or neither are accepted."""
    cycle = Cycle(probe_on=on, probe_off=off)
    if (on is None) == (off is None):
        if on is not None and on.isdigit() and off.isdigit() and int(on) == int(off):
            with pytest.raises(OptionError, match="one M code cannot switch the probe both on and off"):
                cycle.check()
        else:
            cycle.check()
    elif off is None:
        with pytest.raises(UsageError, match=r"--probe-on \S+ without --probe-off: the probing program would leave "
                                             r"the probe switched on after the cycle; give --probe-off MNN"):
            cycle.check()
    else:
        with pytest.raises(UsageError, match=r"--probe-off \S+ without --probe-on: .* give --probe-on MNN"):
            cycle.check()


@pytest.mark.parametrize("command", sorted(GENERATORS))
@pytest.mark.parametrize("given_option, missing, said", [
    (("--probe-on", "M50"), "--probe-off", "--probe-on M50 without --probe-off: the probing program would leave the "
     "probe switched on after the cycle; give --probe-off MNN, the M code that switches it off, or --probe-off none "
     "if the probe switches itself off (a timer)"),
    (("--probe-off", "m51"), "--probe-on", "--probe-off M51 without --probe-on: the probing program would run its "
     "skip moves with the probe off unless something else switched it on; give --probe-on MNN, the M code that "
     "switches it on, or --probe-on none if the machine switches it on by itself (with the tool change)"),
])
def test_every_probing_program_generator_refuses_half_a_probe_switch(run, tmp_path, command, given_option, missing,
                                                                     said):
    target = tmp_path / "O8100.nc"
    result = run(command, *GENERATORS[command], "--tool", "T0909", *given_option, "-o", str(target))
    assert result.exit_code == EXIT_USAGE
    assert result.stdout == ""
    assert result.stderr == f"postproc: error: {said}\n"
    assert not target.exists()


@pytest.mark.parametrize("command", sorted(GENERATORS))
def test_a_probe_that_switches_itself_off_is_said_so_in_the_program(run, command):
    """--probe-off none: the program switches the probe on with its M code and says, where the
    M code to switch it off would stand, that the probe does it by itself."""
    result = run(command, *GENERATORS[command], "--tool", "T0909", "--probe-on", "M50", "--probe-off", "none")
    assert result.exit_code == 0
    lines = result.stdout.splitlines()
    assert "M50 (PROBE ON)" in lines
    assert lines[-3:] == ["(THE PROBE SWITCHES ITSELF OFF)", "M30", "%"]
    assert "--probe" not in result.stderr
