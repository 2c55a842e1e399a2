"""Joint least-squares fits of error models to ballbar traces: a public helper for compensators.

Why jointly. A ballbar mounted off the circle's centre by (c_x, c_z) adds ``c_x cos + c_z sin``
to the trace (first order). Round the whole circle no machine error has a first harmonic, so a
separate circle fit takes out the set-up and nothing else. On a partial arc that is no longer
so: over 0..180 deg the X scaling's reading ``R a_x cos^2`` and the Z scaling's ``R a_z sin^2``
both project onto ``sin``, so a separate circle fit takes part of them with the set-up centre
and biases both. Here the set-up centre is two more columns of one linear least-squares
problem: whatever the arc, the centre takes only what no model parameter can explain.

Several tests. The traces of one circle (one radius, one nominal centre: its ccw and cw runs,
made on one mount) share one set-up centre, a *mount*; every other circle has its own. The
machine's parameters are common to all. A constant error (the machine's errors at a test's
centre) reads like a set-up offset and goes with that test's centre: a ballbar cannot see a
translation.

The data, as flat arrays over every sample of every trace (:class:`Samples`): where the
command was (x, z and the offsets from the test centre), which way it went (unit tangent,
each axis's direction), the trace and mount of each sample, and the reading with any centre a
reader removed put back. A model is a mapping of parameter names to their *unit errors*
``(e_x, e_z)`` at the samples (one array each): what the parameter at value 1 does to the
tool's position. The bar reads ``e_x cos + e_z sin``. Any model fits: the parametric machine
model of :func:`machine_errors`, per-side scalings, or a smooth error map's basis functions.

The statistics (:func:`fit`). Columns are scaled to unit length and the design decomposed by
SVD (numpy's LAPACK): a parameter in a direction the data cannot see (a singular value below
1e-9 of the largest) is *inseparable* and named with its partners. Otherwise the covariance
is ``s^2 (A^T A)^-1`` with s^2 from the residuals, enlarged where the residuals are correlated
along the trace (unmodelled pitch errors, the reversals' transitions: a Newey-West estimate
with Bartlett weights, bandwidth by Andrews' AR(1) rule, per trace), so the uncertainties do
not pretend that neighbouring samples are independent. Each parameter's *effect* is its sigma
times the largest error it models at the samples (``|(e_x, e_z)|``): scaling times the radius,
half the backlash, and so on. :func:`require` refuses, naming the arc and the parameter, a fit
whose parameters' 3-sigma effect exceeds a limit (5 um by default: 50 ppm of scaling at 100 mm,
10 um of backlash, about what the machines measured have): the uncertainty grows as the arc
shrinks, and there is a point where a parameter is a guess.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..diagnostics import Inseparable, Location, MeasurementError, Undetermined
from .parameters import EFFECT_LIMIT_MM, Estimate

if TYPE_CHECKING:
    from .readers.ballbar import BallbarTrace

MAX_GAP_DEG = 10.0  #: a trace with no gap wider than this goes round the whole circle
SEPARABLE = 1e-9  #: smallest singular value, relative to the largest, of a separable design

#: name -> (what people call it, factor from the parameter's unit, unit shown)
LABELS = {
    "scaling_x": ("scaling X", 1e6, "ppm"),
    "scaling_z": ("scaling Z", 1e6, "ppm"),
    "scaling_x_plus": ("scaling X (+ side)", 1e6, "ppm"),
    "scaling_x_minus": ("scaling X (- side)", 1e6, "ppm"),
    "scaling_z_plus": ("scaling Z (+ side)", 1e6, "ppm"),
    "scaling_z_minus": ("scaling Z (- side)", 1e6, "ppm"),
    "backlash_x": ("backlash X", 1e3, "um"),
    "backlash_z": ("backlash Z", 1e3, "um"),
    "squareness": ("squareness", 1e6, "urad"),
    "servo_mismatch": ("servo mismatch", 1e3, "um"),
    "apparent_squareness": ("squareness + servo mismatch", 1e6, "urad"),
    "centre_x": ("set-up centre x", 1e3, "um"),
    "centre_z": ("set-up centre z", 1e3, "um"),
}


def label(name: str) -> str:
    return LABELS.get(name, (name.replace("_", " "), 1.0, ""))[0]


def shown(name: str, value: float) -> str:
    """A value of a parameter in the unit people read it in: ``+12.3 ppm``."""
    _, factor, unit = LABELS.get(name, (name, 1e3, "um"))
    return f"{value * factor:+.3g} {unit}".rstrip()


# -- which traces share a set-up centre ---------------------------------------------------------


def mount_key(trace: BallbarTrace) -> tuple[float, float, float]:
    """Traces with one key were run on one mount: one radius, one nominal centre."""
    return (round(trace.radius, 9), round(trace.centre[0], 9), round(trace.centre[1], 9))


def mounts(traces: Sequence[BallbarTrace]) -> list[list[int]]:
    """The traces' indices grouped by mount, in the order each mount first appears."""
    groups: dict[tuple[float, float, float], list[int]] = {}
    for index, trace in enumerate(traces):
        groups.setdefault(mount_key(trace), []).append(index)
    return list(groups.values())


