"""What a ballbar test says about the machine: ISO 230-4 figures and a parametric diagnosis.

Conventions (docs/methods.md §2): theta about the test centre (xc, zc) from +X towards +Z; ``cw``
(G02) runs with theta increasing, ``ccw`` (G03) with theta decreasing; a deviation is bar
length minus nominal radius, positive outside the circle. Deviations are small against the
radius, so everything here is first order in deviation / radius, as the reader's centre
removal is (the neglected terms are below 0.01 um for a 60 um set-up offset at 100 mm).

ISO 230-4 figures (docs/methods.md §3.3), all in mm:

- G, circular deviation per direction: max - min of the deviation about the trace's own
  least-squares circle (its constant and first harmonic removed).
- G(b), bidirectional circular deviation: the same over both traces about one common
  least-squares centre. The reader centred each trace on its own, so the removed set-up
  centres are added back first: both runs were made on one mount.
- F, radial deviation per direction: min and max of the processed trace, i.e. of the path
  about the set-up centre the reader removed (the nominal centre itself for a
  ``centered = true`` trace) with the nominal radius. Unlike G it keeps the mean radius error.
- H, circular hysteresis: the largest |cw - ccw| at one angle, both traces about the common
  centre of G(b), each interpolated (linearly) at the other's angles where it has samples
  no more than MAX_GAP_DEG apart.

Parametric diagnosis (docs/methods.md §3.4): a linear least-squares fit to both traces as measured (set-up centres
added back) of the per-axis errors, origin at the test centre, v the commanded velocity:

    e_x = a_x (x - xc) + s (z - zc) - (b_x / 2) sign(v_x) - m v_x / |v|
    e_z = a_z (z - zc)              - (b_z / 2) sign(v_z)

a: scaling (actual minus nominal per unit length); b: backlash, the full step at the axis
reversal (lost motion: the axis lags its command by b/2); s: squareness, the X error per unit
Z (rad); m = F (tau_x - tau_z): servo mismatch, the length the X axis lags behind Z at the
feed F (mm; positive when X lags). The bar reads e . (cos, sin), so with k = +1 for cw and
-1 for ccw:

    dR = R (a_x cos^2 + a_z sin^2) + (s R + k m) sin cos
         + k (b_x / 2) sign(sin) cos - k (b_z / 2) sign(cos) sin + c_x cos + c_z sin

(c_x, c_z) is the set-up centre. No constant radius offset is fitted: cos^2 + sin^2 = 1 makes
it the same column as a_x = a_z, and the bar length is calibrated, so a mean radius error is
read as scaling of both axes. Backlash and servo mismatch flip with the direction, squareness
and scaling do not, so one trace cannot tell s from m: a one-direction diagnosis reports
their sum as ``apparent_squareness`` (s + k m / R) and leaves both unset.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .diagnostics import Location, MeasurementError
from .figures import Figures, figures
from .measurements.ballbar import BallbarTrace, pair

MAX_GAP_DEG = 10.0  #: largest gap between samples the diagnosis and H interpolate across
SCALING_BACKLASH = ("scaling_x", "scaling_z", "backlash_x", "backlash_z")  #: fitted from any trace
CENTRE = ("centre_x", "centre_z")  #: the set-up centre


@dataclass(frozen=True, slots=True)
class DirectionFigures:
    """ISO 230-4 figures of one direction's trace."""

    direction: str  #: "ccw" or "cw"
    circular_deviation: float  #: G, mm
    radial_min: float  #: F, smallest deviation, mm
    radial_max: float  #: F, largest deviation, mm
    figures: Figures  #: the four figures of the processed trace (docs/methods.md §12), um


@dataclass(frozen=True, slots=True)
class CircularTest:
    """ISO 230-4 figures of a test; the bidirectional ones need both directions."""

    by_direction: tuple[DirectionFigures, ...]  #: ccw first
    bidirectional_deviation: float | None  #: G(b), mm
    hysteresis: float | None  #: H, mm


@dataclass(frozen=True, slots=True)
class Estimate:
    """A fitted parameter and its 1-sigma uncertainty, s^2 (A^T A)^-1 of the linear fit."""

    value: float
    sigma: float


