"""ISO 230-4 figures, the parametric diagnosis and ``postproc ballbar``.

The ISO figures are checked exactly on analytic traces; the diagnosis against a small
physical model of the machine (``Machine``), simulated along the commanded circle in each
direction and read through a bar whose pivot is off the circle's centre, in both file forms.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings, strategies as st

from support import SAMPLES
from postproc.measure.ballbar_analysis import circular_deviation, circular_test, diagnose, predict
from postproc.cli.main import main
from postproc.diagnostics import MeasurementError
from postproc.measure.readers.ballbar import read_ballbar

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
    """What a pivot off the centre by PIVOT adds to the bar length (to second order: the bar is the
    hypotenuse, (PIVOT . tangent)^2 / 2R more)."""
    theta = np.radians(theta_deg)
    cos, sin = np.cos(theta), np.sin(theta)
    return -PIVOT[0] * cos - PIVOT[1] * sin + (PIVOT[1] * cos - PIVOT[0] * sin) ** 2 / (2 * RADIUS)


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


# -- partial arcs ---------------------------------------------------------------------------------

ARC = np.arange(-20.0, 200.01, 0.5)  #: a lathe's 220 deg test in XZ (ISO 13041-6), the spindle side left out


def test_partial_arc_figures_match_a_circle_fitted_to_the_points(tmp_path):
    """G over a partial arc is the width about the least-squares circle of the arc as measured: the
    linearised fit agrees with a free circle fitted to the measured points (Levenberg-Marquardt)."""
    from postproc.geometry.fitting import fit_circle

    deviations = SHAPES["ccw"](ARC) + setup(ARC)
    trace = read_ballbar(write_trace(tmp_path / "t.csv", "ccw", deviations, ARC))
    assert trace.arc == pytest.approx((340.0, 220.0))
    points = trace.points()
    free = fit_circle(points)
    assert circular_deviation(trace) == pytest.approx(float(np.ptp(free.residuals)), abs=2e-6)


def test_hysteresis_of_partial_arcs_is_taken_where_both_runs_measured(tmp_path):
    ccw = read_ballbar(write_trace(tmp_path / "a.csv", "ccw", 0.001 + 0.0 * ARC, ARC, centered="true"))
    later = ARC[ARC >= 30.0]
    cw = read_ballbar(write_trace(tmp_path / "b.csv", "cw", 0.003 + 0.0 * later, later, centered="true"))
    test = circular_test([ccw, cw])
    assert test.hysteresis == pytest.approx(0.002, abs=1e-12)  # no interpolation across either gap


def analytic_machine(angles, direction, scaling=(40e-6, -30e-6), backlash=(0.004, 0.006), squareness=25e-6,
                     mismatch=0.0005, pivot=PIVOT):
    """The model's reading, exactly (first order in the errors, second in the set-up)."""
    k = 1.0 if direction == "cw" else -1.0
    theta = np.radians(angles)
    cos, sin = np.cos(theta), np.sin(theta)
    dx, dz = np.sign(np.round(-k * sin, 12)), np.sign(np.round(k * cos, 12))
    dx, dz = np.where(dx == 0, np.sign(np.round(cos, 12)), dx), np.where(dz == 0, np.sign(np.round(sin, 12)), dz)
    e_x = scaling[0] * RADIUS * cos + squareness * RADIUS * sin - backlash[0] / 2 * dx + mismatch * k * sin
    e_z = scaling[1] * RADIUS * sin - backlash[1] / 2 * dz
    return (e_x * cos + e_z * sin - pivot[0] * cos - pivot[1] * sin
            + (pivot[1] * cos - pivot[0] * sin) ** 2 / (2 * RADIUS))


