"""The tolerance-driven segmenter: the fewest blocks that follow a target path.

A target is a nominal move (line or arc) plus a displacement sampled along it: what a
compensator asks for. The segmenter plans blocks on the control's grid (resolution.py)
and chooses between

- one line, when the target is straight within the tolerance;
- one arc through the (rounded) end points, its centre fitted to the target;
- several arcs, found greedily (each reaches as far as it can while every target sample
  and every point of the arc stays within the tolerance, the way good arc welders fit
  arcs to polylines);
- lines by polar interpolation whose vertices straddle the target: placed outside it by
  nearly the tolerance, so that each chord dips inside by as much as its vertices stand
  out. On a circle of radius R with tolerance t a chord then spans
  ``2 acos((R - t)/(R + t))``, about sqrt(2) longer than chords with vertices on the circle.

Every candidate is measured, not assumed: the planned blocks are rebuilt as the control
will run them (end points rounded to the grid, arcs about the centre their rounded I and K
give, the radius drifting from the start radius to the end radius as a control does when
they differ), sampled, and compared with the target across it (radially about an arc's
centre, normally to a line; both are upper bounds of the true distance).
"""

from __future__ import annotations

import math
from bisect import bisect_left
from dataclasses import dataclass, replace
from functools import cached_property, lru_cache
from typing import NamedTuple

import numpy as np

from ..diagnostics import RADIUS_CHECK, RESOLUTION, TOLERANCE, FitError, PlanError
from ..geometry import TAU, Arc, Line, Segment
from ..machine.profile import DEFAULT
from ..machine.resolution import Grid

AUTO, ARC_MODE, LINE_MODE = "auto", "arc", "line"


@dataclass(frozen=True)
class Target:
    """A nominal move and the displacement wanted along it (sampled at ``t`` in [0, 1])."""

    nominal: Segment
    t: np.ndarray
    d: np.ndarray  #: (n, 2) displacement in radius mm

    @classmethod
    def along(cls, nominal: Segment, t: np.ndarray, d: np.ndarray, nominal_points: np.ndarray) -> "Target":
        """A target whose nominal points at ``t`` the caller has already sampled."""
        target = cls(nominal, t, d)
        target.__dict__["points"] = nominal_points + d  # what the cached property would compute
        return target

    def at(self, t) -> np.ndarray:
        t = np.atleast_1d(np.asarray(t, dtype=float))
        shift = np.column_stack([np.interp(t, self.t, self.d[:, 0]), np.interp(t, self.t, self.d[:, 1])])
        return self.nominal.point_at(t) + shift

    @cached_property
    def points(self) -> np.ndarray:
        return self.nominal.point_at(self.t) + self.d

    @cached_property
    def bend(self) -> float:
        """How far the displacement departs from changing linearly along the move, mm."""
        measure_bends([self])
        return self.__dict__["bend"]

    @property
    def start(self) -> tuple[float, float]:
        return tuple(self.points[0].tolist())  # tolist: iterating a numpy row costs an IndexError at its end

    @property
    def end(self) -> tuple[float, float]:
        return tuple(self.points[-1].tolist())


def measure_bends(targets: list[Target]) -> None:
    """:attr:`Target.bend` of many targets in one array pass, the same arithmetic row for row:
    the planner asks it of every line, and a program has thousands of short ones."""
    targets = [target for target in targets if "bend" not in target.__dict__]
    if not targets:
        return
    counts = [len(target.t) for target in targets]
    d = np.concatenate([target.d for target in targets])
    first = np.repeat(np.array([target.d[0] for target in targets]), counts, axis=0)
    last = np.repeat(np.array([target.d[-1] for target in targets]), counts, axis=0)
    linear = first + np.concatenate([target.t for target in targets])[:, None] * (last - first)
    starts = np.cumsum([0] + counts[:-1])
    bends = np.maximum.reduceat(np.abs(d - linear).max(axis=1), starts).tolist()
    for target, bend in zip(targets, bends):
        target.__dict__["bend"] = bend  # what the cached property would compute


def sample_params(nominal: Segment, spacing: float = 0.05, lowest: int = 16, highest: int = 1024) -> np.ndarray:
    """Where to ask a compensator for its correction along a nominal move."""
    count = math.ceil(nominal.length / spacing)
    if isinstance(nominal, Arc):
        count = max(count, math.ceil(abs(math.degrees(nominal.sweep)) / 0.5))
    return unit_steps(min(max(count, lowest), highest) + 1)


@lru_cache(maxsize=4096)
def unit_steps(n: int) -> np.ndarray:
    """``np.linspace(0, 1, n)``, made once per count and read-only: a program asks for the
    same few counts thousands of times."""
    steps = np.linspace(0.0, 1.0, n)
    steps.setflags(write=False)
    return steps