def test_text(test: Sequence[BallbarTrace]) -> str:
    """One test's circle and its traces, for messages: ``R 100 mm about x 0, z -200 mm: ccw a.csv, cw b.csv``."""
    first = test[0]
    return (f"R {first.radius:g} mm about x {first.centre[0]:g}, z {first.centre[1]:g} mm: "
            + ", ".join(f"{trace.direction} {trace.path}" for trace in test))


def tests_text(grouped: Sequence[Sequence[BallbarTrace]]) -> str:
    """Every test's circle and traces, numbered: ``test 1: R 100 mm about ...; test 2: ...``."""
    return "; ".join(f"test {number}: {test_text(test)}" for number, test in enumerate(grouped, 1))


def arc_text(trace: BallbarTrace) -> str:
    """``220 deg from -20 to 200 deg`` or ``the whole circle``."""
    start, span = trace.arc
    if span >= 360.0:
        return "the whole circle"
    start = start - 360.0 if start > 180.0 else start
    return f"{span:.0f} deg from {start:.0f} to {start + span:.0f} deg"


def arcs_text(traces: Sequence[BallbarTrace]) -> str:
    """The arcs of several traces, each arc once: ``ccw.csv and cw.csv (220 deg from -20 to 200 deg)``."""
    by_arc: dict[str, list[str]] = {}
    for trace in traces:
        by_arc.setdefault(arc_text(trace), []).append(trace.path)
    return "; ".join(f"{' and '.join(paths)} ({arc})" for arc, paths in by_arc.items())


def more_evidence(traces: Sequence[BallbarTrace], *more: str) -> str:
    """What to measure for a fit the traces do not determine, of what they lack: a longer arc
    unless every trace goes round, the other direction unless each test has both; then ``more``."""
    asks = [] if all(trace.full for trace in traces) else ["a longer arc (220 deg or the whole circle)"]
    if any({traces[i].direction for i in group} != {"ccw", "cw"} for group in mounts(traces)):
        asks.append("both directions")
    asks += more
    return ", ".join(asks[:-1]) + (" or " if len(asks) > 1 else "") + asks[-1]


# -- the samples ------------------------------------------------------------------------------------


def setup_reading(cos, sin, radius, cx, cz) -> np.ndarray:
    """What a set-up centre (c_x, c_z) adds to the bar at theta: its first harmonic, and to second
    order (the bar is the hypotenuse) (c . t)^2 / 2R, t the tangent: 0.03 um for 80 um at 100 mm,
    of one sign all round."""
    return cx * cos + cz * sin + (cz * cos - cx * sin) ** 2 / (2.0 * radius)


def as_measured(trace: BallbarTrace) -> np.ndarray:
    """A trace's deviations with the centre its reader removed put back."""
    theta = np.radians(trace.angles)
    return trace.deviations + setup_reading(np.cos(theta), np.sin(theta), trace.radius, *trace.setup_centre)


def recentred(trace: BallbarTrace, centre: tuple[float, float]) -> BallbarTrace:
    """The trace as measured less another set-up centre (x, z)."""
    from dataclasses import replace

    theta = np.radians(trace.angles)
    deviations = as_measured(trace) - setup_reading(np.cos(theta), np.sin(theta), trace.radius, *centre)
    return replace(trace, deviations=deviations, setup_centre=(float(centre[0]), float(centre[1])))


