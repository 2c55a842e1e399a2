"""ISO 230-4 figures, the parametric diagnosis and ``postproc ballbar``.

The ISO figures are checked exactly on analytic traces; the diagnosis against a small
physical model of the machine (``Machine``), simulated along the commanded circle in each
direction and read through a bar whose pivot is off the circle's centre, in both file forms.
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np
import pytest
from click.testing import CliRunner

from postproc.ballbar_analysis import circular_deviation, circular_test, diagnose, predict
from postproc.cli import main
from postproc.diagnostics import MeasurementError
from postproc.measurements.ballbar import read_ballbar

RADIUS = 100.0
CENTRE = (120.0, -80.0)  #: the test circle's centre in the machine, mm
PIVOT = (0.040, -0.055)  #: where the bar's pivot sits relative to that centre, mm
FEED = 1000.0  #: mm/min


def write_trace(path, direction, deviations, angles=None, start=None, **header) -> str:
    """A trace file: processed when ``angles`` are given, raw (``start`` degrees) otherwise."""
    lines = ["# postproc ballbar 1", f"# radius_mm = {RADIUS}", f"# direction = {direction}"]
    lines += [f"# {key} = {value}" for key, value in header.items()]
    if angles is None:
        lines += [f"# start_angle_deg = {float(start)!r}", "deviation_mm", *(repr(float(v)) for v in deviations)]
    else:
        lines += ["angle_deg,deviation_mm", *(f"{float(a)!r},{float(v)!r}" for a, v in zip(angles, deviations))]
    path.write_text("\n".join(lines) + "\n")
    return str(path)


# -- ISO 230-4 figures on analytic traces -------------------------------------------------

GRID = np.arange(360.0)
SHAPES = {  # deviation (mm) of each direction about its centre: G, F and H follow by hand
    "ccw": lambda t: 0.002 + 0.003 * np.cos(2 * np.radians(t)),  # G 6 um, F -1 .. +5 um
    "cw": lambda t: -0.001 + 0.002 * np.cos(2 * np.radians(t)),  # G 4 um, F -3 .. +1 um
}
EXPECTED = {"G": {"ccw": 0.006, "cw": 0.004}, "F": {"ccw": (-0.001, 0.005), "cw": (-0.003, 0.001)},
            "Gb": 0.005 - (-0.003), "H": 0.004}  # H: |cw - ccw| = 0.003 + 0.001 cos(2 theta), largest at 0


def setup(theta_deg):
    """What a pivot off the centre by PIVOT adds to the bar length (first order)."""
    theta = np.radians(theta_deg)
    return -PIVOT[0] * np.cos(theta) - PIVOT[1] * np.sin(theta)


def analytic_processed(tmp_path, direction):
    return write_trace(tmp_path / f"{direction}.csv", direction, SHAPES[direction](GRID) + setup(GRID), GRID)


def analytic_raw(tmp_path, direction):
    """Six equal readings per degree, so that each averaged sample is the shape at its mean angle."""
    sign = 1.0 if direction == "cw" else -1.0
    means = sign * np.arange(360.0)  # with this start, group g averages to s g degrees
    readings = np.repeat(SHAPES[direction](means) + setup(means), 6)
    return write_trace(tmp_path / f"{direction}.csv", direction, readings, start=-sign * 2.5 / 6)


@pytest.mark.parametrize("write", [analytic_processed, analytic_raw])
def test_iso_figures_are_exact_on_analytic_traces(tmp_path, write):
    traces = [read_ballbar(write(tmp_path, d)) for d in ("cw", "ccw")]
    test = circular_test(traces)
    assert [d.direction for d in test.by_direction] == ["ccw", "cw"]
    for figures in test.by_direction:
        assert figures.circular_deviation == pytest.approx(EXPECTED["G"][figures.direction], abs=1e-12)
        assert (figures.radial_min, figures.radial_max) == pytest.approx(EXPECTED["F"][figures.direction], abs=1e-12)
    assert test.bidirectional_deviation == pytest.approx(EXPECTED["Gb"], abs=1e-12)
    assert test.hysteresis == pytest.approx(EXPECTED["H"], abs=1e-12)


def test_circular_deviation_is_about_the_least_squares_centre_of_a_centred_trace(tmp_path):
    deviations = 0.002 * np.cos(np.radians(GRID)) + SHAPES["ccw"](GRID)
    trace = read_ballbar(write_trace(tmp_path / "t.csv", "ccw", deviations, GRID, centered="true"))
    assert trace.setup_centre == (0.0, 0.0)
    assert circular_deviation(trace) == pytest.approx(0.006, abs=1e-12)
    assert circular_test([trace]).by_direction[0].radial_max == pytest.approx(0.007, abs=1e-12)


def test_hysteresis_interpolates_between_the_other_traces_samples(tmp_path):
    ccw = read_ballbar(write_trace(tmp_path / "a.csv", "ccw", np.zeros(360), GRID, centered="true"))
    half = GRID + 0.5  # cw halfway between: a triangle wave 0/2 um interpolates to 1 um at ccw's angles
    cw = read_ballbar(write_trace(tmp_path / "b.csv", "cw", 0.002 * (np.arange(360) % 2), half, centered="true"))
    assert circular_test([ccw, cw]).hysteresis == pytest.approx(0.002, abs=1e-12)


# -- the parametric diagnosis against a simulated machine ---------------------------------

@dataclass(frozen=True)
class Machine:
    """Per-axis errors of a two-axis lathe (docs/methods.md §8) plus squareness and servo lag."""

    scaling_x: float = 40e-6
    scaling_z: float = -30e-6
    backlash_x: float = 0.004  #: mm, full step at the reversal
    backlash_z: float = 0.006
    squareness: float = 25e-6  #: X error per unit Z
    lag_x: float = 0.0003  #: s the X axis lags behind Z
    pitch_x: float = 0.0003  #: mm, amplitude of the ballscrew-pitch term in X ...
    pitch_z: float = 0.0003  #: ... and in Z, an order below the errors above
    pitch: float = 12.0  #: mm

    @property
    def servo_mismatch(self) -> float:
        return FEED / 60.0 * self.lag_x

    def bar(self, theta_deg, direction: str) -> np.ndarray:
        """Bar length minus radius while the command passes theta; errors about the machine origin."""
        k = 1.0 if direction == "cw" else -1.0
        theta = np.radians(theta_deg)
        x, z = CENTRE[0] + RADIUS * np.cos(theta), CENTRE[1] + RADIUS * np.sin(theta)
        velocity_x, velocity_z = -k * np.sin(theta), k * np.cos(theta)
        lagged = theta - k * FEED / 60.0 / RADIUS * self.lag_x  # X follows its command lag_x late
        wave = np.sin(2 * np.pi * z / self.pitch)
        actual_x = (CENTRE[0] + RADIUS * np.cos(lagged) + self.scaling_x * x + self.squareness * z
                    - self.backlash_x / 2 * np.sign(velocity_x) + self.pitch_x * wave)
        actual_z = z + self.scaling_z * z - self.backlash_z / 2 * np.sign(velocity_z) + self.pitch_z * wave
        return np.hypot(actual_x - CENTRE[0] - PIVOT[0], actual_z - CENTRE[1] - PIVOT[1]) - RADIUS

    def centre_offset(self) -> tuple[float, float]:
        """The first harmonic of the trace: the errors' translation at the centre, less the pivot offset."""
        return (self.scaling_x * CENTRE[0] + self.squareness * CENTRE[1] - PIVOT[0],
                self.scaling_z * CENTRE[1] - PIVOT[1])


