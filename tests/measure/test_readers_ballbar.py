"""postproc.measure.readers.ballbar: reading a trace costs time linear in its samples and no
Python object per sample, and an angle given twice is still found as it always was."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from postproc.measure.readers.ballbar import read_ballbar, repeated_angle
from support.long_traces import peak_bytes, python_lines, write_trace


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
