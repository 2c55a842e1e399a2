"""Smooth error maps over the working plane, fitted to ballbar traces: a public helper for compensators.

What it fits (docs/methods.md §16): the machine's position error as two smooth functions of the
commanded position, ``e_x(x, z)`` and ``e_z(x, z)``, plus whatever the caller adds as unit errors
(backlash by each axis's direction of travel, servo mismatch), to any number of ballbar traces,
each test with its own set-up centre: the samples, the columns and the set-up centres are those
of :mod:`postproc.measure.ballbar_fit`, the field's basis functions being more columns of the same design.

- :class:`Basis`: cubic tensor-product B-splines (scipy's :class:`~scipy.interpolate.BSpline`)
  over a box, ``INTERVALS`` knot intervals per axis. Cubic B-splines reproduce every polynomial
  up to degree 3, so a straight slide, a bow and a scale error are all in the space.
- :func:`fit_map`: penalised least squares. Two roughness penalties, each with its own weight:
  the *main* one, ``integral of f_xx^2 + f_zz^2``, bends each error along each axis; the
  *interaction* one, ``integral of f_xz^2``, is zero exactly for fields that are sums of a
  function of x and a function of z (each slide's errors depending on its own position, the
  kinematic model of a two-axis machine) and measures how far a field departs from that. Both
  weights are chosen by restricted maximum likelihood (REML, Wood 2011): the weights under which
  the traces are most probable, given the smoothness they imply. Not generalised
  cross-validation: ballbar samples lie on a few circles, and GCV judges a fit by how well it
  predicts a left-out sample *on* a circle, which a field bent anywhere between the circles
  does as well; its score is flat over six decades of the weight there, and its minimum lands
  on whichever end numerical noise favours. REML also weighs the penalty's own determinant, so
  it picks the smoothness the data can carry between the circles.
- The gauge: a ballbar cannot see a rigid motion of the field (a translation goes with every
  test's set-up centre, and a small rotation reads as a set-up offset on every circle). Three
  linear conditions pin it: the field is zero at the gauge point (the first test's centre) and
  ``d e_z / d x`` is zero there (the slides' squareness taken as X error along Z, as
  ``parametric`` and the simulator's ``squareness_rad`` take it). Probe data of a cut part pin
  it instead (:func:`rigid_fit`).
- The posterior: coefficients ~ N(fitted, s^2 (A^T A + S)^-1) (the Bayesian reading of the
  penalty, Wahba 1983), s^2 from the residuals over the degrees of freedom the penalty leaves;
  :meth:`Field.sigma` gives each component's 1-sigma at any point, relative to the gauge.
- :class:`Support`: where the measurements support the map: the convex hull of the commanded
  positions of every sample (and of any probe point), within ``SUPPORT_MARGIN_MM``. Inside it the
  map interpolates between measured arcs; outside it extrapolates on the penalty's linear part
  alone, which no measurement checks. Chosen over a bound on the posterior sigma because that
  sigma scales with the noise of the traces and with the prior: the same test arcs would
  support a region that shrinks as the bar gets noisier, which says more about the bar than
  about where the machine was measured.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import BSpline
from scipy.optimize import minimize

try:
    from threadpoolctl import threadpool_limits
except ImportError:  # declared in pyproject.toml; an environment not reinstalled since runs slower, not wrong
    import contextlib

    def threadpool_limits(*args, **kwargs):
        return contextlib.nullcontext()

from . import ballbar_fit
from .ballbar_fit import Samples
from ..diagnostics import Location

DEGREE = 3  #: cubic B-splines
INTERVALS = 6  #: knot intervals per axis over the box the measurements span
SUPPORT_MARGIN_MM = 0.05  #: a point this close outside the hull of the measurements is inside it
GRID = 49  #: uncertainty grid points per axis (stored with a model; read bilinearly)
#: natural-log range of each penalty weight, relative to the design's scale. Beyond e^16 the normal
#: equations lose the digits the fit needs (measured: at e^25 a fit left 0.43 um of residual where
#: e^16 leaves 0.30 um), while from e^13 on the map changes by nanometres: its penalised part is zero.
_LOG_SPAN = (-20.0, 16.0)


# -- the basis ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Basis:
    """Cubic tensor-product B-splines over a box: ``B_ij(x, z) = X_i(x) Z_j(z)``, index ``i * nz + j``."""

    knots_x: np.ndarray
    knots_z: np.ndarray
    degree: int = DEGREE

    @classmethod
    def over(cls, box: tuple[tuple[float, float], tuple[float, float]], intervals: int = INTERVALS) -> Basis:
        """Equally spaced knots over the box, the end knots repeated (clamped)."""
        def knots(low: float, high: float) -> np.ndarray:
            if not high > low:
                raise ValueError(f"an empty range {low:g} .. {high:g}")
            inner = np.linspace(low, high, intervals + 1)
            return np.concatenate([[low] * DEGREE, inner, [high] * DEGREE])

        (x0, x1), (z0, z1) = box
        return cls(knots(x0, x1), knots(z0, z1))

    @property
    def nx(self) -> int:
        return len(self.knots_x) - self.degree - 1

    @property
    def nz(self) -> int:
        return len(self.knots_z) - self.degree - 1

    @property
    def size(self) -> int:
        return self.nx * self.nz

    @property
    def box(self) -> tuple[tuple[float, float], tuple[float, float]]:
        return ((float(self.knots_x[0]), float(self.knots_x[-1])), (float(self.knots_z[0]), float(self.knots_z[-1])))

    def axis(self, which: str, values, derivative: int = 0) -> np.ndarray:
        """Every basis function of one axis (or its derivative) at the values, (n, nx or nz); beyond
        the knots the end polynomials continue."""
        knots, count = (self.knots_x, self.nx) if which == "x" else (self.knots_z, self.nz)
        spline = BSpline(knots, np.eye(count), self.degree, extrapolate=True)
        if derivative:
            spline = spline.derivative(derivative)
        return spline(np.asarray(values, dtype=float).ravel())

    def values(self, x, z, dx: int = 0, dz: int = 0) -> np.ndarray:
        """The tensor basis (or a derivative of it) at points, (n, size)."""
        bx, bz = self.axis("x", x, dx), self.axis("z", z, dz)
        return (bx[:, :, None] * bz[:, None, :]).reshape(len(bx), -1)

    def evaluate(self, coefficients: np.ndarray, x, z) -> np.ndarray:
        """sum of c_ij X_i(x) Z_j(z) at points: (X C) . Z row by row, no (n, size) matrix."""
        bx, bz = self.axis("x", x), self.axis("z", z)
        return np.einsum("ij,ij->i", bx @ coefficients.reshape(self.nx, self.nz), bz)

    def penalties(self) -> tuple[np.ndarray, np.ndarray]:
        """(main, interaction): the integrals over the box of ``f_xx^2 + f_zz^2`` and of ``f_xz^2`` as
        quadratic forms of the coefficients, from exact one-dimensional Gram matrices."""
        gx = [self._gram("x", d) for d in range(3)]
        gz = [self._gram("z", d) for d in range(3)]
        return np.kron(gx[2], gz[0]) + np.kron(gx[0], gz[2]), np.kron(gx[1], gz[1])

    def _gram(self, which: str, derivative: int) -> np.ndarray:
        """Integral of the product of every pair of one axis's basis derivatives: Gauss-Legendre on
        each knot interval, exact for the piecewise polynomials of degree 2 * DEGREE."""
        knots = self.knots_x if which == "x" else self.knots_z
        nodes, weights = np.polynomial.legendre.leggauss(self.degree + 1)
        edges = np.unique(knots)
        low, high = edges[:-1, None], edges[1:, None]
        points = ((low + high) / 2 + (high - low) / 2 * nodes).ravel()
        scale = ((high - low) / 2 * weights).ravel()
        values = self.axis(which, points, derivative)
        return (values * scale[:, None]).T @ values

    def as_dict(self) -> dict:
        return {"degree": self.degree, "knots_x_mm": self.knots_x.tolist(), "knots_z_mm": self.knots_z.tolist()}

    @classmethod
    def from_dict(cls, data: Mapping) -> Basis:
        basis = cls(np.asarray(data["knots_x_mm"], dtype=float), np.asarray(data["knots_z_mm"], dtype=float),
                    int(data["degree"]))
        for knots in (basis.knots_x, basis.knots_z):
            if knots.ndim != 1 or len(knots) < 2 * basis.degree + 2 or np.any(np.diff(knots) < 0) \
                    or not np.all(np.isfinite(knots)):
                raise ValueError("the knots must be finite, ascending, and enough for the degree")
        return basis


# -- the field ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Field:
    """e_x and e_z over a basis, with the 1-sigma of each on a grid (relative to the gauge)."""

    basis: Basis
    cx: np.ndarray  #: coefficients of e_x, (size,)
    cz: np.ndarray  #: coefficients of e_z
    grid_x: np.ndarray  #: the uncertainty grid's x values, mm
    grid_z: np.ndarray
    sigma_x: np.ndarray  #: 1-sigma of e_x at the grid points, (len(grid_x), len(grid_z)), mm
    sigma_z: np.ndarray

    def errors(self, x, z) -> tuple[np.ndarray, np.ndarray]:
        """(e_x, e_z) at points, mm."""
        return self.basis.evaluate(self.cx, x, z), self.basis.evaluate(self.cz, x, z)

    def sigma(self, x, z) -> tuple[np.ndarray, np.ndarray]:
        """The 1-sigma of e_x and of e_z at points (bilinear on the grid; held at its edge beyond it)."""
        return _bilinear(self.grid_x, self.grid_z, self.sigma_x, x, z), _bilinear(self.grid_x, self.grid_z, self.sigma_z, x, z)

    def shifted(self, offset: np.ndarray) -> Field:
        """The field plus coefficients of a rigid motion (or any field over the same basis)."""
        size = self.basis.size
        return Field(self.basis, self.cx + offset[:size], self.cz + offset[size:], self.grid_x, self.grid_z,
                     self.sigma_x, self.sigma_z)

    def as_dict(self) -> dict:
        return {"basis": self.basis.as_dict(), "coefficients_x_mm": self.cx.tolist(),
                "coefficients_z_mm": self.cz.tolist(),
                "uncertainty": {"x_mm": self.grid_x.tolist(), "z_mm": self.grid_z.tolist(),
                                "sigma_x_mm": self.sigma_x.tolist(), "sigma_z_mm": self.sigma_z.tolist()}}

    @classmethod
    def from_dict(cls, data: Mapping) -> Field:
        basis = Basis.from_dict(data["basis"])
        cx = np.asarray(data["coefficients_x_mm"], dtype=float)
        cz = np.asarray(data["coefficients_z_mm"], dtype=float)
        grid = data["uncertainty"]
        gx, gz = np.asarray(grid["x_mm"], dtype=float), np.asarray(grid["z_mm"], dtype=float)
        sx, sz = np.asarray(grid["sigma_x_mm"], dtype=float), np.asarray(grid["sigma_z_mm"], dtype=float)
        if cx.shape != (basis.size,) or cz.shape != (basis.size,):
            raise ValueError(f"{basis.size} coefficients per axis expected")
        if sx.shape != (len(gx), len(gz)) or sz.shape != sx.shape or len(gx) < 2 or len(gz) < 2:
            raise ValueError("the uncertainty grid does not match its axes")
        if not all(np.all(np.isfinite(a)) for a in (cx, cz, gx, gz, sx, sz)):
            raise ValueError("the map holds numbers that are not finite")
        return cls(basis, cx, cz, gx, gz, sx, sz)


def _bilinear(gx: np.ndarray, gz: np.ndarray, values: np.ndarray, x, z) -> np.ndarray:
    x = np.clip(np.asarray(x, dtype=float).ravel(), gx[0], gx[-1])
    z = np.clip(np.asarray(z, dtype=float).ravel(), gz[0], gz[-1])
    i = np.clip(np.searchsorted(gx, x, side="right") - 1, 0, len(gx) - 2)
    j = np.clip(np.searchsorted(gz, z, side="right") - 1, 0, len(gz) - 2)
    a = (x - gx[i]) / (gx[i + 1] - gx[i])
    b = (z - gz[j]) / (gz[j + 1] - gz[j])
    return ((1 - a) * (1 - b) * values[i, j] + a * (1 - b) * values[i + 1, j]
            + (1 - a) * b * values[i, j + 1] + a * b * values[i + 1, j + 1])


def rigid(basis: Basis, point: tuple[float, float]) -> np.ndarray:
    """Coefficients (2 size, 3) of the rigid motions about ``point``: translation in x, in z, and a
    small rotation ``(-(z - zp), x - xp)`` per radian. B-splines reproduce linear functions, so
    these are exact: a linear function's coefficients are its values at the Greville abscissae."""
    size = basis.size
    gx = _greville(basis.knots_x, basis.degree)
    gz = _greville(basis.knots_z, basis.degree)
    x, z = np.meshgrid(gx, gz, indexing="ij")
    x, z = x.ravel() - point[0], z.ravel() - point[1]
    modes = np.zeros((2 * size, 3))
    modes[:size, 0] = 1.0
    modes[size:, 1] = 1.0
    modes[:size, 2], modes[size:, 2] = -z, x
    return modes