@pytest.mark.parametrize("start, span", [(-20.0, 220.0), (0.0, 180.0), (30.0, 150.0), (200.0, 200.0)])
def test_the_centre_fitted_with_the_model_leaves_the_model_unbiased_on_any_arc(tmp_path, start, span):
    """On a partial arc a separate circle fit takes part of the scaling with the centre (the class of
    defect); fitted jointly, every parameter comes back exactly from noise-free traces."""
    angles = np.arange(start, start + span + 0.01, 0.5)
    traces = [read_ballbar(write_trace(tmp_path / f"{d}.csv", d, analytic_machine(angles, d), angles))
              for d in ("ccw", "cw")]
    diagnosis = diagnose(traces)
    expected = {"scaling_x": 40e-6, "scaling_z": -30e-6, "backlash_x": 0.004, "backlash_z": 0.006,
                "squareness": 25e-6, "servo_mismatch": 0.0005}
    for name, value in expected.items():
        assert getattr(diagnosis, name).value == pytest.approx(value, abs=1e-9), name
    assert [e.value for e in diagnosis.centre_offset] == pytest.approx([-PIVOT[0], -PIVOT[1]], abs=1e-9)
    # what a separate circle fit (constant and first harmonic) takes out of the scaling on this arc
    theta = np.radians(angles)
    harmonics = np.column_stack([np.ones_like(theta), np.cos(theta), np.sin(theta)])
    scaling = RADIUS * 40e-6 * np.cos(theta) ** 2
    taken = harmonics @ np.linalg.lstsq(harmonics, scaling, rcond=None)[0]
    assert np.abs(scaling - taken).max() < np.abs(scaling).max()  # a separate fit would have eaten part of it


def test_uncertainties_grow_as_the_arc_shrinks(tmp_path):
    rng = np.random.default_rng(13)
    sigmas = []
    for span in (360.0, 220.0, 180.0):
        angles = np.arange(-20.0, -20.0 + span, 0.5) if span < 360 else np.arange(0.0, 360.0, 0.5)
        traces = [read_ballbar(write_trace(tmp_path / f"{d}{span:.0f}.csv", d,
                                           analytic_machine(angles, d) + rng.normal(0, NOISE, angles.size), angles))
                  for d in ("ccw", "cw")]
        sigmas.append(diagnose(traces).scaling_z.sigma)
    assert sigmas[0] < sigmas[1] < sigmas[2]


def test_a_90_deg_arc_is_refused_naming_the_arc_and_the_parameter(tmp_path):
    rng = np.random.default_rng(5)
    angles = np.arange(0.0, 90.01, 0.5)
    traces = [read_ballbar(write_trace(tmp_path / f"{d}.csv", d, analytic_machine(angles, d)
                                       + rng.normal(0, NOISE, angles.size), angles)) for d in ("ccw", "cw")]
    with pytest.raises(MeasurementError, match=r"\(90 deg from 0 to 90 deg\), scaling [XZ] \+-\d+(\.\d+)? ppm .* not "
                                               r"determined: 3 sigma of the error it models is above 5 um"):
        diagnose(traces)
    result = invoke(*(t.path for t in traces), "--json")
    assert result.exit_code == 3 and result.stdout == ""
    assert "90 deg from 0 to 90 deg" in result.stderr and "--no-diagnosis" in result.stderr
    figures_only = invoke(*(t.path for t in traces), "--json", "--no-diagnosis")
    assert figures_only.exit_code == 0, figures_only.stderr
    report = json.loads(figures_only.stdout)
    assert report["scaling_x"] is None and report["circular_deviation_mm"]["ccw"] > 0
    assert report["captured_arc_deg"]["cw"] == pytest.approx({"start": 0.0, "span": 90.0})


def test_one_direction_on_a_half_circle_cannot_tell_backlash_from_the_set_up(tmp_path):
    """Over 0..180 deg X travels one way only: in one run its backlash reads like a set-up offset."""
    angles = np.arange(0.0, 180.01, 0.5)
    rng = np.random.default_rng(8)
    trace = read_ballbar(write_trace(tmp_path / "ccw.csv", "ccw", analytic_machine(angles, "ccw")
                                     + rng.normal(0, NOISE, angles.size), angles))
    with pytest.raises(MeasurementError, match="backlash X"):
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


