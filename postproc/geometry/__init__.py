"""Plane geometry in radius coordinates (x, z): lines, arcs and profiles made of them.

Conventions (docs/formats.md §1): ``theta`` about a centre is measured from +X towards +Z,
``x = xc + r cos(theta)``, ``z = zc + r sin(theta)``; an arc's ``sweep`` is signed, positive
for G02 (theta increasing, ``cw``) and negative for G03. Batches of points are numpy arrays
of shape (n, 2) holding (x, z) rows; a parameter ``t`` runs from 0 at a segment's start to 1
at its end.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

TAU = 2.0 * math.pi


def as_points(points) -> np.ndarray:
    array = np.asarray(points, dtype=float)
    return array.reshape(-1, 2)


@dataclass(frozen=True, slots=True)
class Line:
    x0: float
    z0: float
    x1: float
    z1: float

    @property
    def start(self) -> tuple[float, float]:
        return (self.x0, self.z0)

    @property
    def end(self) -> tuple[float, float]:
        return (self.x1, self.z1)

    @property
    def length(self) -> float:
        return math.hypot(self.x1 - self.x0, self.z1 - self.z0)

    @property
    def direction(self) -> tuple[float, float]:
        length = self.length
        if length == 0.0:
            return (0.0, 0.0)
        return ((self.x1 - self.x0) / length, (self.z1 - self.z0) / length)

    def point_at(self, t) -> np.ndarray:
        t = np.asarray(t, dtype=float)[..., None]
        return np.array((self.x0, self.z0)) + t * np.array((self.x1 - self.x0, self.z1 - self.z0))

    def tangent_at(self, t) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        return np.broadcast_to(np.array(self.direction), t.shape + (2,)).copy()

    def direction_at(self, t: float) -> tuple[float, float]:
        """The unit tangent at one parameter, as floats (:meth:`tangent_at` takes arrays)."""
        return self.direction

    def param_of(self, points) -> np.ndarray:
        """The parameter of each point's foot on the infinite line (not clamped)."""
        p = as_points(points)
        d = np.array(self.end) - np.array(self.start)
        denominator = float(d @ d)
        if denominator == 0.0:
            return np.zeros(len(p))
        return ((p - np.array(self.start)) @ d) / denominator

    def closest(self, points) -> tuple[np.ndarray, np.ndarray]:
        """(t, foot) of the nearest point of the segment to each point."""
        t = np.clip(self.param_of(points), 0.0, 1.0)
        return t, self.point_at(t)

    def distance(self, points) -> np.ndarray:
        p = as_points(points)
        return np.linalg.norm(p - self.closest(p)[1], axis=1)

    def reversed(self) -> "Line":
        return Line(self.x1, self.z1, self.x0, self.z0)


QUADRANTS = tuple(range(-8, 9))  #: the multiples of 90 deg where an arc's axis may reverse, k and k + 4 alike
_QUARTER_TURNS = np.array(QUADRANTS) * (math.pi / 2)


