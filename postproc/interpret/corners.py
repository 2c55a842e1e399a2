"""``,C`` chamfers and ``,R`` fillets between two moves, as the control inserts them.

A corner word on a G01/G02/G03 block asks the control to cut the corner between that move
and the next: ``,C`` with a straight chamfer whose ends lie at the given distance from the
virtual corner (measured straight, also along an arc), ``,R`` with an arc of the given
radius tangent to both moves. The two moves are shortened to meet the inserted one.
"""

from __future__ import annotations

import math


from ..diagnostics import CornerError
from .motion import ARC, CORNER, LINE, RUN, Move


def _tangent(move: Move, at_end: bool) -> tuple[float, float]:
    """Unit direction of travel at the start or the end of a move."""
    if move.kind == LINE:
        dx, dz = move.x1 - move.x0, move.z1 - move.z0
        length = math.hypot(dx, dz)
        if length == 0:
            raise CornerError("a corner next to a move of zero length")
        return dx / length, dz / length
    px, pz = (move.x1, move.z1) if at_end else (move.x0, move.z0)
    rx, rz = px - move.xc, pz - move.zc
    radius = math.hypot(rx, rz)
    # theta grows for G02: the tangent is the radius turned +90 degrees.
    tx, tz = (-rz / radius, rx / radius) if move.cw else (rz / radius, -rx / radius)
    return tx, tz


def _contains(move: Move, x: float, z: float) -> bool:
    """Whether a point on the move's line or circle lies within the move itself."""
    if move.kind == LINE:
        dx, dz = move.x1 - move.x0, move.z1 - move.z0
        t = ((x - move.x0) * dx + (z - move.z0) * dz) / (dx * dx + dz * dz)
        return -1e-9 <= t <= 1 + 1e-9
    start = math.atan2(move.z0 - move.zc, move.x0 - move.xc)
    end = math.atan2(move.z1 - move.zc, move.x1 - move.xc)
    point = math.atan2(z - move.zc, x - move.xc)
    sign = 1.0 if move.cw else -1.0
    sweep = (sign * (end - start)) % (2 * math.pi) or 2 * math.pi
    along = (sign * (point - start)) % (2 * math.pi)
    return along <= sweep + 1e-9 or along >= 2 * math.pi - 1e-9


def _offset_intersections(first: Move, second: Move, side: float, radius: float) -> list[tuple[float, float]]:
    """Centres at ``radius`` from both moves, on the ``side`` (+1 left) of travel."""
    loci = [_locus(first, side, radius), _locus(second, side, radius)]
    kinds = (loci[0][0], loci[1][0])
    if kinds == ("line", "line"):
        (_, a, u), (_, b, v) = loci
        denominator = u[0] * v[1] - u[1] * v[0]
        if abs(denominator) < 1e-12:
            return []
        t = ((b[0] - a[0]) * v[1] - (b[1] - a[1]) * v[0]) / denominator
        return [(a[0] + t * u[0], a[1] + t * u[1])]
    if "line" in kinds:
        line, circle = (loci[0], loci[1]) if kinds[0] == "line" else (loci[1], loci[0])
        return _line_circle(line[1], line[2], circle[1], circle[2])
    return _circle_circle(loci[0][1], loci[0][2], loci[1][1], loci[1][2])


def _locus(move: Move, side: float, radius: float):
    if move.kind == LINE:
        ux, uz = _tangent(move, True)
        nx, nz = -uz, ux  # left normal
        return ("line", (move.x0 + side * radius * nx, move.z0 + side * radius * nz), (ux, uz))
    arc_radius = math.hypot(move.x0 - move.xc, move.z0 - move.zc)
    inward = 1.0 if move.cw else -1.0  # the left side of a G02 arc faces its centre
    return ("circle", (move.xc, move.zc), arc_radius - side * inward * radius)


def _line_circle(a, u, c, r) -> list[tuple[float, float]]:
    fx, fz = a[0] - c[0], a[1] - c[1]
    b = fx * u[0] + fz * u[1]
    disc = b * b - (fx * fx + fz * fz - r * r)
    if disc < 0 or r <= 0:
        return []
    root = math.sqrt(disc)
    return [(a[0] + t * u[0], a[1] + t * u[1]) for t in (-b - root, -b + root)]


