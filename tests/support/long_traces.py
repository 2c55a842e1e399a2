"""Traces at the scale shops bring (hundreds of thousands of samples), and a count of the Python
work done on them: the tests that keep a trace's cost linear and free of a Python object per
sample without timing anything."""

from __future__ import annotations

import sys
import tracemalloc
from pathlib import Path

import numpy as np

import postproc

PACKAGE = str(Path(postproc.__file__).parent)


def write_trace(path: Path, count: int, direction: str, seed: int = 1, raw: bool = False) -> Path:
    """A processed (or raw) trace of ``count`` samples round R 100: a few ppm of scaling, squareness,
    backlash, a set-up offset, a pitch error, noise correlated along the run and white noise."""
    rng = np.random.default_rng(seed)
    k = 1.0 if direction == "cw" else -1.0
    theta_deg = np.mod(k * np.arange(count) * 360.0 / count, 360.0)
    t = np.radians(theta_deg)
    c, s = np.cos(t), np.sin(t)
    deviation = (100.0 * (4e-6 * c**2 - 3e-6 * s**2) + (12e-6 * 100.0 + k * 0.0015) * s * c
                 + k * 0.002 * np.sign(s) * c - k * 0.0015 * np.sign(c) * s + 0.012 * c - 0.008 * s
                 + 0.0008 * np.sin(7 * t + 0.3))
    noise = rng.normal(0.0, 0.0003 * np.sqrt(1 - 0.995**2), count)
    deviation += _ar1(noise, 0.995) + rng.normal(0.0, 0.0002, count)
    header = (f"# postproc ballbar 1\n# radius_mm = 100\n# direction = {direction}\n# feed_mm_min = 1000\n"
              + ("# start_angle_deg = 0\ndeviation_mm\n" if raw else "angle_deg,deviation_mm\n"))
    columns = [deviation] if raw else [theta_deg, deviation]
    formats = ["%.7f"] if raw else ["%.6f", "%.7f"]
    with open(path, "w") as handle:
        handle.write(header)
        np.savetxt(handle, np.column_stack(columns), fmt=formats, delimiter=",")
    return path


def _ar1(noise: np.ndarray, rho: float) -> np.ndarray:
    """x_i = rho x_(i-1) + noise_i, by the closed form over blocks (no loop per sample)."""
    out = np.empty_like(noise)
    carry = 0.0
    block = 256
    powers = rho ** np.arange(block)
    for first in range(0, len(noise), block):
        part = noise[first: first + block]
        n = len(part)
        # x_j = rho^(j+1) carry + sum_{i<=j} rho^(j-i) part_i
        scaled = part / powers[:n]
        out[first: first + n] = powers[:n] * (rho * carry + np.cumsum(scaled))
        carry = out[first + n - 1]
    return out


def python_lines(call, *args, **kwargs) -> tuple[int, object]:
    """(lines of postproc's own Python run, result) of ``call(*args, **kwargs)``: work done per
    sample in Python, or per lag of a loop, shows as lines that grow with the samples."""
    count = 0

    def local(frame, event, arg):
        nonlocal count
        if event == "line":
            count += 1
        return local

    def calls(frame, event, arg):
        return local if frame.f_code.co_filename.startswith(PACKAGE) else None

    sys.settrace(calls)
    try:
        result = call(*args, **kwargs)
    finally:
        sys.settrace(None)
    return count, result


def peak_bytes(call, *args, **kwargs) -> tuple[int, object]:
    """(the most memory Python and numpy held at once above the start, result) of the call."""
    tracemalloc.start()
    try:
        start = tracemalloc.get_traced_memory()[0]
        result = call(*args, **kwargs)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    return peak - start, result