@dataclass(frozen=True, slots=True)
class Arc:
    """An arc about a centre; when its end radius ``r1`` differs from its start radius (within
    the control's radius check), the radius drifts evenly with the angle, as a control runs it."""

    xc: float
    zc: float
    r: float  #: start radius
    theta0: float  #: start angle, radians
    sweep: float  #: signed, radians: positive for G02 (theta increasing)
    r1: float | None = None  #: end radius, when it differs from the start radius

    @property
    def end_radius(self) -> float:
        return self.r if self.r1 is None else self.r1

    def radius_at(self, t):
        return self.r if self.r1 is None else self.r + np.asarray(t, dtype=float) * (self.r1 - self.r)

    def part(self, a: float, b: float) -> "Arc":
        """The arc from parameter a to parameter b."""
        if self.r1 is None:
            return Arc(self.xc, self.zc, self.r, self.theta0 + a * self.sweep, (b - a) * self.sweep)
        return Arc(self.xc, self.zc, float(self.radius_at(a)), self.theta0 + a * self.sweep, (b - a) * self.sweep,
                   float(self.radius_at(b)))

    @classmethod
    def through(cls, start, end, centre, cw: bool, full: bool = False) -> "Arc":
        """The arc about ``centre`` from ``start`` to ``end`` in the G02 (cw) or G03 direction."""
        xc, zc = centre
        theta0 = math.atan2(start[1] - zc, start[0] - xc)
        theta1 = math.atan2(end[1] - zc, end[0] - xc)
        if cw:
            sweep = (theta1 - theta0) % TAU
        else:
            sweep = -((theta0 - theta1) % TAU)
        if sweep == 0.0 and full:
            sweep = TAU if cw else -TAU
        r0 = math.hypot(start[0] - xc, start[1] - zc)
        r1 = math.hypot(end[0] - xc, end[1] - zc)
        return cls(xc, zc, r0, theta0, sweep, None if abs(r1 - r0) < 1e-12 else r1)

    @property
    def cw(self) -> bool:
        return self.sweep > 0

    @property
    def centre(self) -> tuple[float, float]:
        return (self.xc, self.zc)

    @property
    def theta1(self) -> float:
        return self.theta0 + self.sweep

    @property
    def start(self) -> tuple[float, float]:
        return (self.xc + self.r * math.cos(self.theta0), self.zc + self.r * math.sin(self.theta0))

    @property
    def end(self) -> tuple[float, float]:
        r = self.end_radius
        return (self.xc + r * math.cos(self.theta1), self.zc + r * math.sin(self.theta1))

    @property
    def length(self) -> float:
        return abs(self.sweep) * (self.r + self.end_radius) / 2.0

    def point_at(self, t) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        theta = self.theta0 + t * self.sweep
        r = self.radius_at(t)
        points = np.empty(np.shape(theta) + (2,))  # filled column by column: np.stack costs more than the sums
        points[..., 0] = self.xc + r * np.cos(theta)
        points[..., 1] = self.zc + r * np.sin(theta)
        return points

    def tangent_at(self, t) -> np.ndarray:
        theta = self.theta0 + np.asarray(t, dtype=float) * self.sweep
        sign = 1.0 if self.sweep >= 0 else -1.0
        return np.stack([-sign * np.sin(theta), sign * np.cos(theta)], axis=-1)

    def direction_at(self, t: float) -> tuple[float, float]:
        """The unit tangent at one parameter, as floats (:meth:`tangent_at` takes arrays)."""
        theta = self.theta0 + t * self.sweep
        sign = 1.0 if self.sweep >= 0 else -1.0
        return (-sign * math.sin(theta), sign * math.cos(theta))

    def param_of(self, points) -> np.ndarray:
        """Parameter of each point's angle along the sweep; beyond [0, 1] when outside it.

        An angle outside the sweep is placed on the side it is nearer to, so clamping gives
        the nearer end.
        """
        p = as_points(points)
        theta = np.arctan2(p[:, 1] - self.zc, p[:, 0] - self.xc)
        sign = 1.0 if self.sweep >= 0 else -1.0
        along = (sign * (theta - self.theta0)) % TAU  # 0..2pi in the direction of travel
        span = abs(self.sweep)
        beyond = along > span
        behind = beyond & (along - span > (TAU - along))
        along = np.where(behind, along - TAU, along)
        return along / span if span > 0 else np.zeros(len(p))

    def closest(self, points) -> tuple[np.ndarray, np.ndarray]:
        t = np.clip(self.param_of(points), 0.0, 1.0)
        return t, self.point_at(t)

    def distance(self, points) -> np.ndarray:
        p = as_points(points)
        return np.linalg.norm(p - self.closest(p)[1], axis=1)

    def radial(self, points) -> np.ndarray:
        """Distance of each point from the centre minus the radius (positive outside)."""
        p = as_points(points)
        return np.hypot(p[:, 0] - self.xc, p[:, 1] - self.zc) - self.r

    def reversal_params(self, quadrants: tuple[int, ...] = QUADRANTS) -> list[float]:
        """Parameters strictly inside the arc where an axis reverses: theta a multiple of 90 deg on a
        circle; on a spiral (``r1``) that angle plus ``atan(dr / (r(t) sweep))``, where the drift of
        the radius cancels the turn (``d(r cos theta)/dt = 0``, likewise for z). An I/K arc whose
        radius drifts by a micrometre over a short sweep has its apex tens of micrometres from the
        quadrant point: where the control reverses the axis, and the R form of the same arc does.

        ``quadrants``: the multiples k of 90 deg tried (:func:`reversal_params_of` leaves out
        those that cannot fall inside the sweep)."""
        span = abs(self.sweep)
        if span == 0.0:
            return []
        sign = 1.0 if self.sweep >= 0 else -1.0
        drift = 0.0 if self.r1 is None else self.r1 - self.r
        found = []
        for k in quadrants:
            theta = k * math.pi / 2
            along = (sign * (theta - self.theta0)) % TAU
            for _ in range(3 if drift else 0):  # the offset depends on r(t): a fixed point, settled in three
                r = self.r + min(max(along / span, 0.0), 1.0) * drift
                along = (sign * (theta + math.atan(drift / (r * self.sweep)) - self.theta0)) % TAU
            if 1e-9 < along < span - 1e-9:
                found.append(along / span)
        distinct: list[float] = []  # k and k + 4 name one angle, wrapped to parameters a rounding apart
        for t in sorted(found):
            if not distinct or t - distinct[-1] > 1e-9:
                distinct.append(round(t, 12))
        return distinct

    def reversed(self) -> "Arc":
        return Arc(self.xc, self.zc, self.end_radius, self.theta1, -self.sweep, None if self.r1 is None else self.r)