class Cut(NamedTuple):
    """One block as the control will run it: end points on the grid, arcs about the
    centre that the rounded start point and rounded I, K define.

    Immutable; a named tuple rather than a frozen dataclass (like :class:`Move`): the
    segmenter weighs several candidate cuts for every move, and a tuple is built several
    times faster. Change one with ``cut._replace(...)``.
    """

    x0: float
    z0: float
    x1: float
    z1: float
    xc: float | None = None
    zc: float | None = None
    cw: bool | None = None
    rapid: bool = False  #: a positioning move (G00) kept as one

    @property
    def is_arc(self) -> bool:
        return self.xc is not None

    @property
    def start(self) -> tuple[float, float]:
        return (self.x0, self.z0)

    @property
    def end(self) -> tuple[float, float]:
        return (self.x1, self.z1)

    @property
    def length(self) -> float:
        if not self.is_arc:
            return math.hypot(self.x1 - self.x0, self.z1 - self.z0)
        r0, r1, sweep = self._spiral()
        return abs(sweep) * (r0 + r1) / 2.0

    def _spiral(self) -> tuple[float, float, float]:
        r0 = math.hypot(self.x0 - self.xc, self.z0 - self.zc)
        r1 = math.hypot(self.x1 - self.xc, self.z1 - self.zc)
        a0 = math.atan2(self.z0 - self.zc, self.x0 - self.xc)
        a1 = math.atan2(self.z1 - self.zc, self.x1 - self.xc)
        sweep = (a1 - a0) % TAU if self.cw else -((a0 - a1) % TAU)
        if sweep == 0.0:
            sweep = TAU if self.cw else -TAU
        return r0, r1, sweep

    def sample(self, spacing: float) -> np.ndarray:
        """Points of the path as the control runs it, at most ``spacing`` apart."""
        if not self.is_arc:
            n = max(2, math.ceil(self.length / spacing) + 1)
            s = unit_steps(n)[:, None]
            return np.array(self.start) + s * (np.array(self.end) - np.array(self.start))
        s, a0, sweep, r0, r1 = self._steps(spacing)
        theta = a0 + s * sweep
        radius = r0 + s * (r1 - r0)
        points = np.empty((len(s), 2))
        points[:, 0] = self.xc + radius * np.cos(theta)
        points[:, 1] = self.zc + radius * np.sin(theta)
        return points

    def _steps(self, spacing: float) -> tuple[np.ndarray, float, float, float, float]:
        """An arc cut's sample parameters, start angle, sweep and radii."""
        r0, r1, sweep = self._spiral()
        n = max(8, math.ceil(abs(sweep) * max(r0, r1) / spacing) + 1)
        return unit_steps(n), math.atan2(self.z0 - self.zc, self.x0 - self.xc), sweep, r0, r1

    @property
    def radius_mismatch(self) -> float:
        if not self.is_arc:
            return 0.0
        r0, r1, _ = self._spiral()
        return abs(r1 - r0)

    @property
    def radius(self) -> float:
        return self._spiral()[0] if self.is_arc else math.inf