def _greville(knots: np.ndarray, degree: int) -> np.ndarray:
    return np.array([knots[i + 1: i + degree + 1].mean() for i in range(len(knots) - degree - 1)])


# -- the support -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class Support:
    """The convex hull of the points where the machine was measured (counter-clockwise vertices)."""

    vertices: np.ndarray  #: (m, 2)

    @classmethod
    def of(cls, points: np.ndarray) -> Support:
        """Andrew's monotone chain: the hull's vertices in order, collinear points dropped."""
        unique = np.unique(np.round(np.asarray(points, dtype=float), 9), axis=0)
        if len(unique) < 3:
            raise ValueError("fewer than three distinct points span no region")
        ordered = unique[np.lexsort((unique[:, 1], unique[:, 0]))]

        def chain(points):
            kept: list[np.ndarray] = []
            for p in points:
                while len(kept) >= 2 and _turn(kept[-2], kept[-1], p) <= 0:
                    kept.pop()
                kept.append(p)
            return kept

        lower, upper = chain(ordered), chain(ordered[::-1])
        vertices = np.array(lower[:-1] + upper[:-1])
        if len(vertices) < 3:
            raise ValueError("the points lie on a line: they span no region")
        return cls(vertices)

    def outside(self, points: np.ndarray, margin: float = SUPPORT_MARGIN_MM) -> np.ndarray:
        """How far each point lies outside the hull (0 inside or within ``margin``), mm."""
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        start = self.vertices
        edge = np.roll(start, -1, axis=0) - start
        normal = np.column_stack([edge[:, 1], -edge[:, 0]]) / np.hypot(edge[:, 0], edge[:, 1])[:, None]  # outward
        distance = np.einsum("ijk,jk->ij", points[:, None, :] - start[None, :, :], normal).max(axis=1)
        return np.where(distance > margin, distance, 0.0)

    def box(self) -> tuple[tuple[float, float], tuple[float, float]]:
        (x0, z0), (x1, z1) = self.vertices.min(axis=0), self.vertices.max(axis=0)
        return (float(x0), float(x1)), (float(z0), float(z1))

    def area(self) -> float:
        x, z = self.vertices[:, 0], self.vertices[:, 1]
        return 0.5 * float(np.sum(x * np.roll(z, -1) - np.roll(x, -1) * z))


