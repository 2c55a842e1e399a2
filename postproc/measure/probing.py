"""From a probe file to deviations from the nominal profile (docs/methods.md §9): what the probe
compensators (``omp-feedback``, ``tool-offset``) build on.

1. the touched points ``P = C + (R_stylus + k(n)) n``, with ``k`` from a calibration model
   (:mod:`postproc.measure.pretravel`), or 0 with a warning;
2. the datum stability check: the datum probed before and after the profile must agree within
   ``repeatability_mm`` on every axis, or the inspection is refused (SafetyError) unless forced;
3. the deviation of each touched point from the nominal profile (any chain of lines and arcs)
   along the profile's normal pointing out of the material, positive = material left;
4. screening for the nub and outliers (:mod:`postproc.measure.screening`), each touch only against
   the touches on its own feature of the profile (:mod:`postproc.measure.features`): never across a
   corner, where the error a cut leaves steps.

:func:`probe_profile` does all four; the steps are public for compensators that need one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..diagnostics import Location, MeasurementError, Reporter, SafetyError
from .features import Feature, features, owners
from ..geometry import Nearest, Profile, as_points
from ..machine.bounds import MAX_CORRECTION
from .readers.probe import MISREADINGS, ProbeFile, Touches, far_datum_cause, likely_cause
from .pretravel import CalibrationModel
from .screening import Screening, screen

MAX_APPROACH_ANGLE = 80.0  #: degrees between an approach and the surface normal it may touch
FORCE_FLAG = "--force"  #: the command-line override of a failed datum check
_TIE = 1e-9  #: mm; segments this close to equally near are told apart by the approach
#: touches read otherwise (check_on_profile) fit a profile only if their deviations then spread
#: over at most this share of the touches' extent (a part's form: 0.1 mm over 10 mm), or FORM_FLOOR_MM
FORM_SHARE = 0.01
FORM_FLOOR_MM = 0.01


def touched_points(touches: Touches, calibration: CalibrationModel | None = None,
                   reporter: Reporter | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The touched points (n, 2) and the pretravel k (mm) used at each.

    With a calibration, a touch more than 5 deg outside its directions is a MeasurementError
    at that row; without one, k = 0 and ``reporter`` is warned.
    """
    if calibration is None:
        if reporter is not None:
            reporter.warn("no probe calibration given: the pretravel is taken as k = 0 (give --calibration)",
                          Location(touches.path))
        k = np.zeros(len(touches.centres))
    else:
        k = calibration.k_for(touches)
    return touches.touched(k), k


def check_datum(probe: ProbeFile, force: bool = False, reporter: Reporter | None = None) -> list[str]:
    """The stability check (docs/methods.md §9.3, Figure 6.14): notes for the report.

    :raises SafetyError: when the datum moved by more than ``repeatability_mm`` on an axis,
        unless ``force`` (then ``reporter`` is warned).
    """
    if not probe.datum_before:
        return [f"{probe.path}: no datum probed before and after the profile: stability not checked"]
    notes = []
    for axis in sorted(probe.datum_before):
        before, after = probe.datum_before[axis], probe.datum_after[axis]
        drift = after - before
        text = (f"datum_before_{axis}_mm = {before:g} and datum_after_{axis}_mm = {after:g} differ by "
                f"{abs(drift):.4f} mm, more than repeatability_mm = {probe.repeatability:g}")
        if abs(drift) > probe.repeatability + 1e-12:
            unit = far_datum_cause(before, after, probe.repeatability, probe.centres[:, "xz".index(axis)])
            if unit:
                text += f"; or, {unit}"
            if not force:
                raise SafetyError(f"the machine moved during the inspection: {text}; the points are not valid "
                                  f"(re-probe after a cool-down, or {FORCE_FLAG} to use them anyway)",
                                  Location(probe.path))
            if reporter is not None:
                reporter.warn(f"{text}; used anyway ({FORCE_FLAG})", Location(probe.path))
            notes.append(f"{probe.path}: {text} (used anyway, {FORCE_FLAG})")
        else:
            notes.append(f"{probe.path}: datum {axis} stable: {before:g} before, {after:g} after "
                         f"({drift:+.4f} mm, repeatability {probe.repeatability:g})")
    return notes


