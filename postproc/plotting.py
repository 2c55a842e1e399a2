"""Figures of ballbar traces, written to .png or .svg by the file's extension.

The polar plot is drawn the way the G18 plane is seen from +Y: Z to the right, X up, so a
G02 (cw) run goes clockwise on the page. The nominal circle is drawn at a fixed size and the
deviation is magnified about it, with rings at plus and minus a round number of micrometres
that the legend states. A partial arc (a lathe's XZ test, ISO 13041-6) is drawn as measured:
the trace stops where the capture stops, and the part of the nominal circle no trace covers
is dotted; no line crosses a gap between samples. matplotlib is imported inside the functions (importing postproc stays
fast) and only its object API is used (no pyplot, no global backend switch).
"""

from __future__ import annotations

import io
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from .ballbar_fit import MAX_GAP_DEG
from .diagnostics import UsageError
from .measurements.ballbar import BallbarTrace
from .output import write_atomically

FORMATS = (".png", ".svg")
COLOURS = {"ccw": "tab:blue", "cw": "tab:red"}
BAND = 0.3  #: the ring at the scale's deviation sits this fraction of the nominal radius away


def plot_traces(traces: Sequence[BallbarTrace], path: str, title: str | None = None) -> None:
    """Polar plot of traces: deviation magnified about the nominal circle, one colour per direction."""
    _check(path)
    from matplotlib.figure import Figure

    scale_um = _round_up(max(float(np.abs(t.deviations).max()) for t in traces) * 1000.0)
    figure = Figure(figsize=(6.4, 6.4))
    axes = figure.add_subplot()
    ring = np.linspace(0.0, 360.0, 721)
    covered = np.zeros(ring.size, dtype=bool)
    for trace in traces:
        covered |= np.isfinite(trace.at(ring))
    for offset, style in ((0.0, "-"), (-1.0, ":"), (1.0, ":")):
        radius = 1.0 + offset * BAND
        inside = covered if offset == 0.0 else np.ones(ring.size, dtype=bool)
        for part, line in ((inside, style), (~inside, ":")):
            if part.any():
                shown = np.radians(np.where(part, ring, np.nan))
                axes.plot(radius * np.sin(shown), radius * np.cos(shown), line, color="grey", linewidth=0.8)
    radii = sorted({t.radius for t in traces})
    for trace in traces:
        theta, deviation = along_arc(trace)
        radius = 1.0 + deviation * 1000.0 / scale_um * BAND
        theta = np.radians(theta)
        named = f" R{trace.radius:g}" if len(radii) > 1 else ""
        axes.plot(radius * np.sin(theta), radius * np.cos(theta), color=COLOURS[trace.direction], linewidth=1.0,
                  linestyle="-" if len(radii) == 1 else ("-", "--", "-.", ":")[radii.index(trace.radius) % 4],
                  label=f"{trace.direction.upper()} ({'G02' if trace.cw else 'G03'}){named}")
    axes.set_aspect("equal")
    axes.set_axis_off()
    limit = 1.0 + 1.9 * BAND
    axes.set_xlim(-limit, limit)
    axes.set_ylim(-limit, limit)
    axes.annotate("+Z", (1.0 + 1.6 * BAND, 0.0), ha="center", va="center")
    axes.annotate("+X", (0.0, 1.0 + 1.6 * BAND), ha="center", va="center")
    axes.legend(loc="lower right", fontsize="small")
    radius_mm = traces[0].radius
    spans = sorted({round(t.arc[1]) for t in traces if t.arc[1] < 360.0})
    partial = f", partial arc {'/'.join(f'{s:g}' for s in spans)} deg (ISO 13041-6)" if spans else ""
    axes.set_title(title or f"Ballbar, R = {', '.join(f'{r:g}' for r in radii)} mm{partial}", fontsize="medium")
    magnification = BAND * radius_mm * 1000.0 / scale_um
    figure.text(0.5, 0.03, f"nominal circle solid{' (dotted: not measured)' if spans else ''}; dotted rings "
                f"at \u00b1{scale_um:g} um "
                f"(deviation magnified \u00d7{magnification:,.0f})", ha="center", fontsize="small")
    _save(figure, path)


def along_arc(trace: BallbarTrace) -> tuple[np.ndarray, np.ndarray]:
    """Angles (degrees, increasing from the start of the captured arc, unwrapped) and deviations,
    with NaN between samples further apart than MAX_GAP_DEG so that no line crosses a gap; a
    whole circle comes back closed."""
    start, span = trace.arc
    along = np.mod(trace.angles - start, 360.0)
    start = start - 360.0 if start > 180.0 else start  # an arc across +X reads -20 .. 200, not 340 .. 560
    order = np.argsort(along, kind="stable")
    angles, deviations = start + along[order], trace.deviations[order]
    if span >= 360.0:
        return np.append(angles, angles[0] + 360.0), np.append(deviations, deviations[0])
    gaps = np.flatnonzero(np.diff(angles) > MAX_GAP_DEG) + 1
    return np.insert(angles, gaps, np.nan), np.insert(deviations, gaps, np.nan)


def plot_deviation_vs_angle(series: Sequence[tuple[str, Sequence[float], Sequence[float]]], path: str,
                            title: str | None = None) -> None:
    """Deviation in um against theta in degrees; ``series`` are (label, angles_deg, deviations_mm)."""
    _check(path)
    from matplotlib.figure import Figure

    figure = Figure(figsize=(8.0, 4.5))
    axes = figure.add_subplot()
    for label, angles, deviations in series:
        axes.plot(angles, np.asarray(deviations, dtype=float) * 1000.0, label=label, linewidth=1.0)
    axes.axhline(0.0, color="grey", linewidth=0.8)
    axes.set_xlabel("theta (deg, from +X towards +Z)")
    axes.set_ylabel("deviation (um)")
    axes.grid(True, linewidth=0.3)
    axes.legend(fontsize="small")
    if title:
        axes.set_title(title, fontsize="medium")
    _save(figure, path)


def _check(path: str) -> None:
    if Path(path).suffix.lower() not in FORMATS:
        raise UsageError(f"a plot is written as {' or '.join(FORMATS)}, not {path!r}")


def _save(figure, path: str) -> None:
    """Render in memory, then write all or nothing (output.py), so a failed run leaves no half file."""
    buffer = io.BytesIO()
    kind = Path(path).suffix.lower()[1:]
    figure.savefig(buffer, format=kind, metadata={"Date": None} if kind == "svg" else None)
    write_atomically(path, buffer.getvalue())


def _round_up(value_um: float) -> float:
    """The smallest of 1, 2, 5 times a power of ten that is at least ``value_um``."""
    if value_um <= 0.0:
        return 1.0
    power = 10.0 ** math.floor(math.log10(value_um))
    return next(step * power for step in (1.0, 2.0, 5.0, 10.0) if step * power >= value_um)
