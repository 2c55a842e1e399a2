"""How far a written block runs from the nominal path: the last check before a block is written.

The self-check measures each replacement against the compensated path it was planned for,
within the tolerance. This check measures it against the nominal path itself, which no
option changes: a written cut may lie no further from the move it replaces than the largest
correction plus the tolerance. It is what refuses, whatever went wrong before it, an arc
written as its chord (``--tolerance 20``), a connecting move to a wrong point, or a plan that
wandered off.

It must be cheap (it runs on every replaced block), so it is exact rather than sampled: the
distance from a line or an arc to a line or an arc is largest at an end of the cut, where
the cut passes closest to or farthest from a point of the nominal (its centre, its ends), where
it runs parallel to a nominal line, or where it crosses from beside the nominal segment to
beyond one of its ends. Those few places are computed in closed form and the distance is
measured there; a spiral arc (end radius differing from the start within the control's radius
check) is located as its circle and measured as the spiral it is.
"""

from __future__ import annotations

import math

from .geometry import TAU, Line, Segment
from .segmenter import Cut


def farthest(cut: Cut, nominal: Segment) -> float:
    """The largest distance, in mm, of any point of ``cut`` from the nominal segment."""
    if cut.xc is None:
        if type(nominal) is Line:  # the distance from a segment is convex: largest at an end
            return max(_distance(cut.x0, cut.z0, nominal), _distance(cut.x1, cut.z1, nominal))
        points = _line_points(cut, nominal)
    else:
        points = _arc_points(cut, nominal)
    return max([_distance(x, z, nominal) for x, z in points])


# ---------------------------------------------------------------------- distance from the nominal


def _distance(px: float, pz: float, nominal: Segment) -> float:
    """The distance of a point from a nominal line or arc (an arc's nearest point: the one at the
    point's angle within the sweep, else the nearer end)."""
    if type(nominal) is Line:
        dx, dz = nominal.x1 - nominal.x0, nominal.z1 - nominal.z0
        length2 = dx * dx + dz * dz
        t = 0.0 if length2 == 0.0 else min(1.0, max(0.0, ((px - nominal.x0) * dx + (pz - nominal.z0) * dz) / length2))
        return math.hypot(px - nominal.x0 - t * dx, pz - nominal.z0 - t * dz)
    span = abs(nominal.sweep)
    sign = 1.0 if nominal.sweep >= 0 else -1.0
    along = (sign * (math.atan2(pz - nominal.zc, px - nominal.xc) - nominal.theta0)) % TAU
    if span > 0.0 and along <= span:
        t = along / span
        theta = nominal.theta0 + t * nominal.sweep
        r = nominal.r if nominal.r1 is None else nominal.r + t * (nominal.r1 - nominal.r)
        return abs(math.hypot(px - nominal.xc, pz - nominal.zc) - r) if nominal.r1 is None else \
            math.hypot(px - nominal.xc - r * math.cos(theta), pz - nominal.zc - r * math.sin(theta))
    (sx, sz), (ex, ez) = nominal.start, nominal.end
    return min(math.hypot(px - sx, pz - sz), math.hypot(px - ex, pz - ez))


def _boundaries(nominal: Segment) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """Lines (a point and a direction) where a point passes from beside the nominal to beyond an
    end: the normals at a line's ends; the rays through an arc's ends, and the line equidistant
    from its two ends (where the nearer end changes)."""
    if type(nominal) is Line:
        dx, dz = nominal.x1 - nominal.x0, nominal.z1 - nominal.z0
        return [(nominal.start, (-dz, dx)), (nominal.end, (-dz, dx))]
    (sx, sz), (ex, ez) = nominal.start, nominal.end
    rays = [(nominal.centre, (math.cos(theta), math.sin(theta))) for theta in (nominal.theta0, nominal.theta1)]
    if (sx, sz) != (ex, ez):
        rays.append((((sx + ex) / 2.0, (sz + ez) / 2.0), (sz - ez, ex - sx)))
    return rays