class Frame:
    """Coordinates along (u) and across (v) a nominal move, both in mm.

    About an arc: u is the arc length of the angle from the start, v the radial distance
    outside the nominal radius. Along a line: u along it, v to its left. A target that
    stays near its nominal is a graph v(u) in this frame, and for two such graphs the
    difference of v at equal u is never less than their true distance.
    """

    def __init__(self, nominal: Segment):
        self.nominal = nominal
        if isinstance(nominal, Arc):
            self.centre = np.array(nominal.centre)
            self.cx, self.cz = nominal.xc, nominal.zc
            self.sign = 1.0 if nominal.sweep >= 0 else -1.0
            self.mid = nominal.theta0 + nominal.sweep / 2.0
            self.half = abs(nominal.sweep) / 2.0
            self.r = nominal.r
        else:
            self.origin = np.array(nominal.start)
            direction = np.array(nominal.direction)
            self.direction = direction
            self.normal = np.array([-direction[1], direction[0]])

    def uv(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if isinstance(self.nominal, Arc):
            rel = points - self.centre
            return self._arc_uv(rel[:, 0], rel[:, 1])
        rel = points - self.origin
        return rel @ self.direction, rel @ self.normal

    def _arc_uv(self, rel_x: np.ndarray, rel_z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """u and v of points given relative to an arc frame's centre (worked in place)."""
        along = np.arctan2(rel_z, rel_x)
        if self.sign > 0.0:
            along -= self.mid
        else:  # (along - mid) * -1 in one pass: IEEE subtraction is exactly antisymmetric (a zero's sign
            np.subtract(self.mid, along, out=along)  # aside, which the pi added next erases)
        along += math.pi
        if not (along[along.argmin()] >= 0.0 and along[along.argmax()] < TAU):  # else the remainder is each value
            np.remainder(along, TAU, out=along)  # (a zero's sign aside, which subtracting pi erases)
        along -= math.pi
        along += self.half
        along *= self.r
        across = np.hypot(rel_x, rel_z)
        across -= self.r
        return along, across

    def path_uv(self, cut: "Cut", spacing: float) -> tuple[np.ndarray, np.ndarray]:
        """``uv(cut.sample(spacing))``, without stacking the points of an arc cut in an arc frame."""
        if not (cut.is_arc and isinstance(self.nominal, Arc)):
            return self.uv(cut.sample(spacing))
        s, a0, sweep, r0, r1 = cut._steps(spacing)
        theta = s * sweep
        theta += a0
        radius = s * (r1 - r0)
        radius += r0
        rel_x = np.cos(theta)
        rel_x *= radius
        rel_x += cut.xc
        rel_x -= self.cx
        rel_z = np.sin(theta)
        rel_z *= radius
        rel_z += cut.zc
        rel_z -= self.cz
        return self._arc_uv(rel_x, rel_z)


def _deviation(target_u: np.ndarray, target_v: np.ndarray, pu: np.ndarray, pv: np.ndarray,
               target_graph: bool = True, target_rising: bool = False) -> float:
    """Largest distance across the frame between a target and a path (u, v of each), both
    graphs in u. ``target_graph`` False: the caller knows the target turns back in u;
    ``target_rising``: it knows the target's u strictly increases (see :func:`_rising_deviation`)."""
    if not target_graph:
        return math.inf
    steps = pu[1:] - pu[:-1]
    least = steps[steps.argmin()]  # NaN if any step is: then the least of the others decides
    if least < -1e-9 or (least != least and np.fmin.reduce(steps) < -1e-9):
        return math.inf  # not a graph over the nominal: this path does not follow the target
    low = max(target_u[0], pu[0])
    high = min(target_u[-1], pu[-1])
    if target_rising and least > 0.0:
        return _rising_deviation(target_u, target_v, pu, pv, low, high)
    grid = np.concatenate([target_u, pu])
    grid = grid[(grid >= low) & (grid <= high)]
    if len(grid) == 0:
        return math.inf
    gap = np.abs(np.interp(grid, target_u, target_v) - np.interp(grid, pu, pv))
    return float(_largest_of(gap))


def _rising_deviation(target_u: np.ndarray, target_v: np.ndarray, pu: np.ndarray, pv: np.ndarray, low, high) -> float:
    """:func:`_deviation` of two graphs whose u both strictly increase, the same float with half
    the interpolation: each graph read at its own samples is its own v (``np.interp`` returns
    ``fp[j]`` where ``x == xp[j]``), so the gap at a target sample is its v less the path read
    there, and at a path sample the target read there less its v; and the samples of each within
    [low, high] are one run, found by a search at the end where the other graph reaches less far."""
    first, last = 0, len(target_u)
    start, stop = 0, len(pu)
    if target_u[0] >= pu[0]:
        start = int(pu.searchsorted(low, "left"))
    else:
        first = int(target_u.searchsorted(low, "left"))
    if target_u[-1] <= pu[-1]:
        stop = int(pu.searchsorted(high, "right"))
    else:
        last = int(target_u.searchsorted(high, "right"))
    if first >= last and start >= stop:
        return math.inf
    largest = -math.inf
    if first < last:
        gap = np.abs(target_v[first:last] - np.interp(target_u[first:last], pu, pv))
        largest = gap[gap.argmax()]
    if start < stop:
        gap = np.abs(np.interp(pu[start:stop], target_u, target_v) - pv[start:stop])
        largest = _largest(largest, gap[gap.argmax()])
    return float(largest)


def _largest_of(values: np.ndarray):
    """``values.max()`` (NaN if any value is), read at its index: a ufunc reduction costs several
    times an arg-search on the short arrays the segmenter works on."""
    return values[values.argmax()]


def _largest(a: float, b: float) -> float:
    """``np.maximum`` of two floats: the larger, NaN if either is."""
    return a if a >= b or a != a else b


@lru_cache(maxsize=16)
def _grid_constants(grid: Grid) -> tuple[float, int, float]:
    """A grid's step, decimals and unit (properties worked out on every call), once per grid."""
    return grid.step, grid.decimals, grid.unit


@dataclass(frozen=True)
class Limits:
    """What the control accepts and what the plan must keep to."""

    tolerance: float
    grid: Grid
    arc_radius_tolerance: float = DEFAULT.arc_radius_tolerance  #: the machine profile's
    max_arc_radius: float = DEFAULT.max_arc_radius
    spacing: float = 0.02  #: sampling of planned paths when measuring them


@dataclass
class Plan:
    cuts: list[Cut]
    deviation: float  #: measured largest distance from the target
    method: str
    widened: bool = False  #: merged beyond the tolerance (to keep blocks long enough), with a warning


def arc_cut_spacing(cut: Cut, spacing: float, tolerance: float, frame: float, frame_x: float, frame_z: float) -> float:
    """:meth:`Segmenter._spacing` of an arc cut, in a frame of curvature ``frame`` (0 along a
    line) about (``frame_x``, ``frame_z``), whose own spacing is ``spacing``."""
    radius = math.hypot(cut.x0 - cut.xc, cut.z0 - cut.zc)
    curvature = 1.0 / radius
    if frame:
        mid_x, mid_z = (cut.x0 + cut.x1) / 2.0, (cut.z0 + cut.z1) / 2.0
        same = (cut.xc - mid_x) * (frame_x - mid_x) + (cut.zc - mid_z) * (frame_z - mid_z) > 0.0
        curvature = abs(curvature - frame) if same else curvature + frame
    if curvature * spacing * spacing <= 0.08 * tolerance:
        return spacing
    return math.sqrt(0.08 * tolerance / curvature)


def chord_cannot_follow(nominal: Arc, shift: float, tolerance: float, grid: Grid) -> bool:
    """Whether a nominal arc bows away from its chord by more than the tolerance and a
    displacement of at most ``shift`` with the rounding of both ends could make up."""
    sagitta = min(nominal.r, nominal.end_radius) * (1.0 - math.cos(min(abs(nominal.sweep), math.pi) / 2.0))
    return sagitta > tolerance + 2.0 * shift + 2.0 * grid.rounding_error


class Segmenter:
    """Plans one target; create one per target."""

    def __init__(self, target: Target, limits: Limits):
        self.target = target
        self.limits = limits
        self.grid = limits.grid
        self.frame = Frame(target.nominal)
        self.u, self.v = self.frame.uv(target.points)
        steps = self.u[1:] - self.u[:-1]
        self._backwards = (steps < -1e-9).nonzero()[0].tolist()  # k where u[k + 1] < u[k]
        self._rising = len(steps) > 0 and bool(steps[steps.argmin()] > 0.0)  # u strictly increases (NaN: no)
        self.tol = limits.tolerance
        # A chord sampled every h and read linearly across an arc's frame misses up to h^2/(8r):
        # keep that under a hundredth of the tolerance on small arcs (arc cuts: see _spacing).
        self.spacing = limits.spacing
        self._frame_curvature = 0.0
        if isinstance(target.nominal, Arc):
            self.spacing = min(limits.spacing, math.sqrt(8.0 * target.nominal.r * self.tol * 0.01))
            self._frame_curvature = 1.0 / target.nominal.r
        last = len(target.t) - 1
        self.last = last
        ends = target.points[::last].tolist() if last else target.points[[0, 0]].tolist()
        self._ends = ends  #: the target's first and last sample, as floats
        self.vertices: dict[int, tuple[float, float]] = {0: self.grid.snap(*ends[0]), last: self.grid.snap(*ends[1])}

    # ---------------------------------------------------------------- measuring

    def _graph(self, i: int, j: int) -> bool:
        """Whether target samples i..j run forwards in u (a graph over the nominal)."""
        backwards = self._backwards
        at = bisect_left(backwards, i)
        return at == len(backwards) or backwards[at] >= j

    def _spacing(self, cut: Cut) -> float:
        """How far apart to sample a cut so that reading it linearly across the frame misses
        less than a hundredth of the tolerance: h^2 k / 8, k the curvature of the cut as the
        frame draws it. A line across an arc's frame bends by the frame's curvature (the
        frame's own spacing); an arc by the difference of its curvature and the frame's when it
        turns the same way, their sum when it turns the other. A small arc fitted to a wavy
        target (radius 0.3 mm on a 5 mm arc) needs samples far closer than its frame's."""
        if cut.xc is None:
            return self.spacing
        frame = self._frame_curvature
        return arc_cut_spacing(cut, self.spacing, self.tol, frame, self.frame.cx if frame else 0.0,
                               self.frame.cz if frame else 0.0)

    def _measure(self, cut: Cut, i: int, j: int, ends: float | None = None) -> float:
        """Deviation of one cut from the target samples i..j (and its end points; ``ends``: their
        larger distance from the cut's, when the caller has it)."""
        pu, pv = self.frame.path_uv(cut, self._spacing(cut))
        deviation = _deviation(self.u[i : j + 1], self.v[i : j + 1], pu, pv, self._graph(i, j), self._rising)
        if ends is None:
            ends = self._ends_off(cut.x0, cut.z0, cut.x1, cut.z1, i, j)
        return max(deviation, ends)

    def _ends_off(self, x0: float, z0: float, x1: float, z1: float, i: int, j: int) -> float:
        """How far the ends of a cut lie from target samples i and j."""
        points = self.target.points
        first = self._ends[0] if i == 0 else points[i].tolist()
        last = self._ends[1] if j == self.last else points[j].tolist()
        return max(math.dist((x0, z0), first), math.dist((x1, z1), last))

    def measure(self, cuts: list[Cut]) -> float:
        """Deviation of a whole plan from the whole target."""
        pu, pv = self.frame.uv(np.concatenate([cut.sample(self._spacing(cut)) for cut in cuts]))
        deviation = _deviation(self.u, self.v, pu, pv, self._graph(0, self.last), self._rising)
        ends = max(math.dist(cuts[0].start, self.target.start), math.dist(cuts[-1].end, self.target.end))
        return max(deviation, ends)

    # ---------------------------------------------------------------- grid points

    def _vertex(self, index: int, offset: float = 0.0) -> tuple[float, float]:
        """A grid point near sample ``index``, ``offset`` outside the target (across the frame).

        Several nearby grid points are tried and the one nearest to the wanted offset wins:
        on a fine grid the target passes close to some grid point, and choosing it spends
        almost none of the tolerance on rounding.
        """
        if offset == 0.0 and index in self.vertices:
            return self.vertices[index]
        point = self.target.points[index]
        outward = self._outward(index)
        wanted = point + offset * outward
        base = self.grid.snap(*wanted.tolist())
        candidates = np.array([self.grid.snap(base[0] + dx * self.grid.x_step, base[1] + dz * self.grid.z_step)
                               for dx in (-1, 0, 1) for dz in (-1, 0, 1)])
        cu, cv = self.frame.uv(candidates)
        stand = cv - np.interp(cu, self.u, self.v)
        error = np.abs(stand - offset * self._v_sign(outward)) + 0.1 * np.hypot(*(candidates - wanted).T)
        best = tuple(candidates[int(np.argmin(error))].tolist())
        if offset == 0.0:
            self.vertices[index] = best
        return best

    def _v_sign(self, outward: np.ndarray) -> float:
        if isinstance(self.frame.nominal, Arc):
            return 1.0  # outward is radial here
        return float(np.sign(outward @ self.frame.normal)) or 1.0

    def _outward(self, index: int) -> np.ndarray:
        """Unit vector across the target, away from its centre of curvature."""
        if isinstance(self.frame.nominal, Arc):
            point = self.target.points[index]
            radial = point - self.frame.centre
            return radial / np.linalg.norm(radial)
        normal = self.frame.normal
        curvature = self._line_curvature(index)
        return -normal if curvature > 0 else normal

    def _line_curvature(self, index: int) -> float:
        lo, hi = max(index - 8, 0), min(index + 8, self.last)
        if hi - lo < 2:
            return 0.0
        u, v = self.u[lo : hi + 1], self.v[lo : hi + 1]
        if np.ptp(u) < 1e-9:  # a stretch under a nanometre has no curvature to read (and polyfit would be ill-posed)
            return 0.0
        return float(np.polyfit(u, v, 2)[0])

    # ---------------------------------------------------------------- candidate cuts

    def line(self, i: int, j: int, a=None, b=None) -> Cut:
        a = a if a is not None else self._vertex(i)
        b = b if b is not None else self._vertex(j)
        return Cut(a[0], a[1], b[0], b[1])

    def arc(self, i: int, j: int) -> tuple[Cut | None, float]:
        """The best arc through the grid points at samples i and j, and its measured deviation."""
        a, b = self._vertex(i), self._vertex(j)
        if a == b:
            return None, math.inf
        points = self.target.points[i : j + 1]
        mid = ((a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0)
        chord = (b[0] - a[0], b[1] - a[1])
        half = math.sqrt(chord[0] * chord[0] + chord[1] * chord[1]) / 2.0
        normal = (-chord[1] / (2.0 * half), chord[0] / (2.0 * half))
        start = self._centre_guess(points, i, j)
        if start is None:
            return None, math.inf
        lam = (start[0] - mid[0]) * normal[0] + (start[1] - mid[1]) * normal[1]
        lam = self._refine(points, mid, normal, a, lam)
        if lam is None:
            return None, math.inf
        centre = (mid[0] + lam * normal[0], mid[1] + lam * normal[1])
        radius = math.hypot(half, lam)
        if radius > self.limits.max_arc_radius:
            return None, math.inf
        cw = self._direction(a, b, centre, points[len(points) // 2].tolist())
        cuts, rings = [], []
        radius_tolerance = self.limits.arc_radius_tolerance
        for cand in self._rounded_centres(a, centre):
            r0 = math.hypot(a[0] - cand[0], a[1] - cand[1])  # as Cut._spiral
            r1 = math.hypot(b[0] - cand[0], b[1] - cand[1])
            if abs(r1 - r0) > radius_tolerance:
                continue
            if abs(cand[0] - a[0]) < 1e-12 and abs(cand[1] - a[1]) < 1e-12:
                continue
            cuts.append(Cut(a[0], a[1], b[0], b[1], cand[0], cand[1], cw))
            rings.append((r0, r1) if r0 <= r1 else (r1, r0))
        if not cuts:
            return None, math.inf
        ends = self._ends_off(a[0], a[1], b[0], b[1], i, j)  # as _measure
        best, best_dev = None, math.inf
        for bound, _, cut in sorted(zip(self._radial_bounds(cuts, rings, points), range(len(cuts)), cuts)):
            if max(bound, ends) >= best_dev:
                break  # no candidate left can beat the best: measuring them is wasted work
            deviation = self._measure(cut, i, j, ends)
            if deviation < best_dev:
                best, best_dev = cut, deviation
        return best, best_dev

    def _radial_bounds(self, cuts: list[Cut], rings: list[tuple[float, float]], points: np.ndarray) -> list[float]:
        """For each arc cut, a lower bound of what :meth:`_measure` gives, without sampling it.

        A target sample's distance to the cut's circle (to the ring between its two radii,
        for a cut whose ends sit at slightly different radii) is never more than the
        deviation measured across the frame, less the small error of reading the sampled
        path linearly (a hundredth of the tolerance, see ``spacing``: the slack is five).
        The ends are left out: they may lie beyond the cut's span. All cuts at once, the
        last few sums of each in floats (numpy calls on four values cost more than they do)."""
        slack = 0.05 * self.tol
        if len(points) <= 2:
            return [-slack] * len(cuts)
        inner = points[1:-1]
        centres = np.array([(cut.xc, cut.zc) for cut in cuts])
        distance = np.hypot(inner[None, :, 0] - centres[:, None, 0], inner[None, :, 1] - centres[:, None, 1])
        # the farthest sample outside a ring and the nearest inside it decide: a rounded
        # difference with a fixed ring radius grows with the distance, so max(d - r) is max(d) - r
        farthest, nearest = distance.max(axis=1).tolist(), distance.min(axis=1).tolist()
        return [_largest(_largest(far - high, low - near), 0.0) - slack
                for far, near, (low, high) in zip(farthest, nearest, rings)]

    def _centre_guess(self, points: np.ndarray, i: int, j: int):
        if isinstance(self.frame.nominal, Arc) and j - i >= 0.5 * self.last:
            return (self.frame.cx, self.frame.cz)
        if len(points) >= 3:
            from ..geometry.fitting import hyper_fit  # here: a program of single arcs never needs it (a small job's start)

            try:
                xc, zc, _ = hyper_fit(points)
                return (xc, zc)
            except (FitError, np.linalg.LinAlgError, ValueError):
                return None
        return None

    @staticmethod
    def _refine(points, mid, normal, a, lam, iterations: int = 12):
        """Gauss-Newton on the centre's place along the chord's bisector (least squares).

        With the centre at ``mid + lam * normal`` (``normal`` a unit vector across the chord
        from ``a`` to its mirror end), the radius is ``hypot(half, lam)`` and each sample's
        offset along the normal is ``q - lam``: only the distances are arrays, each worked in
        a buffer of its own (an iteration costs a dozen ufunc calls on a few dozen samples:
        their overhead, not the arithmetic, is the time)."""
        rel = points - mid
        rel_x, rel_z = rel[:, 0], rel[:, 1]
        q = rel @ normal
        nx, nz = float(normal[0]), float(normal[1])
        half = math.dist(a, mid)
        subtract, divide, hypot = np.subtract, np.divide, np.hypot
        dist, jac, other = np.empty(len(q)), np.empty(len(q)), np.empty(len(q))
        for _ in range(iterations):
            subtract(rel_x, lam * nx, out=dist)
            subtract(rel_z, lam * nz, out=other)
            hypot(dist, other, out=dist)
            radius = math.hypot(half, lam)
            if radius == 0 or dist[dist.argmin()] == 0.0:  # a sample at the centre (NaN: none, as min() reads)
                return None
            # d(dist)/d(lam) = -(q - lam)/dist ; d(radius)/d(lam) = lam/radius
            subtract(lam, q, out=jac)
            divide(jac, dist, out=jac)
            subtract(jac, lam / radius, out=jac)
            denominator = float(jac.dot(jac))  # the method: the same ddot as ``@``, at less than half its call's cost
            if denominator == 0:
                return lam
            subtract(dist, radius, out=dist)  # the residual
            step = -float(jac.dot(dist)) / denominator
            lam += step
            if abs(step) < 1e-12 * max(1.0, abs(lam)):
                break
        return lam if math.isfinite(lam) else None

    @staticmethod
    def _direction(a, b, centre, middle) -> bool:
        """G02 (cw) when the target's middle lies on the theta-increasing way from a to b."""
        t0 = math.atan2(a[1] - centre[1], a[0] - centre[0])
        t1 = math.atan2(b[1] - centre[1], b[0] - centre[0])
        tm = math.atan2(middle[1] - centre[1], middle[0] - centre[0])
        return ((tm - t0) % TAU) < ((t1 - t0) % TAU)

    def _rounded_centres(self, a, centre):
        """The centres the four roundings of I and K (down or up, each) give.

        A word of ``k`` steps is ``rounded(k * step, decimals)``: ``k * step`` lies within a
        hair of k/10**decimals for any |k| under 2**51 (the centre is within the profile's
        max_arc_radius, at most 100 m, here), so the decimal it rounds to is that quotient, and
        parsing it gives the nearest float, which Python's true division of the two integers
        gives too: the same floats without formatting and parsing four strings per arc."""
        step, decimals, unit = _grid_constants(self.grid)
        scale = 10**decimals
        ix = (centre[0] - a[0]) / unit / step
        kz = (centre[1] - a[1]) / unit / step
        x_down, x_up = a[0] + math.floor(ix) / scale * unit, a[0] + math.ceil(ix) / scale * unit  # unit: Grid.offset_of
        z_down, z_up = a[1] + math.floor(kz) / scale * unit, a[1] + math.ceil(kz) / scale * unit
        return {(x_down, z_down), (x_down, z_up), (x_up, z_down), (x_up, z_up)}

    # ---------------------------------------------------------------- plans

    def single_line(self) -> Plan | None:
        if self._chord_cannot_follow():
            return None
        cut = self.line(0, self.last)
        if cut.start == cut.end:
            return None
        deviation = self._measure(cut, 0, self.last)
        return Plan([cut], deviation, "line") if deviation <= self.tol else None

    def _chord_cannot_follow(self) -> bool:
        """True when the nominal arc bows away from its chord by more than the tolerance and
        the displacement together with the rounding of both ends could make up: no
        single line can then follow the target, and measuring one is wasted work."""
        nominal = self.target.nominal
        if not isinstance(nominal, Arc):
            return False
        shift = float(_largest_of(np.hypot(self.target.d[:, 0], self.target.d[:, 1])))
        return chord_cannot_follow(nominal, shift, self.tol, self.grid)

    def single_arc(self) -> Plan | None:
        cut, deviation = self.arc(0, self.last)
        if cut is None:
            return None
        return Plan([cut], deviation, "arc") if deviation <= self.tol else None

    def arcs(self) -> Plan | None:
        """Greedy: from each break, the farthest sample an arc (or a line) reaches in tolerance."""
        cuts, i = [], 0
        while i < self.last:
            j, cut = self._reach(i, lambda a, b: self._fitting_arc_or_line(a, b))
            if cut is None:
                return None
            cuts.append(cut)
            i = j
        return self._finish(cuts, "arcs")

    def _fitting_arc_or_line(self, i: int, j: int) -> Cut | None:
        line = self.line(i, j)
        if line.start != line.end and self._measure(line, i, j) <= self.tol:
            return line
        cut, deviation = self.arc(i, j)
        if cut is not None and deviation <= self.tol:
            return cut
        return None

    def lines(self) -> Plan | None:
        """Chords whose vertices straddle the target (polar interpolation about an arc).

        A vertex stands outside the target by nearly the tolerance; where rounding leaves one
        so far out that no chord can leave it, the chord before is redone ending on the target.
        """
        offset = self.stand_off
        cuts: list[Cut] = []
        starts: list[tuple[int, float]] = []  # (sample a chord starts at, how far its end stands off)
        i, start, stand_off = 0, self._vertex(0), offset
        while i < self.last:
            j, cut = self._reach(i, self._chord_maker(start, stand_off))
            if cut is None and stand_off:  # end this chord on the target instead
                stand_off = 0.0
                j, cut = self._reach(i, self._chord_maker(start, stand_off))
            if cut is None:
                if not cuts or starts[-1][1] == 0.0:
                    return None
                cuts.pop()
                i, _ = starts.pop()
                start = cuts[-1].end if cuts else self._vertex(0)
                stand_off = 0.0  # redo the chord before, ending on the target
                continue
            cuts.append(cut)
            starts.append((i, stand_off if j != self.last else 0.0))
            start, i, stand_off = cut.end, j, offset
        return self._finish(cuts, "lines")

    @property
    def stand_off(self) -> float:
        """How far outside the target a chord's vertex stands: nearly the tolerance, less rounding."""
        return max(self.tol - 0.55 * self.grid.rounding_error, 0.0) * 0.92

    def _chord_maker(self, start: tuple[float, float], offset: float):
        def chord(i: int, j: int) -> Cut | None:
            end = self._vertex(j, 0.0 if j == self.last else offset)
            if end == start:
                return None
            cut = Cut(start[0], start[1], end[0], end[1])
            return cut if self._measure_chord(cut, i, j) <= self.tol else None

        return chord

    def _measure_chord(self, cut: Cut, i: int, j: int) -> float:
        """A chord's vertices stand off the target on purpose: measure only across it."""
        pu, pv = self.frame.path_uv(cut, self._spacing(cut))
        deviation = _deviation(self.u[i : j + 1], self.v[i : j + 1], pu, pv, self._graph(i, j), self._rising)
        if i == 0:
            deviation = max(deviation, math.dist(cut.start, self.target.start))
        if j == self.last:
            deviation = max(deviation, math.dist(cut.end, self.target.end))
        return deviation

    def _reach(self, i: int, make):
        """The farthest j > i for which ``make(i, j)`` gives a cut (binary search)."""
        cut = make(i, self.last)
        if cut is not None:
            return self.last, cut
        lo, hi = i + 1, self.last
        best = None
        while lo < hi:
            mid = (lo + hi) // 2
            candidate = make(i, mid)
            if candidate is not None:
                best = (mid, candidate)
                lo = mid + 1
            else:
                hi = mid
        if best is None:
            candidate = make(i, i + 1)
            return (i + 1, candidate) if candidate is not None else (i + 1, None)
        return best

    def _finish(self, cuts: list[Cut], method: str) -> Plan | None:
        cuts = [cut for cut in cuts if cut.start != cut.end]
        if not cuts:
            return None
        return Plan(cuts, self.measure(cuts), method)


def plan(target: Target, limits: Limits, mode: str = AUTO) -> Plan:
    """The fewest blocks within tolerance, as ``mode`` allows; raises PlanError if none,
    saying which limit stops it."""
    found = _plan(target, limits, mode)
    if found is None:
        raise _unplannable(target, limits, mode)
    return found


def _plan(target: Target, limits: Limits, mode: str) -> Plan | None:
    if isinstance(target.nominal, Arc) and abs(target.nominal.sweep) >= 2.0 * math.pi - 1e-9:
        return _plan_circle(target, limits, mode)
    straight = _straight(target, limits)
    if straight is not None:
        return straight
    segmenter = Segmenter(target, limits)
    straight = segmenter.single_line()
    if straight is not None:
        return straight
    candidates: list[Plan] = []
    if mode in (AUTO, ARC_MODE):
        single = segmenter.single_arc()
        if single is not None:
            return single
        several = segmenter.arcs()
        if several is not None:
            candidates.append(several)
    if mode in (AUTO, LINE_MODE) or not candidates:
        chords = segmenter.lines()
        if chords is not None and (mode != ARC_MODE or not candidates):
            candidates.append(chords)
    if not candidates:
        return None
    return min(candidates, key=lambda p: (len(p.cuts), p.method != "arcs"))


def _plan_circle(target: Target, limits: Limits, mode: str) -> Plan | None:
    """A whole circle in one block (a ballbar test program's): its ends are one point, which no
    arc or chord between them can follow, so it is planned as its two halves, split at the
    sample nearest half way, and written as their blocks."""
    k = int(np.argmin(np.abs(target.t - 0.5)))
    middle = float(target.t[k])
    halves = [Target(target.nominal.part(0.0, middle), target.t[: k + 1] / middle, target.d[: k + 1]),
              Target(target.nominal.part(middle, 1.0), (target.t[k:] - middle) / (1.0 - middle), target.d[k:])]
    plans = [_plan(half, limits, mode) for half in halves]
    if any(found is None for found in plans):
        return None
    return Plan([cut for found in plans for cut in found.cuts], max(found.deviation for found in plans),
                plans[0].method if plans[0].method == plans[1].method else "arcs",
                any(found.widened for found in plans))


def _unplannable(target: Target, limits: Limits, mode: str) -> "PlanError":
    """Why no plan keeps within the tolerance: each limit is relaxed in turn, and the first
    whose relaxing lets a plan through is named (worked out only when planning failed)."""
    tolerance, grid = limits.tolerance, limits.grid
    needed = _needed_tolerance(target, limits, mode)
    start, end = target.start, target.end
    a, b = grid.snap(*start), grid.snap(*end)
    off = max(math.dist(a, start), math.dist(b, end))
    within = f"within {tolerance * 1000:.2f} um"
    finer = replace(limits, grid=replace(grid, decimals=grid.decimals + 2))
    if a == b:
        return PlanError(f"the move is shorter than one step of the output grid ({grid.step:g} "
                         f"{'in' if grid.inch else 'mm'}): both its ends fall on one grid point", RESOLUTION, needed)
    if off <= tolerance and mode != LINE_MODE and _plan(target, replace(limits, arc_radius_tolerance=math.inf),
                                                         mode) is not None:
        return PlanError(f"the control's arc radius check ({limits.arc_radius_tolerance:g} mm) refuses every arc "
                         f"that keeps {within}, and lines do not keep it", RADIUS_CHECK, needed)
    if off > tolerance or _plan(target, finer, mode) is not None:
        detail = f": an end point falls {off * 1000:.2f} um off the target" if off > tolerance else ""
        return PlanError(f"the output grid ({grid.step:g} {'in' if grid.inch else 'mm'} steps) cannot place the "
                         f"blocks {within} of the target{detail}", RESOLUTION, needed)
    return PlanError(f"no blocks keep {within} of the target", TOLERANCE, needed)


def _needed_tolerance(target: Target, limits: Limits, mode: str) -> float | None:
    """The tolerance (mm) the nearest plan found keeps to, trying ever larger ones; None when
    even 0.1 mm is not enough."""
    tolerance = limits.tolerance
    while tolerance < 0.1:
        tolerance = min(tolerance * 2.0, 0.1)
        found = _plan(target, replace(limits, tolerance=tolerance), mode)
        if found is not None:
            return found.deviation
    return None


def _straight(target: Target, limits: Limits) -> Plan | None:
    """A line moved by a displacement that changes linearly along it is a line: one block,
    its deviation the larger rounding of its two ends (a segment lies between its ends).
    The common case of a whole program's short lines, planned without sampling."""
    if not isinstance(target.nominal, Line):
        return None
    if target.bend > 1e-12:
        return None
    start, end = target.points[0].tolist(), target.points[-1].tolist()
    a, b = limits.grid.snap(*start), limits.grid.snap(*end)
    if a == b:
        return None
    deviation = max(math.dist(a, start), math.dist(b, end))
    if deviation > limits.tolerance:
        return None
    return Plan([Cut(a[0], a[1], b[0], b[1])], deviation, "line")


def chord_minimum(radius: float, sweep: float, tolerance: float) -> int:
    """The fewest straddling chords over ``sweep`` radians of a circle (docs/methods.md §13)."""
    step = 2.0 * math.acos((radius - tolerance) / (radius + tolerance))
    return math.ceil(abs(sweep) / step)


__all__ = ["Target", "Cut", "Plan", "Limits", "plan", "PlanError", "RESOLUTION", "RADIUS_CHECK", "TOLERANCE", "sample_params", "measure_bends", "chord_minimum", "Line", "Arc"]