def _turn(a, b, c) -> float:
    return float((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))


# -- the fit ----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class MapFit:
    """A field, the other parameters and every mount's set-up centre, fitted together by penalised least squares."""

    samples: Samples
    field: Field
    names: tuple[str, ...]  #: the other parameters (backlash, servo mismatch), in order
    values: np.ndarray  #: their values
    sigmas: np.ndarray  #: their 1-sigma
    centres: np.ndarray  #: (mounts, 2) set-up centre of each mount, mm
    residuals: np.ndarray  #: measured minus fitted at every sample, mm
    used: np.ndarray  #: the samples fitted (not in a reversal's take-up of the play)
    weights: tuple[float, float]  #: the penalty weights chosen (main, interaction), relative to the design's scale
    edf: float  #: effective degrees of freedom of the whole fit
    sigma: float  #: the residuals' standard deviation over the degrees of freedom left, mm
    gauge: tuple[float, float]  #: where the field and d e_z / d x are zero

    def estimate(self, name: str) -> ballbar_fit.Estimate:
        index = self.names.index(name)
        return ballbar_fit.Estimate(float(self.values[index]), float(self.sigmas[index]))

    def trace_residuals(self, index: int) -> np.ndarray:
        return self.residuals[self.samples.of_trace(index)]

    @property
    def gcv(self) -> float:
        """Generalised cross-validation's score of the fit, ``n RSS / (n - edf)^2``: reported to show
        why it does not choose the weights (docs/methods.md §16.1)."""
        kept = self.residuals[self.used]
        count = len(kept)
        return count * float(kept @ kept) / (count - self.edf) ** 2