@dataclass(frozen=True)
class Samples:
    """Every sample of a set of traces as flat arrays: the commanded test and the reading."""

    traces: tuple  #: the traces, in the order given
    groups: tuple[tuple[int, ...], ...]  #: the trace indices of each mount
    trace: np.ndarray  #: index of the trace of each sample
    mount: np.ndarray  #: index of the mount of each sample
    cos: np.ndarray  #: of theta about the trace's test centre
    sin: np.ndarray
    radius: np.ndarray  #: the trace's nominal radius, mm
    x: np.ndarray  #: commanded position, mm (radius coordinates)
    z: np.ndarray
    u: np.ndarray  #: x minus the trace's test centre
    w: np.ndarray  #: z minus the trace's test centre
    tx: np.ndarray  #: unit tangent in the trace's direction of travel
    tz: np.ndarray
    dx: np.ndarray  #: direction each axis travels (at a reversal: the way it last travelled), +1 or -1
    dz: np.ndarray
    feed: np.ndarray  #: mm/min, NaN where the trace states none
    along: np.ndarray  #: degrees from the start of the trace's captured arc
    measured: np.ndarray  #: the reading, mm, with any centre the reader removed put back

    @classmethod
    def of(cls, traces: Sequence[BallbarTrace]) -> Samples:
        groups = mounts(traces)
        mount_of = np.empty(len(traces), dtype=int)
        for index, group in enumerate(groups):
            mount_of[group] = index
        parts: dict[str, list[np.ndarray]] = {key: [] for key in (
            "trace", "cos", "sin", "radius", "x", "z", "u", "w", "tx", "tz", "feed", "along", "measured")}
        for index, trace in enumerate(traces):
            theta = np.radians(trace.angles)
            cos, sin = np.cos(theta), np.sin(theta)
            k = 1.0 if trace.direction == "cw" else -1.0  # cw: theta increasing
            size = len(theta)
            parts["trace"].append(np.full(size, index))
            parts["cos"].append(cos)
            parts["sin"].append(sin)
            parts["radius"].append(np.full(size, float(trace.radius)))
            parts["u"].append(trace.radius * cos)
            parts["w"].append(trace.radius * sin)
            parts["x"].append(trace.centre[0] + trace.radius * cos)
            parts["z"].append(trace.centre[1] + trace.radius * sin)
            parts["tx"].append(-k * sin)
            parts["tz"].append(k * cos)
            parts["feed"].append(np.full(size, np.nan if trace.feed is None else float(trace.feed)))
            parts["along"].append(np.mod(trace.angles - trace.arc[0], 360.0))
            parts["measured"].append(as_measured(trace))
        # one key at a time, each trace's part let go as it is copied: no second copy of the samples
        flat = {key: values[0] if len(values) == 1 else np.concatenate(values) for key, values in
                ((key, parts.pop(key)) for key in list(parts))}
        flat["trace"] = flat["trace"].astype(int)
        # exactly at a reversal an axis still lags the way it last travelled (its play not yet
        # taken up): just before theta in time, the tangent's sign there is cos's (X) and sin's (Z)
        dx = np.sign(np.round(flat["tx"], 12))
        dz = np.sign(np.round(flat["tz"], 12))
        dx = np.where(dx == 0.0, np.sign(np.round(flat["cos"], 12)), dx)
        dz = np.where(dz == 0.0, np.sign(np.round(flat["sin"], 12)), dz)
        return cls(traces=tuple(traces), groups=tuple(tuple(g) for g in groups), mount=mount_of[flat["trace"]],
                   dx=dx, dz=dz, **flat)

    @property
    def directions(self) -> set[str]:
        return {trace.direction for trace in self.traces}

    def of_trace(self, index: int) -> np.ndarray:
        """A boolean mask of one trace's samples."""
        return self.trace == index


