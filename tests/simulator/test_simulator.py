"""The virtual lathe: determinism, a perfect machine, each error term's signature, its files."""

from __future__ import annotations

import json
import math
import tempfile
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings
from hypothesis import strategies as st

from postproc.cli.main import main
from postproc.diagnostics import EXIT_BAD_INPUT, MeasurementError, OptionError
from postproc.measure.readers.ballbar import read_ballbar
from postproc.measure.readers.probe import read_calibration, read_probe
from postproc.simulator import (Simulation, ballbar_test, calibrate, cut, generator, inspect, load, nominal,
                                probe_profile, read_program)
from postproc.simulator.config import from_table
from postproc.simulator.errors import play
from postproc.simulator.nominal import run_program
from postproc.simulator.files import calibration_text, probe_text, read_surface, surface_text, trace_text
from support import SAMPLES
from support.parts import SHAFT

HEMISHELL = str(SAMPLES / "programs" / "hemishell.nc")
MACHINE = str(SAMPLES / "machines" / "v40r-sim.toml")
R = 57.15
FINE = {"cut": {"step_mm": 0.005}}  # chords 5e-8 mm inside the arc: "exact" below 1e-7


def simulation(**table) -> Simulation:
    """A machine with only these errors, and a fine surface polyline."""
    return from_table({**table, "cut": {**FINE["cut"], **table.get("cut", {})}})


def hemishell(sim: Simulation, line: int | None = 10):
    name, moves = read_program(HEMISHELL)
    return moves, nominal(moves, line, line, program=name)


def write(tmp_path: Path, name: str, text: str) -> str:
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def radial(points: np.ndarray, centre=(0.0, 0.0)) -> np.ndarray:
    return np.hypot(points[:, 0] - centre[0], points[:, 1] - centre[1]) - R


# -- determinism ----------------------------------------------------------------------------


def test_the_same_seed_gives_the_same_files_and_another_seed_other_noise():
    sim = from_table({"ballbar": {"noise_mm": 0.0003}, "probe": {"noise_mm": 0.0005, "pretravel_mm": 0.005}})
    moves, arc = hemishell(sim)
    surface = cut(moves, arc, sim)

    def files(seed: int) -> list[str]:
        return [trace_text(ballbar_test(sim, generator(seed, "ballbar-ccw-raw"), "ccw", "raw"), {}),
                probe_text(probe_profile(surface, arc, sim, generator(seed, "probe")), {}),
                calibration_text(calibrate(sim, generator(seed, "calibrate")), {})]

    first, again, other = files(7), files(7), files(8)
    assert first == again
    assert all(a != b for a, b in zip(first, other))


def test_the_sample_files_are_what_the_simulator_makes_of_the_sample_machine():
    sim, _ = load(MACHINE)
    run = ballbar_test(sim, generator(sim.seed, "ballbar-ccw-processed"), "ccw", "processed")
    provenance = {"simulated-by": "samples/make_samples.py", "machine": "samples/machines/v40r-sim.toml",
                  "seed": sim.seed}
    assert (SAMPLES / "ballbar" / "v40r-100-ccw.csv").read_text() == trace_text(run, provenance)


# -- a perfect machine ------------------------------------------------------------------------


def test_a_perfect_machine_makes_zero_deviations_everywhere(tmp_path):
    sim = simulation()
    for direction in ("ccw", "cw"):
        for form in ("processed", "raw"):
            run = ballbar_test(sim, generator(1, "x"), direction, form)
            assert np.abs(run.deviations).max() < 1e-12
    moves, arc = hemishell(sim)
    surface = cut(moves, arc, sim)
    assert np.abs(radial(surface.points)).max() < 1e-9
    probe = probe_profile(surface, arc, sim, generator(1, "probe"))
    touched = probe.centres + 3.0 * probe.approach
    assert np.abs(radial(touched)).max() < 1e-7
    assert np.abs(inspect(surface, arc, sim, generator(1, "cmm")).deviations).max() < 1e-7


# -- each error term alone --------------------------------------------------------------------


def _signature(table: dict, direction: str) -> np.ndarray:
    run = ballbar_test(simulation(**table), None, direction)
    return np.radians(run.angles), run.deviations