@dataclass(frozen=True, slots=True)
class Diagnosis:
    """The machine errors fitted to a test; ``predict`` gives the trace they explain."""

    radius: float  #: mm
    directions: tuple[str, ...]  #: the directions fitted, ccw first
    scaling_x: Estimate  #: a_x, per unit length
    scaling_z: Estimate  #: a_z
    backlash_x: Estimate  #: b_x, mm, full step at the reversal
    backlash_z: Estimate  #: b_z, mm
    squareness: Estimate | None  #: s, rad (X error per unit Z); both directions only
    servo_mismatch: Estimate | None  #: m, mm (X lags Z by m / feed); both directions only
    apparent_squareness: Estimate | None  #: s + k m / R, rad; one direction only
    centre_offset: tuple[Estimate, Estimate]  #: set-up centre (x, z), mm
    residual: Figures  #: of measured minus fitted, um
    feed: float | None  #: mm/min, when every trace states the same feed

    @property
    def servo_lag_ms(self) -> Estimate | None:
        """The X-behind-Z time lag m / F, when the feed is known."""
        if self.servo_mismatch is None or self.feed is None:
            return None
        per_mm = 60000.0 / self.feed
        return Estimate(self.servo_mismatch.value * per_mm, self.servo_mismatch.sigma * per_mm)


def circular_deviation(trace: BallbarTrace) -> float:
    """G: width of the deviation about the trace's own least-squares circle."""
    residual = _about_centre(trace.angles, trace.deviations)
    return float(residual.max() - residual.min())


def circular_test(traces: Sequence[BallbarTrace]) -> CircularTest:
    """G and F of each trace; G(b) and H when a ccw and a cw trace are given."""
    ordered = _ordered(traces)
    by_direction = tuple(
        DirectionFigures(t.direction, circular_deviation(t), float(t.deviations.min()), float(t.deviations.max()),
                         figures(t.deviations))
        for t in ordered)
    if len(ordered) == 1:
        return CircularTest(by_direction, None, None)
    ccw, cw = ordered
    measured = [_as_measured(ccw), _as_measured(cw)]
    residual = _about_centre(np.concatenate([ccw.angles, cw.angles]), np.concatenate(measured))
    ccw_r, cw_r = residual[: len(ccw.angles)], residual[len(ccw.angles):]
    gaps = np.concatenate([_difference(ccw.angles, ccw_r, cw.angles, cw_r),
                           _difference(cw.angles, cw_r, ccw.angles, ccw_r)])
    if gaps.size == 0:
        raise MeasurementError("the ccw and cw traces share no angles; circular hysteresis needs them to overlap",
                               Location(cw.path))
    return CircularTest(by_direction, float(residual.max() - residual.min()), float(np.abs(gaps).max()))


def diagnose(traces: Sequence[BallbarTrace]) -> Diagnosis:
    """Fit the error model to one trace or to a ccw and a cw trace, each round the whole circle."""
    ordered = _ordered(traces)
    for trace in ordered:
        if trace.max_gap() > MAX_GAP_DEG:
            raise MeasurementError(f"the parametric diagnosis needs a trace round the whole circle; this one has a "
                                   f"gap of {trace.max_gap():.1f} deg (at most {MAX_GAP_DEG:g})", Location(trace.path))
    both = len(ordered) == 2
    names = [*SCALING_BACKLASH, *(("squareness", "servo_mismatch") if both else ("apparent_squareness",)), *CENTRE]
    design = np.concatenate([_design(t.angles, t.radius, t.direction, names) for t in ordered])
    measured = np.concatenate([_as_measured(t) for t in ordered])
    solution, *_ = np.linalg.lstsq(design, measured, rcond=None)
    residual = measured - design @ solution
    variance = float(residual @ residual) / (len(measured) - len(names))
    sigma = np.sqrt(np.diag(np.linalg.inv(design.T @ design)) * variance)
    fit = {name: Estimate(float(v), float(s)) for name, v, s in zip(names, solution, sigma)}
    feeds = {t.feed for t in ordered}
    return Diagnosis(
        radius=ordered[0].radius, directions=tuple(t.direction for t in ordered),
        scaling_x=fit["scaling_x"], scaling_z=fit["scaling_z"], backlash_x=fit["backlash_x"],
        backlash_z=fit["backlash_z"], squareness=fit.get("squareness"), servo_mismatch=fit.get("servo_mismatch"),
        apparent_squareness=fit.get("apparent_squareness"), centre_offset=(fit["centre_x"], fit["centre_z"]),
        residual=figures(residual), feed=feeds.pop() if len(feeds) == 1 else None)