def fit_map(samples: Samples, basis: Basis, others: Mapping[str, tuple[np.ndarray, np.ndarray]],
            gauge: tuple[float, float], weights: tuple[float, float] | None = None) -> MapFit:
    """See :func:`_fit_map`; with the BLAS held to one thread: the fit factorises a few hundred
    matrices of a couple of hundred rows, where a multi-threaded BLAS spends 20 to 50 times the
    arithmetic handing the work between threads (measured: 0.3 s on one thread, 7 to 20 s on two
    busy cores)."""
    with threadpool_limits(limits=1, user_api="blas"):
        return _fit_map(samples, basis, others, gauge, weights)


def _fit_map(samples: Samples, basis: Basis, others: Mapping[str, tuple[np.ndarray, np.ndarray]],
             gauge: tuple[float, float], chosen: tuple[float, float] | None) -> MapFit:
    """Penalised least squares of the field over ``basis``, the ``others`` unit errors and every
    mount's set-up centre; the penalty weights by REML; the gauge fixed at ``gauge``.

    As :func:`postproc.measure.ballbar_fit.fit`, the fit runs twice: the set-up centres' second-order share
    of the bar is taken off the readings for the second, and with backlash among ``others`` the
    samples where an axis takes up its play after a reversal are left out of it. ``weights``
    (main, interaction; relative to the design's scale, as :attr:`MapFit.weights` reports them)
    replace REML's choice: to see what another smoothness would give.

    :raises postproc.measure.ballbar_fit.Inseparable: the traces cannot separate the unpenalised part (the
        field's linear part, the others and the centres), e.g. one direction alone.
    """
    size = basis.size
    rows = basis.values(samples.x, samples.z)
    field = rows * samples.cos[:, None], rows * samples.sin[:, None]
    matrix = np.column_stack([field[0], field[1], ballbar_fit.design(samples, others)])
    names = tuple(others)
    extra = len(names)
    total = matrix.shape[1]
    constraint = np.zeros((3, total))
    at = basis.values([gauge[0]], [gauge[1]])[0]
    constraint[0, :size] = at
    constraint[1, size:2 * size] = at
    constraint[2, size:2 * size] = basis.values([gauge[0]], [gauge[1]], dx=1)[0]
    reduced = np.linalg.svd(constraint)[2][3:].T  # (total, total - 3): every vector meeting the gauge
    main, interaction = (_embedded(p, total, size) for p in basis.penalties())
    penalties = (reduced.T @ main @ reduced, reduced.T @ interaction @ reduced)

    used = np.ones(len(samples.measured), dtype=bool)
    measured = samples.measured
    whole = matrix @ reduced
    _check_separable(whole, penalties, samples, names)
    for second in (False, True):
        design = whole[used]
        normal = design.T @ design
        if not second:  # the second pass leaves out a few samples at the reversals: the same smoothness
            scales = tuple(np.trace(normal) / max(np.trace(p), 1e-300) for p in penalties)
            weights = chosen or _reml_weights(design, measured[used], normal, penalties, scales)
        penalty = sum(w * s * p for w, s, p in zip(weights, scales, penalties))
        inverse = np.linalg.inv(normal + penalty)
        theta = inverse @ (design.T @ measured[used])
        solution = reduced @ theta
        if second:
            break
        centres = solution[2 * size + extra:]
        measured = samples.measured - ballbar_fit.second_order(samples, centres)
        play = {axis: abs(float(solution[2 * size + names.index(f"backlash_{axis}")]))
                for axis in "xz" if f"backlash_{axis}" in names}
        if play:
            used = ~ballbar_fit.take_up(samples, play.get("x", 0.0), play.get("z", 0.0))
            if used.sum() <= total:
                used[:] = True
    residuals = measured - matrix @ solution
    kept = residuals[used]
    edf = float(np.trace(inverse @ normal))
    variance = float(kept @ kept) / max(used.sum() - edf, 1.0)
    covariance = variance * reduced @ inverse @ reduced.T
    field_cov = covariance[:2 * size, :2 * size]
    gx = np.linspace(*basis.box[0], GRID)
    gz = np.linspace(*basis.box[1], GRID)
    mesh_x, mesh_z = np.meshgrid(gx, gz, indexing="ij")
    grid_rows = basis.values(mesh_x.ravel(), mesh_z.ravel())
    sx = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", grid_rows, field_cov[:size, :size], grid_rows), 0.0))
    sz = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", grid_rows, field_cov[size:, size:], grid_rows), 0.0))
    result_field = Field(basis, solution[:size], solution[size:2 * size], gx, gz, sx.reshape(GRID, GRID),
                         sz.reshape(GRID, GRID))
    sigmas = np.sqrt(np.maximum(np.diag(covariance), 0.0))
    return MapFit(samples, result_field, names, solution[2 * size: 2 * size + extra],
                  sigmas[2 * size: 2 * size + extra], solution[2 * size + extra:].reshape(-1, 2), residuals, used,
                  tuple(float(w) for w in weights), edf, math.sqrt(variance), (float(gauge[0]), float(gauge[1])))


