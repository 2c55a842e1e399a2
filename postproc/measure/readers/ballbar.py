"""Ballbar traces: reading both forms of formats.md and the processing of docs/methods.md §3.

A trace is the radial deviation (bar length minus nominal radius; positive outside the
circle) against theta about the test centre, in one direction of travel: ``ccw`` is the
G03 run (theta decreasing), ``cw`` the G02 run (theta increasing). It may cover the whole
circle or a partial arc (a lathe's test in XZ stops short of the spindle: about 220 deg,
ISO 13041-6); the captured arc is what the samples span, and nothing here interpolates
across the part of the circle that was not measured.

The raw form has readings in time order and no angles: they are averaged in groups of six
(a setting), given evenly spaced angles over the captured arc in the test's direction (the
averaged sample takes the mean angle of its members), and the set-up centre is removed by
least squares. A ballbar mounted off the machine's circle centre by (a, b) adds
``a cos(theta) + b sin(theta)`` to the trace to first order (and, being the hypotenuse,
``(b cos - a sin)^2 / 2R`` more, which is removed with it). Round the whole circle the
machine's errors have no first harmonic, so that is all the fit removes; on a partial arc they
do, so the centre is fitted jointly with the machine's error model
(:mod:`postproc.measure.ballbar_fit`): only what the model cannot explain goes with the centre.
``centered = true`` skips the removal.

Minimum evidence (refused below it, naming the file): 36 samples (after averaging) over at
least 90 deg of arc. Every reader's traces are held to it (:func:`check_evidence`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import ballbar_fit
from ..ballbar_fit import MAX_GAP_DEG
from ...diagnostics import Location, MeasurementError, Reporter
from ..parameters import BAR_LENGTH_MM, TOO_LONG, bar_length_problem
from .csvfile import read_table
from .lengths import travel_problem

MAGIC = "# postproc ballbar 1"
KEYS = {"radius_mm", "direction", "center_x_mm", "center_z_mm", "feed_mm_min", "start_angle_deg",
        "capture_arc_deg", "centered"}
PROCESSED = ["angle_deg", "deviation_mm"]
RAW = ["deviation_mm"]
MIN_SAMPLES = 36  #: fewest samples (after averaging) a trace may have
MIN_ARC_DEG = 90.0  #: shortest arc a trace may cover
#: the single-direction model the reader's centre is fitted with (ballbar_fit.machine_errors)
CENTRING_MODEL = ("scaling_x", "scaling_z", "backlash_x", "backlash_z", "apparent_squareness")


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
    #: the file's line of each sample (raw form: of the first reading it averages); None when
    #: the samples came from elsewhere (a saved model, a shop reader)
    rows: np.ndarray | None = None

    @property
    def cw(self) -> bool:
        return self.direction == "cw"

    @property
    def full(self) -> bool:
        """Whether the samples go all the way round (no gap larger than MAX_GAP_DEG)."""
        return self.max_gap() <= MAX_GAP_DEG

    @property
    def arc(self) -> tuple[float, float]:
        """The captured arc as (start, span) in degrees, from ``start`` in increasing theta:
        the circle less its widest gap; (0, 360) round the whole circle."""
        angles = self.angles
        gaps = np.diff(np.concatenate([angles, [angles[0] + 360.0]]))
        widest = int(np.argmax(gaps))
        if gaps[widest] <= MAX_GAP_DEG:
            return 0.0, 360.0
        return float(angles[(widest + 1) % len(angles)]), float(360.0 - gaps[widest])

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
        gap = self.max_gap(start, end)
        if gap > max_gap:
            raise MeasurementError(
                f"a gap of {gap:.1f} deg in the trace between {start:.1f} and {end:.1f} deg (it captured "
                f"{ballbar_fit.arc_text(self)}); {use} allows {max_gap:g} deg and does not extrapolate a trace",
                Location(self.path),
            )

    def at(self, theta_deg, max_gap: float | None = MAX_GAP_DEG) -> np.ndarray:
        """Deviation at angles (degrees), interpolated linearly and periodically; NaN between
        samples more than ``max_gap`` degrees apart (outside a partial arc), unless it is None."""
        theta = np.mod(np.asarray(theta_deg, dtype=float), 360.0)
        angles = np.concatenate([self.angles[-1:] - 360.0, self.angles, self.angles[:1] + 360.0])
        values = np.concatenate([self.deviations[-1:], self.deviations, self.deviations[:1]])
        result = np.interp(theta, angles, values)
        if max_gap is not None:
            after = np.searchsorted(angles, theta, side="right").clip(1, len(angles) - 1)
            outside = (angles[after] - angles[after - 1] > max_gap) & (theta != angles[after - 1])
            result = np.where(outside, np.nan, result)
        return result

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
    """Angles of evenly spaced raw samples: sample i at start + s i capture / n (formats.md)."""
    sign = 1.0 if cw else -1.0
    return start + sign * np.arange(count) * capture / count


def raw_samples(readings: np.ndarray, start: float, capture: float, cw: bool, averaging: int,
                reporter: Reporter | None, path: str) -> tuple[np.ndarray, np.ndarray]:
    """Angles and deviations of raw readings (formats.md): evenly spaced over the captured arc in
    the run's direction, averaged in groups (a remainder is dropped, with a warning)."""
    angles = raw_angles(len(readings), start, capture, cw)
    if averaging > 1:
        readings, dropped = average(readings, averaging)
        angles, _ = average(angles, averaging)
        if dropped and reporter is not None:
            reporter.warn(f"the last {dropped} readings do not fill a group of {averaging}; they are not used",
                          Location(path))
    return np.mod(angles, 360.0), readings


