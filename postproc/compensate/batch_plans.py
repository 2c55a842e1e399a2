"""One-block plans of many targets at once: for each target that :func:`.segmenter.plan` plans
as one line or one arc, that plan, worked out for a whole batch of targets by arrays.

A CAM program's moves are each planned as one block, and planning them one at a time costs
numpy calls on a few dozen samples per move: their overhead, not the arithmetic, is the time.
Here a batch's straight lines (:func:`.segmenter._straight`) are snapped together, and every
stage of :meth:`.segmenter.Segmenter.arc` runs once for all of its arcs: the targets across their
frames, the ends on the grid, the chord, the centre's Gauss-Newton fit, the rounded centres and
their radial bounds, and, in rounds, the candidates' paths across the frames.

The plans are the segmenter's, float for float. Each array operation is the one the segmenter
makes on the same operands (numpy's element-wise functions give an element the same value
wherever it stands in an array), and what the segmenter works out with :mod:`math` (radii,
angles, distances) is worked out here with :mod:`math` too. Two things cannot be reproduced
by arrays, and neither decides a plan here:

- the centre's fit, whose sums cannot be taken in the order of the segmenter's dot products:
  the fitted centre only chooses which rounded centres are tried, which way the arc turns and
  whether its radius is within the profile's largest, so a target whose centre lies within a
  thousand times the fit's settling step of a rounding boundary, of a turning boundary or of
  the largest radius (or beyond it) is left to the segmenter;
- a value that rounds to a decimal within a hair of a half, or a scaled value beyond the
  integers a float holds: rounded by the grid's own format.

A target the segmenter would plan by another route (a bent line, a full circle, a target that
turns back across its frame, one whose block does not keep within the tolerance) gets ``None``,
and is planned on its own. An arc whose chord may follow it is measured as a line first, as
the segmenter measures it.
"""

from __future__ import annotations

import math

import numpy as np

from ..geometry import TAU, Arc, Line
from ..machine.resolution import rounded
from .segmenter import (Cut, Limits, Plan, Target, _deviation, _grid_constants, arc_cut_spacing, chord_cannot_follow,
                        measure_bends, unit_steps)

#: the Gauss-Newton fit's iterations and settling step, as :meth:`Segmenter._refine`'s
_ITERATIONS = 12
_SETTLED = 1e-12
#: how far (mm, relative to the centre's distance from the chord, at least 1) a centre fitted
#: here may lie from the segmenter's: a thousand times the fit's settling step
_FIT_DOUBT = 1e-9
#: a scaled value within this of a half, or this large, is rounded by the grid's own format instead
_NEAR_HALF = 1e-6
_EXACT = 2.0**52


def batch_plans(targets: list[Target], limits: list[Limits], arcs: bool = True) -> list[Plan | None]:
    """For each target (planned within the limits beside it), the plan :func:`.segmenter.plan`
    gives it when that plan is one straight line (in every mode) or, with ``arcs`` (AUTO and ARC
    mode), one arc; None where it is not, or is not settled here (the caller then plans the
    target on its own)."""
    found: list[Plan | None] = [None] * len(targets)
    lines = [k for k, target in enumerate(targets) if type(target.nominal) is Line]
    if lines:
        for k, plan in zip(lines, _straight([targets[k] for k in lines], [limits[k] for k in lines])):
            found[k] = plan
    chosen = [k for k, target in enumerate(targets) if arcs and _eligible(target)]
    if chosen:
        for k, plan in zip(chosen, _Batch([targets[k] for k in chosen], [limits[k] for k in chosen]).plans()):
            found[k] = plan
    return found


def _straight(targets: list[Target], limits: list[Limits]) -> list[Plan | None]:
    """:func:`.segmenter._straight` of many line targets: a line moved by a displacement that
    changes linearly along it is one block between its snapped ends."""
    measure_bends(targets)
    plans: list[Plan | None] = [None] * len(targets)
    keep = [k for k, target in enumerate(targets) if target.bend <= 1e-12]  # NaN: left to the segmenter
    if not keep:
        return plans
    ends = np.array([(*targets[k].points[0].tolist(), *targets[k].points[-1].tolist()) for k in keep])
    grids = np.array([_grid_of(limits[k]) for k in keep])
    decimals, diameter, unit = grids.T
    (ax, az), (bx, bz) = (_snapped(ends[:, 0], ends[:, 1], decimals, diameter, unit),
                          _snapped(ends[:, 2], ends[:, 3], decimals, diameter, unit))
    dist = math.dist
    for k, (sx, sz, ex, ez), a_x, a_z, b_x, b_z in zip(keep, ends.tolist(), ax.tolist(), az.tolist(), bx.tolist(),
                                                         bz.tolist()):
        if a_x == b_x and a_z == b_z:
            continue
        deviation = max(dist((a_x, a_z), (sx, sz)), dist((b_x, b_z), (ex, ez)))
        if deviation <= limits[k].tolerance:
            plans[k] = Plan([Cut(a_x, a_z, b_x, b_z)], deviation, "line")
    return plans