def _circle_circle(c0, r0, c1, r1) -> list[tuple[float, float]]:
    dx, dz = c1[0] - c0[0], c1[1] - c0[1]
    d = math.hypot(dx, dz)
    if d == 0 or d > r0 + r1 or d < abs(r0 - r1) or r0 <= 0 or r1 <= 0:
        return []
    a = (r0 * r0 - r1 * r1 + d * d) / (2 * d)
    h = math.sqrt(max(r0 * r0 - a * a, 0.0))
    mx, mz = c0[0] + a * dx / d, c0[1] + a * dz / d
    return [(mx - h * dz / d, mz + h * dx / d), (mx + h * dz / d, mz - h * dx / d)]


def _foot(move: Move, x: float, z: float) -> tuple[float, float]:
    """The point of the move's line or circle nearest to (x, z)."""
    if move.kind == LINE:
        ux, uz = _tangent(move, True)
        t = (x - move.x0) * ux + (z - move.z0) * uz
        return move.x0 + t * ux, move.z0 + t * uz
    rx, rz = x - move.xc, z - move.zc
    scale = math.hypot(move.x0 - move.xc, move.z0 - move.zc) / math.hypot(rx, rz)
    return move.xc + rx * scale, move.zc + rz * scale


def _at_distance(move: Move, corner: tuple[float, float], distance: float, before: bool) -> tuple[float, float]:
    """The point of the move at a straight ``distance`` from the corner (its end or start)."""
    if move.kind == LINE:
        ux, uz = _tangent(move, True)
        sign = -1.0 if before else 1.0
        return corner[0] + sign * distance * ux, corner[1] + sign * distance * uz
    radius = math.hypot(move.x0 - move.xc, move.z0 - move.zc)
    candidates = _circle_circle(corner, distance, (move.xc, move.zc), radius)
    inside = [point for point in candidates if _contains(move, *point)]
    if not inside:
        raise CornerError(f"chamfer {distance:g} mm is longer than the arc it cuts (FANUC alarm PS0055)")
    return min(inside, key=lambda p: math.hypot(p[0] - corner[0], p[1] - corner[1]))


def corner_moves(first: Move, second: Move, kind: str, size: float) -> tuple[Move, Move, Move]:
    """The first move shortened, the corner move, and the second move shortened."""
    if size <= 0:
        raise CornerError(f"corner {kind}{size:g}: the size must be positive")
    corner = (first.x1, first.z1)
    t1, t2 = _tangent(first, True), _tangent(second, False)
    turn = t1[0] * t2[1] - t1[1] * t2[0]
    if abs(turn) < 1e-9 and t1[0] * t2[0] + t1[1] * t2[1] > 0:
        raise CornerError(f"corner {kind} between moves that do not turn: there is no corner to cut")
    if kind == ",C":
        a = _at_distance(first, corner, size, True)
        b = _at_distance(second, corner, size, False)
        inserted = Move(LINE, first.line, a[0], a[1], b[0], b[1], role=CORNER, feed=first.feed,
                        per_rev=first.per_rev, comp=first.comp, tool=first.tool)
    else:
        side = 1.0 if turn > 0 else -1.0
        centres = _offset_intersections(first, second, side, size)
        if not centres:
            raise CornerError(f"corner ,R{size:g} does not fit between these moves (FANUC alarm PS0055)")
        centre = min(centres, key=lambda c: math.hypot(c[0] - corner[0], c[1] - corner[1]))
        a, b = _foot(first, *centre), _foot(second, *centre)
        inserted = Move(ARC, first.line, a[0], a[1], b[0], b[1], xc=centre[0], zc=centre[1], cw=turn > 0,
                        role=CORNER, feed=first.feed, per_rev=first.per_rev, comp=first.comp, tool=first.tool)
    if not (_contains(first, *a) and _contains(second, *b)):
        raise CornerError(f"corner {kind}{size:g} is larger than the moves it joins (FANUC alarm PS0055)")
    return (
        first._replace(x1=a[0], z1=a[1]),
        inserted._replace(role=CORNER if first.role == RUN else first.role),
        second._replace(x0=b[0], z0=b[1]),
    )
