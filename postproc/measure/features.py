"""The features of a turned profile: its lines and arcs, the corners between them, and where
to touch each one.

A feature is one line or one arc of a nominal profile. Moves that continue the same line
(collinear, same direction) or the same arc (same centre, radius and sense) are one feature:
a program that cuts a diameter in three blocks still cuts one diameter. Where two features
meet, the tangent either turns (a **corner**: the ends of a chamfer or a taper, a shoulder
without a fillet) or runs on (a **tangent join**: a fillet into a diameter).

Why the probe compensators care: the error a cut leaves along the surface normal is smooth
along a feature but steps at a corner, because a tool-setting error and the push-off of the
cut project differently onto each feature's normal (a tool set 8 um long in X leaves a
diameter 8 um big and a face not at all). Screening a touch against neighbours round a
corner, or interpolating the error across one, mixes two normals; so everything that reads
probe points does it per feature (:mod:`postproc.measure.probing`, :mod:`postproc.corrections.probed`).

Where to touch (:func:`spread`): at least ``minimum`` touches on every feature, the rest
shared out by length, evenly spaced along each feature and clear of its ends by ``inset``.
At a concave corner the stylus needs more room than that: a ball of radius R touching one
feature near a corner where the tangent turns by phi meets the other feature unless it stays
about ``R tan(phi / 2)`` from the corner (R at a square shoulder), so the inset there is
raised to what the stylus needs (:func:`corner_room`). A feature too short to hold a touch
clear of its ends gets none, and says so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..diagnostics import SpreadError
from ..geometry import Arc, Line, Profile, Segment

MIN_TOUCHES = 3  #: the fewest touches on a feature among which one bad touch (the nub, a chip) shows
CORNER_DEG = 1.0  #: a join where the tangent turns by more than this is a corner
SAME_MM = 0.001  #: moves whose lines or circles agree this closely continue one feature
SAME_RAD = 1e-4  #: and whose directions agree this closely (0.001 mm over 10 mm)


@dataclass(frozen=True)
class Feature:
    """One line or arc of a profile: the segments ``first`` to ``stop - 1`` of it."""

    number: int  #: 1-based, along the profile
    first: int  #: index of its first segment in the profile
    stop: int  #: one past its last segment
    s0: float  #: arc length along the profile where it starts, mm
    s1: float  #: and where it ends
    kind: str  #: face, diameter, taper, G02 arc or G03 arc
    radius: float | None  #: arcs: the radius, mm
    lines: tuple[int, int] | None  #: source lines of its first and last move, when known
    turn_in: float | None  #: radians the tangent turns into it (+ to the left); None at the profile's start
    turn_out: float | None  #: radians it turns out of it; None at the profile's end

    @property
    def length(self) -> float:
        return self.s1 - self.s0

    def describe(self) -> str:
        """``the face on line 12``, ``the G02 arc R5 on lines 8-9``: for messages."""
        what = self.kind if self.radius is None else f"{self.kind} R{self.radius:g}"
        if self.lines is None:
            return f"feature {self.number} (the {what} from {self.s0:.3f} to {self.s1:.3f} mm along the profile)"
        first, last = self.lines
        where = f"line {first}" if first == last else f"lines {first}-{last}"
        return f"the {what} on {where}"


def _tangent(segment: Segment, at_end: bool) -> np.ndarray:
    return np.asarray(segment.direction_at(1.0 if at_end else 0.0), dtype=float)


def turn(before: Segment, after: Segment) -> float:
    """Radians the tangent turns from the end of ``before`` to the start of ``after`` (+ to the left)."""
    a, b = _tangent(before, True), _tangent(after, False)
    return math.atan2(a[0] * b[1] - a[1] * b[0], float(a @ b))


def _continues(before: Segment, after: Segment) -> bool:
    """Whether ``after`` goes on along the same line or the same arc as ``before``."""
    if isinstance(before, Line) and isinstance(after, Line):
        return abs(turn(before, after)) <= SAME_RAD
    if isinstance(before, Arc) and isinstance(after, Arc):
        return (before.cw == after.cw and math.hypot(before.xc - after.xc, before.zc - after.zc) <= SAME_MM
                and abs(before.end_radius - after.r) <= SAME_MM and abs(turn(before, after)) <= SAME_RAD)
    return False


def _kind(segment: Segment) -> tuple[str, float | None]:
    if isinstance(segment, Arc):
        return ("G02 arc" if segment.cw else "G03 arc"), round(segment.r, 6)
    tx, tz = segment.direction
    if abs(tz) <= SAME_RAD:
        return "face", None
    if abs(tx) <= SAME_RAD:
        return "diameter", None
    return "taper", None


def features(profile: Profile, lines: tuple[int, ...] | None = None) -> tuple[Feature, ...]:
    """The profile's features in order. ``lines``: the source line of each segment, for messages."""
    segments = profile.segments
    groups: list[list[int]] = []
    for index, segment in enumerate(segments):
        if groups and _continues(segments[groups[-1][-1]], segment):
            groups[-1].append(index)
        else:
            groups.append([index])
    offsets = profile.offsets
    found = []
    for number, group in enumerate(groups, 1):
        first, last = group[0], group[-1]
        kind, radius = _kind(segments[first])
        turn_in = turn(segments[first - 1], segments[first]) if first > 0 else None
        turn_out = turn(segments[last], segments[last + 1]) if last + 1 < len(segments) else None
        found.append(Feature(number, first, last + 1, float(offsets[first]), float(offsets[last + 1]), kind, radius,
                             None if lines is None else (lines[first], lines[last]), turn_in, turn_out))
    return tuple(found)


