"""Probe pretravel as a smooth function of the approach direction (docs/methods.md §9.2; the dissertation's chapter 4).

A calibration run on the sphere artifact gives at each touch ``k = R_measured - R_artifact``.
The source fitted a 1st-order polynomial over one half of the sphere and a 2nd-order one over
the other; we do not assume a shape. Every candidate below is a linear least-squares model,
scored by leave-one-out cross-validation (the exact shortcut ``e_i / (1 - h_ii)`` with ``h``
the hat matrix), and the one with the smallest prediction error is used; ties go to the one
with fewer parameters.

Candidates (``theta`` in degrees, the angle of the outward surface normal, unwrapped about the
middle of the calibrated directions so a range across 0 deg is one piece):

- ``poly-N``, N = 0..5: one polynomial in theta over the whole range;
- ``harmonic-N``, N = 1..4: a Fourier series in theta up to the N-th harmonic (the three-point
  sensor's lobing repeats with direction);
- ``split-A/B-continuous`` and ``split-A/B-jump``, A, B = 0..3: order A for theta below the pole
  (90 deg, the +X half, where an outside profile lies) and order B above it (the -X half), joined
  at the pole or each with its own constant. The source's model is ``split-2/1-jump``.

A candidate the data cannot score (more parameters than the touches support, or a touch only
it can explain, such as a half with too few touches) is left out of the ranking.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Sequence

import numpy as np

from ..diagnostics import Location, MeasurementError
from .readers.probe import MAX_PRETRAVEL_MM, CalibrationRun, Touches, likely_cause, outside_directions

POLE = 90.0  #: theta of a touch straight down, where the split candidates join
DIRECTION_LIMIT = 5.0  #: degrees a probe direction may lie outside the calibrated ones
STYLUS_TOLERANCE = 1e-6  #: mm; a probe file with another stylus cannot use the calibration


@dataclass(frozen=True, slots=True)
class Frame:
    """Where the calibrated directions lie: theta is unwrapped about ``centre``."""

    centre: float  #: degrees
    half: float  #: half the calibrated span, degrees (at least 1)
    pole: float  #: the pole's theta in the unwrapped frame

    def unwrap(self, theta) -> np.ndarray:
        theta = np.asarray(theta, dtype=float)
        return self.centre + (theta - self.centre + 180.0) % 360.0 - 180.0

    @classmethod
    def around(cls, theta: np.ndarray) -> "Frame":
        """The frame of directions ``theta`` (degrees): cut the circle at their widest gap."""
        ordered = np.sort(np.asarray(theta, dtype=float) % 360.0)
        gaps = np.diff(np.concatenate([ordered, [ordered[0] + 360.0]]))
        first = ordered[(int(np.argmax(gaps)) + 1) % len(ordered)]
        unwrapped = first + (ordered - first) % 360.0
        low, high = float(unwrapped.min()), float(unwrapped.max())
        centre = (low + high) / 2.0
        centre -= 360.0 * round(centre / 360.0)  # in -180..180, so a range across 0 reads -60..60
        pole = centre + (POLE - centre + 180.0) % 360.0 - 180.0
        return cls(centre, max((high - low) / 2.0, 1.0), pole)


@dataclass(frozen=True, slots=True)
class Shape:
    """One candidate: its name and its design matrix."""

    kind: str  #: poly, harmonic or split
    below: int  #: the order (for split: below the pole)
    above: int = 0  #: split only: the order above the pole
    continuous: bool = True  #: split only: joined at the pole

    @property
    def name(self) -> str:
        if self.kind == "split":
            return f"split-{self.below}/{self.above}-{'continuous' if self.continuous else 'jump'}"
        return f"{self.kind}-{self.below}"

    @classmethod
    def parse(cls, name: str) -> "Shape":
        kind, _, rest = name.partition("-")
        if kind == "split":
            orders, _, join = rest.partition("-")
            below, above = orders.split("/")
            return cls(kind, int(below), int(above), join == "continuous")
        return cls(kind, int(rest))

    def design(self, u: np.ndarray, frame: Frame) -> np.ndarray:
        """Columns of the model at unwrapped directions ``u`` (degrees)."""
        if self.kind == "poly":
            t = (u - frame.centre) / frame.half
            return np.column_stack([t**j for j in range(self.below + 1)])
        if self.kind == "harmonic":
            a = np.radians(u)
            columns = [np.ones_like(u)]
            for j in range(1, self.below + 1):
                columns += [np.cos(j * a), np.sin(j * a)]
            return np.column_stack(columns)
        t = (u - frame.pole) / frame.half
        low, high = (t < 0).astype(float), (t >= 0).astype(float)
        if self.continuous:
            columns = [np.ones_like(u)]
            columns += [low * t**j for j in range(1, self.below + 1)]
            columns += [high * t**j for j in range(1, self.above + 1)]
        else:
            columns = [low * t**j for j in range(self.below + 1)] + [high * t**j for j in range(self.above + 1)]
        return np.column_stack(columns)


SHAPES = (
    [Shape("poly", n) for n in range(6)]
    + [Shape("harmonic", n) for n in range(1, 5)]
    + [Shape("split", a, b, join) for join in (True, False) for a in range(4) for b in range(4)
       if not (join and a == b == 0)]
)


@dataclass(frozen=True, slots=True)
class Candidate:
    """A candidate's cross-validation score."""

    name: str
    parameters: int
    cv_rms: float  #: mm, RMS of the leave-one-out prediction errors
    fit_rms: float  #: mm, RMS of the residuals of the fit to all touches


