"""Figures of ballbar traces, written to .png or .svg by the file's extension.

The polar plot is the one shops know from their ballbar software: the G18 plane seen from +Y
(Z to the right, X up, so a G02 (cw) run goes clockwise on the page), the nominal circle at a
fixed size and the deviation magnified about it, with rings a round number of micrometres
apart, each labelled with its deviation, and the magnification stated. Beside it, the test
(radius, feed, captured arc, when it was measured, the files) and its figures: the ISO 230-4
circular test (G per direction, G(b), H; ISO 13041-6 named for a lathe's partial arc) and the
diagnosis (backlash, scaling, squareness, servo mismatch, each with its 1-sigma uncertainty),
named and in the units of :mod:`postproc.report.quantities`. It is A4 wide at 150 dpi, so it
prints. A partial arc (ISO 13041-6) is drawn as measured: the trace stops where the capture
stops, the part of the nominal circle no trace covers is dotted, and no line crosses a gap
between samples. matplotlib is imported inside the functions (importing postproc stays fast)
and only its object API is used (no pyplot, no global backend switch).
"""

from __future__ import annotations

import datetime as dt
import io
import math
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..measure.ballbar_fit import MAX_GAP_DEG
from ..diagnostics import MeasurementError, UsageError
from ..measure.readers.ballbar import BallbarTrace
from ..files.output import write_atomically

FORMATS = (".png", ".svg")
COLOURS = {"ccw": "tab:blue", "cw": "tab:red"}
BAND = 0.36  #: the outermost ring sits this fraction of the nominal radius outside the nominal circle
A4_WIDTH_IN = 8.27  #: the polar plot prints across an A4 page
PRINT_DPI = 150
DRAWN_POINTS = 20000  #: points of a trace drawn at most (along_arc): a page shows far fewer
FIT = object()  #: plot_traces(diagnosis=FIT): diagnose the traces to write the diagnosis on the plot
DIAGNOSIS_SHOWN = ("backlash_x", "backlash_z", "scaling_x", "scaling_z", "squareness", "servo_mismatch",
                   "apparent_squareness")


def plot_traces(traces: Sequence[BallbarTrace], path: str, title: str | None = None, *, test=None,
                diagnosis=FIT, measured: str | None = None) -> None:
    """Polar plot of traces with the test's figures written beside it.

    ``test`` is the ISO 230-4 circular test of the first test's traces (computed when not
    given); ``diagnosis`` the parametric diagnosis (fitted here by default; None leaves it
    off); ``measured`` when the traces were taken (by default each file's ``measured`` header
    key, or its modification time).
    """
    _check(path)
    from matplotlib.figure import Figure

    from ..measure.ballbar_analysis import circular_test, diagnose, tests

    traces = list(traces)
    reason = ""
    if test is None:
        try:
            test = circular_test(tests(traces)[0])
        except MeasurementError as exc:
            reason = exc.message
    if diagnosis is FIT:
        try:
            diagnosis = diagnose(traces)
        except MeasurementError as exc:
            diagnosis, reason = None, exc.message
    peak = max(float(np.nanmax(np.abs(t.deviations))) for t in traces) * 1000.0
    step = _round_up(peak / 3.0)  #: um between rings
    rings = max(1, math.ceil(peak / step - 1e-9))
    scale_um = rings * step  #: the outermost ring's deviation
    figure = Figure(figsize=(A4_WIDTH_IN, 6.2), dpi=PRINT_DPI)
    axes = figure.add_axes((0.01, 0.0, 0.58, 0.9))
    covered = _polar_grid(axes, traces, step, rings, scale_um)
    radii = sorted({t.radius for t in traces})
    for trace in traces:
        theta, deviation = along_arc(trace)
        radius = 1.0 + deviation * 1000.0 / scale_um * BAND
        theta = np.radians(theta)
        named = f" R{trace.radius:g}" if len(radii) > 1 else ""
        axes.plot(radius * np.sin(theta), radius * np.cos(theta), color=COLOURS[trace.direction], linewidth=1.1,
                  linestyle="-" if len(radii) == 1 else ("-", "--", "-.", ":")[radii.index(trace.radius) % 4],
                  label=f"{trace.direction.upper()} ({'G02' if trace.cw else 'G03'}){named}")
    axes.legend(loc="lower right", fontsize=8, framealpha=0.9)
    radius_mm = traces[0].radius
    magnification = BAND * radius_mm * 1000.0 / scale_um
    partial = not covered.all()
    figure.text(0.02, 0.965, title or ("Ballbar test, ISO 230-4" + (" / ISO 13041-6 (partial arc)" if partial else "")),
                fontsize=13, fontweight="bold", va="top")
    figure.text(0.02, 0.925, "the XZ plane seen from +Y: Z to the right, X up; cw (G02) runs clockwise",
                fontsize=8, color="0.3", va="top")
    lines = _test_lines(traces, radii, measured) + [("", "")] + _iso_lines(test) + [("", "")]
    lines += _diagnosis_lines(diagnosis, reason) + [("", "")]
    lines += [("Scale", None), ("rings every", f"{step:g} um"), ("outermost ring", f"\u00b1{scale_um:g} um"),
              ("deviation magnified", f"\u00d7{magnification:,.0f}"),
              ("nominal circle", "solid" + (" (dotted: not measured)" if partial else ""))]
    _panel(figure, lines)
    _save(figure, path)