@pytest.mark.parametrize("direction", ["ccw", "cw"])
def test_scaling_makes_the_peanut_r_times_ax_cos2_plus_az_sin2(direction, tmp_path):
    sim = simulation(x={"scaling": 3e-5}, z={"scaling": -2e-5})
    for form in ("processed", "raw"):
        run = ballbar_test(sim, None, direction, form)
        trace = read_ballbar(write(tmp_path, f"{form}.csv", trace_text(run, {})))
        theta = np.radians(trace.angles)
        expected = 100.0 * (3e-5 * np.cos(theta) ** 2 - 2e-5 * np.sin(theta) ** 2)
        assert np.abs(trace.deviations - expected).max() < 1e-7


@pytest.mark.parametrize("direction, start", [("ccw", 200.0), ("cw", -20.0)])
def test_a_partial_arc_is_captured_as_the_lathe_runs_it(direction, start, tmp_path):
    """220 deg from -20 to 200 deg (ISO 13041-6), 2 deg over-travel: both forms read back on that arc,
    with the backlash step where X reverses inside it and the same peanut as the whole circle."""
    sim = simulation(x={"scaling": 3e-5, "backlash_mm": 0.004}, z={"scaling": -2e-5})
    for form in ("processed", "raw"):
        run = ballbar_test(sim, None, direction, form, start=start, capture=220.0, overtravel=2.0)
        assert run.capture == 220.0 and run.angles[0] == pytest.approx(start)
        text = trace_text(run, {})
        assert ("# capture_arc_deg = 220" in text) == (form == "raw")
        trace = read_ballbar(write(tmp_path, f"{form}.csv", text))
        arc_start, span = trace.arc
        assert (arc_start - 340.0) % 360.0 <= 0.5 and 219.0 < span <= 220.0
        assert np.isnan(trace.at(270.0)) and not np.isnan(trace.at(90.0))
        k = 1.0 if direction == "cw" else -1.0
        step = trace.at(3.0) - trace.at(-3.0)  # X reverses at 0 deg
        assert step == pytest.approx(k * 0.004 * math.cos(math.radians(3.0)), abs=3e-7)


@pytest.mark.parametrize("direction, sign", [("ccw", -1.0), ("cw", 1.0)])
@pytest.mark.parametrize("axis, reversals", [("x", (0.0, 180.0)), ("z", (90.0, 270.0))])
def test_backlash_is_a_step_of_b_at_each_reversal_of_its_axis_signed_by_direction(direction, sign, axis, reversals,
                                                                                 tmp_path):
    b = 0.004
    run = ballbar_test(simulation(**{axis: {"backlash_mm": b}}), None, direction)
    trace = read_ballbar(write(tmp_path, "t.csv", trace_text(run, {})))
    for reversal in reversals:
        step = trace.at(reversal + 3.0) - trace.at(reversal - 3.0)
        assert step == pytest.approx(sign * b * math.cos(math.radians(3.0)), abs=2e-7)
    # between the reversals the axis lags by b/2 against its direction of travel
    theta = np.radians(trace.angles)
    k = 1.0 if direction == "cw" else -1.0
    if axis == "x":
        expected = k * b / 2 * np.sign(np.sin(theta)) * np.cos(theta)
    else:
        expected = -k * b / 2 * np.sign(np.cos(theta)) * np.sin(theta)
    away = np.abs(((trace.angles + 45.0) % 90.0) - 45.0) > 2.0
    assert np.abs(trace.deviations - expected)[away].max() < 2e-7


@pytest.mark.parametrize("direction", ["ccw", "cw"])
def test_servo_mismatch_grows_with_feed_and_flips_with_direction_squareness_does_not(direction):
    k = 1.0 if direction == "cw" else -1.0
    for feed in (500.0, 2000.0):
        run = ballbar_test(simulation(x={"lag_s": 1e-4}), None, direction, feed=feed)
        theta = np.radians(run.angles)
        mismatch = feed / 60.0 * 1e-4
        assert np.abs(run.deviations - k * mismatch * np.sin(theta) * np.cos(theta)).max() < 1e-7
    theta, deviations = _signature({"squareness_rad": 1e-5}, direction)
    assert np.abs(deviations - 100.0 * 1e-5 * np.sin(theta) * np.cos(theta)).max() < 1e-7