def _grid_of(limits: Limits) -> tuple[float, float, float]:
    """The grid's decimals, X factor (2 when X is written as a diameter) and unit (mm)."""
    _, decimals, unit = _grid_constants(limits.grid)
    return decimals, 2.0 if limits.grid.diameter else 1.0, unit


def _snapped(x: np.ndarray, z: np.ndarray, decimals: np.ndarray, diameter: np.ndarray, unit: np.ndarray):
    """:meth:`Grid.snap` of many points: the word as the quotient of its digits (``rint`` of the
    scaled value) by the scale, as parsing the decimal gives; by the grid's own correctly rounded
    format (:func:`rounded`) where the scaled value lies within a hair of a half, or beyond the
    integers a float holds exactly."""
    scale = 10.0**decimals
    words = []
    for value in (x * diameter / unit, z / unit):
        scaled = value * scale
        word = np.rint(scaled) / scale
        word += 0.0
        doubtful = (np.abs(np.abs(scaled - np.floor(scaled)) - 0.5) < _NEAR_HALF) | (np.abs(scaled) >= _EXACT)
        for k in np.flatnonzero(doubtful & np.isfinite(scaled)).tolist():
            word[k] = rounded(float(value[k]), int(decimals[k])) + 0.0
        words.append(word)
    return words[0] * unit / diameter, words[1] * unit


def _eligible(target: Target) -> bool:
    """An arc target that :func:`.segmenter.plan` may plan as one arc by :meth:`Segmenter.arc`."""
    nominal = target.nominal
    return type(nominal) is Arc and abs(nominal.sweep) < 2.0 * math.pi - 1e-9 and len(target.t) >= 3


def _segment_starts(counts: np.ndarray) -> np.ndarray:
    starts = np.zeros(len(counts), dtype=np.int64)
    np.cumsum(counts[:-1], out=starts[1:])
    return starts


def _within(counts: np.ndarray) -> np.ndarray:
    """Each row's place within its segment, for segments of ``counts`` rows laid end to end."""
    return np.arange(int(counts.sum())) - np.repeat(_segment_starts(counts), counts)