def _polar_grid(axes, traces, step: float, rings: int, scale_um: float) -> np.ndarray:
    """The nominal circle (dotted where no trace covers it), the labelled rings, the axes; returns
    which of 721 angles from 0 to 360 deg a trace covers."""
    ring = np.linspace(0.0, 360.0, 721)
    covered = np.zeros(ring.size, dtype=bool)
    for trace in traces:
        covered |= np.isfinite(trace.at(ring))
    label_at = _label_angle(ring, covered)
    for k in range(-rings, rings + 1):
        radius = 1.0 + k * step / scale_um * BAND
        nominal = k == 0
        for part, line in ((covered if nominal else np.ones(ring.size, dtype=bool), "-"), (~covered, ":")):
            if part.any() and (nominal or line == "-"):
                shown = np.radians(np.where(part, ring, np.nan))
                axes.plot(radius * np.sin(shown), radius * np.cos(shown), line,
                          color="0.25" if nominal else "0.78", linewidth=1.3 if nominal else 0.6, zorder=1)
        if nominal:  # the nominal circle is the drawn one: its 0 would crowd the traces
            continue
        text = f"{k * step:+g}" + (" um" if abs(k) == rings else "")
        angle = math.radians(label_at)
        upright = (90.0 - label_at) % 180.0 - 90.0  # along the ring, never upside down
        axes.text(radius * math.sin(angle), radius * math.cos(angle), text, fontsize=7, ha="center", va="center",
                  rotation=upright, rotation_mode="anchor", color="0.2", zorder=5,
                  bbox={"boxstyle": "round,pad=0.12", "fc": "white", "ec": "none", "alpha": 0.85})
    inner, outer = 1.0 - 1.08 * BAND, 1.0 + 1.08 * BAND
    for angle, name in ((0.0, "+X"), (90.0, "+Z"), (180.0, "-X"), (270.0, "-Z")):
        a = math.radians(angle)
        axes.plot([inner * math.sin(a), outer * math.sin(a)], [inner * math.cos(a), outer * math.cos(a)],
                  color="0.78", linewidth=0.6, zorder=1)
        axes.text((outer + 0.08) * math.sin(a), (outer + 0.08) * math.cos(a), f"{name}\n{angle:g}\u00b0",
                  fontsize=8, ha="center", va="center", color="0.25")
    axes.set_aspect("equal")
    axes.set_axis_off()
    limit = 1.0 + 1.6 * BAND
    axes.set_xlim(-limit, limit)
    axes.set_ylim(-limit, limit)
    return covered


