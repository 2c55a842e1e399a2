"""Reading ballbar traces (postproc.measure.readers.ballbar).

Where a length or the captured arc is not what the file says: raw readings said to go round the
whole circle (``capture_arc_deg`` 360, or left out) whose ends do not meet are the readings of a
partial arc, refused naming ``capture_arc_deg``; a test centre beyond any lathe's travel is a
unit, refused at its line. A whole circle's raw readings, with the machine's own steps at the
reversals, are read as ever. Reading a trace costs time linear in its samples and no Python
object per sample, and an angle given twice is still found as it always was."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings, strategies as st

from postproc.cli.main import main
from postproc.diagnostics import MeasurementError
from postproc.measure.readers.ballbar import open_ends, read_ballbar, repeated_angle
from support import SAMPLES
from support.long_traces import peak_bytes, python_lines, write_trace

MACHINE = str(SAMPLES / "machines" / "v40r-sim.toml")


def machine_trace(theta_deg: np.ndarray, cw: bool, offset=(0.012, -0.007), backlash=(0.004, 0.002),
                  seed: int = 0) -> np.ndarray:
    """Bar readings (mm) of a machine with a set-up offset, a peanut and a backlash step at each
    axis reversal, in the run's direction, with 0.2 um of noise."""
    theta = np.radians(theta_deg)
    sign = 1.0 if cw else -1.0
    x_moving_down, z_moving_down = np.sin(theta) * sign > 0, -np.cos(theta) * sign > 0
    steps = (backlash[0] * np.where(x_moving_down, 0.5, -0.5) * np.abs(np.cos(theta))
             + backlash[1] * np.where(z_moving_down, 0.5, -0.5) * np.abs(np.sin(theta)))
    noise = np.random.default_rng(seed).normal(0.0, 0.0002, theta.size)
    return offset[0] * np.cos(theta) + offset[1] * np.sin(theta) + 0.0025 * np.cos(2 * theta) + steps + noise


@settings(max_examples=60, deadline=None)
@given(start=st.floats(0.0, 360.0), cw=st.booleans(), count=st.integers(216, 4320),
       offset=st.tuples(st.floats(-0.05, 0.05), st.floats(-0.05, 0.05)),
       backlash=st.tuples(st.floats(0.0, 0.02), st.floats(0.0, 0.02)), seed=st.integers(0, 99),
       drift=st.floats(-0.004, 0.004))
def test_a_whole_circles_readings_close(start, cw, count, offset, backlash, seed, drift):
    """A whole circle's last and first readings are neighbours, whatever its start (a reversal's
    step there recurs at the axis's other reversal), set-up offset, backlash, or a drift of the
    bar of a few um from the first reading to the last (finely sampled, its steps are a tenth
    of a um: the drift is no gap)."""
    theta = start + (1 if cw else -1) * np.arange(count) * 360.0 / count
    readings = machine_trace(theta, cw, offset, backlash, seed) + np.linspace(0.0, drift, count)
    assert open_ends(readings) is None


@pytest.mark.parametrize("drift", [0.001, 0.002, 0.004, -0.004])
def test_a_finely_sampled_circle_that_drifted_closes(drift):
    """4320 readings of a round machine, 0.03 um of noise: its steps are a tenth of a um, and a
    bar that drifted some um from the first reading to the last is still a whole circle (it
    was refused as a partial arc at 1 um)."""
    theta = np.radians(np.arange(4320) * 360.0 / 4320)
    readings = (0.002 * np.sin(2 * theta) + np.linspace(0.0, drift, theta.size)
                + np.random.default_rng(1).normal(0.0, 0.00003, theta.size))
    assert open_ends(readings) is None


@settings(max_examples=60, deadline=None)
@given(start=st.floats(0.0, 360.0), cw=st.booleans(), arc=st.floats(150.0, 300.0), count=st.integers(216, 4320),
       offset=st.tuples(st.floats(0.005, 0.05), st.floats(-0.05, 0.05)), seed=st.integers(0, 99))
def test_a_partial_arcs_readings_do_not_close(start, cw, arc, count, offset, seed):
    """A set-up offset of 5 um or more (a ballbar is mounted to some um) leaves a partial arc's
    ends far apart; without one the arc may close by chance, and then nothing tells."""
    theta = start + (1 if cw else -1) * np.arange(count) * arc / count
    readings = machine_trace(theta, cw, offset, (0.004, 0.002), seed)
    gap = abs(readings[0] - readings[-1])
    if gap < 3 * 0.005 + 6 * np.abs(np.diff(readings)).max():  # the ends met by chance
        return
    assert "these readings do not go round it" in open_ends(readings)


def _simulated(tmp_path, *options: str) -> str:
    out = tmp_path / "raw.csv"
    result = CliRunner().invoke(main, ["simulate", "ballbar", "--machine", MACHINE, "--form", "raw", "-o", str(out),
                                       *options], catch_exceptions=False)
    assert result.exit_code == 0, result.stderr
    return str(out)