def test_the_pitch_term_and_straightness_follow_their_equations():
    theta, deviations = _signature({"pitch_mm": 12.0, "x": {"pitch_amplitude_mm": 3e-4},
                                    "z": {"pitch_amplitude_mm": 2e-4}}, "ccw")
    wave = np.sin(2 * np.pi * 100.0 * np.sin(theta) / 12.0)
    assert np.abs(deviations - wave * (3e-4 * np.cos(theta) + 2e-4 * np.sin(theta))).max() < 1e-7
    theta, deviations = _signature({"z": {"straightness_mm": 1e-3, "straightness_span_mm": [-200.0, 200.0]}}, "cw")
    bow = 1e-3 * (1.0 - (100.0 * np.sin(theta) / 200.0) ** 2)
    assert np.abs(deviations - bow * np.cos(theta)).max() < 1e-7


def test_general_error_terms_add_their_polynomials_about_the_reference():
    """A bowed Z slide (an X error growing with z squared), a Z error growing with x squared and
    an x-times-z term, about a reference off the origin: each where the ballbar reads it."""
    terms = [{"axis": "x", "value_mm": 4e-3, "z_power": 2}, {"axis": "z", "value_mm": 3e-3, "x_power": 2},
             {"axis": "z", "value_mm": -1e-3, "x_power": 1, "z_power": 1, "length_mm": 50.0}]
    table = {"reference_x_mm": 10.0, "reference_z_mm": -20.0, "term": terms}
    theta, deviations = _signature(table, "ccw")
    u, w = 100.0 * np.cos(theta) - 10.0, 100.0 * np.sin(theta) + 20.0
    ex = 4e-3 * (w / 100.0) ** 2
    ez = 3e-3 * (u / 100.0) ** 2 - 1e-3 * (u / 50.0) * (w / 50.0)
    bar = np.hypot(100.0 * np.cos(theta) + ex, 100.0 * np.sin(theta) + ez) - 100.0  # um-sized: exact, not first order
    assert np.abs(deviations - bar).max() < 1e-9
    assert [term.axis for term in from_table(table).term] == ["x", "z", "z"]


def test_lost_motion_is_the_play_operator():
    command_ = np.array([0.0, 1.0, 2.0, 1.999, 1.0, 1.0, 3.0])
    slide = play(command_, 0.004)
    expected = [-0.002, 0.998, 1.998, 1.998, 1.002, 1.002, 2.998]
    assert slide == pytest.approx(expected, abs=1e-12)
    assert play(command_, 0.004, last=-1.0)[0] == pytest.approx(0.002)


def test_a_tool_setting_offset_translates_the_surface(tmp_path):
    name, moves = read_program(write(tmp_path, "shaft.nc", SHAFT))
    shaft = nominal(moves, program=name)
    offset = np.array([0.012, -0.007])
    surface = cut(moves, shaft, simulation(cut={"tool_offset_x_mm": 0.012, "tool_offset_z_mm": -0.007}))
    assert np.abs(shaft.profile.closest(surface.points - offset).distance).max() < 1e-9
    assert surface.points[0] == pytest.approx(np.array(shaft.profile.segments[0].start) + offset)


def test_deflection_leaves_material_along_the_outward_normal():
    sim = simulation(cut={"deflection_x_mm": 0.003, "deflection_z_mm": 0.003})
    moves, arc = hemishell(sim)
    deviations = inspect(cut(moves, arc, sim), arc, sim, None).deviations
    assert deviations == pytest.approx(np.full(36, 0.003), abs=1e-7)


def test_the_tool_off_centre_height_leaves_a_nub_at_the_pole():
    y, height = 0.25, 0.02
    sim = simulation(cut={"tool_y_mm": y, "nub_height_mm": height})
    moves, arc = hemishell(sim)
    surface = cut(moves, arc, sim)
    assert surface.points[:3] == pytest.approx(np.array([[0.0, R + height], [y, R + height], [y, R]]))
    deviations = inspect(surface, arc, sim, None).deviations
    assert deviations[0] == pytest.approx(height, abs=1e-9)
    assert deviations[1:] == pytest.approx(np.full(35, math.hypot(R, y) - R), abs=1e-7)
    probe = probe_profile(surface, arc, sim, None)
    touched = probe.centres + 3.0 * probe.approach
    assert touched[0, 1] - R == pytest.approx(height, abs=1e-9)