@pytest.mark.parametrize("form", ["processed", "raw"])
def test_220_deg_traces_are_diagnosed_not_an_internal_error(tmp_path, form):
    """The IndexError class: every figure over a partial arc, processed and raw alike."""
    paths = []
    for direction, start in (("ccw", 200.0), ("cw", -20.0)):
        path = str(tmp_path / f"{direction}.csv")
        result = CliRunner().invoke(main, ["simulate", "ballbar", "--machine", str(SAMPLES / "machines" / "v40r-sim.toml"),
                                           "--direction", direction, "--form", form, "--start-angle", str(start),
                                           "--capture-arc", "220", "--overtravel", "2", "-o", path])
        assert result.exit_code == 0, result.stderr
        paths.append(path)
    result = invoke(*paths, "--json")
    assert (result.exit_code, result.stderr) == (0, "")
    report = json.loads(result.stdout)
    assert report["captured_arc_deg"]["ccw"]["span"] == pytest.approx(220.0, abs=0.6)
    assert report["hysteresis_mm"] > 0 and report["bidirectional_circular_deviation_mm"] > 0
    assert report["scaling_x"] == pytest.approx(80e-6, abs=4e-6)  # the sample machine: +80 / -100 ppm, 4 / 3 um
    assert report["scaling_z"] == pytest.approx(-100e-6, abs=4e-6)
    assert report["backlash_x_mm"] == pytest.approx(0.004, abs=0.0006)
    assert report["backlash_z_mm"] == pytest.approx(0.003, abs=0.0006)
    assert any("ISO 13041-6" in note for note in report["notes"])
    text = invoke(*paths)
    assert "ISO 230-4 (ISO 13041-6 for lathes)" in text.stdout and "220 deg from -20 to 200 deg" in text.stdout


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


def test_the_same_trace_twice_is_refused(simulated_test):
    result = invoke(simulated_test[0], simulated_test[0])
    assert result.exit_code == 3 and "the same trace given twice" in result.stderr
    result = invoke(*simulated_test, simulated_test[0])
    assert result.exit_code == 3 and "the same trace given twice" in result.stderr


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
    from postproc.report.plotting import plot_deviation_vs_angle

    traces = [read_ballbar(path) for path in simulated_test]
    target = tmp_path / "angle.svg"
    plot_deviation_vs_angle([(t.direction, t.angles, t.deviations) for t in traces], str(target), "traces")
    assert target.stat().st_size > 1000


# -- sanity checks: results no machine gives, with their likely cause ----------------------------------

SAMPLE = {d: SAMPLES / "ballbar" / f"v40r-100-{d}.csv" for d in ("ccw", "cw")}
HEMISHELL = str(SAMPLES / "programs" / "hemishell.nc")


def edited(tmp_path, change) -> list[str]:
    """The sample test's two traces with their text changed by ``change(direction, text)``."""
    paths = []
    for direction, path in SAMPLE.items():
        target = tmp_path / path.name
        target.write_text(change(direction, path.read_text()))
        paths.append(str(target))
    return paths


def swapped(direction, text):
    other = "cw" if direction == "ccw" else "ccw"
    return text.replace(f"# direction = {direction}\n", f"# direction = {other}\n")


def test_swapped_direction_labels_are_refused_by_compensators_and_named_by_ballbar(tmp_path, run):
    paths = edited(tmp_path, swapped)
    for plugin in ("parametric", "effective-angle", "ballbar-inverse"):
        result = run("compensate", HEMISHELL, "--plugin", plugin, *(a for p in paths for a in ("--ballbar", p)))
        assert result.exit_code == 3 and result.stdout == "", plugin
        assert "are both negative" in result.stderr and "the ccw and cw labels look swapped" in result.stderr, plugin
        assert "servo" in result.stderr or plugin == "ballbar-inverse"
    forced = run("compensate", HEMISHELL, "--plugin", "parametric", "--force", *(a for p in paths for a in ("--ballbar", p)))
    assert forced.exit_code == 0 and "look swapped" in forced.stderr and "warning:" in forced.stderr
    report = invoke(*paths, "--json")
    assert report.exit_code == 0 and "warning: backlash X -" in report.stderr
    assert any("look swapped" in text for text in json.loads(report.stdout)["warnings"])
    assert json.loads(report.stdout)["servo_lag_ms"] < 0  # the lag flips with the labels too