def _embedded(penalty: np.ndarray, total: int, size: int) -> np.ndarray:
    """A field penalty applied to both components, inside the whole parameter vector."""
    full = np.zeros((total, total))
    full[:size, :size] = penalty
    full[size:2 * size, size:2 * size] = penalty
    return full


def _check_separable(design: np.ndarray, penalties: tuple[np.ndarray, np.ndarray], samples: Samples,
                     names: Sequence[str]) -> None:
    """Refuse when the data cannot determine what no penalty touches (the field's linear part, the
    other parameters, the set-up centres): the penalised fit would then return the penalty's guess."""
    values, vectors = np.linalg.eigh(penalties[0] + penalties[1])
    free = vectors[:, values < 1e-9 * values.max()]
    columns = design @ free
    norms = np.linalg.norm(columns, axis=0)
    singular = np.linalg.svd(columns / np.where(norms > 0, norms, 1.0), compute_uv=False)
    if norms.min() == 0.0 or singular[-1] < ballbar_fit.SEPARABLE * singular[0]:
        raise ballbar_fit.Inseparable(
            f"on {ballbar_fit.arcs_text(samples.traces)}, the map's linear part, {', '.join(names) or 'nothing else'} "
            "and the set-up centres cannot be told apart: measure both directions of each test, on arcs of 180 deg "
            "or more", Location(samples.traces[0].path), tuple(names))


