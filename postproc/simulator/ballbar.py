"""The ballbar test on the virtual lathe (docs/methods.md §3.1).

The commanded test, in one direction at one feed: a radial feed-in of ``feed_in_mm`` from
outside the circle, ``overtravel_deg`` of pre-travel (180), ``capture_arc_deg`` captured from
``start_angle_deg`` (360), as much over-travel, and the feed-out: 720 deg of arc for the full
test, a partial arc (a lathe's 220 deg, ISO 13041-6) with a few degrees either side; the
direction of travel of each axis known at every moment. ``ccw`` (G03) runs with theta
decreasing, ``cw`` (G02) increasing.

The tool-side ball is where the machine puts it (:meth:`.errors.Machine.tool_path`: errors
by each axis's direction of travel, servo lag at the feed); the bar reads its distance to
the pivot, which sits at the nominal centre plus the set-up offset, minus the nominal
radius, plus noise. Readings are evenly spaced in time, hence in commanded angle:

- processed: one reading every ``spacing_deg``, with its commanded theta;
- raw: ``oversample`` readings per ``spacing_deg``, in time order; the reader spaces them
  as docs/formats.md §4 says (sample i at start + s i capture / n) and averages them in sixes.

:func:`program_test` runs the bar along a part program's feed moves instead (the dissertation's
loop, docs/methods.md §5.1): a compensated test circle measured again. The bar reads the
distance from the tool to the pivot at the test circle's centre (plus the set-up offset) along
the feed moves that run on the circle (every point within ``ON_CIRCLE_MM`` of it); each
reading is given the commanded point's angle about the centre, one every ``spacing_deg``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..diagnostics import Location, OptionError
from ..geometry import Arc, Line, segment_of
from ..interpret.motion import ARC, LINE, Move
from .config import Simulation
from .errors import Machine
from .path import Commanded, Timeline, sample, speed

DIRECTIONS = ("ccw", "cw")
FORMS = ("processed", "raw")
ON_CIRCLE_MM = 0.5  #: a feed move whose every point lies this close to the test circle runs on it
#: the first (last) lines on it whose ends' radii differ by more than this reach the circle (lead-in,
#: lead-out); a chord of a compensated circle's differ by microns, a 5 mm tangent lead-in's at 100 mm by 125 um
CHORD_MM = 0.01
TURNED_BACK_DEG = 1.0  #: a run on the test circle that goes back by more than this is no ballbar test


@dataclass(frozen=True)
class BallbarRun:
    radius: float
    centre: tuple[float, float]
    direction: str  #: "ccw" or "cw"
    feed: float  #: mm/min
    start_angle: float  #: theta of the first reading, degrees
    angles: np.ndarray  #: commanded theta of each reading, degrees (time order, not wrapped)
    deviations: np.ndarray  #: bar length minus nominal radius, mm
    raw: bool
    capture: float = 360.0  #: the captured arc, degrees


def ballbar_test(simulation: Simulation, rng: np.random.Generator | None, direction: str = "ccw",
                 form: str = "processed", radius: float | None = None, centre: tuple[float, float] | None = None,
                 feed: float | None = None, start: float | None = None, capture: float | None = None,
                 overtravel: float | None = None) -> BallbarRun:
    """Run the test; ``radius``, ``centre``, ``feed``, ``start`` (theta of the first captured sample),
    ``capture`` (the arc captured) and ``overtravel`` default to ``[simulation.ballbar]``."""
    setup = simulation.ballbar
    if direction not in DIRECTIONS:
        raise OptionError(f"direction {direction!r}: expected ccw or cw")
    if form not in FORMS:
        raise OptionError(f"form {form!r}: expected processed or raw")
    radius = setup.radius_mm if radius is None else radius
    feed = setup.feed_mm_min if feed is None else feed
    centre = (setup.center_x_mm, setup.center_z_mm) if centre is None else centre
    start = setup.start_angle_deg if start is None else start
    capture = setup.capture_arc_deg if capture is None else capture
    overtravel = setup.overtravel_deg if overtravel is None else overtravel
    if not 0.0 < capture <= 360.0:
        raise OptionError(f"the captured arc must be more than 0 and at most 360 deg, not {capture:g}")
    if not 0.0 <= overtravel <= 180.0:
        raise OptionError(f"the over-travel must be 0 to 180 deg, not {overtravel:g}")
    if not radius > setup.feed_in_mm:
        raise OptionError(f"the test radius must exceed the feed-in of {setup.feed_in_mm:g} mm")
    if not feed > 0:
        raise OptionError("the feed must be positive")
    raw = form == "raw"
    count = max(int(round(capture / setup.spacing_deg)), 1) * (setup.oversample if raw else 1)
    step = capture / count
    sense = 1.0 if direction == "cw" else -1.0
    total = capture + 2.0 * overtravel

    # progress along the whole arc: 0 at its start, the capture from the over-travel on
    readings = overtravel + step * np.arange(count)
    around = np.arange(0.0, total + step / 2, step)
    first = start - sense * overtravel
    quarter = np.arange(math.floor(first / 90.0) - 9, math.floor(first / 90.0) + 10) * 90.0
    reversals = sense * (quarter - first)
    reversals = reversals[(reversals > 0) & (reversals < total)]
    progress = np.concatenate([around, readings, reversals])
    captured = np.concatenate([np.zeros(around.size, bool), np.ones(count, bool), np.zeros(reversals.size, bool)])
    order = np.argsort(progress, kind="stable")
    progress, captured = progress[order], captured[order]

    xc, zc = centre
    outer = radius + setup.feed_in_mm
    ends = np.radians([first, first + sense * total])
    arc = Arc(xc, zc, radius, float(ends[0]), float(ends[1] - ends[0]))
    feed_in = Line(xc + outer * math.cos(ends[0]), zc + outer * math.sin(ends[0]), *arc.start)
    feed_out = Line(*arc.end, xc + outer * math.cos(ends[1]), zc + outer * math.sin(ends[1]))
    timeline = Timeline.of([feed_in, arc, feed_out], [feed] * 3)
    ends_only = np.array([0.0, 1.0])
    pieces = [timeline.sample(0, ends_only), timeline.sample(1, progress / total), timeline.sample(2, ends_only)]
    owner = np.concatenate([np.zeros(2, int), np.ones(progress.size, int), np.full(2, 2)])
    commanded = Commanded(timeline, np.concatenate([p for p, _ in pieces]), np.concatenate([t for _, t in pieces]),
                          owner, np.concatenate([ends_only, progress / total, ends_only]))
    actual = Machine(simulation).tool_path(commanded)[2:-2][captured]
    pivot = np.array([xc + setup.setup_offset_x_mm, zc + setup.setup_offset_z_mm])
    deviations = np.linalg.norm(actual - pivot, axis=1) - radius
    if rng is not None and setup.noise_mm > 0:
        deviations = deviations + rng.normal(0.0, setup.noise_mm, deviations.size)
    angles = (first + sense * progress)[captured]
    return BallbarRun(radius, centre, direction, feed, start, angles, deviations, raw, capture)


def program_test(simulation: Simulation, rng: np.random.Generator | None, moves: list[Move], program: str,
                 radius: float | None = None, centre: tuple[float, float] | None = None, start: float | None = None,
                 capture: float | None = None) -> BallbarRun:
    """The bar along a program's feed moves (the moves of a test circle, compensated or not).

    ``centre`` and ``radius`` default to those of the program's feed arcs (one centre and radius
    for all of them, else an OptionError asks for them); ``start`` (theta of the first reading)
    and ``capture`` (the arc read) default to the whole arc the moves on the circle run, or the
    360 deg in its middle when they run more (a test with pre- and over-travel).

    :raises OptionError: no feed move runs on the circle, the moves on it are not one run, or
        they turn back; the captured arc is not within what they run.
    """
    where = Location(program)
    feed = [(index, move) for index, move in enumerate(moves)
            if move.kind in (LINE, ARC) and move.known and segment_of(move).length > 0.0]
    centre, radius = _circle(feed, centre, radius, where)
    setup = simulation.ballbar
    on = [index for index, move in feed if _on_circle(move, centre, radius)]
    while on and _reaches(moves[on[0]], centre, radius):  # the lead-in, not the test
        on.pop(0)
    while on and _reaches(moves[on[-1]], centre, radius):  # the lead-out
        on.pop()
    if not on:
        raise OptionError(f"no feed move runs on the test circle of radius {radius:g} mm about x {centre[0]:g}, "
                          f"z {centre[1]:g} (within {ON_CIRCLE_MM:g} mm); give --radius, --center-x and --center-z",
                          where)
    kept = [index for index, _ in feed]
    first, last = kept.index(on[0]), kept.index(on[-1])
    if kept[first:last + 1] != on:
        gap = next(index for index in kept[first:last + 1] if index not in on)
        raise OptionError(f"the moves on the test circle are not one run: the move on line {moves[gap].line} leaves "
                          "it between them", where)
    step = min(0.05, radius * math.radians(setup.spacing_deg) / 4.0)
    commanded = sample(moves, set(on), step, simulation, program)
    actual = Machine(simulation).tool_path(commanded)
    mask = np.isin(commanded.move, on)
    points, actual, time = commanded.points[mask], actual[mask], commanded.time[mask]
    order = np.argsort(time, kind="stable")
    points, actual = points[order], actual[order]
    theta = np.degrees(np.unwrap(np.arctan2(points[:, 1] - centre[1], points[:, 0] - centre[0])))
    sense = 1.0 if theta[-1] > theta[0] else -1.0
    theta = sense * theta  # increasing in the run's sense
    reached = np.maximum.accumulate(theta)
    if np.any(reached - theta > TURNED_BACK_DEG):
        raise OptionError("the moves on the test circle turn back: a ballbar test runs one way round", where)
    # a compensated path's connecting moves may step back a hair: the bar reads where the path is new
    ahead = np.concatenate([[True], theta[1:] > reached[:-1]])
    theta, unique = np.unique(theta[ahead], return_index=True)
    actual = actual[ahead][unique]
    span = float(theta[-1] - theta[0])
    if capture is None:
        capture = min(span, 360.0)
    if start is None:
        begin = theta[0] + max(0.0, (span - capture) / 2.0)
    else:
        begin = sense * start
        begin += 360.0 * math.ceil((theta[0] - begin - 1e-9) / 360.0)  # the first time the run passes it
    count = max(int(round(capture / setup.spacing_deg)), 1)
    readings = begin + (capture / count) * np.arange(count)  # as the built-in test: the end not read again
    if not (0.0 < capture <= 360.0) or readings[-1] > theta[-1] + 1e-9:
        raise OptionError(f"the captured arc ({capture:g} deg from {sense * begin % 360.0:g} deg) is not within the "
                          f"{span:.1f} deg the moves run on the test circle", where)
    pivot = np.array(centre) + np.array([setup.setup_offset_x_mm, setup.setup_offset_z_mm])
    bar = np.hypot(actual[:, 0] - pivot[0], actual[:, 1] - pivot[1]) - radius
    deviations = np.interp(readings, theta, bar)
    if rng is not None and setup.noise_mm > 0:
        deviations = deviations + rng.normal(0.0, setup.noise_mm, deviations.size)
    direction = "cw" if sense > 0 else "ccw"
    return BallbarRun(radius, centre, direction, speed(moves[on[0]], simulation, program), float(sense * readings[0]),
                      sense * readings, deviations, False, float(capture))


def _circle(feed: list[tuple[int, Move]], centre: tuple[float, float] | None, radius: float | None,
            where: Location) -> tuple[tuple[float, float], float]:
    """The test circle: as given, or the program's feed arcs' one centre and radius."""
    arcs = [segment_of(move) for _, move in feed if move.kind == ARC]
    if centre is None:
        centres = {(round(arc.xc, 6), round(arc.zc, 6)) for arc in arcs}
        if len(centres) != 1:
            raise OptionError("the test circle's centre: " + ("the program has no feed arc" if not centres else
                              f"the program's arcs have {len(centres)} centres") + "; give --center-x and --center-z",
                              where)
        centre = next(iter(centres))
    if radius is None:
        radii = {round(arc.r, 6) for arc in arcs if math.isclose(arc.xc, centre[0], abs_tol=1e-6)
                 and math.isclose(arc.zc, centre[1], abs_tol=1e-6)}
        if len(radii) != 1:
            raise OptionError("the test circle's radius: no feed arc about the centre has one radius; give --radius",
                              where)
        radius = next(iter(radii))
    if not radius > 0:
        raise OptionError(f"--radius {radius:g}: the radius must be positive", where)
    return (float(centre[0]), float(centre[1])), float(radius)


def _on_circle(move: Move, centre: tuple[float, float], radius: float) -> bool:
    points = segment_of(move).point_at(np.linspace(0.0, 1.0, 33))
    return bool(np.all(np.abs(np.hypot(points[:, 0] - centre[0], points[:, 1] - centre[1]) - radius) <= ON_CIRCLE_MM))


def _reaches(move: Move, centre: tuple[float, float], radius: float) -> bool:
    """A line that comes onto the circle (or leaves it) from another radius rather than running
    along it as a chord does: its ends' radii differ by more than CHORD_MM. A test's lead-in or
    lead-out, however near the circle it runs (a tangent one, 125 um off at 5 mm from 100 mm)."""
    if move.kind != LINE:
        return False
    ends = segment_of(move).point_at(np.array([0.0, 1.0]))
    off = np.hypot(ends[:, 0] - centre[0], ends[:, 1] - centre[1]) - radius
    return abs(float(off[1] - off[0])) > CHORD_MM