def test_errors_common_to_cutting_and_probing_cancel_in_the_probe_but_not_on_the_cmm():
    sim = simulation(x={"scaling": 3e-5}, z={"scaling": -2e-5})
    moves, arc = hemishell(sim)
    surface = cut(moves, arc, sim)
    cmm = inspect(surface, arc, sim, None).deviations
    probe = probe_profile(surface, arc, sim, None)
    probed = radial(probe.centres + 3.0 * probe.approach)
    assert np.abs(cmm).max() > 1.5e-3
    assert np.abs(probed).max() < 1.5e-4  # the stylus centre is 3 mm from where the tool cut


def test_the_datum_moves_by_the_thermal_drift(tmp_path):
    sim = simulation(probe={"datum_x_mm": 95.0, "datum_z_mm": 10.0, "drift_x_mm": 0.001, "drift_z_mm": 0.002,
                            "pretravel_mm": 0.004})
    moves, arc = hemishell(sim)
    run = probe_profile(cut(moves, arc, sim), arc, sim, None)
    assert run.datum_after["x"] - run.datum_before["x"] == pytest.approx(-0.001, abs=1e-9)
    assert run.datum_after["z"] - run.datum_before["z"] == pytest.approx(-0.002, abs=1e-9)
    assert run.datum_before["z"] == pytest.approx(10.0 + 3.0 - 0.004, abs=1e-9)
    probe = read_probe(write(tmp_path, "p.csv", probe_text(run, {})))
    assert probe.datum_before == pytest.approx(run.datum_before, abs=1e-7)
    assert probe.repeatability == 0.003


# -- files read back by the project's readers ---------------------------------------------------


def test_traces_read_back_in_both_forms_with_the_set_up_offset_removed(tmp_path):
    sim = simulation(ballbar={"setup_offset_x_mm": 0.04, "setup_offset_z_mm": -0.025, "start_angle_deg": 270.0})
    for direction in ("ccw", "cw"):
        processed = read_ballbar(write(tmp_path, "p.csv", trace_text(ballbar_test(sim, None, direction), {})))
        raw = read_ballbar(write(tmp_path, "r.csv", trace_text(ballbar_test(sim, None, direction, "raw"), {})))
        assert raw.raw and not processed.raw and len(raw.angles) == len(processed.angles) == 720
        for trace in (processed, raw):
            assert trace.direction == direction and trace.radius == 100.0 and trace.feed == 1000.0
            assert trace.setup_centre == pytest.approx((-0.04, 0.025), abs=1e-5)
            assert np.abs(trace.deviations).max() < 0.047**2 / 100.0  # second order: |offset|^2 / 2R


def test_probe_and_calibration_files_read_back(tmp_path):
    sim = simulation(probe={"pretravel_mm": 0.005})
    moves, arc = hemishell(sim)
    run = probe_profile(cut(moves, arc, sim), arc, sim, None, count=20)
    probe = read_probe(write(tmp_path, "p.csv", probe_text(run, {"seed": 3})))
    assert probe.centres == pytest.approx(run.centres, abs=1e-7)
    assert probe.approach == pytest.approx(run.approach, abs=1e-7)
    assert probe.extras == {"x-seed": "3"} and probe.datum_before == {}
    calibration = read_calibration(write(tmp_path, "c.csv", calibration_text(calibrate(sim, None), {})))
    assert len(calibration.centres) == 73
    assert calibration.theta[[0, 36, 72]] == pytest.approx([180.0, 90.0, 0.0])


def test_the_sphere_calibration_gives_k_equal_to_minus_the_pretravel(tmp_path):
    sim = simulation(probe={"pretravel_mm": 0.006, "lobing_mm": 0.0015, "lobes": 3, "lobing_phase_deg": 20.0})
    run = calibrate(sim, None)
    calibration = read_calibration(write(tmp_path, "c.csv", calibration_text(run, {})))
    expected = -(0.006 + 0.0015 * np.cos(np.radians(3 * (calibration.theta - 20.0))))
    assert calibration.factors() == pytest.approx(expected, abs=2e-7)