def test_a_radius_that_is_not_the_bars_is_named(tmp_path, run):
    """The sample test read as if the bar were 4 mm long: its scaling comes out 25 times too large."""
    paths = edited(tmp_path, lambda d, text: text.replace("# radius_mm = 100\n", "# radius_mm = 4\n"))
    result = run("compensate", HEMISHELL, "--plugin", "parametric", *(a for p in paths for a in ("--ballbar", p)))
    assert result.exit_code == 3 and result.stdout == ""
    assert "beyond 500 ppm" in result.stderr and "is radius_mm (4 mm) the bar's length" in result.stderr
    assert f"{paths[0]}:2: warning: radius_mm = 4 is shorter than any ballbar" in result.stderr
    assert "warning: scaling X +1979 ppm and scaling Z -2519 ppm are beyond 500 ppm" in invoke(*paths).stderr
    forced = run("compensate", HEMISHELL, "--plugin", "parametric", "--force", *(a for p in paths for a in ("--ballbar", p)))
    assert forced.exit_code == 0 and "beyond 500 ppm" in forced.stderr  # --force applies them, as it says
    model = tmp_path / "m.json"
    fitted = run("fit", "--plugin", "parametric", "--force", *(a for p in paths for a in ("--ballbar", p)), "-o", str(model))
    assert fitted.exit_code == 3 and not model.exists()  # the traces' fault, not the plugin's (exit 5)
    assert "--force kept what the measurements are refused for" in fitted.stderr and "compensate with --force" in fitted.stderr


@pytest.mark.parametrize("radius", [1001, 100000, 1e9])
def test_a_radius_no_circular_test_has_is_refused_at_its_line(tmp_path, run, radius):
    """The sample test read as if the bar were 100000 mm long (written in um): its scaling
    comes out a thousand times too small and the correction loses it, silently. No circular test
    is that large: the header line is refused, with the unit it most likely is in."""
    paths = edited(tmp_path, lambda d, text: text.replace("# radius_mm = 100\n", f"# radius_mm = {radius:g}\n"))
    result = run("compensate", HEMISHELL, "--plugin", "parametric", *(a for p in paths for a in ("--ballbar", p)))
    assert result.exit_code == 3 and result.stdout == ""
    assert result.stderr.startswith(f"{paths[0]}:2: error: radius_mm = {radius:g} is above 1000") and "in um" in result.stderr
    assert invoke(*paths).exit_code == 3


def test_a_mean_radius_error_is_named_as_the_wrong_radius(tmp_path):
    angles = np.arange(0.0, 360.0, 1.0)
    # a 100 mm bar with 100.2 in its header: -0.2 mm everywhere, and the machine's own +5 ppm mean scaling
    paths = [write_trace(tmp_path / f"{d}.csv", d, analytic_machine(angles, d) - 0.2, angles) for d in ("ccw", "cw")]
    result = invoke(*paths, "--json")
    assert result.exit_code == 0
    warnings = json.loads(result.stdout)["warnings"]
    assert any("mean radius error of -199.5 um on the 100 mm radius: radius_mm does not match the bar's length" in w
               for w in warnings), warnings


def test_a_backlash_beyond_50_um_asks_for_the_units(tmp_path, run):
    angles = np.arange(0.0, 360.0, 1.0)
    paths = [write_trace(tmp_path / f"{d}.csv", d, analytic_machine(angles, d, backlash=(0.08, 0.004)), angles)
             for d in ("ccw", "cw")]
    result = run("compensate", HEMISHELL, "--plugin", "parametric", *(a for p in paths for a in ("--ballbar", p)))
    assert result.exit_code == 3
    assert "backlash X +80.0 um is beyond 50 um: are the deviations in mm?" in result.stderr


def test_one_negative_backlash_is_a_warning_not_a_refusal(tmp_path, run):
    """A control whose backlash compensation is set too high reads negative lost motion on that axis."""
    angles = np.arange(0.0, 360.0, 1.0)
    paths = [write_trace(tmp_path / f"{d}.csv", d, analytic_machine(angles, d, backlash=(-0.003, 0.004)), angles)
             for d in ("ccw", "cw")]
    result = run("compensate", HEMISHELL, "--plugin", "parametric", *(a for p in paths for a in ("--ballbar", p)))
    assert result.exit_code == 0
    assert "backlash X is negative (-3.00 um): the control's backlash compensation may be set too high" in result.stderr