class _Batch:
    """The targets of one batch through the stages; ``live`` marks those still on their way."""

    def __init__(self, targets: list[Target], limits: list[Limits]):
        self.targets, self.limits = targets, limits
        self.count = len(targets)
        self.counts = np.array([len(target.t) for target in targets])
        self.starts = _segment_starts(self.counts)
        self.points = np.concatenate([target.points for target in targets])
        values = {}
        for within in limits:
            if id(within) not in values:
                step, decimals, unit = _grid_constants(within.grid)
                values[id(within)] = (within.tolerance, decimals, 2.0 if within.grid.diameter else 1.0, unit, step,
                                      within.max_arc_radius)
        table = np.array([values[id(within)] for within in limits])
        self.tol, self.decimals, self.diameter, self.unit, self.step, self.max_radius = table.T
        shift = np.maximum.reduceat(np.hypot(*np.concatenate([target.d for target in targets]).T), self.starts)
        #: the targets :meth:`Segmenter.single_line` measures a line for first (their chord may follow them)
        self.line_first = ~np.array([chord_cannot_follow(target.nominal, size, within.tolerance, within.grid)
                                     for target, size, within in zip(targets, shift.tolist(), limits)], dtype=bool)
        self.live = np.ones(self.count, dtype=bool)
        self.lines: list[Plan | None] = [None] * self.count

    def plans(self) -> list[Plan | None]:
        stages = (self._frames, self._ends, self._lines_first, self._fit, self._centres, self._candidates, self._bounds)
        for stage in stages:
            if not self.live.any():
                return self.lines
            stage()
        return [line or arc for line, arc in zip(self.lines, self._measure())]

    def _spacing(self, k: int) -> float:
        """:attr:`Segmenter.spacing` of target k: its frame's sampling of a planned path."""
        tolerance = self.limits[k].tolerance
        return min(self.limits[k].spacing, math.sqrt(8.0 * self.targets[k].nominal.r * tolerance * 0.01))

    # ---------------------------------------------------------------- the targets

    def _frames(self) -> None:
        """Each target across its nominal's frame (:meth:`Frame.uv`), and whether it runs
        forwards along it (:attr:`Segmenter._backwards`, ``_rising``)."""
        nominals = [target.nominal for target in self.targets]
        frame = np.array([(n.xc, n.zc, n.theta0 + n.sweep / 2.0, n.sweep >= 0, abs(n.sweep) / 2.0, n.r) for n in nominals])
        self.frame = frame
        cx, cz, mid, forward, half, r = (frame[:, k].repeat(self.counts) for k in range(6))
        self.u, self.v = _arc_uv(self.points[:, 0] - cx, self.points[:, 1] - cz, mid, forward > 0.0, half, r)
        steps = np.empty(len(self.u))
        np.subtract(self.u[1:], self.u[:-1], out=steps[:-1])
        steps[self.starts[1:] - 1] = math.inf  # across two targets
        steps[-1] = math.inf
        least = np.minimum.reduceat(steps, self.starts)
        self.live &= least >= -1e-9  # a target that turns back across its frame: every arc measures inf
        self.rising = (least > 0.0).tolist()

    def _ends(self) -> None:
        """The target's ends on the grid (:meth:`Grid.snap`, the segmenter's vertices), how far
        they lie off the target, and the chord between them (as :meth:`Segmenter.arc` works
        them out), once for the line tried first and the arcs after it."""
        last = self.starts + self.counts - 1
        first_x, first_z = self.points[self.starts].T
        last_x, last_z = self.points[last].T
        ax, az = _snapped(first_x, first_z, self.decimals, self.diameter, self.unit)
        bx, bz = _snapped(last_x, last_z, self.decimals, self.diameter, self.unit)
        self.live &= (ax != bx) | (az != bz)
        self.a, self.b = (ax, az), (bx, bz)
        self.mid = ((ax + bx) / 2.0, (az + bz) / 2.0)
        chord_x, chord_z = bx - ax, bz - az
        with np.errstate(all="ignore"):
            self.half = np.sqrt(chord_x * chord_x + chord_z * chord_z) / 2.0
            self.normal = (-chord_z / (2.0 * self.half), chord_x / (2.0 * self.half))
        self.ends_off = np.full(self.count, math.inf)  # Segmenter._ends_off: how far they lie off the target
        for k in np.flatnonzero(self.live).tolist():
            self.ends_off[k] = max(math.dist((float(ax[k]), float(az[k])), (float(first_x[k]), float(first_z[k]))),
                                   math.dist((float(bx[k]), float(bz[k])), (float(last_x[k]), float(last_z[k]))))

    def _lines_first(self) -> None:
        """:meth:`Segmenter.single_line` of the targets whose chord may follow them: the line
        between the snapped ends, sampled as the segmenter samples it and measured across the
        frame; one within the tolerance is the plan, the others go on to their arcs."""
        which = np.flatnonzero(self.live & self.line_first).tolist()
        if not which:
            return
        (ax, az), (bx, bz) = (self.a[0].tolist(), self.a[1].tolist()), (self.b[0].tolist(), self.b[1].tolist())
        counts = np.array([max(2, math.ceil(math.hypot(bx[k] - ax[k], bz[k] - az[k]) / self._spacing(k)) + 1)
                           for k in which])  # Cut.sample's
        s = np.concatenate([unit_steps(n) for n in counts.tolist()])
        rows = np.array(which)
        x0, z0 = self.a[0][rows].repeat(counts), self.a[1][rows].repeat(counts)
        x = x0 + s * (self.b[0][rows] - self.a[0][rows]).repeat(counts)
        z = z0 + s * (self.b[1][rows] - self.a[1][rows]).repeat(counts)
        cx, cz, mid, forward, half, r = (self.frame[rows, k].repeat(counts) for k in range(6))
        u, v = _arc_uv(x - cx, z - cz, mid, forward > 0.0, half, r)
        ends = np.cumsum(counts).tolist()
        for k, a, b in zip(which, [0] + ends[:-1], ends):
            target_rows = slice(self.starts[k], self.starts[k] + self.counts[k])
            off = float(self.ends_off[k])
            deviation = max(_deviation(self.u[target_rows], self.v[target_rows], u[a:b], v[a:b], True, self.rising[k]),
                            off)
            if deviation <= self.tol[k]:
                self.lines[k] = Plan([Cut(ax[k], az[k], bx[k], bz[k])], deviation, "line")
                self.live[k] = False

    # ---------------------------------------------------------------- the centre

    def _fit(self) -> None:
        """:meth:`Segmenter._refine` of every live target at once, from the nominal's centre
        (:meth:`Segmenter._centre_guess` of a whole arc target), each stopping on its own step
        as the segmenter's does; a fit that fails or does not settle is left to the segmenter."""
        live = np.flatnonzero(self.live)
        counts = self.counts[live]
        mid_x, mid_z = self.mid[0][live], self.mid[1][live]
        nx, nz = self.normal[0][live], self.normal[1][live]
        half = self.half[live]
        lam = (self.frame[live, 0] - mid_x) * nx + (self.frame[live, 1] - mid_z) * nz
        active = np.ones(len(live), dtype=bool)
        failed = np.zeros(len(live), dtype=bool)
        work = None
        with np.errstate(all="ignore"):
            for _ in range(_ITERATIONS):
                if work is None or active[work].sum() < 0.5 * len(work):  # the working rows: the targets still moving
                    work = np.flatnonzero(active)
                    n = counts[work]
                    starts = _segment_starts(n)
                    at = np.arange(len(work)).repeat(n)  # each row's target among the working ones
                    rows = self.starts[live[work]].repeat(n) + _within(n)
                    rel_x = self.points[rows, 0] - mid_x[work][at]
                    rel_z = self.points[rows, 1] - mid_z[work][at]
                    row_nx, row_nz = nx[work][at], nz[work][at]
                    q = rel_x * row_nx + rel_z * row_nz
                lam_work = lam[work]
                lam_at = lam_work[at]
                dist = np.hypot(rel_x - lam_at * row_nx, rel_z - lam_at * row_nz)
                radius = np.hypot(half[work], lam_work)
                jac = (lam_at - q) / dist - (lam_work / radius)[at]
                denominator = np.add.reduceat(jac * jac, starts)
                step = -np.add.reduceat(jac * (dist - radius[at]), starts) / denominator
                bad = ((radius == 0.0) | (np.minimum.reduceat(dist, starts) == 0.0) | (denominator == 0.0)
                       | ~np.isfinite(step))
                moving = active[work]
                lam[work] = np.where(moving & ~bad, lam_work + step, lam_work)
                failed[work] |= moving & bad
                active[work] = moving & ~bad & ~(np.abs(step) < _SETTLED * np.maximum(1.0, np.abs(lam[work])))
                if not active.any():
                    break
        self.live[live] = ~active & ~failed & np.isfinite(lam)
        self.lam = np.zeros(self.count)
        self.lam[live] = lam

    def _centres(self) -> None:
        """The fitted centre, the way the arc turns (:meth:`Segmenter._direction`) and the I and
        K words in grid steps (as :meth:`Segmenter._rounded_centres` counts them), where the
        fit's doubt cannot change them, for an arc whose radius is clearly within the largest."""
        lam, (mid_x, mid_z), (nx, nz) = self.lam, self.mid, self.normal
        doubt = _FIT_DOUBT * np.maximum(1.0, np.abs(lam))
        with np.errstate(all="ignore"):
            centre_x, centre_z = mid_x + lam * nx, mid_z + lam * nz
            self.live &= np.hypot(self.half, lam) < self.max_radius - doubt  # the segmenter refuses a larger one
            margin = doubt / (self.unit * self.step)
            (ax, az), (bx, bz) = self.a, self.b
            for steps in ((centre_x - ax) / self.unit / self.step, (centre_z - az) / self.unit / self.step):
                self.live &= (steps - np.floor(steps) > margin) & (np.ceil(steps) - steps > margin)
            self.centre_steps = ((centre_x - ax) / self.unit / self.step, (centre_z - az) / self.unit / self.step)
            middle = self.points[self.starts + self.counts // 2]
            turns = [_turns(ax, az, bx, bz, mid_x + way * nx, mid_z + way * nz, middle)
                     for way in (lam - doubt, lam, lam + doubt)]
        self.live &= (turns[0] == turns[1]) & (turns[1] == turns[2])
        self.cw = turns[1]

    def _candidates(self) -> None:
        """The candidate cuts of :meth:`Segmenter.arc`: the rounded centres in the order the segmenter's set of
        them gives, less those the radius check refuses and one on the start point, with the
        ring of each."""
        live = np.flatnonzero(self.live)
        unit = self.unit[live]
        scale = 10.0**self.decimals[live]
        ix, kz = self.centre_steps[0][live], self.centre_steps[1][live]
        ax, az = self.a[0][live], self.a[1][live]
        x_down, x_up = ax + np.floor(ix) / scale * unit, ax + np.ceil(ix) / scale * unit  # Grid.offset_of
        z_down, z_up = az + np.floor(kz) / scale * unit, az + np.ceil(kz) / scale * unit
        rows = zip(live.tolist(), ax.tolist(), az.tolist(), self.b[0][live].tolist(), self.b[1][live].tolist(),
                   x_down.tolist(), x_up.tolist(), z_down.tolist(), z_up.tolist())
        owner, centres, rings = [], [], []
        hypot = math.hypot
        for k, a_x, a_z, b_x, b_z, xd, xu, zd, zu in rows:
            radius_tolerance = self.limits[k].arc_radius_tolerance
            kept = 0
            for x, z in {(xd, zd), (xd, zu), (xu, zd), (xu, zu)}:
                r0 = hypot(a_x - x, a_z - z)  # as Cut._spiral
                r1 = hypot(b_x - x, b_z - z)
                if abs(r1 - r0) > radius_tolerance or (abs(x - a_x) < 1e-12 and abs(z - a_z) < 1e-12):
                    continue
                owner.append(k)
                centres.append((x, z))
                rings.append((r0, r1) if r0 <= r1 else (r1, r0))
                kept += 1
            if not kept:
                self.live[k] = False
        self.owner = np.array(owner, dtype=np.int64)
        self.centres = np.array(centres).reshape(-1, 2)
        self.rings = np.array(rings).reshape(-1, 2)

    def _bounds(self) -> None:
        """:meth:`Segmenter._radial_bounds` of every candidate, and the order each target's
        candidates are measured in: least bound first, then as the set gave them."""
        owner = self.owner
        counts = self.counts[owner] - 2  # the inner samples
        rows = np.repeat(self.starts[owner] + 1, counts) + _within(counts)
        distance = np.hypot(self.points[rows, 0] - self.centres[:, 0].repeat(counts),
                            self.points[rows, 1] - self.centres[:, 1].repeat(counts))
        starts = _segment_starts(counts)
        far, near = np.maximum.reduceat(distance, starts), np.minimum.reduceat(distance, starts)
        bounds = np.maximum(np.maximum(far - self.rings[:, 1], self.rings[:, 0] - near), 0.0) - 0.05 * self.tol[owner]
        self.live[owner[np.isnan(bounds)]] = False
        self.order = np.lexsort((np.arange(len(owner)), bounds, owner))  # by target, bound, then the set's order
        self.bounds = bounds

    # ---------------------------------------------------------------- measuring

    def _measure(self) -> list[Plan | None]:
        """The candidates measured in rounds, as :meth:`Segmenter.arc` goes through them: each
        target's next candidate is measured unless its bound (or the ends' distance) already
        reaches the best deviation found; the best one within the tolerance is the plan."""
        order = self.order[self.live[self.owner[self.order]]]
        owner = self.owner[order]
        first = np.flatnonzero(np.r_[True, owner[1:] != owner[:-1]]) if len(owner) else np.zeros(0, dtype=np.int64)
        rank = np.arange(len(order)) - first.repeat(np.diff(np.r_[first, len(order)]))
        best = np.full(self.count, math.inf)
        chosen = np.full(self.count, -1)
        going = np.ones(self.count, dtype=bool)
        bounds, ends, centres = self.bounds.tolist(), self.ends_off.tolist(), self.centres.tolist()
        (ax, az), (bx, bz) = (self.a[0].tolist(), self.a[1].tolist()), (self.b[0].tolist(), self.b[1].tolist())
        cw = self.cw.tolist()
        for round_ in range(4):
            jobs = []
            for pair in order[rank == round_].tolist():
                k = int(self.owner[pair])
                if not going[k]:
                    continue
                if max(bounds[pair], ends[k]) >= best[k]:
                    going[k] = False  # no candidate left can beat the best
                    continue
                x, z = centres[pair]
                jobs.append((k, pair, Cut(ax[k], az[k], bx[k], bz[k], x, z, cw[k])))
            if not jobs:
                break
            for (k, pair, cut), (pu, pv) in zip(jobs, self._paths(jobs)):
                rows = slice(self.starts[k], self.starts[k] + self.counts[k])
                deviation = max(_deviation(self.u[rows], self.v[rows], pu, pv, True, self.rising[k]), ends[k])
                if deviation < best[k]:
                    best[k], chosen[k] = deviation, pair
        plans: list[Plan | None] = [None] * self.count
        tolerance = self.tol.tolist()
        for k in np.flatnonzero(self.live & (chosen >= 0)).tolist():
            if best[k] <= tolerance[k]:
                x, z = centres[chosen[k]]
                plans[k] = Plan([Cut(ax[k], az[k], bx[k], bz[k], x, z, cw[k])], float(best[k]), "arc")
        return plans

    def _paths(self, jobs: list[tuple[int, int, Cut]]) -> list[tuple[np.ndarray, np.ndarray]]:
        """:meth:`Frame.path_uv` of each job's arc cut in its target's frame, all at once, each
        sampled as :meth:`Segmenter._spacing` says."""
        frame = self.frame
        steps = []
        for k, _, cut in jobs:
            nominal = self.targets[k].nominal
            steps.append(cut._steps(arc_cut_spacing(cut, self._spacing(k), self.limits[k].tolerance, 1.0 / nominal.r,
                                                    nominal.xc, nominal.zc)))
        counts = np.array([len(s) for s, *_ in steps])
        s = np.concatenate([s for s, *_ in steps])
        per_cut = np.array([(a0, sweep, r1 - r0, r0, cut.xc, cut.zc) for (_, a0, sweep, r0, r1), (_, _, cut) in
                            zip(steps, jobs)])
        a0, sweep, drift, r0, xc, zc = (per_cut[:, k].repeat(counts) for k in range(6))
        owners = np.array([k for k, _, _ in jobs])
        cx, cz, mid, forward, half, r = (frame[owners, k].repeat(counts) for k in range(6))
        theta = s * sweep
        theta += a0
        radius = s * drift
        radius += r0
        rel_x = np.cos(theta)
        rel_x *= radius
        rel_x += xc
        rel_x -= cx
        rel_z = np.sin(theta)
        rel_z *= radius
        rel_z += zc
        rel_z -= cz
        u, v = _arc_uv(rel_x, rel_z, mid, forward > 0.0, half, r)
        ends = np.cumsum(counts).tolist()
        return [(u[a:b], v[a:b]) for a, b in zip([0] + ends[:-1], ends)]


def _turns(ax, az, bx, bz, centre_x, centre_z, middle: np.ndarray) -> np.ndarray:
    """:meth:`Segmenter._direction` of many arcs: G02 (True) when the middle sample lies on the
    theta-increasing way from a to b about the centre."""
    t0 = np.arctan2(az - centre_z, ax - centre_x)
    t1 = np.arctan2(bz - centre_z, bx - centre_x)
    tm = np.arctan2(middle[:, 1] - centre_z, middle[:, 0] - centre_x)
    return np.remainder(tm - t0, TAU) < np.remainder(t1 - t0, TAU)


def _arc_uv(rel_x: np.ndarray, rel_z: np.ndarray, mid, forward, half, r) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`Frame._arc_uv` element by element, each element with its own frame (``forward``:
    the frame's sweep is not negative)."""
    along = np.arctan2(rel_z, rel_x)
    along = np.where(forward, along - mid, mid - along)
    along += math.pi
    outside = ~((along >= 0.0) & (along < TAU))
    if outside.any():  # the remainder of a value within [0, tau) is that value
        along[outside] = np.remainder(along[outside], TAU)
    along -= math.pi
    along += half
    along *= r
    across = np.hypot(rel_x, rel_z)
    across -= r
    return along, across


__all__ = ["batch_plans"]