def _label_angle(ring: np.ndarray, covered: np.ndarray) -> float:
    """Where the rings are labelled: in the middle of the widest arc no trace covers (kept clear of
    the axes' names), else at 225 deg."""
    if covered.all():
        return 225.0
    free = np.concatenate([~covered, ~covered])
    best, start, length = (0, 0), None, 0
    for index, empty in enumerate(free):
        if empty:
            start = index if start is None else start
            length = index - start + 1
            if length > best[1]:
                best = (start, length)
        else:
            start = None
    middle = float(ring[int(best[0] + best[1] / 2.0) % ring.size])
    off_axis = (middle + 45.0) % 90.0 - 45.0  # degrees from the nearest axis, whose name is written there
    return middle + (12.0 - abs(off_axis)) * (1.0 if off_axis >= 0 else -1.0) if abs(off_axis) < 12.0 else middle


def _test_lines(traces, radii, measured: str | None) -> list[tuple[str, str | None]]:
    from ..measure.ballbar_fit import arc_text

    feeds = sorted({t.feed for t in traces if t.feed is not None})
    lines: list[tuple[str, str | None]] = [("The test", None),
                                           ("radius", ", ".join(f"{r:g}" for r in radii) + " mm"),
                                           ("feed", ", ".join(f"{f:g}" for f in feeds) + " mm/min" if feeds
                                            else "not stated")]
    for trace in traces:
        lines.append((f"{trace.direction} ({'G02' if trace.cw else 'G03'})",
                      f"{os.path.basename(trace.path)}: {arc_text(trace)}"))
    lines.append(("measured", measured or _measured(traces)))
    return lines


def _measured(traces) -> str:
    """When the traces were taken: their ``measured`` header key, else their files' time."""
    from ..measure.readers.csvfile import measured_time

    times, stated = [], True
    for trace in traces:
        moment = measured_time(trace.path) if os.path.isfile(trace.path) else None
        if moment is None and os.path.isfile(trace.path):
            moment, stated = dt.datetime.fromtimestamp(os.stat(trace.path).st_mtime, dt.timezone.utc), False
        if moment is not None:
            times.append(moment)
    if not times:
        return "not recorded"
    return moment_text(min(times)) + ("" if stated else " (file time)")