def _score(design: np.ndarray, k: np.ndarray) -> tuple[np.ndarray, float, float] | None:
    """(coefficients, LOO RMS, fit RMS), or None when the data cannot score this model."""
    n, p = design.shape
    if n - p < 2 or np.linalg.matrix_rank(design) < p:
        return None
    q, _ = np.linalg.qr(design)
    leverage = np.sum(q**2, axis=1)
    if leverage.max() > 1.0 - 1e-6:
        return None
    coefficients = np.linalg.lstsq(design, k, rcond=None)[0]
    residuals = k - design @ coefficients
    loo = residuals / (1.0 - leverage)
    return coefficients, float(np.sqrt(np.mean(loo**2))), float(np.sqrt(np.mean(residuals**2)))


@dataclass(frozen=True)
class CalibrationModel:
    """The pretravel ``k(theta)`` chosen by cross-validation, and how the candidates scored."""

    source: str  #: the calibration file(s), for messages
    stylus_radius: float  #: mm, of the calibrated stylus
    shape: Shape
    coefficients: np.ndarray
    frame: Frame
    calibrated: np.ndarray  #: unwrapped theta of the calibration touches, degrees
    candidates: tuple[Candidate, ...]  #: every scored candidate, best first

    @property
    def name(self) -> str:
        return self.shape.name

    @property
    def chosen(self) -> Candidate:
        """The score of the model in use (the best one unless another was asked for)."""
        return next(c for c in self.candidates if c.name == self.name)

    @property
    def span(self) -> tuple[float, float]:
        """The calibrated directions, degrees (unwrapped: ``low`` may be negative)."""
        return float(self.calibrated.min()), float(self.calibrated.max())

    def k_of(self, theta):
        """Pretravel k (mm) at outward-normal directions ``theta`` (degrees); no range check."""
        u = self.frame.unwrap(theta)
        k = self.shape.design(np.atleast_1d(u), self.frame) @ self.coefficients
        return float(k[0]) if np.ndim(theta) == 0 else k

    def check(self, touches: Touches, limit: float = DIRECTION_LIMIT) -> None:
        """Refuse a probe file this calibration does not cover (direction or stylus)."""
        if abs(touches.stylus_radius - self.stylus_radius) > STYLUS_TOLERANCE:
            raise MeasurementError(
                f"stylus_radius_mm is {touches.stylus_radius:g} here but {self.stylus_radius:g} in the "
                f"calibration {self.source}: a calibration holds for the stylus it was made with",
                Location(touches.path),
            )
        theta = touches.theta
        outside = outside_directions(theta, self.calibrated, limit)
        if len(outside):
            i = int(outside[0])
            low, high = self.span
            off = max(low - self.frame.unwrap(theta[i]), self.frame.unwrap(theta[i]) - high)
            more = f" (and {len(outside) - 1} more rows)" if len(outside) > 1 else ""
            raise MeasurementError(
                f"this touch approaches at theta {theta[i]:.1f} deg, {off:.1f} deg outside the directions "
                f"calibrated in {self.source} ({low:.1f}..{high:.1f} deg; at most {limit:g} deg beyond is "
                f"allowed){more}",
                touches.where(i),
            )

    def k_for(self, touches: Touches) -> np.ndarray:
        """k at each touch of a probe file, after :meth:`check`."""
        self.check(touches)
        return np.atleast_1d(self.k_of(touches.theta))

    def report(self) -> list[str]:
        """Lines for reports: the data, the choice and every candidate's CV score."""
        low, high = self.span
        chosen = self.chosen
        scores = ", ".join(f"{c.name} {c.cv_rms * 1000:.3f}" for c in self.candidates)
        return [
            f"calibration {self.source}: {len(self.calibrated)} touches, theta {low:.1f}..{high:.1f} deg",
            f"pretravel model {chosen.name} ({chosen.parameters} parameters): leave-one-out RMS "
            f"{chosen.cv_rms * 1000:.3f} um, fit RMS {chosen.fit_rms * 1000:.3f} um",
            f"leave-one-out RMS (um) of the candidates, best first: {scores}",
        ]

    def as_dict(self) -> dict:
        """JSON-able form, for a compensator's saved model."""
        return {"source": self.source, "stylus_radius_mm": self.stylus_radius, "model": self.name,
                "coefficients": [float(c) for c in self.coefficients],
                "frame": {"centre_deg": self.frame.centre, "half_deg": self.frame.half, "pole_deg": self.frame.pole},
                "calibrated_theta_deg": [float(u) for u in self.calibrated],
                "candidates": [{"model": c.name, "parameters": c.parameters, "cv_rms_mm": c.cv_rms,
                                "fit_rms_mm": c.fit_rms} for c in self.candidates]}

    @classmethod
    def from_dict(cls, data: dict) -> "CalibrationModel":
        frame = Frame(data["frame"]["centre_deg"], data["frame"]["half_deg"], data["frame"]["pole_deg"])
        candidates = tuple(Candidate(c["model"], c["parameters"], c["cv_rms_mm"], c["fit_rms_mm"])
                           for c in data["candidates"])
        return cls(data["source"], data["stylus_radius_mm"], Shape.parse(data["model"]),
                   np.array(data["coefficients"], dtype=float), frame,
                   np.array(data["calibrated_theta_deg"], dtype=float), candidates)