def test_a_surface_file_reads_back_and_refuses_a_negative_radius(tmp_path):
    sim = simulation()
    moves, arc = hemishell(sim)
    surface = cut(moves, arc, sim)
    path = write(tmp_path, "s.csv", surface_text(surface, {"program": "hemishell.nc"}))
    assert read_surface(path).points == pytest.approx(surface.points, abs=1e-7)
    bad = write(tmp_path, "bad.csv", "# postproc surface 1\nx_mm,z_mm\n1.0,2.0\n-0.5,2.0\n")
    with pytest.raises(MeasurementError, match=r"bad.csv:4: error: a surface radius cannot be negative"):
        read_surface(bad)


# -- configuration ----------------------------------------------------------------------------


def test_the_sample_machine_loads_and_unknown_keys_are_refused_naming_the_file(tmp_path):
    """Every refusal of the [simulation] table names the key's line and column, as the rest of
    the profile's do: in a nested table, in the n-th [[simulation.term]], at a table's header."""
    sim, profile = load(MACHINE)
    assert sim.x.scaling == 8e-5 and sim.probe.datum_z_mm == 10.0 and profile.name == "okuma-howa-v40r-virtual"
    assert sim.x.straightness_span_mm == profile.x_limits
    term = "[[simulation.term]]\naxis = \"x\"\nvalue_mm = 1\n"
    for text, message, where in (
            ("[simulation.x]\nscalling = 1e-5\n",
             r"unknown key 'simulation.x.scalling' in the machine profile; did you mean 'scaling'\?", "2:1"),
            ("[simulation]\nwobble = 1\n", "unknown key 'simulation.wobble'", "2:1"),
            ("[simulation.z]\nbacklash_mm = -0.1\n", "'simulation.z.backlash_mm' cannot be negative", "2:1"),
            ("[simulation.ballbar]\noversample = 1.5\n", "'simulation.ballbar.oversample' must be a whole", "2:1"),
            ("[simulation]\nseed = 1\n  x = 3\n", "'simulation.x' must be a table", "3:3"),
            ("[simulation]\nterm = 3\n", "'simulation.term' must be an array of tables", "2:1"),
            ("[simulation.q]\na = 1\n", "unknown key 'simulation.q'", "1:2"),
            ("simulation = 3\n", "'simulation' must be a table", "1:1"),
            ("[[simulation.term]]\naxis = \"y\"\nvalue_mm = 1\n", r"'simulation\.term\[1\]\.axis' must be \"x\" or \"z\"", "2:1"),
            (term + "[[simulation.term]]\nvalue_mm = 1\naxis = \"y\"\n", r"'simulation\.term\[2\]\.axis' must be", "6:1"),
            ("[[simulation.term]]\naxis = \"x\"\n", r"'simulation\.term\[1\]' needs 'value_mm'", "1:3"),
            ("[[simulation.term]]\naxis = \"x\"\nvalue_mm = 1\nz_power = 7\n",
             r"'simulation\.term\[1\]\.z_power' must be a whole number from 0 to 6", "4:1")):
        path = write(tmp_path, "m.toml", text)
        with pytest.raises(OptionError, match=message) as caught:
            load(path)
        assert str(caught.value).startswith(f"{path}:{where}: error: "), (text, str(caught.value))