# ---------------------------------------------------------------------- the places on a line cut


def _line_points(cut: Cut, nominal: Segment) -> list[tuple[float, float]]:
    """Where a line cut may be farthest from a nominal arc: its ends, its point nearest the
    arc's centre (inside the circle), and where it crosses a boundary (the distance from an end
    of the arc is convex along a line, so largest at the ends of the stretch it governs)."""
    ax, az, dx, dz = cut.x0, cut.z0, cut.x1 - cut.x0, cut.z1 - cut.z0
    points = [(cut.x0, cut.z0), (cut.x1, cut.z1)]
    length2 = dx * dx + dz * dz
    if length2 == 0.0:
        return points
    params = [((nominal.xc - ax) * dx + (nominal.zc - az) * dz) / length2]
    for (qx, qz), (ex, ez) in _boundaries(nominal):  # where the cut crosses the line through q along e
        denominator = dx * ez - dz * ex
        if denominator != 0.0:
            params.append(((qx - ax) * ez - (qz - az) * ex) / denominator)
    points += [(ax + s * dx, az + s * dz) for s in params if 0.0 < s < 1.0]
    return points


# ---------------------------------------------------------------------- the places on an arc cut


def _spiral(cut: Cut) -> tuple[float, float, float, float]:
    """Start angle, signed sweep, start and end radius of an arc cut (as the control runs it)."""
    r0 = math.hypot(cut.x0 - cut.xc, cut.z0 - cut.zc)
    r1 = math.hypot(cut.x1 - cut.xc, cut.z1 - cut.zc)
    a0 = math.atan2(cut.z0 - cut.zc, cut.x0 - cut.xc)
    a1 = math.atan2(cut.z1 - cut.zc, cut.x1 - cut.xc)
    sweep = (a1 - a0) % TAU if cut.cw else -((a0 - a1) % TAU)
    if sweep == 0.0:
        sweep = TAU if cut.cw else -TAU
    return a0, sweep, r0, r1


def _arc_points(cut: Cut, nominal: Segment) -> list[tuple[float, float]]:
    """Where an arc cut may be farthest from the nominal: its ends; its points nearest to and
    farthest from a nominal arc's centre, or farthest on either side of a nominal line; its
    points farthest from the nominal's ends; where it crosses a boundary."""
    a0, sweep, r0, r1 = _spiral(cut)
    radius = (r0 + r1) / 2.0
    wx, wz = cut.xc, cut.zc
    angles: list[float] = []
    if type(nominal) is Line:
        phi = math.atan2(nominal.x0 - nominal.x1, nominal.z1 - nominal.z0)  # the line's normal
        angles += [phi, phi + math.pi]
    elif (nominal.xc, nominal.zc) != (wx, wz):
        phi = math.atan2(nominal.zc - wz, nominal.xc - wx)
        angles += [phi, phi + math.pi]
    for qx, qz in (nominal.start, nominal.end):
        if (qx, qz) != (wx, wz):
            angles.append(math.atan2(wz - qz, wx - qx))  # away from the end
    for (qx, qz), (ex, ez) in _boundaries(nominal):  # where the circle crosses the line through q along e
        norm = math.hypot(ex, ez)
        if norm == 0.0 or radius == 0.0:
            continue
        k = (ex * (qz - wz) - ez * (qx - wx)) / (norm * radius)  # m . (q - w), m = (-ez, ex) / norm
        if abs(k) <= 1.0:
            alpha, spread = math.atan2(ex, -ez), math.acos(k)
            angles += [alpha + spread, alpha - spread]
    span = abs(sweep)
    sign = 1.0 if sweep >= 0 else -1.0
    points = [(cut.x0, cut.z0), (cut.x1, cut.z1)]
    for phi in angles:
        along = (sign * (phi - a0)) % TAU
        if along < span:
            s = along / span
            theta, r = a0 + s * sweep, r0 + s * (r1 - r0)
            points.append((wx + r * math.cos(theta), wz + r * math.sin(theta)))
    return points