#: Touches that read the artifact larger (beyond the noise), or smaller by more than
#: MAX_PRETRAVEL_MM (:mod:`postproc.measure.readers.probe`), come from a wrong radius in the file.
LARGER_MM = 0.005  #: how much larger the artifact may read, at the median touch: noise


def _physical(k: np.ndarray, source: str, runs: Sequence[CalibrationRun] = ()) -> None:
    """Refuse touches no probe gives: the artifact read larger than it is (a trigger before
    contact), or smaller by more than any pretravel; naming the misreading of a run's file
    (:data:`~postproc.measure.readers.probe.MISREADINGS`: a stylus radius given as the diameter
    or in inches...) under which its touches read as a probe's, where one does."""
    if not _unphysical(k):
        return
    median, least = float(np.median(k)), float(k.min())
    found = (f"the touches read the artifact {median * 1000:+.1f} um larger than it is at the median touch (a "
             "probe triggers after contact: it reads it smaller)" if median > LARGER_MM else
             f"a touch reads the artifact {-least * 1000:.1f} um smaller than it is, more than the "
             f"{MAX_PRETRAVEL_MM * 1000:g} um of pretravel a touch-trigger probe has")
    for run in runs:
        def fits(centres: np.ndarray, stylus: float) -> bool:
            return not _unphysical(replace(run, centres=centres, stylus_radius=stylus).factors())

        cause = likely_cause(run, fits, "")
        if cause:
            raise MeasurementError(f"{found}: {cause}", Location(run.path))
    raise MeasurementError(f"{found}: artifact_radius_mm or stylus_radius_mm in the file is most likely not the "
                           "one measured (the artifact's certificate, the stylus as fitted): correct it, or "
                           "calibrate again", Location(source))


def _unphysical(k: np.ndarray) -> bool:
    return bool(np.median(k) > LARGER_MM or k.min() < -MAX_PRETRAVEL_MM)


def fit_calibration(runs: CalibrationRun | Sequence[CalibrationRun], model: str | None = None) -> CalibrationModel:
    """Choose and fit the pretravel model of one or several calibration runs (same stylus).

    :param model: a candidate's name (``split-2/1-jump`` is the source's) to use instead of the
        best one; every candidate is scored and reported all the same.
    """
    runs = [runs] if isinstance(runs, CalibrationRun) else list(runs)
    source = ", ".join(run.path for run in runs)
    for run in runs[1:]:
        if abs(run.stylus_radius - runs[0].stylus_radius) > STYLUS_TOLERANCE:
            raise MeasurementError(f"stylus_radius_mm is {run.stylus_radius:g} here but "
                                   f"{runs[0].stylus_radius:g} in {runs[0].path}", Location(run.path))
    theta = np.concatenate([run.theta for run in runs])
    k = np.concatenate([run.factors() for run in runs])
    if len(k) < 3:
        raise MeasurementError(f"{len(k)} touches: a calibration needs at least 3", Location(source))
    _physical(k, source, runs)
    frame = Frame.around(theta)
    u = frame.unwrap(theta)
    scored = []
    for shape in SHAPES:
        result = _score(shape.design(u, frame), k)
        if result is not None:
            coefficients, cv, fit = result
            scored.append((cv, len(coefficients), shape, coefficients, fit))
    scored.sort(key=lambda item: (item[0], item[1]))
    names = [item[2].name for item in scored]
    if model is not None and model not in names:
        known = "" if model in {shape.name for shape in SHAPES} else " (not a candidate)"
        raise MeasurementError(f"the pretravel model {model!r}{known} cannot be fitted to these touches; "
                               f"candidates that can: {', '.join(names)}", Location(source))
    _, _, shape, coefficients, _ = scored[names.index(model) if model is not None else 0]
    candidates = tuple(Candidate(s.name, p, c, f) for c, p, s, _, f in scored)
    return CalibrationModel(source, runs[0].stylus_radius, shape, coefficients, frame, u, candidates)