@settings(max_examples=20, deadline=None)
@given(st.floats(-0.008, 0.008), st.floats(-0.008, 0.008))
def test_a_profile_that_starts_at_or_just_past_the_spindle_axis_is_cut_and_inspected(dx, dz):
    """A compensated hemishell: the arc's centre moved by (dx, dz) (a centre-offset compensation), the
    lead-in along the spindle axis meeting the arc's start a few micrometres on either side of the
    axis. The lead-in turns no surface (it is left out of the profile), the arc is cut from where it
    crosses the axis, and the CMM measures every point, the pole included: against the compensated
    program's own profile zero, against the hemishell the shift along each normal."""
    runner = CliRunner()
    x0, z0 = 2.0 * dx, R + dz
    text = (f"%\nO0001\nG18 G21 G40 G99\nG00 X0. Z62.\nG01 X{x0:.4f} Z{z0:.4f} F0.08\n"
            f"G03 X{2.0 * (R + dx):.4f} Z{dz:.4f} I0. K{-R:.4f}\nG00 X120. Z62.\nM30\n%\n")
    with tempfile.TemporaryDirectory() as folder:
        program, surface = str(Path(folder) / "shifted.nc"), str(Path(folder) / "surface.csv")
        Path(program).write_text(text)
        own = runner.invoke(main, ["simulate", "inspect", program, "--json"])
        assert own.exit_code == 0, own.stderr
        assert np.abs([p["deviation_mm"] for p in json.loads(own.stdout)["points"]]).max() < 1e-5
        cut_ = runner.invoke(main, ["simulate", "cut", program, "-o", surface])
        assert cut_.exit_code == 0, cut_.stderr
        against = runner.invoke(main, ["simulate", "inspect", HEMISHELL, "--from-line", "10", "--to-line", "10",
                                       "--surface", surface, "--json"])
        assert against.exit_code == 0, against.stderr
    points = json.loads(against.stdout)["points"]
    theta = np.arctan2([p["z_mm"] for p in points], [p["x_mm"] for p in points])
    shift = float(f"{x0:.4f}") / 2.0 * np.cos(theta) + float(f"{dz:.4f}") * np.sin(theta)
    assert np.array([p["deviation_mm"] for p in points]) == pytest.approx(shift, abs=2e-5)


def test_a_profile_entered_at_rapid_starts_where_the_lagging_axes_reach_it(tmp_path):
    """Servo lags of 1.2 and 1.05 ms: as the profile's first feed move starts, the axes still run the
    rapid that brought the tool there (0.2 mm of it at 10 m/min). That is no surface of the profile:
    the CMM's first point, at the very start, measures the profile as well as the others."""
    program = write(tmp_path, "shaft.nc", "%\nO0001\nG18 G21 G40 G99\nG00 X83.7 Z3.\nG00 X25.9 Z0.\n"
                                          "G01 X28.2 Z-1.15 F0.1\nG01 Z-10.35\nG01 X40.\nG00 X80. Z5.\nM30\n%\n")
    machine = write(tmp_path, "lag.toml", "[simulation.x]\nlag_s = 0.0012\n[simulation.z]\nlag_s = 0.00105\n")
    result = CliRunner().invoke(main, ["simulate", "inspect", program, "--machine", machine, "--json"])
    assert result.exit_code == 0, result.stderr
    deviations = [point["deviation_mm"] for point in json.loads(result.stdout)["points"]]
    assert np.abs(deviations).max() < 0.001


def test_a_probe_that_would_hit_another_part_of_the_profile_is_an_error():
    sim = simulation()
    name, moves = read_program(HEMISHELL)
    whole = nominal(moves, program=name)  # the arc and the retract along the equator's face
    assert [move.line for move in whole.moves] == [10, 11]
    with pytest.raises(MeasurementError, match="collide"):
        probe_profile(cut(moves, whole, sim), whole, sim, None)


# -- the command line -------------------------------------------------------------------------


def invoke(*args: str):
    """``postproc simulate ARGS`` through the real command line."""
    return CliRunner().invoke(main, ["simulate", *args])


def test_cli_ballbar_writes_a_trace_the_reader_takes(tmp_path):
    target = tmp_path / "cw.csv"
    result = invoke("ballbar", "--machine", MACHINE, "--direction", "cw", "--form", "raw", "--radius", "80",
                    "--feed", "500", "-o", str(target))
    assert (result.exit_code, result.stdout) == (0, "")
    trace = read_ballbar(str(target))
    assert (trace.direction, trace.radius, trace.feed, trace.raw) == ("cw", 80.0, 500.0, True)
    again = invoke("ballbar", "--machine", MACHINE, "--direction", "cw", "--form", "raw", "--radius", "80",
                   "--feed", "500")
    assert again.stdout == target.read_text()
    other = invoke("ballbar", "--machine", MACHINE, "--direction", "cw", "--form", "raw", "--radius", "80",
                   "--feed", "500", "--seed", "1")
    assert other.stdout != target.read_text()