# -- a ccw and a cw trace pair only when they are of one test -------------------------------------

PAIRING = ("error-map", "parametric", "effective-angle", "ballbar-inverse", "iterative")


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(field=st.sampled_from(["radius_mm", "center_x_mm", "center_z_mm"]),
       shift=st.sampled_from([-150.0, -0.5, 0.001, 2.0, 200.0]))
def test_a_ccw_and_a_cw_trace_of_two_tests_are_never_paired(tmp_path_factory, run, field, shift):
    """Another radius or centre in the cw trace's header makes it another test: every compensator
    that pairs the directions refuses naming both files, and ``postproc ballbar``'s diagnosis too
    (it would read squareness and servo mismatch off two circles' set-ups)."""
    folder = tmp_path_factory.mktemp("mixed")
    angles = np.arange(0.0, 360.0, 1.0)
    header = {"center_x_mm": 0.0, "center_z_mm": 0.0}
    ccw = write_trace(folder / "ccw.csv", "ccw", analytic_machine(angles, "ccw"), angles, **header)
    other = dict(header)
    if field == "radius_mm":
        text_radius = RADIUS + abs(shift)
    else:
        other[field] += shift
        text_radius = RADIUS
    cw = write_trace(folder / "cw.csv", "cw", analytic_machine(angles, "cw"), angles, **other)
    if text_radius != RADIUS:
        Path(cw).write_text(Path(cw).read_text().replace(f"# radius_mm = {RADIUS}\n", f"# radius_mm = {text_radius}\n"))
    for plugin in PAIRING:
        result = run("compensate", HEMISHELL, "--plugin", plugin, "--ballbar", ccw, "--ballbar", cw)
        assert (result.exit_code, result.stdout) == (3, ""), plugin
        assert "different tests" in result.stderr or "trace of each test" in result.stderr, plugin
        assert f"ccw {ccw}" in result.stderr and f"cw {cw}" in result.stderr, plugin
        assert result.stderr.count("error:") == 1, plugin
    report = invoke(ccw, cw)
    assert (report.exit_code, report.stdout) == (3, "")
    assert "the ccw and the cw traces are of different tests" in report.stderr
    assert f"ccw {ccw}" in report.stderr and f"cw {cw}" in report.stderr
    assert "--no-diagnosis" in report.stderr
    alone = invoke(ccw, cw, "--no-diagnosis")  # the ISO figures of each test, stated as two tests
    assert (alone.exit_code, alone.stderr) == (0, "")
    assert "ballbar test 1:" in alone.stdout and "ballbar test 2:" in alone.stdout


def test_a_test_with_one_direction_beside_a_paired_one_is_refused_by_what_pairs_each_test(tmp_path, run):
    """Parametric fits one model to every test: a one-direction test beside a paired one adds to it.
    error-map and effective-angle pair each test's runs: the lone test is refused, named."""
    angles = np.arange(0.0, 360.0, 1.0)
    paths = [write_trace(tmp_path / f"{d}.csv", d, analytic_machine(angles, d), angles) for d in ("ccw", "cw")]
    lone = write_trace(tmp_path / "far-ccw.csv", "ccw", analytic_machine(angles, "ccw"), angles, center_z_mm=-150.0)
    given = [a for p in (*paths, lone) for a in ("--ballbar", p)]
    for plugin in ("error-map", "effective-angle"):
        result = run("compensate", HEMISHELL, "--plugin", plugin, *given)
        assert (result.exit_code, result.stdout) == (3, ""), plugin
        assert "R 100 mm about x 0, z -150 mm has no cw trace" in result.stderr, plugin
        assert result.stderr.startswith(f"{lone}: error: {plugin} needs a ccw (G03) and a cw (G02) trace of each test")
    assert invoke(*paths, lone).exit_code == 0


# -- a spike in a trace is named, never blamed on the arc ---------------------------------------