MACHINE = Machine()
NOISE = 0.0003  #: mm, one sigma per reading


def simulated(tmp_path, direction, form, rng) -> str:
    header = {"center_x_mm": CENTRE[0], "center_z_mm": CENTRE[1], "feed_mm_min": FEED}
    if form == "processed":
        angles = np.arange(0.0, 360.0, 0.5)
        readings = MACHINE.bar(angles, direction) + rng.normal(0.0, NOISE, angles.size)
        return write_trace(tmp_path / f"{direction}.csv", direction, readings, angles, **header)
    start = {"ccw": 33.3, "cw": 213.3}[direction]
    count = 6 * 720
    angles = start + (1.0 if direction == "cw" else -1.0) * np.arange(count) * 360.0 / count
    readings = MACHINE.bar(angles, direction) + rng.normal(0.0, NOISE, count)
    return write_trace(tmp_path / f"{direction}.csv", direction, readings, start=start, **header)


@pytest.fixture(params=["processed", "raw"])
def simulated_test(request, tmp_path):
    rng = np.random.default_rng(2006)
    return [simulated(tmp_path, direction, request.param, rng) for direction in ("ccw", "cw")]


def test_diagnosis_recovers_the_simulated_machine(simulated_test):
    traces = [read_ballbar(path) for path in simulated_test]
    diagnosis = diagnose(traces)
    assert diagnosis.scaling_x.value == pytest.approx(MACHINE.scaling_x, rel=0.05)
    assert diagnosis.scaling_z.value == pytest.approx(MACHINE.scaling_z, rel=0.05)
    assert diagnosis.backlash_x.value == pytest.approx(MACHINE.backlash_x, abs=0.0005)
    assert diagnosis.backlash_z.value == pytest.approx(MACHINE.backlash_z, abs=0.0005)
    assert diagnosis.squareness.value == pytest.approx(MACHINE.squareness, rel=0.15)
    assert diagnosis.servo_mismatch.value == pytest.approx(MACHINE.servo_mismatch, rel=0.1)
    assert diagnosis.servo_lag_ms.value == pytest.approx(MACHINE.lag_x * 1000, rel=0.1)
    centre = [e.value for e in diagnosis.centre_offset]
    assert centre == pytest.approx(MACHINE.centre_offset(), abs=0.0003)
    for estimate in (diagnosis.scaling_x, diagnosis.backlash_z, diagnosis.squareness, diagnosis.servo_mismatch):
        assert 0 < estimate.sigma < abs(estimate.value) / 10
    assert diagnosis.residual.rms < 0.5  # um: noise and the unmodelled pitch term
    for trace in traces:  # the model predicts the processed trace back
        predicted = predict(diagnosis, trace.angles, trace.direction)
        assert np.sqrt(np.mean((predicted - trace.deviations) ** 2)) < 0.0005


