"""Closed loop on turned profiles of many features: omp-feedback, tool-offset, parametric and
effective-angle on shafts the project was not tuned on.

Each profile is drawn from a seed (:class:`support.parts.TurnedProfile`): an end face from the
axis or not, a chamfer, a diameter, a concave G02 fillet, a shoulder face, a convex G03 round,
a long diameter, a taper and a face; in mm or in inches; finished directly or roughed with G71
and finished with G70. Each is cut on the virtual lathe, measured, compensated through the
command line, cut again and inspected by the virtual CMM along the nominal normals, and the
four figures (docs/methods.md §12) are taken over the whole profile and per feature (a line or an
arc), leaving out the CMM points within ``EDGE`` of a feature's ends (a corner has no normal).

- probe compensators: a virtual lathe with a tool-setting error and push-off (the error each
  feature shows differs with its normal), a probe with pretravel, lobing and noise,
  calibrated on the sphere, 40 touches spread over the features as ``probe-program`` does;
- ballbar compensators: a virtual lathe with per-axis scaling, backlash and a pitch term (the
  machine of Table 6.7), a CCW and a CW ballbar test about the work origin.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from postproc.cli.main import main
from support.parts import TurnedProfile
from support.closed_loop import MACHINE as TABLE_6_7, Inspected

FEATURE_UM = {False: 1.0, True: 1.3}  #: a feature's mean after compensation, within: in inches the output's
#: 0.0001 in step is 2.54 um, so a face may stay up to half of it off
TOUCHES = 40
INSET = 0.5

#: (seed, inch, G71/G70): each drawn profile in one of the program forms
CASES = [(11, False, False), (12, True, False), (13, False, True), (14, True, True), (15, False, False)]
IDS = [f"seed{seed}-{'inch' if inch else 'mm'}{'-g71' if cycle else ''}" for seed, inch, cycle in CASES]

TOOL_SET = (0.011, -0.007)  #: the tool-setting error, radius mm

PROBED_MACHINE = f"""name = "tool-setting-and-push-off"
[simulation]
seed = 19
[simulation.probe]
pretravel_mm = 0.006
lobing_mm = 0.0015
noise_mm = 0.0005
datum_x_mm = 120.0
datum_z_mm = 10.0
[simulation.cut]
tool_offset_x_mm = {TOOL_SET[0]}
tool_offset_z_mm = {TOOL_SET[1]}
{{push_off}}
[simulation.cmm]
noise_mm = 0.0003
"""
PUSH_OFF = "deflection_x_mm = 0.004\ndeflection_z_mm = 0.006"

# the machine of Table 6.7 (support.closed_loop), its tool changed at (100, 150), its CMM with 0.3 um of noise
BALLBAR_MACHINE = TABLE_6_7.replace("pitch_mm = 12.0\n", "pitch_mm = 12.0\nhome_x_mm = 100.0\nhome_z_mm = 150.0\n") \
    .replace("points = 34\n", "noise_mm = 0.0003\n")


def cli(*args):
    result = CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)
    assert result.exit_code == 0, result.stderr
    return result


def write(folder: Path, name: str, text: str) -> str:
    path = folder / name
    path.write_text(text)
    return str(path)


def drawn(case, folder: Path) -> tuple[TurnedProfile, str, tuple[int, int]]:
    seed, inch, cycle = case
    shaft = TurnedProfile.drawn(seed, inch)
    return shaft, write(folder, f"shaft{seed}.nc", shaft.program(cycle)), shaft.profile_lines(cycle)


def probed(program: str, machine: str, lines: tuple[int, int], folder: Path) -> tuple[str, str]:
    probe, calibration = folder / "p.csv", folder / "c.csv"
    cli("simulate", "probe", program, "--machine", machine, "--from-line", lines[0], "--to-line", lines[1],
        "--points", TOUCHES, "--inset", INSET, "-o", probe)
    cli("simulate", "calibrate", "--machine", machine, "-o", calibration)
    return str(probe), str(calibration)


# -- omp-feedback -----------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_omp_feedback_takes_each_features_error_out_of_a_turned_profile(case, tmp_path):
    machine = write(tmp_path, "machine.toml", PROBED_MACHINE.format(push_off=PUSH_OFF))
    _, program, lines = drawn(case, tmp_path)
    probe, calibration = probed(program, machine, lines, tmp_path)
    compensated = tmp_path / "compensated.nc"
    result = cli("compensate", program, "--plugin", "omp-feedback", "--probe", probe, "--calibration", calibration,
                 "-o", compensated)
    assert "warning" not in result.stderr.replace("no probe calibration", ""), result.stderr

    before = Inspected(program, program, machine, lines)
    after = Inspected(str(compensated), program, machine, lines)
    print(f"omp-feedback {case}:\n{before.table(after)}")
    spread = max(before.means().values()) - min(before.means().values())
    assert spread > 8.0  # the features' errors differ: a single offset would not do
    assert after.figures.std <= 1.0 and abs(after.figures.mean) <= 0.5
    assert all(abs(mean) <= FEATURE_UM[case[1]] for mean in after.means().values()), after.means()


def test_omp_feedback_with_touches_spread_evenly_corrects_each_feature_that_has_enough(tmp_path):
    """A probe run that ignores the features: touches at the profile's ends, on corners, wherever they
    fall. Every feature with 3 touches or more comes right; the chamfer, with fewer, is left as it was
    and named in a warning."""
    machine = write(tmp_path, "machine.toml", PROBED_MACHINE.format(push_off=PUSH_OFF))
    shaft = TurnedProfile.drawn(21)
    program = write(tmp_path, "shaft.nc", shaft.program())
    first, last = shaft.profile_lines()
    lines = (first, last - 2)  # up to the long diameter: no concave corner a touch could not reach
    probe = tmp_path / "p.csv"
    cli("simulate", "probe", program, "--machine", machine, "--from-line", lines[0], "--to-line", lines[1],
        "--points", TOUCHES, "-o", probe)
    cli("simulate", "calibrate", "--machine", machine, "-o", tmp_path / "c.csv")
    compensated = tmp_path / "compensated.nc"
    result = cli("compensate", program, "--plugin", "omp-feedback", "--probe", probe, "--calibration",
                 tmp_path / "c.csv", "-o", compensated)
    chamfer = f"the taper on line {first}"
    assert f"omp-feedback: {chamfer} has 2 touches (rows " in result.stderr
    assert "at least 3 per feature are needed to screen them for the nub and outliers: left as programmed" \
        in result.stderr
    before = Inspected(program, program, machine, lines)
    after = Inspected(str(compensated), program, machine, lines)
    print(f"omp-feedback, touches spread evenly:\n{before.table(after)}")
    assert after.means()[chamfer] == pytest.approx(before.means()[chamfer], abs=0.5)
    others = {name: mean for name, mean in after.means().items() if name != chamfer}
    assert all(abs(mean) <= 1.0 for mean in others.values()), others


# -- tool-offset ------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("case", CASES[:4], ids=IDS[:4])
def test_tool_offset_finds_the_tool_setting_error_on_a_turned_profile(case, tmp_path):
    """The path moved, or (in the G71/G70 programs, whose contour must keep starting where the cycle
    does) the tool's wear offset changed by a G10 the virtual lathe obeys."""
    machine = write(tmp_path, "machine.toml", PROBED_MACHINE.format(push_off=""))
    shaft, program, lines = drawn(case, tmp_path)
    probe, calibration = probed(program, machine, lines, tmp_path)
    report, compensated = tmp_path / "report.json", tmp_path / "compensated.nc"
    apply = "wear-offset" if case[2] else "path"
    cli("compensate", program, "--plugin", "tool-offset", "--probe", probe, "--calibration", calibration,
        "--option", f"apply={apply}", "--report", report, "-o", compensated)
    fitted = json.loads(report.read_text())["compensators"][0]
    assert fitted["offset_mm"]["x"] == pytest.approx(TOOL_SET[0], abs=0.0005)
    assert fitted["offset_mm"]["z"] == pytest.approx(TOOL_SET[1], abs=0.0005)
    assert fitted["points_used"] == TOUCHES and not fitted["left_out"]
    if apply == "wear-offset":
        written = compensated.read_text().splitlines()
        units = "G18 G20 G40 G99" if shaft.inch else "G18 G21 G40 G99"
        assert written[written.index(units) + 1] == fitted["g10"]

    before = Inspected(program, program, machine, lines)
    after = Inspected(str(compensated), program, machine, lines)
    print(f"tool-offset {case} ({apply}):\n{before.table(after)}")
    assert after.figures.std <= 1.0 and abs(after.figures.mean) <= 0.5
    assert all(abs(mean) <= FEATURE_UM[case[1]] for mean in after.means().values()), after.means()


