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
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..diagnostics import OptionError
from ..geometry import Arc, Line
from .config import Simulation
from .errors import Machine
from .path import Commanded, Timeline

DIRECTIONS = ("ccw", "cw")
FORMS = ("processed", "raw")


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