def test_one_trace_gives_scaling_and_backlash_but_not_squareness(simulated_test):
    ccw = read_ballbar(simulated_test[0])
    diagnosis = diagnose([ccw])
    assert diagnosis.scaling_x.value == pytest.approx(MACHINE.scaling_x, rel=0.05)
    assert diagnosis.scaling_z.value == pytest.approx(MACHINE.scaling_z, rel=0.05)
    assert diagnosis.backlash_x.value == pytest.approx(MACHINE.backlash_x, abs=0.0005)
    assert diagnosis.backlash_z.value == pytest.approx(MACHINE.backlash_z, abs=0.0005)
    assert diagnosis.squareness is None and diagnosis.servo_mismatch is None and diagnosis.servo_lag_ms is None
    expected = MACHINE.squareness - MACHINE.servo_mismatch / RADIUS  # ccw sees s - m / R
    assert diagnosis.apparent_squareness.value == pytest.approx(expected, rel=0.15)
    assert predict(diagnosis, [0.0, 45.0], "ccw").shape == (2,)
    with pytest.raises(ValueError, match="cannot predict cw"):
        predict(diagnosis, [0.0], "cw")


def test_diagnosis_refuses_a_trace_that_leaves_part_of_the_circle_out(tmp_path):
    angles = np.arange(0.0, 270.0, 1.0)
    trace = read_ballbar(write_trace(tmp_path / "t.csv", "cw", np.zeros(angles.size), angles))
    with pytest.raises(MeasurementError, match="whole circle"):
        diagnose([trace])


# -- the command -----------------------------------------------------------------------------

def invoke(*args: str):
    """``postproc ballbar ARGS`` through the real command line."""
    return CliRunner().invoke(main, ["ballbar", *args], catch_exceptions=False)


CONTRACT_KEYS = {"circular_deviation_mm", "radial_deviation_mm", "hysteresis_mm", "scaling_x", "scaling_z",
                 "backlash_x_mm", "backlash_z_mm", "squareness_rad", "center_offset_mm"}


