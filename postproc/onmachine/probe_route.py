"""Where the stylus may go: the surfaces a program turns, and safe routes between touches.

The stylus is a ball of radius R; every check here is on its centre. The surfaces are the
feed moves (lines, arcs, threads) the program runs, except those on the spindle axis (they
turn nothing), and their mirror images across the axis (the part is a body of revolution,
so a stylus that strays over the axis meets its other side). The probe body, the turret, the
chuck and stock the program does not cut are not known here.

The envelope is the box around every known position of the program (its rapids included:
the tool reached them through air), the touches and the datum, grown by R + clearance. Its
top edge (above everything) and right edge (beyond the largest radius) are clear of every
known surface by that much; routes outside the part run on them at rapid. The other edges
lead under the part or across the axis and are never used.

A route from one touch's approach start to the next keeps the ball at least
R + clearance / 2 from every surface (checked on samples a quarter of the clearance apart, so
between samples it stays more than R + 3/8 clearance away). In order of preference:

1. a candidate path near the part (the profile's offset at the approach standoff, made by
   :mod:`postproc.onmachine.probe_cycle`), cut into as few straight legs as stay clear;
2. out along an escape line that is as clear (the touch's outward normal, else +Z, else +X)
   to the envelope, round it, and in along the other touch's escape line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..geometry import Segment, as_points, segment_of
from ..interpret.motion import ARC, LINE, THREAD, Move
from ..measure.nominal import on_axis

ESCAPES = ((0.0, 1.0), (1.0, 0.0))  #: +Z, then +X: escape lines tried after the outward normal
SAMPLES_PER_CLEARANCE = 4  #: route checks sample every clearance / 4
APPROACH_SAMPLES = 41  #: samples of an approach from its start to the nominal contact
TOLERANCE = 1e-6  #: mm; geometry this close counts as touching


@dataclass(frozen=True, slots=True)
class Leg:
    """One move of the stylus centre: to (x, z) in radius mm, at rapid or at the travel feed."""

    x: float
    z: float
    rapid: bool


class Surfaces:
    """What the stylus must not touch: the surfaces a program turns."""

    def __init__(self, moves: list[Move]):
        surfaces = [(segment_of(m), m.line) for m in moves
                    if m.kind in (LINE, ARC, THREAD) and m.known and not on_axis(m)]
        self.segments: list[Segment] = [s for s, _ in surfaces if s.length > 0.0]
        self.lines: list[int] = [line for s, line in surfaces if s.length > 0.0]

    def _each(self, points) -> np.ndarray:
        """(segments, n) distances of points from each surface and its mirror image."""
        p = as_points(points)
        if not self.segments:
            return np.full((1, len(p)), np.inf)
        mirror = p * np.array([-1.0, 1.0])
        return np.array([np.minimum(s.distance(p), s.distance(mirror)) for s in self.segments])

    def distance(self, points) -> np.ndarray:
        """Distance of each point from the nearest surface."""
        return self._each(points).min(axis=0)

    def nearest_line(self, point) -> int | None:
        """The source line of the surface nearest to a point."""
        if not self.segments:
            return None
        return self.lines[int(np.argmin(self._each(point)[:, 0]))]


@dataclass(frozen=True, slots=True)
class Envelope:
    """The box outside which nothing the program knows lies (radius mm)."""

    x_hi: float
    z_hi: float
    z_lo: float

    @classmethod
    def around(cls, points, grow: float) -> "Envelope":
        p = as_points(points)
        return cls(float(np.max(np.abs(p[:, 0]))) + grow, float(np.max(p[:, 1])) + grow,
                   float(np.min(p[:, 1])) - grow)

    @property
    def corner(self) -> tuple[float, float]:
        """Above everything and beyond the largest radius: where the program starts and ends."""
        return (self.x_hi, self.z_hi)

    def exit(self, start, direction) -> tuple[float, float] | None:
        """Where a line from ``start`` leaves the box, if through the top or the right edge."""
        (px, pz), (dx, dz) = start, direction
        edges = []
        if dx > TOLERANCE:
            edges.append(((self.x_hi - px) / dx, "right"))
        elif dx < -TOLERANCE:
            edges.append(((-self.x_hi - px) / dx, "left"))
        if dz > TOLERANCE:
            edges.append(((self.z_hi - pz) / dz, "top"))
        elif dz < -TOLERANCE:
            edges.append(((self.z_lo - pz) / dz, "bottom"))
        t, edge = min(edges)
        if edge not in ("top", "right") or t < 0.0:
            return None
        if edge == "top":
            return (min(px + t * dx, self.x_hi), self.z_hi)
        return (self.x_hi, min(pz + t * dz, self.z_hi))

    def _along(self, point) -> float:
        """Position on the path over the top edge and down the right edge."""
        x, z = point
        return x if z >= self.z_hi - TOLERANCE else self.x_hi + (self.z_hi - z)

    def between(self, a, b) -> list[tuple[float, float]]:
        """The points from edge point ``a`` to edge point ``b`` (a excluded) over the top and right edges."""
        ua, ub = self._along(a), self._along(b)
        corner = self._along(self.corner)
        path = [self.corner] if min(ua, ub) < corner - TOLERANCE and max(ua, ub) > corner + TOLERANCE else []
        return path + [tuple(b)]


class Router:
    """Safe routes for a ball of ``radius`` among ``surfaces``, inside ``envelope``."""

    def __init__(self, surfaces: Surfaces, envelope: Envelope, radius: float, clearance: float):
        self.surfaces = surfaces
        self.envelope = envelope
        self.radius = radius
        self.clearance = clearance

    def clear(self, a, b) -> bool:
        """Whether the straight move from ``a`` to ``b`` keeps the ball R + clearance/2 from every surface."""
        a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
        step = self.clearance / SAMPLES_PER_CLEARANCE
        count = max(2, math.ceil(float(np.linalg.norm(b - a)) / step) + 1)
        t = np.linspace(0.0, 1.0, count)[:, None]
        distance = self.surfaces.distance(a + t * (b - a))
        return bool(np.all(distance >= self.radius + self.clearance / 2.0 - TOLERANCE))

    def blocked(self, start, centre) -> int | None:
        """The line of a surface the ball meets before it reaches ``centre`` moving in from ``start``.

        The ball must stay clear of every surface until it touches its own at ``centre``: by a
        quarter of the clearance, or by what is left of the way where that is less (its own
        surface, and a neighbour round a convex corner, are exactly that far).
        """
        start, centre = np.asarray(start, dtype=float), np.asarray(centre, dtype=float)
        travel = float(np.linalg.norm(centre - start))
        t = np.linspace(0.0, 1.0, APPROACH_SAMPLES)[:, None]
        points = start + t * (centre - start)
        left = travel * (1.0 - t[:, 0])
        allowed = self.radius + np.minimum(left, self.clearance / SAMPLES_PER_CLEARANCE) - TOLERANCE
        short = np.nonzero(self.surfaces.distance(points) < allowed)[0]
        return None if not len(short) else self.surfaces.nearest_line(points[short[0]])

    def escape(self, start, outward) -> tuple[float, float] | None:
        """Where a clear straight line from ``start`` reaches the envelope: along ``outward``, +Z or +X."""
        for direction in (tuple(outward),) + ESCAPES:
            end = self.envelope.exit(start, direction)
            if end is not None and self.clear(start, end):
                return end
        return None

    def simplify(self, path) -> list[tuple[float, float]] | None:
        """Few straight legs along ``path`` (its first point excluded) that stay clear; None if a step is not.

        From each point: straight to the end if that is clear (past a concave corner, say), else
        as far along the path as stays clear.
        """
        points = [tuple(p) for p in as_points(path)]
        legs, i = [], 0
        while i < len(points) - 1:
            if self.clear(points[i], points[-1]):
                legs.append(points[-1])
                break
            j = i + 1
            if not self.clear(points[i], points[j]):
                return None
            while j + 1 < len(points) and self.clear(points[i], points[j + 1]):
                j += 1
            legs.append(points[j])
            i = j
        return legs

    def via_envelope(self, a, a_exit, b_exit, b) -> list[Leg]:
        """Out from ``a`` to the envelope, round it at rapid, in to ``b``."""
        legs = [Leg(*a_exit, rapid=False)]
        legs += [Leg(*p, rapid=True) for p in self.envelope.between(a_exit, b_exit)]
        return legs + [Leg(*b, rapid=False)]