def _reml_weights(design: np.ndarray, measured: np.ndarray, normal: np.ndarray,
                  penalties: tuple[np.ndarray, np.ndarray], scales: tuple[float, float]) -> tuple[float, float]:
    """The penalty weights (relative to ``scales``) that minimise the REML criterion

        (n - M) / 2 log(RSS + b' S b) + 1/2 log|A'A + S| - 1/2 log|S|+,   S = w_1 s_1 P_main + w_2 s_2 P_interaction,

    M the dimension of what S leaves unpenalised, |S|+ the product of its eigenvalues on the
    range the penalties touch: a coarse search along equal weights, then Nelder-Mead in the
    logarithms of both."""
    count = len(measured)
    right = design.T @ measured
    total = float(measured @ measured)
    values, vectors = np.linalg.eigh(sum(p * s for p, s in zip(penalties, scales)))
    ranged = vectors[:, values > 1e-9 * values.max()]  # what the penalties touch, whatever the weights
    free = len(values) - ranged.shape[1]
    restricted = [ranged.T @ p @ ranged for p in penalties]

    def criterion(logs: np.ndarray) -> float:
        logs = np.clip(logs, *_LOG_SPAN)
        weights = [math.exp(l) * s for l, s in zip(logs, scales)]
        system = normal + sum(w * p for w, p in zip(weights, penalties))
        try:
            factor = np.linalg.cholesky(system)
            inner = np.linalg.cholesky(sum(w * p for w, p in zip(weights, restricted)))
        except np.linalg.LinAlgError:
            return math.inf
        half = np.linalg.solve(factor, right)
        left = total - float(half @ half)  # RSS + b'Sb = y'y - b'A'y at the penalised solution
        return ((count - free) / 2.0 * math.log(max(left, 1e-300)) + float(np.sum(np.log(np.diag(factor))))
                - float(np.sum(np.log(np.diag(inner)))))

    ladder = np.arange(-12.0, 12.5, 1.5)
    start = np.full(2, min(ladder, key=lambda l: criterion(np.array([l, l]))))
    simplex = np.array([start, start + [1.5, 0.0], start + [0.0, 1.5]])
    found = minimize(criterion, start, method="Nelder-Mead",
                     options={"xatol": 0.02, "fatol": 1e-3, "maxiter": 400, "initial_simplex": simplex})
    logs = np.clip(found.x, *_LOG_SPAN)
    return float(math.exp(logs[0])), float(math.exp(logs[1]))