Segment = Line | Arc


def reversal_params_of(arcs: list[Arc]) -> list[list[float]]:
    """:meth:`Arc.reversal_params` of many arcs, the same floats: one array pass finds, for
    each arc, the quarter turns that can fall inside its sweep (a spiral moves its apex by
    ``atan(dr / (r sweep))``, never more than ``|dr| / (r |sweep|)``), and only those are
    worked out one by one. A program's arcs mostly span a few degrees and reach none."""
    if not arcs:
        return []
    theta0 = np.array([arc.theta0 for arc in arcs])
    sweep = np.array([arc.sweep for arc in arcs])
    drift = np.array([0.0 if arc.r1 is None else arc.r1 - arc.r for arc in arcs])
    smallest = np.array([arc.r if arc.r1 is None else min(arc.r, arc.r1) for arc in arcs])
    span = np.abs(sweep)
    with np.errstate(divide="ignore", invalid="ignore"):
        reach = np.abs(drift) / (smallest * span)
    reach = np.where(np.isfinite(reach) & (smallest > 0.0), reach, math.inf) + 1e-6
    sign = np.where(sweep >= 0, 1.0, -1.0)
    along = np.remainder(sign[:, None] * (_QUARTER_TURNS[None, :] - theta0[:, None]), TAU)
    near = (along < (span + reach)[:, None]) | (along > (TAU - reach)[:, None])
    near &= (span > 0.0)[:, None]
    found: list[list[float]] = [[] for _ in arcs]
    for row in np.flatnonzero(near.any(axis=1)).tolist():
        found[row] = arcs[row].reversal_params(tuple(np.asarray(QUADRANTS)[near[row]].tolist()))
    return found


@dataclass(frozen=True)
class Profile:
    """A chain of lines and arcs with an arc-length parameter along it."""

    segments: tuple[Segment, ...]

    @cached_property
    def offsets(self) -> np.ndarray:
        """Arc length at the start of each segment, and the total at the end."""
        return np.concatenate([[0.0], np.cumsum([segment.length for segment in self.segments])])

    @property
    def length(self) -> float:
        return float(self.offsets[-1])

    def closest(self, points) -> "Nearest":
        """For each point, the nearest segment, its parameter, foot, distance and arc length."""
        p = as_points(points)
        best = np.full(len(p), np.inf)
        index = np.zeros(len(p), dtype=int)
        param = np.zeros(len(p))
        foot = np.zeros_like(p)
        for i, segment in enumerate(self.segments):
            t, f = segment.closest(p)
            d = np.linalg.norm(p - f, axis=1)
            better = d < best - 1e-12
            best = np.where(better, d, best)
            index = np.where(better, i, index)
            param = np.where(better, t, param)
            foot = np.where(better[:, None], f, foot)
        lengths = np.array([segment.length for segment in self.segments])
        s = self.offsets[index] + param * lengths[index]
        return Nearest(index, param, foot, best, s)

    def left_normals(self, index: np.ndarray, param: np.ndarray) -> np.ndarray:
        """Unit normals to the left of the direction of travel at the given places."""
        normals = np.zeros((len(index), 2))
        for i, segment in enumerate(self.segments):
            mask = index == i
            if mask.any():
                tangent = segment.tangent_at(param[mask])
                normals[mask] = np.stack([-tangent[:, 1], tangent[:, 0]], axis=-1)
        return normals


@dataclass(frozen=True)
class Nearest:
    index: np.ndarray  #: segment of each point
    param: np.ndarray  #: parameter on that segment
    foot: np.ndarray  #: nearest point of the profile
    distance: np.ndarray
    s: np.ndarray  #: arc length of the foot along the profile


def polar(points, centre) -> tuple[np.ndarray, np.ndarray]:
    """Radius and theta (radians) of points about a centre."""
    p = as_points(points)
    dx, dz = p[:, 0] - centre[0], p[:, 1] - centre[1]
    return np.hypot(dx, dz), np.arctan2(dz, dx)


def segment_of(move) -> Segment:
    """The geometry of a known line or arc move."""
    if move.xc is None:
        return Line(move.x0, move.z0, move.x1, move.z1)
    full = (move.x0, move.z0) == (move.x1, move.z1)
    return Arc.through((move.x0, move.z0), (move.x1, move.z1), (move.xc, move.zc), bool(move.cw), full=full)