#: what an angle given twice most often means, for the messages that refuse it
REPEATED = "a second lap or run in one file? give each run of the test as a file of its own"


def repeated_angle(angles: np.ndarray) -> tuple[int, int] | None:
    """The first sample whose angle (modulo 360, to 1e-9 deg) an earlier one has: (it, the earlier).

    Two angles that round alike lie within about 1e-9 deg of each other, or of 0 and 360: only
    neighbours in sorted order that close are compared, so a trace of millions of samples is
    sorted once and holds no Python object per sample."""
    angles = np.asarray(angles, dtype=float)
    if len(angles) < 2:
        return None
    order = np.argsort(angles, kind="stable")
    ring = angles[order]
    close = np.diff(np.append(ring, ring[0] + 360.0)) <= 2e-9  # each to the next, the last to the first
    suspects = np.sort(order[close | np.roll(close, 1)])
    seen: dict[float, int] = {}
    for index in suspects.tolist():
        key = round(float(angles[index]) % 360.0, 9) % 360.0
        if key in seen:
            return index, seen[key]
        seen[key] = index
    return None


def read_ballbar(path: str, reporter: Reporter | None = None, averaging: int = 6, max_deviation: float = 1.0) -> BallbarTrace:
    """Read and process a trace in either form; refuses every problem with its position."""
    table = read_table(path, MAGIC, KEYS, [PROCESSED, RAW])
    radius = table.number("radius_mm", positive=True, required=True, at_most=(BAR_LENGTH_MM[1], TOO_LONG))
    if radius < BAR_LENGTH_MM[0] and reporter is not None:
        reporter.warn(f"radius_mm = {radius:g} is shorter than any ballbar ({BAR_LENGTH_MM[0]:g} to about 600 mm): "
                      f"right for a grid encoder's small circle; a ballbar's test written in inches or cm is in the "
                      f"wrong unit (every length of the file, the deviations too)", Location(path, table.header["radius_mm"][1]))
    direction = table.choice("direction", ("ccw", "cw"), required=True, meaning="ccw: the G03 run, cw: the G02 run")
    centre = (table.coordinate("center_x_mm", 0.0), table.coordinate("center_z_mm", 0.0))
    feed = table.number("feed_mm_min", positive=True)
    centered = table.flag("centered")
    raw = table.columns == RAW
    deviations = table.column("deviation_mm")
    rows = table.lines
    beyond = np.flatnonzero(np.abs(deviations) > max_deviation)
    if beyond.size:
        value = float(deviations[beyond[0]])
        raise table.error(f"deviation {value:g} mm is beyond {max_deviation:g} mm: not a plausible ballbar reading "
                          "(micrometres written as millimetres?)", int(rows[beyond[0]]))

    if raw:
        start = table.number("start_angle_deg", required=True)
        capture = table.number("capture_arc_deg", 360.0, positive=True)
        if capture > 360.0:
            raise table.error("capture_arc_deg cannot exceed 360", table.header["capture_arc_deg"][1])
        problem = open_ends(deviations) if capture == 360.0 else None
        if problem:
            said = "the file says 360" if "capture_arc_deg" in table.header else "without it, 360 is assumed"
            raise table.error(f"{problem}; give the arc they span as capture_arc_deg ({said})", int(rows[-1]))
        angles, deviations = raw_samples(deviations, start, capture, direction == "cw", averaging, reporter, path)
        rows = rows[::averaging][: len(deviations)]
    else:
        for key in ("start_angle_deg", "capture_arc_deg"):
            if key in table.header:
                raise table.error(f"{key} belongs to the raw form (angles are given here)", table.header[key][1])
        written = table.column("angle_deg")
        angles = np.mod(written, 360.0)
        again = repeated_angle(angles)
        if again is not None:
            row, first = again
            same = "" if angles[row] == written[row] else f" ({angles[row]:g} deg)"
            raise table.error(f"angle {written[row]:g} deg{same} again (first on line {rows[first]}): "
                              f"{REPEATED}", int(rows[row]))
    return make_trace(path, radius, direction, angles, deviations, centre, feed, centered, raw, table.extras,
                      averaging if raw else 1, rows)


#: a whole circle's first and last readings are neighbours: a step between them this many times
#: the largest between any other two (and above CLOSURE_FLOOR_MM) is the two ends of an arc
CLOSURE_RATIO = 3.0
#: mm; what the bar may drift (warming, a few um) between a whole circle's first and last readings
CLOSURE_FLOOR_MM = 0.005