@pytest.mark.parametrize("capture", [None, "360"])
def test_a_raw_partial_arc_said_to_be_a_whole_circle_is_refused_naming_capture_arc(tmp_path, capture):
    """Before: the 220 deg run, spread over 360 deg, was refused as a fit its traces do not
    determine (or as a backlash no machine has), with no word of capture_arc_deg."""
    path = _simulated(tmp_path, "--capture-arc", "220", "--start-angle", "-20", "--direction", "cw")
    lines = open(path).read().splitlines()
    text = [line for line in lines if not line.startswith("# capture_arc_deg")]
    if capture is not None:
        text.insert(1, f"# capture_arc_deg = {capture}")
    with open(path, "w") as file:
        file.write("\n".join(text) + "\n")
    with pytest.raises(MeasurementError) as raised:
        read_ballbar(path)
    said = "the file says 360" if capture else "without it, 360 is assumed"
    message = str(raised.value)
    assert message.startswith(f"{path}:{len(text)}: error: the last reading and the first differ by ")
    assert message.endswith(f"give the arc they span as capture_arc_deg ({said})")
    result = CliRunner().invoke(main, ["ballbar", path], catch_exceptions=False)
    assert result.exit_code == 3 and result.stdout == "" and "capture_arc_deg" in result.stderr


@pytest.mark.parametrize("options", [(), ("--capture-arc", "220", "--start-angle", "-20")])
def test_raw_traces_that_say_their_arc_are_read(tmp_path, options):
    trace = read_ballbar(_simulated(tmp_path, *options))
    assert trace.raw and trace.arc[1] == pytest.approx(360.0 if not options else 220.0, abs=1.0)


@pytest.mark.parametrize("key", ["center_x_mm", "center_z_mm"])
def test_a_test_centre_beyond_any_lathes_travel_is_refused_at_its_line(tmp_path, key):
    path = tmp_path / "c.csv"
    rows = "".join(f"{a},0.001\n" for a in range(0, 360, 5))
    path.write_text(f"# postproc ballbar 1\n# radius_mm = 100\n# direction = ccw\n# {key} = 250000\n"
                    f"angle_deg,deviation_mm\n{rows}")
    with pytest.raises(MeasurementError) as raised:
        read_ballbar(str(path))
    assert str(raised.value) == (f"{path}:4: error: {key} = 250000: 250000 mm from the work origin is beyond any "
                                 "lathe's travel (10000 mm): micrometres written as millimetres? (250000 um is 250 mm)")


def repeated_one_by_one(angles) -> tuple[int, int] | None:
    """The definition: the first sample whose angle (modulo 360, to 1e-9 deg) an earlier one has."""
    seen: dict[float, int] = {}
    for index, angle in enumerate(angles):
        key = round(float(angle) % 360.0, 9) % 360.0
        if key in seen:
            return index, seen[key]
        seen[key] = index
    return None


near = st.sampled_from([0.0, 359.9999999996, 360.0, 12.5, 12.5000000004, 12.5000000006, 12.4999999995, 90.0,
                        180.0000000005, 180.0, 359.0])
angle = near | st.floats(0.0, 360.0, allow_nan=False)
jitter = st.sampled_from([0.0, 1e-10, -1e-10, 4e-10, 6e-10, -5e-10, 1.5e-9, 2e-9, 3e-9])


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(angle, jitter), min_size=0, max_size=25))
def test_repeated_angle_is_the_first_repeat_one_by_one(pairs):
    angles = np.mod(np.array([a + j for a, j in pairs], dtype=float), 360.0)
    assert repeated_angle(angles) == repeated_one_by_one(angles)


def test_reading_a_trace_does_no_python_work_per_sample(tmp_path):
    """Ten times the samples, about the same Python: a loop per sample (a row's list, a dict of
    angles) or per lag of the Newey-West sum would be millions of lines more."""
    small = write_trace(tmp_path / "small.csv", 20_000, "ccw", seed=2)
    large = write_trace(tmp_path / "large.csv", 200_000, "ccw", seed=3)
    raw = write_trace(tmp_path / "raw.csv", 200_000, "cw", seed=4, raw=True)
    few, _ = python_lines(read_ballbar, str(small))
    many, trace = python_lines(read_ballbar, str(large))
    raw_lines, raw_trace = python_lines(read_ballbar, str(raw))
    assert len(trace.angles) == 200_000 and len(raw_trace.angles) == 200_000 // 6
    assert many < 2 * few + 1000, (few, many)
    assert raw_lines < 2 * few + 1000, (few, raw_lines)


def test_reading_a_trace_holds_a_few_arrays_per_sample(tmp_path):
    """The peak (the file's text, the set-up centre's fit) in bytes per sample: the arrays of
    the fit, not a Python object per row (the reader once held 730 bytes a sample)."""
    count = 200_000
    path = write_trace(tmp_path / "long.csv", count, "cw", seed=5)
    peak, trace = peak_bytes(read_ballbar, str(path))
    assert trace.rows.min() == 6 and trace.rows.max() == count + 5
    assert peak < 600 * count, f"{peak / count:.0f} bytes per sample"
