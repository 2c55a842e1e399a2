"""How far a written block runs from the nominal path: the last check before a block is written.

The self-check measures each replacement against the compensated path it was planned for,
within the tolerance. This check measures it against the nominal path itself, which no
option changes: a written cut may lie no further from the move it replaces than the largest
correction plus the tolerance. It is what refuses, whatever went wrong before it, an arc
written as its chord (``--tolerance 20``), a connecting move to a wrong point, or a plan that
wandered off.

It must be cheap (it runs on every replaced block), so it is computed, not sampled. The
distance from a line or an arc to a line or an arc is largest at an end of the cut, where the
cut passes closest to or farthest from a point of the nominal (its centre, its ends), where it
runs parallel to a nominal line, or where it crosses from beside the nominal segment to beyond
one of its ends: :func:`farthest` finds those few places in closed form and measures there (a
spiral arc, its end radius differing from its start within the control's radius check, is
located as its circle and measured as the spiral it is). :func:`within` first tries a bound
that takes a handful of operations for the usual case, a cut that follows a nominal arc
inside its sweep, and measures exactly only when the bound does not settle it.
"""

from __future__ import annotations

import math

from ..geometry import TAU, Line, Segment
from .segmenter import Cut

SLIVER = 0.01  #: radians: how far beyond a nominal arc's end the quick bound still reaches


def farthest(cut: Cut, nominal: Segment) -> float:
    """The largest distance, in mm, of any point of ``cut`` from the nominal segment."""
    if cut.xc is None:
        if type(nominal) is Line:  # the distance from a segment is convex: largest at an end
            return max(_distance(cut.x0, cut.z0, nominal), _distance(cut.x1, cut.z1, nominal))
        points = _line_points(cut, nominal)
    else:
        points = _arc_points(cut, nominal)
    return max([_distance(x, z, nominal) for x, z in points])


def within(cut: Cut, nominal: Segment, allowed: float) -> bool:
    """Whether no point of ``cut`` lies further than ``allowed`` from the nominal segment: a
    bound settles it in a few operations where it can (a cut along an arc, inside the arc's
    sweep), the exact :func:`farthest` where it cannot."""
    if cut.xc is None and type(nominal) is Line:  # the distance from a segment is convex: largest at an end
        ax, az = nominal.x0, nominal.z0
        dx, dz = nominal.x1 - ax, nominal.z1 - az
        length2 = dx * dx + dz * dz
        for px, pz in ((cut.x0, cut.z0), (cut.x1, cut.z1)):
            t = 0.0 if length2 == 0.0 else ((px - ax) * dx + (pz - az) * dz) / length2
            t = 0.0 if t < 0.0 else (1.0 if t > 1.0 else t)
            if math.hypot(px - ax - t * dx, pz - az - t * dz) > allowed:
                return False
        return True
    if type(nominal) is not Line:
        bound = _along_arc(cut, nominal)
        if bound is not None and bound <= allowed:
            return True
    return farthest(cut, nominal) <= allowed


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


def _inside(arc, px: float, pz: float) -> float:
    """The parameter of a point's angle along an arc's sweep: beyond [0, 1] outside it, on the
    nearer side (as ``Arc.param_of``)."""
    span = abs(arc.sweep)
    sign = 1.0 if arc.sweep >= 0 else -1.0
    along = (sign * (math.atan2(pz - arc.zc, px - arc.xc) - arc.theta0)) % TAU
    if along > span and along - span > TAU - along:
        along -= TAU
    return along / span


def _along_arc(cut: Cut, arc) -> float | None:
    """A bound on the distance of a cut from a nominal arc when the cut lies within the arc's
    sweep seen from its centre (or beyond an end by a sliver: a corrected point moves along the
    arc too), where the distance is the radial one; else None.

    A line from A to B stays in the wedge between them when that wedge is under half a turn;
    an arc about a centre w nearer the nominal centre c than its radius turns about c one way
    only, from A's angle to B's when its own turn is about as far (not a full turn more). Inside,
    the distance from the arc is at most the farthest the cut gets from c beyond the radius, or
    the nearest short of it; a point beyond an end by the angle e is at most that plus the arc
    length e from the end."""
    span = abs(arc.sweep)
    if not 0.0 < span < TAU:
        return None
    ta, tb = _inside(arc, cut.x0, cut.z0), _inside(arc, cut.x1, cut.z1)
    beyond = max(0.0, -ta, -tb, ta - 1.0, tb - 1.0) * span
    if beyond > SLIVER:
        return None
    low, high = (arc.r, arc.r) if arc.r1 is None else (min(arc.r, arc.r1), max(arc.r, arc.r1))
    cx, cz = arc.xc, arc.zc
    if cut.xc is None:
        if abs(ta - tb) * span >= math.pi:
            return None
        dx, dz = cut.x1 - cut.x0, cut.z1 - cut.z0
        length2 = dx * dx + dz * dz
        s = 0.0 if length2 == 0.0 else min(1.0, max(0.0, ((cx - cut.x0) * dx + (cz - cut.z0) * dz) / length2))
        nearest = math.hypot(cut.x0 + s * dx - cx, cut.z0 + s * dz - cz)
        reach = max(math.hypot(cut.x0 - cx, cut.z0 - cz), math.hypot(cut.x1 - cx, cut.z1 - cz))
    else:
        if not ta <= tb or bool(cut.cw) != (arc.sweep > 0):
            return None
        a0, sweep, r0, r1 = _spiral(cut)
        wx, wz = cut.xc, cut.zc
        if math.hypot(wx - cx, wz - cz) >= min(r0, r1) or abs(abs(sweep) - (tb - ta) * span) >= math.pi / 2:
            return None  # the cut turns about c otherwise than from A's angle to B's
        # on the cut's circle (radius r0), the distance from c is extreme at the ends and where
        # the radius points at c or away from it; a spiral strays from that circle by |r1 - r0|
        gaps = [math.hypot(cut.x0 - cx, cut.z0 - cz), math.hypot(cut.x1 - cx, cut.z1 - cz)]
        towards = math.atan2(cz - wz, cx - wx)
        sign = 1.0 if sweep >= 0 else -1.0
        for phi in (towards, towards + math.pi):
            if (sign * (phi - a0)) % TAU < abs(sweep):
                gaps.append(math.hypot(wx + r0 * math.cos(phi) - cx, wz + r0 * math.sin(phi) - cz))
        drift = abs(r1 - r0)
        nearest, reach = min(gaps) - drift, max(gaps) + drift
    radial = max(reach - low, high - nearest, 0.0)
    return radial + beyond * (reach + radial)


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
    r0, r1, sweep = cut._spiral()
    return math.atan2(cut.z0 - cut.zc, cut.x0 - cut.xc), sweep, r0, r1


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