def open_ends(readings: np.ndarray) -> str | None:
    """What says that raw readings taken to go round the whole circle (a capture of 360 deg, the
    default) do not: their last and first readings are not neighbours. A partial arc's ends (a
    lathe's test in XZ runs about 220 deg), spread over 360 deg, would put every reading at the
    wrong angle. A step there several times any other is such a gap; a machine's own step (the
    backlash at a reversal) recurs within the circle at the axis's other reversal. None if they
    close (or are too few to tell)."""
    if len(readings) < MIN_SAMPLES:
        return None
    closure = abs(float(readings[0] - readings[-1]))
    largest = float(np.max(np.abs(np.diff(readings))))
    if closure > CLOSURE_FLOOR_MM and closure > CLOSURE_RATIO * largest:
        return (f"the last reading and the first differ by {closure * 1000:.2f} um, {closure / max(largest, 1e-12):.0f} "
                f"times the largest step between other neighbours ({largest * 1000:.2f} um): on a whole circle they "
                "are neighbours, so these readings do not go round it (a partial arc: a lathe's test in XZ runs about "
                "220 deg)")
    return None


def make_trace(path: str, radius: float, direction: str, angles, deviations, centre: tuple[float, float] = (0.0, 0.0),
               feed: float | None = None, centered: bool = False, raw: bool = False,
               extras: dict[str, str] | None = None, averaging: int = 1, rows=None) -> BallbarTrace:
    """A trace from its samples as any reader finds them: angles (degrees, any order, taken
    modulo 360) and deviations (mm). Sorts them, holds them to the minimum evidence and removes
    the set-up centre (unless ``centered``) as :func:`read_ballbar` does; for shop readers."""
    problem = bar_length_problem(float(radius))
    if problem:
        raise MeasurementError(f"a test radius of {float(radius):g} mm is {problem}", Location(path))
    for axis, value in zip("xz", centre):
        problem = travel_problem(float(value))
        if problem:
            raise MeasurementError(f"the test centre's {axis} = {float(value):g} mm: {problem}", Location(path))
    angles = np.mod(np.asarray(angles, dtype=float), 360.0)
    angles[angles >= 360.0] = 0.0  # np.mod(-1e-17, 360) is 360
    deviations = np.asarray(deviations, dtype=float)
    order = np.argsort(angles, kind="stable")
    trace = BallbarTrace(path, float(radius), direction, (float(centre[0]), float(centre[1])), angles[order],
                         deviations[order], (0.0, 0.0), centered, feed, raw, dict(extras or {}),
                         None if rows is None else np.asarray(rows)[order])
    check_evidence(trace, averaging)
    if centered:
        return trace
    return ballbar_fit.recentred(trace, setup_centre(trace))


def check_evidence(trace: BallbarTrace, averaging: int = 1) -> None:
    """Refuse a trace too thin to trust: fewer than MIN_SAMPLES samples or MIN_ARC_DEG of arc."""
    count = len(trace.angles)
    if count < MIN_SAMPLES:
        made = f" (averaged from {count * averaging} readings, {averaging} each)" if averaging > 1 else ""
        raise MeasurementError(f"{count} samples{made}: a trace needs at least {MIN_SAMPLES}, over at least "
                               f"{MIN_ARC_DEG:g} deg of arc", Location(trace.path))
    span = trace.arc[1]
    if span < MIN_ARC_DEG - 1e-6:
        raise MeasurementError(f"the trace covers {ballbar_fit.arc_text(trace)}: a trace needs at least "
                               f"{MIN_ARC_DEG:g} deg of arc (a lathe's test in XZ runs about 220 deg)",
                               Location(trace.path))


def setup_centre(trace: BallbarTrace) -> tuple[float, float]:
    """The set-up centre (x, z) of one trace, fitted jointly with the one-direction machine model.

    Round the whole circle this is the trace's first harmonic. A model parameter the arc cannot
    determine is left out (its share then goes with the centre, as a circle fit would take it);
    the diagnosis of both directions fits it again with one centre for both runs.
    """
    samples = ballbar_fit.Samples.of([trace])
    result, _ = ballbar_fit.fit_determined(samples, ballbar_fit.machine_errors(samples, CENTRING_MODEL))
    return result.centre_of_trace(0)


def pair(traces: list[BallbarTrace]) -> tuple[BallbarTrace, BallbarTrace]:
    """The CCW and the CW trace of one test, refusing traces of different tests."""
    if len(traces) != 2:
        raise MeasurementError(f"a CCW and a CW trace of one test are needed, {len(traces)} given",
                               Location(traces[0].path if traces else "<ballbar>"))
    by_direction = {trace.direction: trace for trace in traces}
    if set(by_direction) != {"ccw", "cw"}:
        raise MeasurementError("the two traces must be one ccw (G03) and one cw (G02) run", Location(traces[1].path))
    ccw, cw = by_direction["ccw"], by_direction["cw"]
    if ballbar_fit.mount_key(ccw) != ballbar_fit.mount_key(cw):
        raise MeasurementError(
            f"the ccw and the cw trace are of different tests (a test is one radius and one centre): "
            f"{ballbar_fit.tests_text([[ccw], [cw]])}; give the traces of one test, or correct the radius or "
            "centre in a file's header", Location(cw.path))
    return ccw, cw