def moment_text(moment: dt.datetime) -> str:
    """A measurement's time as the plot and the report state it: to the minute, in UTC."""
    return moment.astimezone(dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")


def _iso_lines(test) -> list[tuple[str, str | None]]:
    if test is None:
        return [("ISO 230-4 circular test", None), ("figures", "none: the traces cannot support them")]
    partial = any(d.arc[1] < 360.0 for d in test.by_direction)
    lines: list[tuple[str, str | None]] = [("ISO 230-4" + (" / 13041-6" if partial else "") + " circular test", None)]
    for d in test.by_direction:
        lines.append((f"G, circular deviation {d.direction}", f"{d.circular_deviation * 1000:.2f} um"))
    if test.bidirectional_deviation is not None:
        lines.append(("G(b), bidirectional", f"{test.bidirectional_deviation * 1000:.2f} um"))
    if test.hysteresis is not None:
        lines.append(("H, circular hysteresis", f"{test.hysteresis * 1000:.2f} um"))
    return lines


def _diagnosis_lines(diagnosis, reason: str) -> list[tuple[str, str | None]]:
    from .quantities import quantity, with_sigma

    if diagnosis is None:
        return [("Diagnosis", None), ("", "not fitted" + (f": {reason[:60]}" if reason else ""))]
    lines: list[tuple[str, str | None]] = [("Diagnosis (\u00b1 1 sigma)", None)]
    values = diagnosis.parameters()
    for name in DIAGNOSIS_SHOWN:
        if name not in values:
            continue
        found = quantity(name)
        value, sigma = with_sigma(found.value(values[name].value), found.value(values[name].sigma))
        lines.append((found.name, f"{value} \u00b1 {sigma} {found.unit}" if sigma else f"{value} {found.unit}"))
    lag = diagnosis.servo_lag_ms
    if lag is not None:
        found = quantity("servo_lag_ms")
        value, sigma = with_sigma(lag.value, lag.sigma)
        lines.append((found.name, f"{value} \u00b1 {sigma} {found.unit}" if sigma else f"{value} {found.unit}"))
    lines.append(("fit residual, RMS", f"{diagnosis.residual.rms:.2f} um"))
    return lines


def _panel(figure, lines: list[tuple[str, str | None]]) -> None:
    """The figures beside the plot: a heading (value None), or a name and its value."""
    y, left, right = 0.90, 0.605, 0.985
    for name, value in lines:
        if value is None:
            figure.text(left, y, name, fontsize=9, fontweight="bold", va="top")
        elif name or value:
            figure.text(left + 0.01, y, name, fontsize=8, va="top", color="0.2")
            figure.text(right, y, value, fontsize=8, va="top", ha="right")
        y -= 0.026 if (name or value) else 0.012


def along_arc(trace: BallbarTrace, most: int = DRAWN_POINTS) -> tuple[np.ndarray, np.ndarray]:
    """Angles (degrees, increasing from the start of the captured arc, unwrapped) and deviations,
    with NaN between samples further apart than MAX_GAP_DEG so that no line crosses a gap; a
    whole circle comes back closed. For drawing only: a trace of more than ``most`` samples is
    thinned to about ``most`` (:func:`drawn`); every figure and fit takes the trace itself."""
    start, span = trace.arc
    along = np.mod(trace.angles - start, 360.0)
    start = start - 360.0 if start > 180.0 else start  # an arc across +X reads -20 .. 200, not 340 .. 560
    order = np.argsort(along, kind="stable")
    angles, deviations = start + along[order], trace.deviations[order]
    if span >= 360.0:
        angles, deviations = drawn(angles, deviations, most)
        return np.append(angles, angles[0] + 360.0), np.append(deviations, deviations[0])
    gaps = np.flatnonzero(np.diff(angles) > MAX_GAP_DEG) + 1
    runs = [drawn(a, d, max(2, most * len(a) // len(angles)))
            for a, d in zip(np.split(angles, gaps), np.split(deviations, gaps))]
    angles, deviations = (np.concatenate([part[k] for part in runs]) for k in (0, 1))
    gaps = np.cumsum([len(part[0]) for part in runs[:-1]], dtype=int)
    return np.insert(angles, gaps, np.nan), np.insert(deviations, gaps, np.nan)


def drawn(angles: np.ndarray, deviations: np.ndarray, most: int) -> tuple[np.ndarray, np.ndarray]:
    """At most about ``most`` of the points of a line, chosen so that it draws as the whole: in
    each run of consecutive points, its first and last and its lowest and highest deviation
    (a spike stays in the drawing). A page shows a few thousand points across; a trace of
    millions would cost matplotlib minutes and gigabytes to draw the same picture."""
    count = len(angles)
    if count <= most:
        return angles, deviations
    size = math.ceil(4 * count / most)
    keep = np.zeros(count, dtype=bool)
    keep[::size] = keep[size - 1::size] = True
    keep[-1] = True
    whole = count // size * size
    rows = deviations[:whole].reshape(-1, size)  # a view: no copy of the trace
    starts = np.arange(0, whole, size)
    keep[starts + rows.argmin(axis=1)] = keep[starts + rows.argmax(axis=1)] = True
    if whole < count:
        tail = deviations[whole:]
        keep[whole + tail.argmin()] = keep[whole + tail.argmax()] = True
    return angles[keep], deviations[keep]


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
    """Render in memory, then write all or nothing (output.py), so a failed run leaves no half file.
    An SVG keeps its text as text (searchable, selectable, read by the tests), not as outlines."""
    import matplotlib

    buffer = io.BytesIO()
    kind = Path(path).suffix.lower()[1:]
    with matplotlib.rc_context({"svg.fonttype": "none"}):
        figure.savefig(buffer, format=kind, metadata={"Date": None} if kind == "svg" else None)
    write_atomically(path, buffer.getvalue())


def _round_up(value_um: float) -> float:
    """The smallest of 1, 2, 5 times a power of ten that is at least ``value_um``."""
    if value_um <= 0.0:
        return 1.0
    power = 10.0 ** math.floor(math.log10(value_um))
    return next(step * power for step in (1.0, 2.0, 5.0, 10.0) if step * power >= value_um)