# -- parametric and effective-angle -----------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def ballbar(tmp_path_factory) -> tuple[str, str, str]:
    folder = tmp_path_factory.mktemp("ballbar")
    machine = write(folder, "machine.toml", BALLBAR_MACHINE)
    traces = []
    for direction in ("ccw", "cw"):
        path = folder / f"{direction}.csv"
        cli("simulate", "ballbar", "--machine", machine, "--direction", direction, "-o", path)
        traces.append(str(path))
    return machine, traces[0], traces[1]


@pytest.mark.parametrize("case", CASES[:4], ids=IDS[:4])
def test_parametric_holds_a_turned_profile_in_mm_inch_and_g71(case, ballbar, tmp_path):
    machine, ccw, cw = ballbar
    _, program, lines = drawn(case, tmp_path)
    compensated = tmp_path / "compensated.nc"
    cli("compensate", program, "--plugin", "parametric", "--ballbar", ccw, "--ballbar", cw, "-o", compensated)
    before = Inspected(program, program, machine, lines)
    after = Inspected(str(compensated), program, machine, lines)
    print(f"parametric {case}:\n{before.table(after)}")
    assert before.figures.rms > 2.0
    assert abs(after.figures.mean) < 1.0 and after.figures.std < 1.0  # the hemishell's figures (Table 6.7)
    # each feature: what the ballbar cannot see (the 12 mm pitch term, 0.6 um) and the output's step remain
    assert all(abs(mean) <= 1.5 for mean in after.means().values()), after.means()


@pytest.mark.parametrize("case", CASES[:4], ids=IDS[:4])
def test_effective_angle_is_never_worse_than_no_compensation_without_saying_so(case, ballbar, tmp_path):
    machine, ccw, cw = ballbar
    _, program, lines = drawn(case, tmp_path)
    compensated = tmp_path / "compensated.nc"
    result = cli("compensate", program, "--plugin", "effective-angle", "--ballbar", ccw, "--ballbar", cw,
                 "-o", compensated)
    before = Inspected(program, program, machine, lines)
    after = Inspected(str(compensated), program, machine, lines)
    print(f"effective-angle {case}:\n{before.table(after)}\n{result.stderr}")
    worse = [name for name in ("mean", "mean_abs", "rms", "std")
             if abs(getattr(after.figures, name)) > abs(getattr(before.figures, name)) + 0.1]
    warned = "predicted to leave this program's feed moves worse than no compensation" in result.stderr
    assert warned or not worse, (worse, result.stderr)