def machine_errors(samples: Samples, names: Sequence[str]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Unit errors of the parametric machine model (docs/methods.md §7, Kakino), offsets about each
    trace's own test centre (a constant between tests goes with the set-up centres):

        e_x = a_x u + s w - (b_x / 2) d_x - m t_x (F / F_0)
        e_z = a_z w       - (b_z / 2) d_z

    a: scaling; b: backlash, the full step at a reversal (the axis lags b/2 behind its
    command); s: squareness (X error per unit Z); m: servo mismatch, X lagging Z along the
    path by m at the first trace's feed F_0 (by m F / F_0 at another feed, when every trace
    states its feed). ``apparent_squareness`` is squareness's column for one direction alone,
    where it also holds that direction's share of the servo mismatch (s + k m / R).
    """
    zero = np.zeros_like(samples.u)
    feeds = samples.feed
    ratio = feeds / feeds[0] if np.all(np.isfinite(feeds)) else np.ones_like(feeds)
    every = {
        "scaling_x": (samples.u, zero),
        "scaling_z": (zero, samples.w),
        "backlash_x": (-0.5 * samples.dx, zero),
        "backlash_z": (zero, -0.5 * samples.dz),
        "squareness": (samples.w, zero),
        "apparent_squareness": (samples.w, zero),
        "servo_mismatch": (-samples.tx * ratio, zero),
    }
    return {name: every[name] for name in names}


# -- the fit ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class JointFit:
    """Model parameters and every mount's set-up centre, fitted together to the samples."""

    samples: Samples
    names: tuple[str, ...]  #: the model's parameters, in order
    values: np.ndarray  #: model parameters, then centre x and z of each mount
    covariance: np.ndarray  #: of ``values``
    reach: np.ndarray  #: largest |(e_x, e_z)| each model parameter models at the samples
    residuals: np.ndarray  #: measured minus fitted, per sample, mm
    condition: float  #: of the column-scaled design
    used: np.ndarray  #: the samples fitted (not in a reversal's take-up of the play)

    @property
    def sigmas(self) -> np.ndarray:
        return np.sqrt(np.diag(self.covariance))

    def estimate(self, name: str) -> Estimate:
        index = self.names.index(name)
        return Estimate(float(self.values[index]), float(self.sigmas[index]))

    def estimates(self) -> dict[str, Estimate]:
        return {name: self.estimate(name) for name in self.names}

    def effect(self, name: str) -> float:
        """1 sigma of the largest error the parameter models at the samples, mm."""
        index = self.names.index(name)
        return float(self.sigmas[index] * self.reach[index])

    def centre(self, mount: int) -> tuple[Estimate, Estimate]:
        """The set-up centre (x, z) of a mount: what the reader should have removed."""
        first = len(self.names) + 2 * mount
        sigma = self.sigmas
        return (Estimate(float(self.values[first]), float(sigma[first])),
                Estimate(float(self.values[first + 1]), float(sigma[first + 1])))

    def centre_of_trace(self, index: int) -> tuple[float, float]:
        mount = int(self.samples.mount[self.samples.trace == index][0])
        x, z = self.centre(mount)
        return x.value, z.value

    def trace_residuals(self, index: int) -> np.ndarray:
        return self.residuals[self.samples.of_trace(index)]


