"""Ballbar traces: reading both forms of docs/formats.md §4 and the processing of
docs/methods.md §3.1-§3.2.

A trace is the radial deviation (bar length minus nominal radius; positive outside the
circle) against theta about the test centre, in one direction of travel: ``ccw`` is the
G03 run (theta decreasing), ``cw`` the G02 run (theta increasing).

The raw form has readings in time order and no angles: they are averaged in groups of six
(a setting), given evenly spaced angles over the captured arc in the test's direction (the
averaged sample takes the mean angle of its members), and the set-up centre is removed by
least squares. A ballbar mounted off the machine's circle centre by (a, b) adds
``a cos(theta) + b sin(theta)`` to the trace to first order; scaling, squareness, servo
mismatch and backlash have no first harmonic, so removing it takes out the set-up and
nothing else. ``centered = true`` skips that removal.
"""

from __future__ import annotations

import datetime as dt
import math
from dataclasses import dataclass, field

import numpy as np

from ..diagnostics import Location, MeasurementError, Reporter
from .csvfile import read_table

MAGIC = "# postproc ballbar 1"
KEYS = {"radius_mm", "direction", "center_x_mm", "center_z_mm", "feed_mm_min", "start_angle_deg",
        "capture_arc_deg", "centered"}
PROCESSED = ["angle_deg", "deviation_mm"]
RAW = ["deviation_mm"]


@dataclass(frozen=True)
class BallbarTrace:
    path: str
    radius: float  #: nominal bar length, mm
    direction: str  #: "ccw" (G03) or "cw" (G02)
    centre: tuple[float, float]  #: nominal test centre (x, z), mm
    angles: np.ndarray  #: theta, degrees in [0, 360), increasing
    deviations: np.ndarray  #: mm, set-up centre removed
    setup_centre: tuple[float, float] = (0.0, 0.0)  #: the removed centre offset (x, z), mm
    centered: bool = False
    feed: float | None = None
    raw: bool = False
    extras: dict[str, str] = field(default_factory=dict)
    measured: dt.datetime | None = None  #: when the trace was measured, if the file says

    @property
    def cw(self) -> bool:
        return self.direction == "cw"

    @property
    def full(self) -> bool:
        """Whether the samples go all the way round (no gap larger than 10 degrees)."""
        return self.max_gap() <= 10.0

    def max_gap(self, start: float | None = None, end: float | None = None) -> float:
        """Largest angular gap between samples, over the whole circle or within [start, end]."""
        angles = self.angles
        if start is None:
            gaps = np.diff(np.concatenate([angles, [angles[0] + 360.0]]))
            return float(gaps.max())
        span = (end - start) % 360.0 or 360.0
        if span >= 360.0:
            return self.max_gap(None)
        inside = np.sort((angles - start) % 360.0)
        inside = inside[inside <= span]
        points = np.concatenate([[0.0], inside, [span]])
        return float(np.diff(points).max())

    def require(self, start: float, end: float, max_gap: float, use: str) -> None:
        """Refuse the trace when it leaves a gap larger than ``max_gap`` degrees in [start, end]."""
        if len(self.angles) < 3:
            raise MeasurementError(f"{len(self.angles)} samples are too few for {use}", Location(self.path))
        gap = self.max_gap(start, end)
        if gap > max_gap:
            raise MeasurementError(
                f"a gap of {gap:.1f} deg in the trace between {start:.1f} and {end:.1f} deg; {use} allows {max_gap:g} deg",
                Location(self.path),
            )

    def at(self, theta_deg) -> np.ndarray:
        """Deviation at angles (degrees), interpolated linearly and periodically."""
        theta = np.mod(np.asarray(theta_deg, dtype=float), 360.0)
        angles = np.concatenate([self.angles[-1:] - 360.0, self.angles, self.angles[:1] + 360.0])
        values = np.concatenate([self.deviations[-1:], self.deviations, self.deviations[:1]])
        return np.interp(theta, angles, values)

    def points(self) -> np.ndarray:
        """The measured path as (x, z) points about the nominal centre."""
        theta = np.radians(self.angles)
        r = self.radius + self.deviations
        return np.column_stack([self.centre[0] + r * np.cos(theta), self.centre[1] + r * np.sin(theta)])


def average(values: np.ndarray, group: int) -> tuple[np.ndarray, int]:
    """Means of consecutive groups; returns them and how many trailing values were dropped."""
    whole = len(values) // group
    dropped = len(values) - whole * group
    return values[: whole * group].reshape(whole, group).mean(axis=1), dropped


def raw_angles(count: int, start: float, capture: float, cw: bool) -> np.ndarray:
    """Angles of evenly spaced raw samples: sample i at start + s i capture / n (docs/formats.md §4)."""
    sign = 1.0 if cw else -1.0
    return start + sign * np.arange(count) * capture / count