def test_cli_cut_probe_calibrate_and_inspect(tmp_path):
    lines = ("--from-line", "10", "--to-line", "10")
    surface = tmp_path / "surface.csv"
    assert invoke("cut", HEMISHELL, "--machine", MACHINE, *lines, "-o", str(surface)).exit_code == 0
    assert surface.read_text().startswith("# postproc surface 1\n")
    probe = invoke("probe", HEMISHELL, "--machine", MACHINE, "--surface", str(surface), "--points", "12", *lines)
    assert probe.exit_code == 0
    assert write(tmp_path, "p.csv", probe.stdout) and len(read_probe(str(tmp_path / "p.csv")).centres) == 12
    calibration = invoke("calibrate", "--machine", MACHINE, "--step-deg", "5", "-o", str(tmp_path / "c.csv"))
    assert calibration.exit_code == 0 and len(read_calibration(str(tmp_path / "c.csv")).centres) == 37
    text = invoke("inspect", HEMISHELL, "--machine", MACHINE, "--surface", str(surface), *lines)
    assert text.exit_code == 0 and text.stdout.startswith(f"{HEMISHELL}: mean +") and "(34 points)" in text.stdout
    report = json.loads(invoke("inspect", HEMISHELL, "--machine", MACHINE, *lines, "--json", "--points", "10").stdout)
    assert report["count"] == 10 and len(report["points"]) == 10
    assert report["points"][0]["deviation_mm"] > 0.02  # the nub
    assert set(report) >= {"mean_um", "mean_abs_um", "rms_um", "std_um"}


def test_cli_errors_are_the_projects_errors_with_their_exit_codes(tmp_path):
    bad = write(tmp_path, "bad.toml", "[simulation.probe]\nstylus = 3\n")
    result = invoke("calibrate", "--machine", bad)
    assert result.exit_code == EXIT_BAD_INPUT and result.stdout == ""
    assert result.stderr.startswith(f"{bad}:2:1: error: ") and "unknown key 'simulation.probe.stylus'" in result.stderr
    result = invoke("probe", HEMISHELL, "--points", "1")
    assert result.exit_code == EXIT_BAD_INPUT and "error:" in result.stderr
    result = invoke("ballbar", "--radius", "-5")
    assert result.exit_code in (EXIT_BAD_INPUT, 2) and "error" in result.stderr.lower()
    result = invoke("inspect", HEMISHELL, "--from-line", "1", "--to-line", "3")
    assert result.exit_code == EXIT_BAD_INPUT and "no feed moves" in result.stderr

def test_the_virtual_lathe_obeys_g10_wear_offsets_in_the_programs_units(tmp_path):
    """U and W add to a wear offset, X and Z set it (X, U diameters), in the units in force; the tool
    that uses the offset cuts that much off where it would have."""
    text = Path(HEMISHELL).read_text()
    base = write(tmp_path, "base.nc", text)
    worn = write(tmp_path, "worn.nc", text.replace("G18 G21 G40 G99\n", "G18 G21 G40 G99\nG10 P1 U-0.020 W0.006\n"
                                                   "G10 P2 X1. Z1.\n"))
    inch = write(tmp_path, "inch.nc", text.replace("G18 G21 G40 G99\n", "G18 G20 G40 G99\nG10 P1 U-0.001\nG21\n"))
    sim = simulation()
    assert run_program(worn)[2] == {1: pytest.approx((-0.010, 0.006)), 2: pytest.approx((0.5, 1.0))}
    assert run_program(inch)[2] == {1: pytest.approx((-0.0127, 0.0))}
    name, moves, wear = run_program(worn)
    surface = cut(moves, nominal(moves, 12, 12, program=name), sim, wear)  # the arc: 2 lines further down
    theta = np.arctan2(surface.points[:, 1], surface.points[:, 0])
    expected = -0.010 * np.cos(theta) + 0.006 * np.sin(theta)  # the arc's normal is radial
    assert np.allclose(radial(surface.points), expected, atol=2e-6)  # to first order in the shift
    _, plain, _ = run_program(base)
    same = cut(plain, nominal(plain, 10, 10), sim)
    assert np.abs(radial(same.points)).max() < 1e-7
    out = tmp_path / "surface.csv"
    assert invoke("cut", worn, "--from-line", "12", "--to-line", "12", "-o", str(out)).exit_code == 0
    written = read_surface(str(out)).points
    theta = np.arctan2(written[:, 1], written[:, 0])
    assert np.allclose(radial(written), -0.010 * np.cos(theta) + 0.006 * np.sin(theta), atol=3e-6)