def design(samples: Samples, unit_errors: Mapping[str, tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """The bar's reading of each parameter at unit value, then each mount's centre x and z."""
    matrix = np.empty((len(samples.cos), len(unit_errors) + 2 * len(samples.groups)))
    for column, (ex, ez) in enumerate(unit_errors.values()):
        np.add(np.broadcast_to(ex, samples.cos.shape) * samples.cos, np.broadcast_to(ez, samples.sin.shape) * samples.sin,
               out=matrix[:, column])
    for mount in range(len(samples.groups)):
        on = samples.mount == mount
        column = len(unit_errors) + 2 * mount
        matrix[:, column] = np.where(on, samples.cos, 0.0)
        matrix[:, column + 1] = np.where(on, samples.sin, 0.0)
    return matrix


def fit(samples: Samples, unit_errors: Mapping[str, tuple[np.ndarray, np.ndarray]]) -> JointFit:
    """Least squares of the model and the set-up centres; Inseparable when no solution is unique.

    The fit is made twice. The first gives the set-up centres, whose second-order share of the
    bar length (:func:`second_order`) is taken off the readings for the second. With backlash
    in the model (``backlash_x``, ``backlash_z``) the samples where an axis is taking up its play
    after a reversal (:func:`take_up`, from the first fit's backlash) are left out of the second:
    the model's step is, on the machine, a ramp while the slide stands still until its motor
    has moved b (a degree or so of arc).
    """
    names = tuple(unit_errors)
    matrix = design(samples, unit_errors)
    count, size = matrix.shape
    every = names + tuple(f"centre_{axis}" for _ in samples.groups for axis in "xz")
    where = Location(samples.traces[0].path)
    if count <= size:
        raise MeasurementError(f"{count} samples cannot fit {size} parameters ({arcs_text(samples.traces)})", where)
    used = np.ones(count, dtype=bool)
    solution, inverse, singular = _solve(matrix, samples.measured, used, every, names, samples.traces)
    measured = samples.measured - second_order(samples, solution[len(names):])
    play = {axis: abs(float(solution[names.index(f"backlash_{axis}")])) for axis in "xz" if f"backlash_{axis}" in names}
    if play:
        used = ~take_up(samples, play.get("x", 0.0), play.get("z", 0.0))
        if used.sum() <= size:
            used[:] = True
    solution, inverse, singular = _solve(matrix, measured, used, every, names, samples.traces)
    residuals = measured - matrix @ solution
    kept = residuals[used]
    variance = float(kept @ kept) / (used.sum() - size)
    covariance = inverse * variance
    correlated = _newey_west(matrix, residuals, used, samples.trace, samples.along, inverse)
    covariance = _larger(covariance, correlated)
    reach = np.array([float(np.max(np.hypot(np.broadcast_to(ex, samples.cos.shape),
                                            np.broadcast_to(ez, samples.cos.shape))))
                      for ex, ez in unit_errors.values()])
    return JointFit(samples, names, solution, covariance, reach, residuals, float(singular[0] / singular[-1]), used)


def without_centres(samples: Samples, values: np.ndarray, radius: bool = False) -> np.ndarray:
    """Values at the samples (a trace minus a model's prediction) less each mount's least-squares
    set-up centre, to second order as :func:`fit` takes it; with ``radius`` less each mount's
    least-squares circle (the centre and a constant: the ISO figures' reference circle)."""
    harmonics = design(samples, {})
    if radius:
        constants = np.column_stack([samples.mount == mount for mount in range(len(samples.groups))]).astype(float)
        harmonics = np.column_stack([harmonics, constants])
    centres, *_ = np.linalg.lstsq(harmonics, values, rcond=None)
    values = values - second_order(samples, centres[: 2 * len(samples.groups)])
    centres, *_ = np.linalg.lstsq(harmonics, values, rcond=None)
    return values - harmonics @ centres


def second_order(samples: Samples, centres: np.ndarray) -> np.ndarray:
    """The set-up centres' reading beyond their first harmonic (:func:`setup_reading`)."""
    cx, cz = centres[0::2][samples.mount], centres[1::2][samples.mount]
    return setup_reading(samples.cos, samples.sin, samples.radius, cx, cz) - cx * samples.cos - cz * samples.sin


def take_up(samples: Samples, backlash_x: float, backlash_z: float) -> np.ndarray:
    """The samples where an axis is still taking up its play after a reversal: its motor has
    moved less than the backlash since the axis turned (X turns where sin = 0, Z where cos = 0),
    the reversal itself included (where the bar reads the glitch of the turn)."""
    theta = np.arctan2(samples.sin, samples.cos)
    k = np.sign(samples.tx * -samples.sin + samples.tz * samples.cos)  # +1 cw (theta increasing), -1 ccw
    inside = np.zeros(theta.shape, dtype=bool)
    for backlash, turns in ((backlash_x, 0.0), (backlash_z, 0.5 * np.pi)):
        if backlash <= 0.0:
            continue
        since = np.mod(theta - turns + 0.5 * np.pi, np.pi) - 0.5 * np.pi  # from the nearest turn, (-90, 90] deg
        travelled = samples.radius * (1.0 - np.cos(since))
        inside |= (k * since >= 0.0) & (travelled < backlash)
    return inside


def _solve(matrix: np.ndarray, measured: np.ndarray, used: np.ndarray, every: tuple[str, ...], names: tuple[str, ...],
           traces) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The least-squares solution over the used rows, (A^T A)^-1 and the singular values of the
    column-scaled design; Inseparable when a direction of the parameters is not seen."""
    where = Location(traces[0].path)
    if len(matrix) > BLOCKED_SAMPLES:
        size = matrix.shape[1]
        reduced = _triangular(matrix, measured, used)
        rows, target = reduced[:size, :size], reduced[:size, size]
    else:
        rows, target = matrix[used], measured[used]
    norms = np.linalg.norm(rows, axis=0)
    unseen = [every[i] for i in np.flatnonzero(norms == 0.0)]
    if unseen:
        raise Inseparable(f"the traces do not see {_names(unseen)} at all: {arcs_text(traces)}", where, tuple(unseen))
    left, singular, right = np.linalg.svd(rows / norms, full_matrices=False)
    small = singular < SEPARABLE * singular[0]
    if small.any():
        involved = [every[i] for i in np.flatnonzero(np.any(np.abs(right[small]) > 0.1, axis=0))]
        model = tuple(name for name in involved if name in names) or tuple(involved)
        raise Inseparable(f"on {arcs_text(traces)}, {_names(involved)} cannot be told apart "
                          f"({'from each other' if len(involved) > 1 else 'from the rest'}); measure "
                          f"{more_evidence(traces, 'tests about more centres')}", where, model)
    solution = right.T @ ((left.T @ target) / singular) / norms
    inverse = (right.T / singular**2) @ right / np.outer(norms, norms)
    return solution, inverse, singular


BLOCKED_SAMPLES = 1 << 17  #: above this many samples the design is reduced a block at a time (:func:`_triangular`)
SOLVE_BLOCK = 1 << 15  #: samples reduced at a time


def _triangular(matrix: np.ndarray, measured: np.ndarray, used: np.ndarray) -> np.ndarray:
    """R of the QR decomposition of the used rows of ``[matrix | measured]``, a block of rows at a
    time: the least-squares problem in (columns + 1) rows instead of one per sample.

    The design Q R has R's singular values and right vectors, and its least-squares solution
    is R's with Q^T b (R's last column) for b: :func:`_solve` decomposes that small R instead
    of a design of millions of rows and keeps no more than a block of them at once. Below
    BLOCKED_SAMPLES the design is decomposed whole, as it always was (the same digits)."""
    reduced = np.zeros((0, matrix.shape[1] + 1))
    for first in range(0, len(matrix), SOLVE_BLOCK):
        keep = used[first: first + SOLVE_BLOCK]
        block = np.column_stack([matrix[first: first + SOLVE_BLOCK][keep], measured[first: first + SOLVE_BLOCK][keep]])
        reduced = np.linalg.qr(np.vstack([reduced, block]), mode="r")
    return reduced


SPIKE_SIGMAS = 8.0  #: a residual this many robust sigmas off its trace's ...
SPIKE_FLOOR_MM = 0.005  #: ... and at least this far, on at most SPIKE_SAMPLES samples in a row, is a spike
SPIKE_SAMPLES = 2
SPIKE_CLEAR_DEG = 3.0  #: not within this of an axis reversal, where the machine itself makes spikes


def spike(samples: Samples, residuals: np.ndarray) -> tuple[str, Location] | None:
    """The largest spike among the traces, said with its file, line, size, cause and remedy, or None.

    A spike is a reading no machine makes: one or two samples far off the fit while their
    neighbours lie on it (a knock, dirt on a ball, the bar re-seating in its cup). Least squares
    spreads it over every parameter, whose uncertainties come from the residuals, so a spike
    reads as a parameter "not determined" and the arc or the directions get the blame: a fit
    refused for its uncertainties names the spike instead. Off the fit means beyond
    SPIKE_SIGMAS of the trace's robust spread (1.4826 times the median absolute residual) and
    SPIKE_FLOOR_MM; a longer run off it is the machine, and so is anything within
    SPIKE_CLEAR_DEG of an axis reversal (a quadrant), where servo and friction make the
    machine's own reversal spikes and raw averaging straddles the backlash step."""
    found: list[tuple[float, int, int]] = []
    clear = math.sin(math.radians(SPIKE_CLEAR_DEG))
    for index in range(len(samples.traces)):
        mask = samples.of_trace(index)
        mine = residuals[mask]
        if len(mine) < 5:
            continue
        middle = float(np.median(mine))
        limit = max(SPIKE_SIGMAS * 1.4826 * float(np.median(np.abs(mine - middle))), SPIKE_FLOOR_MM)
        away = np.minimum(np.abs(samples.cos[mask]), np.abs(samples.sin[mask])) > clear
        off = np.concatenate([[False], (np.abs(mine - middle) > limit) & away, [False]])
        edges = np.flatnonzero(np.diff(off.astype(int)))
        for start, stop in zip(edges[::2], edges[1::2]):
            if stop - start <= SPIKE_SAMPLES:
                at = start + int(np.argmax(np.abs(mine[start:stop] - middle)))
                found.append((abs(float(mine[at] - middle)), index, at))
    if not found:
        return None
    found.sort(reverse=True)
    _, index, at = found[0]
    trace = samples.traces[index]
    values = trace.deviations
    neighbours = [k for k in (at - 2, at - 1, at + 1, at + 2) if 0 <= k < len(values) and abs(k - at) <= 2]
    near = float(np.median(values[[k for k in neighbours if abs(float(values[k] - values[at])) > 0.5 * found[0][0]]
                                  or neighbours]))
    row = None if trace.rows is None else int(trace.rows[at])
    line = "" if row is None else f" line {row}" if not trace.raw else f" (the readings from line {row})"
    where = f"{trace.path}{line}, the sample at {trace.angles[at]:g} deg,"
    redo = ("run the test again" if trace.raw or row is None else
            f"run the test again, or delete that line (a gap of up to {MAX_GAP_DEG:g} deg is bridged)")
    more = f" ({len(found) - 1} more spike{'s' if len(found) > 2 else ''} in the traces)" if len(found) > 1 else ""
    text = (f"{where} reads {values[at]:+.4f} mm where its neighbours read {near:+.4f} mm: a spike of "
            f"{(values[at] - near) * 1000:+.1f} um in one {'averaged group of readings' if trace.raw else 'sample'}, "
            f"not the machine (a knock, dirt on a ball, the bar re-seating){more}: {redo}")
    return text, Location(trace.path, row)


def require(result: JointFit, names: Sequence[str] | None = None, limit: float = EFFECT_LIMIT_MM) -> None:
    """Refuse a fit whose parameters are not determined: 3 sigma of an effect above ``limit`` mm;
    a spike in a trace (:func:`spike`) is named as the cause when there is one."""
    worst = [(3.0 * result.effect(name), name) for name in (names or result.names)
             if 3.0 * result.effect(name) > limit]
    if not worst:
        return
    worst.sort(reverse=True)
    found = spike(result.samples, result.residuals)
    if found is not None:
        raise Undetermined(f"the fit is not determined, and the likely cause is a spike: {found[0]}", found[1],
                           tuple(name for _, name in worst))
    listed = ", ".join(f"{label(name)} +-{shown(name, 3.0 * result.estimate(name).sigma).lstrip('+')} "
                       f"({effect * 1000:.2f} um)" for effect, name in worst)
    raise Undetermined(
        f"on {arcs_text(result.samples.traces)}, {listed} {'is' if len(worst) == 1 else 'are'} not determined: "
        f"3 sigma of the error it models is above {limit * 1000:g} um; measure "
        f"{more_evidence(result.samples.traces, 'a quieter trace')}", Location(result.samples.traces[0].path),
        tuple(name for _, name in worst))


def fit_determined(samples: Samples, unit_errors: Mapping[str, tuple[np.ndarray, np.ndarray]],
                   limit: float = EFFECT_LIMIT_MM) -> tuple[JointFit, tuple[str, ...]]:
    """The fit with every parameter the traces cannot determine left out (the worst first), and
    those left out. For what needs the set-up centre whatever the arc (a reader centring a trace):
    a left-out parameter's share goes with the centre, as a separate circle fit would take it."""
    model = dict(unit_errors)
    dropped: list[str] = []
    while True:
        try:
            result = fit(samples, model)
        except Inseparable as exc:
            if not model or not set(exc.names) & set(model):
                raise
            name = next(n for n in reversed(list(model)) if n in exc.names)
        else:
            effects = [(result.effect(n), n) for n in result.names if 3.0 * result.effect(n) > limit]
            if not effects:
                return result, tuple(dropped)
            name = max(effects)[1]
        del model[name]
        dropped.append(name)


def _names(names: Sequence[str]) -> str:
    return ", ".join(label(name) for name in names)


def _larger(first: np.ndarray, second: np.ndarray) -> np.ndarray:
    """The covariance whose variances are each the larger of the two (correlations from the one chosen)."""
    pick = np.diag(second) > np.diag(first)
    scale = np.sqrt(np.where(pick, np.diag(second), np.diag(first)) / np.maximum(np.diag(first), 1e-300))
    return first * np.outer(scale, scale)


def _newey_west(matrix: np.ndarray, residuals: np.ndarray, used: np.ndarray, trace: np.ndarray, along: np.ndarray,
                inverse: np.ndarray) -> np.ndarray:
    """Covariance robust to residuals correlated along each trace (Newey-West, Bartlett weights).

    The bandwidth of each trace is Andrews' (1991) AR(1) plug-in, ``1.1447 (alpha n)^(1/3)`` with
    ``alpha = 4 rho^2 / ((1 - rho)^6 (1 + rho)^2)``: about 0 for white residuals, longer the
    longer they stay alike. Samples are taken in order along the captured arc (the used rows
    of ``matrix``).
    """
    meat = np.zeros((matrix.shape[1],) * 2)
    for index in np.unique(trace[used]):
        rows = np.flatnonzero((trace == index) & used)
        rows = rows[np.argsort(along[rows], kind="stable")]
        e = residuals[rows]
        n = len(rows)
        denominator = float(e @ e)
        rho = float(e[1:] @ e[:-1]) / denominator if denominator > 0 else 0.0
        rho = min(max(rho, -0.97), 0.97)
        alpha = 4 * rho**2 / ((1 - rho) ** 6 * (1 + rho) ** 2)
        bandwidth = min(int(math.ceil(1.1447 * (alpha * n) ** (1 / 3))), n // 4)
        if n <= BLOCKED_SAMPLES and bandwidth * n <= DIRECT_LAG_PRODUCTS:
            scores = matrix[rows] * residuals[rows, None]
            meat += scores.T @ scores
            for lag in range(1, bandwidth + 1):
                weight = 1.0 - lag / (bandwidth + 1)
                cross = scores[lag:].T @ scores[:-lag]
                meat += weight * (cross + cross.T)
        else:
            meat += _bartlett_windows(lambda a, b: matrix[rows[a:b]] * residuals[rows[a:b], None], n,
                                      matrix.shape[1], bandwidth)
    count, size = int(used.sum()), matrix.shape[1]
    return inverse @ meat @ inverse * (count / max(count - size, 1))


DIRECT_LAG_PRODUCTS = 1 << 23  #: lags times samples up to which the lagged products are summed one lag at a time
WINDOW_BLOCK = 1 << 16  #: windows summed at a time


def _bartlett_windows(scores: Callable[[int, int], np.ndarray], n: int, size: int, bandwidth: int) -> np.ndarray:
    """The Bartlett-weighted sum of lagged products of n scores (``scores(a, b)``: rows a to b),
    ``sum over |l| <= B of (1 - |l| / (B + 1)) sum_t s_t s_(t+l)^T``, in time linear in the
    samples whatever the bandwidth B, a block of rows at a time.

    Each pair of samples l apart lies together in B + 1 - l of the windows of B + 1
    consecutive samples (those at the ends cut short), so the sum is that of every window's
    sum times its transpose, over B + 1; a window's sum is the difference of the running sum
    at its ends, each end read by a cursor that moves one way along the trace. The lag-by-lag
    sum costs B passes over the samples: a long trace of correlated residuals has a bandwidth
    of thousands of samples, and that is quadratic."""
    ahead, behind = _Running(scores, n, size), _Running(scores, n, size)
    total = np.zeros((size, size))
    for first in range(0, n + bandwidth, WINDOW_BLOCK):
        ends = np.arange(first, min(first + WINDOW_BLOCK, n + bandwidth))
        sums = ahead.at(np.minimum(ends, n - 1) + 1) - behind.at(np.maximum(ends - bandwidth, 0))
        total += sums.T @ sums
    return total / (bandwidth + 1)


class _Running:
    """The running sum of n scores (row k: the sum of the first k), read at rows that never go
    back, computed a block at a time and let go behind the reader."""

    def __init__(self, scores: Callable[[int, int], np.ndarray], n: int, size: int):
        self.scores, self.n = scores, n
        self.start = 0  #: the row of held[0]
        self.held = np.zeros((1, size))

    def at(self, rows: np.ndarray) -> np.ndarray:
        """The running sum at ``rows`` (increasing, none before an earlier call's first)."""
        first, last = int(rows[0]), int(rows[-1])
        while self.start + len(self.held) <= last:
            end = self.start + len(self.held)  # the next row: the held last plus score end - 1
            stop = min(end - 1 + WINDOW_BLOCK, self.n)
            more = self.held[-1] + np.cumsum(self.scores(end - 1, stop), axis=0)
            keep = min(max(first - self.start, 0), len(self.held) - 1)  # the last held row starts the next block
            self.held, self.start = np.vstack([self.held[keep:], more]), self.start + keep
        return self.held[rows - self.start]