def centre_offset(angles_deg: np.ndarray, deviations: np.ndarray) -> tuple[float, float]:
    """The least-squares set-up centre (x, z) of a trace: its first harmonic."""
    theta = np.radians(angles_deg)
    design = np.column_stack([np.ones_like(theta), np.cos(theta), np.sin(theta)])
    solution, *_ = np.linalg.lstsq(design, deviations, rcond=None)
    return float(solution[1]), float(solution[2])


def read_ballbar(path: str, reporter: Reporter | None = None, averaging: int = 6, max_deviation: float = 1.0) -> BallbarTrace:
    """Read and process a trace in either form; refuses every problem with its position."""
    table = read_table(path, MAGIC, KEYS, [PROCESSED, RAW])
    radius = table.number("radius_mm", positive=True, required=True)
    direction = table.choice("direction", ("ccw", "cw"), required=True)
    centre = (table.number("center_x_mm", 0.0), table.number("center_z_mm", 0.0))
    feed = table.number("feed_mm_min", positive=True)
    centered = table.flag("centered")
    raw = table.columns == RAW
    deviations = np.array(table.column("deviation_mm"))
    for (line, values), value in zip(table.rows, deviations):
        if abs(value) > max_deviation:
            raise table.error(f"deviation {value:g} mm is beyond {max_deviation:g} mm: not a plausible ballbar reading", line)

    if raw:
        start = table.number("start_angle_deg", required=True)
        capture = table.number("capture_arc_deg", 360.0, positive=True)
        if capture > 360.0:
            raise table.error("capture_arc_deg cannot exceed 360", table.header["capture_arc_deg"][1])
        angles = raw_angles(len(deviations), start, capture, direction == "cw")
        if averaging > 1:
            deviations, dropped = average(deviations, averaging)
            angles, _ = average(angles, averaging)
            if dropped and reporter is not None:
                reporter.warn(f"the last {dropped} readings do not fill a group of {averaging}; they are not used",
                              Location(path))
        angles = np.mod(angles, 360.0)
    else:
        for key in ("start_angle_deg", "capture_arc_deg"):
            if key in table.header:
                raise table.error(f"{key} belongs to the raw form (angles are given here)", table.header[key][1])
        written = np.array(table.column("angle_deg"))
        angles = np.mod(written, 360.0)
        seen: dict[float, int] = {}
        for (line, _), angle, as_written in zip(table.rows, angles, written):
            key = round(float(angle), 9) % 360.0
            if key in seen:
                same = "" if angle == as_written else f" ({angle:g} deg)"
                raise table.error(f"angle {as_written:g} deg{same} again (first on line {seen[key]})", line)
            seen[key] = line
    if len(deviations) < 3:
        raise table.error(f"{len(deviations)} samples: a trace needs at least 3")
    order = np.argsort(angles, kind="stable")
    angles, deviations = angles[order], deviations[order]

    setup = (0.0, 0.0)
    if not centered:
        trace = BallbarTrace(path, radius, direction, centre, angles, deviations)
        if trace.max_gap() > 180.0:
            raise table.error(
                f"the trace covers too little of the circle (a gap of {trace.max_gap():.0f} deg) to find its set-up "
                "centre; give '# centered = true' if it is already centred"
            )
        setup = centre_offset(angles, deviations)
        theta = np.radians(angles)
        deviations = deviations - setup[0] * np.cos(theta) - setup[1] * np.sin(theta)
    return BallbarTrace(path, radius, direction, centre, angles, deviations, setup, centered, feed, raw, table.extras,
                        table.measured)


def pair(traces: list[BallbarTrace]) -> tuple[BallbarTrace, BallbarTrace]:
    """The CCW and the CW trace of one test, refusing traces of different tests."""
    if len(traces) != 2:
        raise MeasurementError(f"a CCW and a CW trace of one test are needed, {len(traces)} given",
                               Location(traces[0].path if traces else "<ballbar>"))
    by_direction = {trace.direction: trace for trace in traces}
    if set(by_direction) != {"ccw", "cw"}:
        raise MeasurementError("the two traces must be one ccw (G03) and one cw (G02) run", Location(traces[1].path))
    ccw, cw = by_direction["ccw"], by_direction["cw"]
    if not math.isclose(ccw.radius, cw.radius, rel_tol=1e-9, abs_tol=1e-9) or ccw.centre != cw.centre:
        raise MeasurementError(
            f"the traces are of different tests: radius {ccw.radius:g}/{cw.radius:g} mm, centre {ccw.centre}/{cw.centre}",
            Location(cw.path),
        )
    return ccw, cw