def rigid_fit(field: Field, gauge: tuple[float, float], points: np.ndarray, normals: np.ndarray,
              deviations: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple[str, ...]]:
    """The rigid motion (translation x, z; rotation about ``gauge``, rad) that the ballbar cannot see,
    from deviations measured along ``normals`` at ``points``: least squares of what the field leaves
    of them. Returns the motion, its 1-sigma, the residuals, and the modes the normals cannot fix
    (a cylinder's normals fix x and the rotation, not z): those stay at the gauge's zero.
    """
    normals = np.asarray(normals, dtype=float)
    offset = np.asarray(points, dtype=float) - np.array(gauge)
    columns = np.column_stack([normals[:, 0], normals[:, 1], -offset[:, 1] * normals[:, 0] + offset[:, 0] * normals[:, 1]])
    ex, ez = field.errors(points[:, 0], points[:, 1])
    left = deviations - (ex * normals[:, 0] + ez * normals[:, 1])
    # scale the rotation to a translation at the points' spread, so that the rank test is fair
    reach = max(float(np.max(np.hypot(offset[:, 0], offset[:, 1]))), 1.0)
    scaled = columns * np.array([1.0, 1.0, 1.0 / reach])
    u, s, vt = np.linalg.svd(scaled, full_matrices=True)
    s = np.concatenate([s, np.zeros(3 - len(s))])
    keep = s > 1e-3 * s[0]
    names = ("translation x", "translation z", "rotation")
    unfixed = tuple(names[i] for i in range(3) if np.any(np.abs(vt[~keep][:, i]) > 0.1))
    u = u[:, :3] if u.shape[1] >= 3 else np.column_stack([u, np.zeros((len(u), 3 - u.shape[1]))])
    solution = vt[keep].T @ ((u[:, keep].T @ left) / s[keep])
    motion = solution * np.array([1.0, 1.0, 1.0 / reach])
    residuals = left - columns @ motion
    dof = max(len(left) - int(keep.sum()), 1)
    variance = float(residuals @ residuals) / dof
    cov = vt[keep].T @ np.diag(1.0 / s[keep] ** 2) @ vt[keep] * variance
    sigma = np.sqrt(np.maximum(np.diag(cov), 0.0)) * np.array([1.0, 1.0, 1.0 / reach])
    return motion, sigma, residuals, unfixed