@dataclass(frozen=True)
class Deviations:
    """Touched points against the nominal profile."""

    nearest: Nearest  #: segment, parameter, foot, distance and arc length ``s`` of each point
    outward: np.ndarray  #: (n, 2) unit normal of the profile at the foot, out of the material
    deviation: np.ndarray  #: mm along ``outward``; positive = material left where the nominal says air


def check_on_profile(deviations: Deviations, touches: Touches, touched: np.ndarray, profile: Profile,
                     allowance: float, unexplained: bool = True) -> None:
    """Refuse touches that lie further from the nominal profile than any correction reaches
    (:data:`~postproc.machine.bounds.MAX_CORRECTION`) plus ``allowance`` (the stock an earlier pass
    left): the file does not describe this profile. One error at the furthest touch's row, with
    the likely cause (:func:`~postproc.measure.readers.probe.likely_cause`: micrometres written as
    millimetres, x written as a diameter, inches, the stylus's diameter or inches, another part or
    set-up), for compensating from such points would move the tool by millimetres.

    :param unexplained: refuse such touches when no misreading explains them too (an inspection
        reports a part that far off as it is; a compensation cannot use it)."""
    limit = MAX_CORRECTION + allowance
    off = np.abs(deviations.deviation)
    worst = int(np.argmax(off))
    if not off[worst] > limit:
        return
    pretravel = touched - touches.centres - touches.stylus_radius * touches.approach

    def fits(centres: np.ndarray, stylus: float) -> bool:
        try:
            again = profile_deviations(centres + stylus * touches.approach + pretravel, touches.approach, profile)
        except MeasurementError:
            return False
        # a reading that shrinks the touches (um, inches) must not merely collapse them onto a bit
        # of profile near the origin: read so, they keep a part's form, not a heap's
        extent = float(np.hypot(*np.ptp(centres, axis=0)))
        return bool(np.all(np.abs(again.deviation) <= limit)
                    and np.ptp(again.deviation) <= max(FORM_SHARE * extent, FORM_FLOOR_MM))

    cause = likely_cause(touches, fits, "a file of another part, another program or another work offset?")
    if unexplained or cause in {why for _, why in MISREADINGS}:
        raise MeasurementError(f"this touch lies {deviations.deviation[worst]:+.4f} mm from the program's nominal "
                               f"profile, beyond the {limit:g} mm any correction reaches: {cause}",
                               touches.where(worst))


def profile_deviations(points, approach, profile: Profile, touches: Touches | None = None) -> Deviations:
    """Signed distance of each touched point from the nearest segment of ``profile``.

    The material side is the one the approach points into, so the outward normal is the
    profile normal against the approach. Only segments whose normal lies within 80 deg of the
    approach can have been touched (a plunge along the axis at the pole cannot); of those the
    nearest is used, ties at a corner going to the better aligned. The deviation is the distance
    to the foot, signed by the side: along the normal inside a segment, from the corner beyond
    an end.

    :param touches: the probe file, to name the row of a touch no segment can explain.
    """
    p = as_points(points)
    a = as_points(approach)
    n = len(p)
    limit = math.cos(math.radians(MAX_APPROACH_ANGLE))
    best = np.full(n, np.inf)
    alignment = np.zeros(n)
    index = np.zeros(n, dtype=int)
    param = np.zeros(n)
    foot = np.zeros_like(p)
    outward = np.zeros_like(p)
    for i, segment in enumerate(profile.segments):
        t, f = segment.closest(p)
        tangent = segment.tangent_at(t)
        left = np.stack([-tangent[:, 1], tangent[:, 0]], axis=-1)
        cosine = np.einsum("ij,ij->i", left, a)
        normal = np.where((cosine > 0)[:, None], -left, left)
        d = np.linalg.norm(p - f, axis=1)
        usable = np.abs(cosine) >= limit
        better = usable & ((d < best - _TIE) | ((d <= best + _TIE) & (np.abs(cosine) > alignment)))
        best = np.where(better, d, best)
        alignment = np.where(better, np.abs(cosine), alignment)
        index = np.where(better, i, index)
        param = np.where(better, t, param)
        foot = np.where(better[:, None], f, foot)
        outward = np.where(better[:, None], normal, outward)
    lost = np.nonzero(~np.isfinite(best))[0]
    if len(lost):
        where = touches.where(int(lost[0])) if touches is not None else None
        raise MeasurementError(f"no segment of the nominal profile faces this touch's approach within "
                               f"{MAX_APPROACH_ANGLE:g} deg: it cannot be compared with the profile", where)
    side = np.einsum("ij,ij->i", p - foot, outward)
    deviation = np.where(side < 0, -best, best)
    lengths = np.array([segment.length for segment in profile.segments])
    s = profile.offsets[index] + param * lengths[index]
    return Deviations(Nearest(index, param, foot, best, s), outward, deviation)