def predict(diagnosis: Diagnosis, theta_deg, direction: str) -> np.ndarray:
    """The deviation the fitted machine gives at theta (degrees) in a direction, without the set-up centre.

    A one-direction diagnosis cannot predict the other direction (its squareness and servo
    mismatch are not separated): that is a ValueError.
    """
    if diagnosis.squareness is not None:
        shear = {"squareness": diagnosis.squareness.value, "servo_mismatch": diagnosis.servo_mismatch.value}
    elif direction in diagnosis.directions:
        shear = {"apparent_squareness": diagnosis.apparent_squareness.value}
    else:
        raise ValueError(f"a diagnosis of the {diagnosis.directions[0]} trace alone cannot predict {direction}")
    values = {name: getattr(diagnosis, name).value for name in SCALING_BACKLASH} | shear
    theta = np.asarray(theta_deg, dtype=float)
    return _design(theta.ravel(), diagnosis.radius, direction, list(values)).dot(list(values.values())).reshape(theta.shape)



def _design(angles_deg: np.ndarray, radius: float, direction: str, names: Sequence[str]) -> np.ndarray:
    """The radial deviation per unit of each named parameter: the model's columns."""
    theta = np.radians(angles_deg)
    cos, sin = np.cos(theta), np.sin(theta)
    k = 1.0 if direction == "cw" else -1.0
    columns = {
        "scaling_x": radius * cos**2,
        "scaling_z": radius * sin**2,
        "backlash_x": k * 0.5 * np.sign(sin) * cos,
        "backlash_z": -k * 0.5 * np.sign(cos) * sin,
        "squareness": radius * sin * cos,
        "servo_mismatch": k * sin * cos,
        "apparent_squareness": radius * sin * cos,
        "centre_x": cos,
        "centre_z": sin,
    }
    return np.column_stack([columns[name] for name in names])


def _ordered(traces: Sequence[BallbarTrace]) -> tuple[BallbarTrace, ...]:
    """One trace, or the ccw and cw traces of one test in that order."""
    return (traces[0],) if len(traces) == 1 else pair(list(traces))


def _as_measured(trace: BallbarTrace) -> np.ndarray:
    """The trace with the reader's removed set-up centre put back."""
    theta = np.radians(trace.angles)
    return trace.deviations + trace.setup_centre[0] * np.cos(theta) + trace.setup_centre[1] * np.sin(theta)


def _about_centre(angles_deg: np.ndarray, deviations: np.ndarray) -> np.ndarray:
    """Deviations about their least-squares circle: constant and first harmonic removed."""
    theta = np.radians(angles_deg)
    design = np.column_stack([np.ones_like(theta), np.cos(theta), np.sin(theta)])
    solution, *_ = np.linalg.lstsq(design, deviations, rcond=None)
    return deviations - design @ solution


def _difference(angles: np.ndarray, values: np.ndarray, other_angles: np.ndarray, other: np.ndarray) -> np.ndarray:
    """values - other at ``angles``, the other trace interpolated periodically, where it is sampled closely enough."""
    order = np.argsort(other_angles)
    ring = np.concatenate([other_angles[order][-1:] - 360.0, other_angles[order], other_angles[order][:1] + 360.0])
    ring_values = np.concatenate([other[order][-1:], other[order], other[order][:1]])
    where = np.mod(angles, 360.0)
    after = np.searchsorted(ring, where, side="right").clip(1, len(ring) - 1)
    close = ring[after] - ring[after - 1] <= MAX_GAP_DEG
    return values[close] - np.interp(where[close], ring, ring_values)[close]