def test_json_has_the_contract_keys(simulated_test):
    result = invoke(*simulated_test, "--json")
    assert (result.exit_code, result.stderr) == (0, "")
    report = json.loads(result.stdout)
    assert CONTRACT_KEYS <= set(report)
    assert set(report["circular_deviation_mm"]) == {"ccw", "cw"}
    assert set(report["radial_deviation_mm"]["cw"]) == {"min", "max"}
    assert set(report["center_offset_mm"]) == {"x", "z"}
    assert report["backlash_z_mm"] == pytest.approx(MACHINE.backlash_z, abs=0.0005)
    assert report["hysteresis_mm"] > 0 and report["needs_both_directions"] == []
    assert report["uncertainty"]["scaling_x"] > 0


def test_one_trace_nulls_what_needs_both_directions(simulated_test):
    result = invoke(simulated_test[1], "--json")
    assert (result.exit_code, result.stderr) == (0, "")
    report = json.loads(result.stdout)
    assert report["circular_deviation_mm"]["ccw"] is None and report["circular_deviation_mm"]["cw"] > 0
    for key in report["needs_both_directions"]:
        assert report[key] is None
    assert {"hysteresis_mm", "squareness_rad"} <= set(report["needs_both_directions"])
    assert report["scaling_x"] == pytest.approx(MACHINE.scaling_x, rel=0.05)


def test_partial_trace_gets_iso_figures_and_no_diagnosis(tmp_path):
    angles = np.arange(0.0, 180.0, 1.0)
    path = write_trace(tmp_path / "t.csv", "cw", 0.001 * np.cos(2 * np.radians(angles)), angles, centered="true")
    report = json.loads(invoke(path, "--json").stdout)
    assert report["radial_deviation_mm"]["cw"] == pytest.approx({"min": -0.001, "max": 0.001}, abs=1e-12)
    assert 0 < report["circular_deviation_mm"]["cw"] < 0.002  # its own centre takes some of cos 2 theta
    assert report["scaling_x"] is None and report["fit_residual_um"] is None
    assert any("whole circle" in note for note in report["notes"])


def test_human_report_on_stdout(simulated_test):
    result = invoke(*simulated_test)
    assert (result.exit_code, result.stderr) == (0, "")
    assert "circular hysteresis H" in result.stdout
    assert "backlash Z" in result.stdout and "ppm" in result.stdout


def test_bad_file_is_reported_with_its_line(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("# postproc ballbar 1\n# radius_mm = 100\n# direction = up\ndeviation_mm\n0.001\n")
    result = invoke(str(path), "--json")
    assert (result.exit_code, result.stdout) == (3, "")
    assert result.stderr.startswith(f"{path}:3: error: direction = 'up'")


def test_two_traces_of_one_direction_are_refused(simulated_test):
    result = invoke(simulated_test[0], simulated_test[0])
    assert result.exit_code == 3 and "one ccw (G03) and one cw (G02)" in result.stderr


def test_more_than_two_traces_is_a_usage_error(simulated_test):
    result = invoke(*simulated_test, simulated_test[0])
    assert result.exit_code == 2 and "one trace or a ccw and a cw trace" in result.stderr


@pytest.mark.parametrize("suffix", [".png", ".svg"])
def test_plot_is_written(simulated_test, tmp_path, suffix):
    target = tmp_path / f"trace{suffix}"
    result = invoke(*simulated_test, "--plot", str(target), "--json")
    assert (result.exit_code, result.stderr) == (0, "")
    assert target.stat().st_size > 1000
    data = target.read_bytes()
    assert data.startswith(b"\x89PNG") if suffix == ".png" else b"<svg" in data
    assert json.loads(result.stdout)["scaling_x"] is not None


def test_plot_of_another_format_is_a_usage_error(simulated_test, tmp_path):
    result = invoke(*simulated_test, "--plot", str(tmp_path / "trace.pdf"))
    assert (result.exit_code, result.stdout) == (2, "")
    assert not (tmp_path / "trace.pdf").exists()


def test_deviation_against_angle_plot(tmp_path, simulated_test):
    from postproc.plotting import plot_deviation_vs_angle

    traces = [read_ballbar(path) for path in simulated_test]
    target = tmp_path / "angle.svg"
    plot_deviation_vs_angle([(t.direction, t.angles, t.deviations) for t in traces], str(target), "traces")
    assert target.stat().st_size > 1000