class Screened:
    """Touches compared with a nominal and screened: what is measured, what drives a correction.

    A base for frozen dataclasses that have the fields ``deviations`` and ``screening``."""

    deviations: Deviations
    screening: Screening

    @property
    def deviation(self) -> np.ndarray:
        """As measured, mm."""
        return self.deviations.deviation

    @property
    def cleaned(self) -> np.ndarray:
        """With the nub and outliers replaced: what should drive a compensation, mm."""
        return self.screening.deviation


@dataclass(frozen=True)
class ProbedProfile(Screened):
    """A probe file read against a nominal profile: what a probe compensator works from."""

    path: str
    rows: tuple[int, ...]  #: the data row of each touch
    touched: np.ndarray  #: (n, 2) touched points, mm
    k: np.ndarray  #: pretravel used at each touch, mm
    deviations: Deviations
    screening: Screening
    notes: tuple[str, ...]  #: for reports: calibration, datum check, screening
    features: tuple[Feature, ...] = ()  #: the profile's
    feature: np.ndarray | None = None  #: index into ``features`` of each touch's feature

    @property
    def kept(self) -> np.ndarray:
        return self.screening.kept


def screen_by_feature(deviations: Deviations, found: tuple[Feature, ...], probe: ProbeFile, points: np.ndarray,
                      index=None, *, floor: float | None = None, fill: str = "extrapolate",
                      reporter: Reporter | None = None) -> tuple[np.ndarray, Screening]:
    """Screen touches against the touches on their own feature: (feature of each touch, screening).

    :param points: the touched points; ``index``: their rows' places in ``probe`` (default all).
    :param floor: mm, the smallest residual called an outlier; default the file's
        ``repeatability_mm``, else 0.002.
    """
    index = np.arange(len(points)) if index is None else np.asarray(index)
    feature = owners(found)[deviations.nearest.index]
    if floor is None:
        floor = probe.repeatability if probe.repeatability is not None else 0.002
    screening = screen(deviations.deviation, deviations.nearest.s, [probe.lines[i] for i in index], groups=feature,
                       names=[f.describe() for f in found], axis_distance=np.abs(points[:, 0]),
                       nub_zone=probe.stylus_radius, floor=floor, fill=fill, path=probe.path, reporter=reporter)
    return feature, screening


def probe_profile(probe: ProbeFile, profile: Profile, calibration: CalibrationModel | None = None, *,
                  reporter: Reporter | None = None, force: bool = False, floor: float | None = None,
                  fill: str = "extrapolate", lines: tuple[int, ...] | None = None) -> ProbedProfile:
    """Check, correct and compare a probe file with the nominal profile, and screen it per feature.

    :param lines: the source line of each segment of ``profile``, to name features in messages.
    :param force: use the points even though the datum moved (the check's override).
    :param floor: mm, the smallest residual called an outlier; default the file's
        ``repeatability_mm``, else 0.002.
    :param fill: how dropped points are replaced, ``extrapolate`` or ``nearest`` (screening).
    :raises SafetyError: the datum moved (and not ``force``).
    :raises MeasurementError: a direction outside the calibration, a touch no segment faces,
        touches far off the profile that a misreading explains (a unit, x as a diameter, the
        stylus), or data too scattered to screen.
    """
    points, k = touched_points(probe, calibration)
    deviations = profile_deviations(points, probe.approach, profile, probe)
    # a file in the wrong unit is named before its datum, which it would make seem to move
    check_on_profile(deviations, probe, points, profile, 0.0, unexplained=False)
    notes = check_datum(probe, force, reporter)
    if calibration is not None:
        notes += calibration.report()
    touched_points(probe, calibration, reporter)
    found = features(profile, lines)
    feature, screening = screen_by_feature(deviations, found, probe, points, floor=floor, fill=fill, reporter=reporter)
    notes += screening.notes
    return ProbedProfile(probe.path, probe.lines, points, k, deviations, screening, tuple(notes), found, feature)
