"""Surfaces the virtual probe and CMM touch: a turned profile, a sphere, a datum face.

A turned surface is a polyline of (rho, z) rows with rho >= 0, the half-profile of a body of
revolution; the other half (-rho, z) is added wherever something touches it, since a stylus
that strays over the spindle axis meets the part's other side.

``contact`` answers where a ball of a given radius, moving from ``start`` along the unit
direction ``n``, first touches the surface: the distance travelled, ``None`` if it does not
within ``limit``, and a :class:`Collision` if the ball already overlaps the surface at its
start.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Protocol

import numpy as np

from ..diagnostics import Collision


class Touchable(Protocol):
    def contact(self, start: np.ndarray, n: np.ndarray, radius: float, limit: float) -> float | None:
        """Distance a ball travels from ``start`` along ``n`` to its first touch, if within ``limit``."""


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


@dataclass(frozen=True)
class Turned:
    """A turned profile: the half-profile polyline (rho >= 0), ordered along the tool path."""

    points: np.ndarray  #: (n, 2) rho, z in mm

    @cached_property
    def _section(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Starts and ends of the segments of both halves of the section, their midpoints and half lengths."""
        mirror = self.points * np.array([-1.0, 1.0])
        starts = np.concatenate([self.points[:-1], mirror[:-1]])
        ends = np.concatenate([self.points[1:], mirror[1:]])
        return starts, ends, (starts + ends) / 2.0, np.linalg.norm(ends - starts, axis=1) / 2.0

    def segments(self, near: np.ndarray | None = None, reach: float = np.inf) -> tuple[np.ndarray, np.ndarray]:
        """Starts and ends of the section's segments, or of those that come within ``reach`` of ``near``."""
        starts, ends, middles, halves = self._section
        if near is None:
            return starts, ends
        close = np.linalg.norm(middles - near, axis=1) <= reach + halves
        return starts[close], ends[close]

    def contact(self, start: np.ndarray, n: np.ndarray, radius: float, limit: float) -> float | None:
        start = np.asarray(start, dtype=float)
        n = np.asarray(n, dtype=float)
        starts, ends = self.segments(start, radius + limit)
        if starts.size == 0:
            return None
        along = ends - starts
        squared = np.einsum("ij,ij->i", along, along)
        t = np.clip(np.einsum("ij,ij->i", start - starts, along) / np.where(squared > 0, squared, 1.0), 0.0, 1.0)
        if np.min(np.linalg.norm(starts + t[:, None] * along - start, axis=1)) < radius - 1e-12:
            raise Collision
        found = []
        # the ball meets a vertex: |start + t n - v| = radius, first root
        vertices = np.concatenate([starts, ends])
        w = vertices - start
        p = w @ n
        disc = p * p - np.einsum("ij,ij->i", w, w) + radius * radius
        ok = disc >= 0
        t = p[ok] - np.sqrt(disc[ok])
        found.append(t[t >= 0])
        # the ball meets a segment's interior, from the side it starts on
        length = np.sqrt(squared)
        keep = length > 0
        starts, along, length = starts[keep], along[keep], length[keep]
        unit = along / length[:, None]
        normal = np.column_stack([-unit[:, 1], unit[:, 0]])
        height = np.einsum("ij,ij->i", start - starts, normal)
        side = np.where(height >= 0, 1.0, -1.0)
        closing = -side * (normal @ n)  # > 0 when the ball moves towards the line
        moving = closing > 0
        t = (side[moving] * height[moving] - radius) / closing[moving]
        touch = start + t[:, None] * n - (side[moving] * radius)[:, None] * normal[moving]
        u = np.einsum("ij,ij->i", touch - starts[moving], unit[moving]) / length[moving]
        inside = (u >= 0.0) & (u <= 1.0) & (t >= 0)
        found.append(t[inside])
        every = np.concatenate(found)
        every = every[every <= limit]
        return float(every.min()) if every.size else None

    def crossing(self, point: np.ndarray, normal: np.ndarray, reach: float) -> float | None:
        """The signed distance u along ``normal`` from ``point`` to the surface, nearest first.

        An end of the polyline off the spindle axis is continued by ``reach`` along its last
        direction, so a point at the very end of a cut that moved away from it still measures.
        So is, where the normal crosses nothing, every segment at both its ends: a point at a
        corner of the profile whose cut corner moved (the face beside it left higher, the
        point buried under it, or a convex edge pulled back) measures its own feature's
        surface continued along its end, as a point beside the corner does.
        """
        starts, ends = self.segments()
        extra = [(a, b) for a, b in ((self.points[1], self.points[0]), (self.points[-2], self.points[-1]))
                 if b[0] > 1e-9 and np.any(a != b)]
        for a, b in extra:
            direction = (b - a) / np.linalg.norm(b - a)
            starts = np.concatenate([starts, [b]])
            ends = np.concatenate([ends, [b + reach * direction]])
        found = _nearest_crossing(starts, ends, point, normal, reach)
        if found is not None:
            return found
        starts, ends = self.segments(point, reach)
        along = ends - starts
        length = np.linalg.norm(along, axis=1)
        keep = length > 0
        unit = along[keep] / length[keep, None]
        return _nearest_crossing(starts[keep] - reach * unit, ends[keep] + reach * unit, point, normal, reach)


def _nearest_crossing(starts: np.ndarray, ends: np.ndarray, point: np.ndarray, normal: np.ndarray,
                      reach: float) -> float | None:
    """The u nearest zero where ``point + u normal`` meets a segment, |u| within ``reach``."""
    along = ends - starts
    denominator = _cross(np.broadcast_to(normal, along.shape), along)
    usable = np.abs(denominator) > 1e-15
    offset = starts[usable] - point
    u = _cross(offset, along[usable]) / denominator[usable]
    t = _cross(offset, np.broadcast_to(normal, offset.shape)) / denominator[usable]
    hits = u[(t >= -1e-12) & (t <= 1.0 + 1e-12) & (np.abs(u) <= reach)]
    if hits.size == 0:
        return None
    return float(hits[np.argmin(np.abs(hits))])


@dataclass(frozen=True)
class Circle:
    """The section of a sphere in the cutting plane."""

    centre: tuple[float, float]
    radius: float

    def contact(self, start: np.ndarray, n: np.ndarray, radius: float, limit: float) -> float | None:
        w = np.asarray(start, dtype=float) - np.array(self.centre)
        reach = self.radius + radius
        if math.hypot(*w) < reach - 1e-12:
            raise Collision
        p = float(w @ n)
        disc = p * p - float(w @ w) + reach * reach
        travel = -p - math.sqrt(max(disc, 0.0))
        return travel if disc >= 0 and 0 <= travel <= limit else None


@dataclass(frozen=True)
class Plane:
    """A flat datum face through ``point`` with the outward unit ``normal``."""

    point: tuple[float, float]
    normal: tuple[float, float]

    def contact(self, start: np.ndarray, n: np.ndarray, radius: float, limit: float) -> float | None:
        normal = np.array(self.normal)
        height = float((np.asarray(start, dtype=float) - np.array(self.point)) @ normal)
        if height < radius - 1e-12:
            raise Collision
        closing = -float(normal @ n)
        travel = (height - radius) / closing if closing > 0 else np.inf
        return travel if travel <= limit else None