def noisy_test(folder, raw: bool, seed: int) -> dict[str, str]:
    """A ccw and a cw whole-circle test of ``analytic_machine`` with 0.3 um of noise, 0.5 deg samples
    (raw: six readings each, in time order from 0 deg)."""
    rng = np.random.default_rng(seed)
    paths = {}
    for d in ("ccw", "cw"):
        if raw:
            sign = 1.0 if d == "cw" else -1.0
            angles = sign * np.arange(4320) * 360.0 / 4320
            paths[d] = write_trace(folder / f"{d}.csv", d, analytic_machine(angles, d) + rng.normal(0, 3e-4, 4320),
                                   start=0.0)
        else:
            angles = np.arange(0.0, 360.0, 0.5)
            paths[d] = write_trace(folder / f"{d}.csv", d, analytic_machine(angles, d) + rng.normal(0, 3e-4, 720),
                                   angles)
    return paths


def spiked(path: str, row: int, size: float, count: int = 1) -> int:
    """Add ``size`` mm to ``count`` readings of a trace file from the ``row``-th; returns its line number."""
    lines = Path(path).read_text().splitlines()
    first = next(i for i, line in enumerate(lines) if line.startswith(("angle_deg", "deviation_mm"))) + 1
    for at in range(first + row, first + row + count):
        cells = lines[at].split(",")
        cells[-1] = repr(float(cells[-1]) + size)
        lines[at] = ",".join(cells)
    Path(path).write_text("\n".join(lines) + "\n")
    return first + row + 1


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(raw=st.booleans(), quadrant=st.integers(0, 3), offset=st.floats(10.0, 80.0),
       size=st.sampled_from([-0.9, -0.05, 0.012, 0.3]), seed=st.integers(0, 2**16))
def test_a_spike_is_named_with_its_file_line_and_size(tmp_path_factory, run, raw, quadrant, offset, size, seed):
    """One reading (raw: one group of six) off by ``size`` anywhere clear of a reversal: the
    diagnosis names it, never an arc too short, and every compensator refuses for it."""
    folder = tmp_path_factory.mktemp("spike")
    paths = noisy_test(folder, raw, seed)
    theta = 90.0 * quadrant + offset  # the ccw run goes from 0 deg downwards: sample k at -k/2 deg
    sample = int(round((360.0 - theta) * 2)) % 720
    line = spiked(paths["ccw"], sample * 6 if raw else sample, size, 6 if raw else 1)  # raw: a group's first line
    said = f"{paths['ccw']} {'line' if not raw else '(the readings from line'} {line}"
    report = invoke(paths["ccw"], paths["cw"])
    assert report.exit_code in (0, 3)
    if report.exit_code == 3:
        assert report.stdout == ""
        assert report.stderr.startswith(f"{paths['ccw']}:{line}: error: the fit is not determined, and the "
                                        f"likely cause is a spike: {said}")
        assert "measure a longer arc" not in report.stderr
    else:
        assert said in report.stderr and "warning:" in report.stderr
    told = float(re.search(r"a spike of ([+-][0-9.]+) um", report.stderr).group(1))
    assert told == pytest.approx(size * 1000, rel=0.1, abs=3.0)
    for plugin in ("parametric", "error-map", "ballbar-inverse"):
        result = run("compensate", HEMISHELL, "--plugin", plugin, "--ballbar", paths["ccw"], "--ballbar", paths["cw"])
        assert (result.exit_code, result.stdout) == (3, ""), plugin
        assert said in result.stderr and "a spike of" in result.stderr, plugin
        assert result.stderr.count("error:") == 1, plugin


@pytest.mark.parametrize("raw", [False, True])
def test_a_trace_without_a_spike_is_not_said_to_have_one(tmp_path, raw):
    """The machine's own steps at the reversals (backlash, raw groups straddling it) are not spikes."""
    paths = noisy_test(tmp_path, raw, 7)
    for given_paths in ([paths["ccw"], paths["cw"]], [str(p) for p in SAMPLE.values()],
                        [str(SAMPLES / "ballbar" / f"v40r-100-{d}-raw.csv") for d in ("ccw", "cw")]):
        report = invoke(*given_paths)
        assert (report.exit_code, report.stderr) == (0, ""), report.stderr