def owners(found: tuple[Feature, ...]) -> np.ndarray:
    """The feature (index into ``found``) of each segment of their profile."""
    return np.repeat(np.arange(len(found)), [feature.stop - feature.first for feature in found])


def is_corner(angle: float | None) -> bool:
    return angle is not None and abs(angle) > math.radians(CORNER_DEG)


def corner_room(angle: float, outward_sign: float, radius: float, clearance: float) -> float:
    """How far (along a feature) a touch must stay from a corner where the tangent turns by ``angle``.

    Zero at a convex corner or a tangent join. At a concave one (the tangent turns away from
    the material, towards the outward normal: ``outward_sign`` is +1 when that is the left
    normal, and a left turn is positive; a path that keeps the material on one side wraps
    round a convex corner towards it) the
    ball approaching along the feature's normal from ``radius + clearance`` out must keep
    ``radius + min(way left, clearance / 4)`` from the other feature all the way in (the
    probing program's approach rule, :mod:`postproc.onmachine.probe_route`), taken on the tangent lines
    at the corner. A turn of 180 deg or more leaves no room: infinity.
    """
    if not is_corner(angle) or angle * outward_sign < 0:
        return 0.0
    phi = abs(angle)
    if phi >= math.pi - 1e-9:
        return math.inf
    sin, cos = math.sin(phi), math.cos(phi)
    need = max((radius + min(h - radius, clearance / 4.0) - h * cos) / sin
               for h in (radius, radius + clearance / 4.0, radius + clearance))
    return 1.02 * need + 1e-3  # a margin: arcs bend away from their tangents


@dataclass(frozen=True)
class Spread:
    """Where the touches go: arc lengths along the profile, and how many each feature got."""

    s: np.ndarray  #: increasing
    counts: tuple[int, ...]  #: touches per feature, in order
    insets: tuple[tuple[float, float], ...]  #: the room kept at each feature's start and end, mm


def spread(found: tuple[Feature, ...], count: int, inset: float = 0.0, minimum: int = MIN_TOUCHES, *,
           outward_sign: float = 1.0, radius: float = 0.0, clearance: float = 0.0) -> Spread:
    """``count`` touches over the features: ``minimum`` on each that can hold them, the rest by length.

    Each feature keeps ``inset`` free at both ends, more at a concave corner
    (:func:`corner_room` for a stylus of ``radius`` approaching from ``clearance`` out). A
    feature whose length that leaves nothing of gets no touch; the caller says so.

    :raises SpreadError: no feature can hold a touch, or ``count`` cannot give ``minimum``
        to every feature that can.
    """
    insets, usable = [], []
    for feature in found:
        room = [max(inset, corner_room(angle, outward_sign, radius, clearance)) if angle is not None else inset
                for angle in (feature.turn_in, feature.turn_out)]
        insets.append((room[0], room[1]))
        usable.append(feature.length - room[0] - room[1])
    usable = np.array(usable)
    open_ = usable > 1e-9
    if not open_.any():
        raise SpreadError("no feature has room for a touch clear of its ends")
    wanted = int(open_.sum()) * minimum
    if count < wanted:
        raise SpreadError(f"{count} touches cannot give each of the {int(open_.sum())} features with room for them "
                          f"{minimum}", wanted)
    counts = np.where(open_, minimum, 0)
    extra = count - wanted
    if extra:
        share = extra * np.where(open_, usable, 0.0) / usable[open_].sum()
        whole = np.floor(share).astype(int)
        order = np.argsort(-(share - whole), kind="stable")
        whole[order[: extra - int(whole.sum())]] += 1
        counts = counts + whole
    s = []
    for feature, (start, end), n in zip(found, insets, counts):
        if n == 0:
            continue
        a, b = feature.s0 + start, feature.s1 - end
        s.append(np.array([(a + b) / 2.0]) if n == 1 else np.linspace(a, b, int(n)))
    return Spread(np.concatenate(s), tuple(int(n) for n in counts), tuple(insets))
