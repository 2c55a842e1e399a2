"""Least-squares fits: circles with free centre and radius, centres with a fixed radius,
and the registration of a fixed profile to measured points.

Each fit starts from an algebraic solution (the Hyper fit of Al-Sharadqah and Chernov,
which has no essential bias and stays stable on short arcs) and is finished with
Levenberg-Marquardt (:func:`scipy.optimize.least_squares`). Each returns its residuals
and the covariance of its parameters (``s^2 (J^T J)^-1`` with ``s^2`` the residual variance),
so every report can say how well the data fix the answer.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..diagnostics import FitError
from . import Profile, as_points


@dataclass(frozen=True)
class CircleFit:
    xc: float
    zc: float
    r: float
    residuals: np.ndarray  #: radial residuals, distance minus radius
    covariance: np.ndarray  #: of (xc, zc, r)

    @property
    def rms(self) -> float:
        return float(np.sqrt(np.mean(self.residuals**2)))


@dataclass(frozen=True)
class CentreFit:
    xc: float
    zc: float
    residuals: np.ndarray
    covariance: np.ndarray  #: of (xc, zc)


@dataclass(frozen=True)
class Registration:
    dx: float
    dz: float
    residuals: np.ndarray  #: signed normal distances after the shift
    covariance: np.ndarray  #: of (dx, dz)


def hyper_fit(points) -> tuple[float, float, float]:
    """Algebraic circle fit (Hyper, SVD form): centre and radius without iteration."""
    p = as_points(points)
    if len(p) < 3:
        raise FitError(f"a circle needs 3 points, {len(p)} given")
    if len(p) == 3:
        return circumcircle(p)
    centroid = p.mean(axis=0)
    x, z = p[:, 0] - centroid[0], p[:, 1] - centroid[1]
    zz = x * x + z * z
    design = np.column_stack([zz, x, z, np.ones(len(p))])
    _, s, vt = np.linalg.svd(design, full_matrices=False)
    v = vt.T
    if s[3] / s[0] < 1e-12:
        a = v[:, 3]
    else:
        mean = design.mean(axis=0)
        n = np.array(
            [
                [8 * mean[0], 4 * mean[1], 4 * mean[2], 2],
                [4 * mean[1], 1, 0, 0],
                [4 * mean[2], 0, 1, 0],
                [2, 0, 0, 0],
            ]
        )
        w = v @ np.diag(s) @ vt
        values, vectors = np.linalg.eig(w @ np.linalg.inv(n) @ w)
        order = np.argsort(values.real)
        a = np.linalg.solve(w, vectors[:, order[1]].real)
    if abs(a[0]) < 1e-300:
        raise FitError("the points lie on a straight line: no circle")
    xc = -a[1] / a[0] / 2 + centroid[0]
    zc = -a[2] / a[0] / 2 + centroid[1]
    r = math.sqrt(a[1] ** 2 + a[2] ** 2 - 4 * a[0] * a[3]) / abs(a[0]) / 2
    return float(xc), float(zc), float(r)


def circumcircle(points) -> tuple[float, float, float]:
    """The circle through three points."""
    (ax, az), (bx, bz), (cx, cz) = as_points(points)
    d = 2.0 * (ax * (bz - cz) + bx * (cz - az) + cx * (az - bz))
    if abs(d) < 1e-300:
        raise FitError("the points lie on a straight line: no circle")
    a2, b2, c2 = ax * ax + az * az, bx * bx + bz * bz, cx * cx + cz * cz
    xc = (a2 * (bz - cz) + b2 * (cz - az) + c2 * (az - bz)) / d
    zc = (a2 * (cx - bx) + b2 * (ax - cx) + c2 * (bx - ax)) / d
    return float(xc), float(zc), float(math.hypot(ax - xc, az - zc))


def _covariance(jacobian: np.ndarray, residuals: np.ndarray) -> np.ndarray:
    dof = max(len(residuals) - jacobian.shape[1], 1)
    variance = float(residuals @ residuals) / dof
    try:
        return np.linalg.inv(jacobian.T @ jacobian) * variance
    except np.linalg.LinAlgError:
        return np.full((jacobian.shape[1],) * 2, np.inf)


def fit_circle(points, start: tuple[float, float, float] | None = None) -> CircleFit:
    """Centre and radius by Levenberg-Marquardt from the Hyper fit."""
    from scipy.optimize import least_squares

    p = as_points(points)
    x0 = np.array(start if start is not None else hyper_fit(p))
    scale = max(float(np.ptp(p, axis=0).max()), 1e-9)

    def residuals(v):
        return np.hypot(p[:, 0] - v[0], p[:, 1] - v[1]) - v[2]

    def jacobian(v):
        d = np.maximum(np.hypot(p[:, 0] - v[0], p[:, 1] - v[1]), 1e-300)
        return np.column_stack([-(p[:, 0] - v[0]) / d, -(p[:, 1] - v[1]) / d, -np.ones(len(p))])

    if len(p) == 3:  # exactly determined: the algebraic circle is the answer
        v = x0
    else:
        result = least_squares(residuals, x0, jac=jacobian, method="lm", x_scale=scale, xtol=1e-15, ftol=1e-15)
        v = result.x
    res = residuals(v)
    return CircleFit(float(v[0]), float(v[1]), float(v[2]), res, _covariance(jacobian(v), res))


def fit_centre(points, radius: float, start: tuple[float, float] | None = None) -> CentreFit:
    """The centre of a circle of known radius through the points (a set-up offset)."""
    from scipy.optimize import least_squares

    p = as_points(points)
    if len(p) < 2:
        raise FitError(f"a centre needs 2 points, {len(p)} given")
    if start is None:
        start = hyper_fit(p)[:2] if len(p) >= 3 else tuple(p.mean(axis=0))

    def residuals(v):
        return np.hypot(p[:, 0] - v[0], p[:, 1] - v[1]) - radius

    def jacobian(v):
        d = np.maximum(np.hypot(p[:, 0] - v[0], p[:, 1] - v[1]), 1e-300)
        return np.column_stack([-(p[:, 0] - v[0]) / d, -(p[:, 1] - v[1]) / d])

    result = least_squares(residuals, np.array(start, dtype=float), jac=jacobian, method="lm", xtol=1e-15, ftol=1e-15)
    v = result.x
    res = residuals(v)
    return CentreFit(float(v[0]), float(v[1]), res, _covariance(jacobian(v), res))


def register(profile: Profile, points, outward: np.ndarray | None = None) -> Registration:
    """The shift (dx, dz) that best lays the profile, shape fixed, onto the points.

    Residuals are signed normal distances (along ``outward`` when given, one unit vector per
    point, else the profile's left normal). A profile whose normals at the points do not
    span both axes (a plain cylinder fixes X only) cannot be registered: FitError.
    """
    from scipy.optimize import least_squares

    p = as_points(points)
    if len(p) < 2:
        raise FitError(f"a registration needs at least 2 points, {len(p)} given")

    def normals_at(shift):
        near = profile.closest(p - shift)
        normal = profile.left_normals(near.index, near.param)
        if outward is not None:
            normal = normal * np.sign(np.sum(normal * outward, axis=1))[:, None]
        return near, normal

    def residuals(shift):
        near, normal = normals_at(shift)
        return np.sum((p - shift - near.foot) * normal, axis=1)

    def jacobian(shift):
        return -normals_at(shift)[1]

    spread = np.linalg.eigvalsh(jacobian(np.zeros(2)).T @ jacobian(np.zeros(2)))
    if spread[0] < 1e-6 * max(spread[1], 1e-300):
        raise FitError("the profile's normals at the points do not fix both axes: the shift is not determined")
    result = least_squares(residuals, np.zeros(2), jac=jacobian, method="lm", xtol=1e-15, ftol=1e-15)
    shift = result.x
    res = residuals(shift)
    return Registration(float(shift[0]), float(shift[1]), res, _covariance(jacobian(shift), res))
