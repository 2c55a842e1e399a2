"""What ballbar tests say about the machine: ISO 230-4 / ISO 13041-6 figures and a parametric diagnosis.

Conventions (docs/methods.md §2): theta about the test centre (xc, zc) from +X towards +Z; ``cw``
(G02) runs with theta increasing, ``ccw`` (G03) with theta decreasing; a deviation is bar
length minus nominal radius, positive outside the circle. Deviations are small against the
radius, so everything here is first order in deviation / radius, as the reader's centre
removal is (the neglected terms are below 0.01 um for a 60 um set-up offset at 100 mm).

A *test* is the traces of one circle (one radius and centre, one mount): one trace, or a ccw
and a cw run. Traces may cover the whole circle or a partial arc (a lathe's XZ test, ISO
13041-6, runs about 220 deg); every figure is taken over the arc as measured.

ISO 230-4 figures of a test, all in mm:

- G, circular deviation per direction: max - min of the deviation about the trace's own
  least-squares circle (its constant and first harmonic removed), over the captured arc.
- G(b), bidirectional circular deviation: the same over both traces about one common
  least-squares centre. The reader centred each trace on its own, so the removed set-up
  centres are added back first: both runs were made on one mount.
- F, radial deviation per direction: min and max of the processed trace, i.e. of the path
  about the set-up centre with the nominal radius (the nominal centre itself for a
  ``centered = true`` trace). Unlike G it keeps the mean radius error.
- H, circular hysteresis: the largest |cw - ccw| at one angle, both traces about the common
  centre of G(b), each interpolated (linearly) at the other's angles where it has samples
  no more than MAX_GAP_DEG apart (so only where both runs captured the arc).

Parametric diagnosis: one linear least-squares fit to every trace as measured (set-up centres
added back) of the per-axis errors and each test's set-up centre (:mod:`postproc.measure.ballbar_fit`),
offsets (u, w) about each test's centre, v the commanded velocity:

    e_x = a_x u + s w - (b_x / 2) sign(v_x) - m v_x / |v|
    e_z = a_z w       - (b_z / 2) sign(v_z)

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
and scaling do not, so one direction cannot tell s from m: a one-direction diagnosis of one
radius reports their sum as ``apparent_squareness`` (s + k m / R) and leaves both unset.

On a partial arc the uncertainties grow (they come from the residuals, robust to their
correlation along the trace); a parameter the arcs cannot separate, or whose 3-sigma effect
exceeds 1 um, refuses the diagnosis naming the arc and the parameter. :func:`plausibility`
names the likely cause of results no machine gives (swapped direction labels, a wrong radius,
units).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from . import ballbar_fit
from .ballbar_fit import MAX_GAP_DEG, Estimate, arcs_text
from .parameters import BOUNDS, MAX_BACKLASH, MAX_NEGATIVE_BACKLASH, MAX_SCALING, beyond_bounds, check_saved
from ..diagnostics import Location, MeasurementError

if TYPE_CHECKING:  # imported where used: a saved model's check (check_saved) needs neither
    from .figures import Figures
    from .readers.ballbar import BallbarTrace

__all__ = ["MAX_GAP_DEG", "BOUNDS", "Estimate", "CircularTest", "Diagnosis", "DirectionFigures", "beyond_bounds",
           "check_saved", "circular_deviation", "circular_test", "diagnose", "jointly_centred", "one_test", "paired",
           "plausibility", "predict", "screen", "tests"]

SCALING_BACKLASH = ("scaling_x", "scaling_z", "backlash_x", "backlash_z")  #: fitted from any trace
CENTRE = ("centre_x", "centre_z")  #: the set-up centre
NEGATIVE_FLOOR = 0.0005  #: mm; a backlash more negative than this (and than 3 sigma) is not noise


@dataclass(frozen=True, slots=True)
class DirectionFigures:
    """ISO 230-4 figures of one direction's trace."""

    direction: str  #: "ccw" or "cw"
    circular_deviation: float  #: G, mm
    radial_min: float  #: F, smallest deviation, mm
    radial_max: float  #: F, largest deviation, mm
    figures: Figures  #: the four figures of the processed trace (docs/methods.md §12), um
    arc: tuple[float, float] = (0.0, 360.0)  #: the captured arc (start, span), degrees
    path: str = ""


@dataclass(frozen=True, slots=True)
class CircularTest:
    """ISO 230-4 figures of a test; the bidirectional ones need both directions."""

    by_direction: tuple[DirectionFigures, ...]  #: ccw first
    bidirectional_deviation: float | None  #: G(b), mm
    hysteresis: float | None  #: H, mm


@dataclass(frozen=True, slots=True)
class Diagnosis:
    """The machine errors fitted to one or several tests; ``predict`` gives the trace they explain."""

    radius: float  #: mm, of the first test
    directions: tuple[str, ...]  #: the directions fitted, ccw first
    scaling_x: Estimate  #: a_x, per unit length
    scaling_z: Estimate  #: a_z
    backlash_x: Estimate  #: b_x, mm, full step at the reversal
    backlash_z: Estimate  #: b_z, mm
    squareness: Estimate | None  #: s, rad (X error per unit Z); both directions only
    servo_mismatch: Estimate | None  #: m, mm (X lags Z by m / feed); both directions only
    apparent_squareness: Estimate | None  #: s + k m / R, rad; one direction only
    centre_offset: tuple[Estimate, Estimate]  #: set-up centre (x, z) of the first test, mm
    residual: Figures  #: of measured minus fitted, um
    feed: float | None  #: mm/min, when every trace states the same feed
    centres: tuple[tuple[Estimate, Estimate], ...] = ()  #: every test's set-up centre, in test order
    arcs: str = ""  #: the arcs fitted, for messages
    paths: tuple[str, ...] = ()  #: the traces fitted, in the order given
    spike: str = ""  #: the largest spike in the traces (ballbar_fit.spike), said; "" when none

    @property
    def servo_lag_ms(self) -> Estimate | None:
        """The X-behind-Z time lag m / F, when the feed is known."""
        if self.servo_mismatch is None or self.feed is None:
            return None
        per_mm = 60000.0 / self.feed
        return Estimate(self.servo_mismatch.value * per_mm, self.servo_mismatch.sigma * per_mm)

    def parameters(self) -> dict[str, Estimate]:
        """Every fitted machine parameter by name (squareness and servo, or the apparent squareness)."""
        names = (*SCALING_BACKLASH, "squareness", "servo_mismatch", "apparent_squareness")
        return {name: getattr(self, name) for name in names if getattr(self, name) is not None}


def circular_deviation(trace: BallbarTrace) -> float:
    """G: width of the deviation about the trace's own least-squares circle."""
    residual = _about_centre(trace.angles, trace.deviations)
    return float(residual.max() - residual.min())


def tests(traces: Sequence[BallbarTrace]) -> list[tuple[BallbarTrace, ...]]:
    """The traces grouped by test (one circle, one mount: its runs, repeats included), ccw runs
    first; a file given twice is refused."""
    seen: dict[str, int] = {}
    for trace in traces:
        if trace.path in seen:
            raise MeasurementError("the same trace given twice (a ccw and a cw run of one test are two files)",
                                   Location(trace.path))
        seen[trace.path] = 1
    grouped = [[traces[i] for i in group] for group in ballbar_fit.mounts(traces)]
    return [tuple(sorted(test, key=lambda t: t.direction != "ccw")) for test in grouped]


def one_test(traces: Sequence[BallbarTrace], who: str = "") -> tuple[BallbarTrace, ...]:
    """The traces of one test, ccw runs first; traces of another radius or centre are refused
    naming every test's files."""
    grouped = tests(traces)
    if len(grouped) != 1:
        raise MeasurementError(f"{who + ': ' if who else ''}the traces are of {len(grouped)} different tests (a test is "
                               f"one radius and one centre): {ballbar_fit.tests_text(grouped)}; give the traces of one "
                               "test, or correct the radius or centre in a file's header", Location(grouped[1][0].path))
    return grouped[0]


def paired(traces: Sequence[BallbarTrace], who: str) -> list[tuple[BallbarTrace, ...]]:
    """The traces grouped by test (:func:`tests`), every test with a ccw and a cw run.

    A ccw and a cw trace pair only when they are of one test (one radius, one nominal centre,
    one mount): what flips with the direction (backlash, servo mismatch) is told from what
    does not by comparing the two runs over one circle, and two circles differ by their
    set-up centres and by the machine's errors where they lie. A test with one direction is
    refused naming every test's files, whether its partner is missing or is of another test.
    """
    grouped = tests(traces)
    lone = [test for test in grouped if len({t.direction for t in test}) < 2]
    if lone:
        missing = "cw" if lone[0][0].direction == "ccw" else "ccw"
        raise MeasurementError(
            f"{who} needs a ccw (G03) and a cw (G02) trace of each test (one radius, one centre), and the traces "
            f"are of {len(grouped)} test{'s' if len(grouped) > 1 else ''}: {ballbar_fit.tests_text(grouped)}; "
            f"R {lone[0][0].radius:g} mm about x {lone[0][0].centre[0]:g}, z {lone[0][0].centre[1]:g} mm has no "
            f"{missing} trace: give it, or correct the radius or centre in a file's header if two files are of one test",
            Location(lone[0][0].path))
    return grouped


def circular_test(traces: Sequence[BallbarTrace]) -> CircularTest:
    """G and F of each trace of one test; G(b) and H of its first ccw and first cw trace."""
    from .figures import figures

    ordered = one_test(traces)
    by_direction = tuple(
        DirectionFigures(t.direction, circular_deviation(t), float(t.deviations.min()), float(t.deviations.max()),
                         figures(t.deviations), t.arc, t.path)
        for t in ordered)
    firsts = {t.direction: t for t in reversed(ordered)}
    if len(firsts) == 1:
        return CircularTest(by_direction, None, None)
    ccw, cw = firsts["ccw"], firsts["cw"]
    measured = [ballbar_fit.as_measured(ccw), ballbar_fit.as_measured(cw)]
    residual = ballbar_fit.without_centres(ballbar_fit.Samples.of([ccw, cw]), np.concatenate(measured), radius=True)
    ccw_r, cw_r = residual[: len(ccw.angles)], residual[len(ccw.angles):]
    gaps = np.concatenate([_difference(ccw.angles, ccw_r, cw.angles, cw_r),
                           _difference(cw.angles, cw_r, ccw.angles, ccw_r)])
    if gaps.size == 0:
        raise MeasurementError("the ccw and cw traces share no angles; circular hysteresis needs them to overlap",
                               Location(cw.path))
    return CircularTest(by_direction, float(residual.max() - residual.min()), float(np.abs(gaps).max()))


def model_names(traces: Sequence[BallbarTrace]) -> list[str]:
    """The machine parameters the traces can tell apart: squareness and servo mismatch need both
    directions, or several radii; one direction of one radius sees only their sum."""
    both = len({t.direction for t in traces}) == 2 or len({round(t.radius, 9) for t in traces}) > 1
    return [*SCALING_BACKLASH, *(("squareness", "servo_mismatch") if both else ("apparent_squareness",))]


def diagnose(traces: Sequence[BallbarTrace], limit: float = ballbar_fit.EFFECT_LIMIT_MM) -> Diagnosis:
    """Fit the machine model to any number of tests, each with its own set-up centre.

    Refuses (MeasurementError naming the arcs and the parameter) when a parameter cannot be
    separated or its 3-sigma effect exceeds ``limit`` mm; and (naming every test's files) when
    the ccw and the cw traces are of different tests only: squareness and servo mismatch are
    told apart by the two directions over one circle, and across circles the set-up centres and
    the machine's errors where each lies differ (a 200 mm move of the centre read 10 urad of
    squareness more, 3 sigma 1 urad, on the sample lathe).
    """
    from .figures import figures

    grouped = tests(traces)
    if len({t.direction for t in traces}) == 2 and all(len({t.direction for t in test}) == 1 for test in grouped):
        raise MeasurementError(
            "the ccw and the cw traces are of different tests (a test is one radius and one centre), and the "
            f"directions pair only within a test: {ballbar_fit.tests_text(grouped)}; give each test's other "
            "direction, or correct the radius or centre in a file's header if two files are of one test",
            Location(grouped[1][0].path))
    ordered = [trace for test in grouped for trace in test]
    samples = ballbar_fit.Samples.of(ordered)
    names = model_names(ordered)
    result = ballbar_fit.fit(samples, ballbar_fit.machine_errors(samples, names))
    ballbar_fit.require(result, limit=limit)
    spike = ballbar_fit.spike(samples, result.residuals)
    fit = result.estimates()
    feeds = {t.feed for t in ordered}
    centres = tuple(result.centre(mount) for mount in range(len(samples.groups)))
    return Diagnosis(
        radius=ordered[0].radius, directions=tuple(d for d in ("ccw", "cw") if d in samples.directions),
        scaling_x=fit["scaling_x"], scaling_z=fit["scaling_z"], backlash_x=fit["backlash_x"],
        backlash_z=fit["backlash_z"], squareness=fit.get("squareness"), servo_mismatch=fit.get("servo_mismatch"),
        apparent_squareness=fit.get("apparent_squareness"), centre_offset=centres[0],
        residual=figures(result.residuals), feed=feeds.pop() if len(feeds) == 1 else None, centres=centres,
        arcs=arcs_text(ordered), paths=tuple(t.path for t in traces), spike=spike[0] if spike else "")


def centred(traces: Sequence[BallbarTrace], diagnosis: Diagnosis) -> list[BallbarTrace]:
    """The traces with their test's jointly fitted set-up centre removed (``centered`` ones as they are)."""
    by_key = {ballbar_fit.mount_key(test[0]): centre for test, centre in zip(tests(traces), diagnosis.centres)}
    return [trace if trace.centered else
            ballbar_fit.recentred(trace, tuple(e.value for e in by_key[ballbar_fit.mount_key(trace)]))
            for trace in traces]


def jointly_centred(traces: Sequence[BallbarTrace]) -> tuple[list[BallbarTrace], ballbar_fit.JointFit]:
    """The traces centred by one fit of the machine model with each test's set-up centre; the
    parameters the arcs cannot determine are left out of it (ballbar_fit.fit_determined), so
    this never refuses. For compensators that use the traces themselves (ballbar-inverse)."""
    samples = ballbar_fit.Samples.of(list(traces))
    result, _ = ballbar_fit.fit_determined(samples, ballbar_fit.machine_errors(samples, model_names(traces)))
    return [trace if trace.centered else ballbar_fit.recentred(trace, result.centre_of_trace(index))
            for index, trace in enumerate(traces)], result


def screen(traces: Sequence[BallbarTrace], reporter, force: bool, who: str = "") -> Diagnosis:
    """The traces' diagnosis held to :func:`plausibility`, for a compensator: a problem refuses
    (MeasurementError naming the first trace) unless ``force``, then it and every warning go
    to ``reporter``. Parameters are not held to a limit here (the compensator holds what it
    uses); only parameters the arcs cannot separate at all refuse."""
    diagnosis = diagnose(traces, math.inf)
    problems, warnings = plausibility(diagnosis)
    where = Location(traces[0].path)
    prefix = f"{who}: " if who else ""
    for text in problems:
        if not force:
            raise MeasurementError(f"{prefix}{text}; --force uses the traces as they are", where)
        reporter.warn(f"{prefix}{text} (--force: used as they are)", where)
    for text in warnings:
        reporter.warn(f"{prefix}{text}", where)
    return diagnosis


def screen_spikes(traces: Sequence[BallbarTrace], reporter, force: bool, who: str,
                  result: ballbar_fit.JointFit | None = None) -> None:
    """For a compensator that cuts the traces themselves into the program (ballbar-inverse,
    iterative): a spike in one (ballbar_fit.spike) refuses naming its file, line and size,
    unless ``force``; ``result``, the traces' joint fit when the caller has made it."""
    if result is None:
        result = jointly_centred(traces)[1]
    found = ballbar_fit.spike(result.samples, result.residuals)
    if found is None:
        return
    text, where = found
    if not force:
        raise MeasurementError(f"{who}: {text}; --force uses the traces as they are", where)
    reporter.warn(f"{who}: {text} (--force: used as they are)", where)


def plausibility(diagnosis: Diagnosis) -> tuple[list[str], list[str]]:
    """Results no machine gives, with their likely cause: (problems, warnings).

    Problems make a compensator refuse (unless forced): a spike in a trace (one or two samples
    far off the fit, ballbar_fit.spike: a compensator would cut it into the part), both
    backlashes clearly negative (the
    ccw and cw labels swapped: every direction-dependent term flips, and the model would
    double the error), a scaling beyond 500 ppm (a radius that is not the bar's length, or a
    unit), a backlash beyond 50 um (a unit, or a machine to repair first). Warnings: one
    backlash clearly negative (a control's backlash compensation set too high).
    """
    problems, warnings = [diagnosis.spike] if diagnosis.spike else [], []
    lag = diagnosis.servo_lag_ms
    servo = ""
    if lag is not None:
        servo = f" (and the servo lag {lag.value:+.3f} ms{', Z behind X' if lag.value < 0 else ''})"
    elif diagnosis.servo_mismatch is not None:
        servo = f" (and the servo mismatch {diagnosis.servo_mismatch.value * 1000:+.2f} um)"
    swapped, caution = backlash_signs(diagnosis.backlash_x, diagnosis.backlash_z, servo)
    problems += [swapped] if swapped else []
    warnings += [caution] if caution else []
    scalings = {"X": diagnosis.scaling_x.value, "Z": diagnosis.scaling_z.value}
    beyond = {axis: value for axis, value in scalings.items() if abs(value) > MAX_SCALING}
    if beyond:
        listed = " and ".join(f"scaling {axis} {value * 1e6:+.0f} ppm" for axis, value in beyond.items())
        values = list(scalings.values())
        if len(beyond) == 2 and values[0] * values[1] > 0 and abs(values[0] - values[1]) < 0.2 * max(map(abs, values)):
            mean = 0.5 * (values[0] + values[1]) * diagnosis.radius * 1000.0
            problems.append(f"{listed}: the traces read a mean radius error of {mean:+.1f} um on the {diagnosis.radius:g} "
                            "mm radius: radius_mm does not match the bar's length")
        else:
            problems.append(f"{listed} {'is' if len(beyond) == 1 else 'are'} beyond {MAX_SCALING * 1e6:.0f} ppm: no "
                            f"machine scales that much; is radius_mm ({diagnosis.radius:g} mm) the bar's length, and "
                            "are the deviations in mm?")
    for axis, e in (("X", diagnosis.backlash_x), ("Z", diagnosis.backlash_z)):
        if abs(e.value) > MAX_BACKLASH:
            problems.append(f"backlash {axis} {e.value * 1000:+.1f} um is beyond {MAX_BACKLASH * 1000:.0f} um: are "
                            "the deviations in mm? (a machine that loses that much needs repair, not compensation)")
        elif e.value < -MAX_NEGATIVE_BACKLASH and not swapped:
            problems.append(f"backlash {axis} {e.value * 1000:+.1f} um is below {-MAX_NEGATIVE_BACKLASH * 1000:.0f} "
                            "um: the control's backlash compensation is set far too high (correct it there), or the "
                            "deviations are not in mm")
    for name, e in (("squareness", diagnosis.squareness), ("servo_mismatch", diagnosis.servo_mismatch)):
        beyond = None if e is None else beyond_bounds(name, e.value)
        problems += [f"{beyond}; are the deviations in mm?"] if beyond else []
    return problems, warnings


def backlash_signs(backlash_x: Estimate, backlash_z: Estimate, servo: str = "") -> tuple[str | None, str | None]:
    """(problem, warning) from the backlash signs: lost motion is never negative, and swapped
    ccw/cw labels flip both (and the servo lag), so both clearly negative means swapped labels;
    one alone, a control whose backlash compensation is set too high."""
    negative = {axis: e for axis, e in (("X", backlash_x), ("Z", backlash_z))
                if e.value < -max(3.0 * e.sigma, NEGATIVE_FLOOR)}
    if len(negative) == 2:
        return (f"backlash X {backlash_x.value * 1000:+.2f} um and Z {backlash_z.value * 1000:+.2f} um are both "
                f"negative{servo}: the ccw and cw labels look swapped (ccw is the G03 run, theta decreasing; cw the "
                "G02 run, theta increasing): check each file's direction header", None)
    if negative:
        axis, e = next(iter(negative.items()))
        return None, (f"backlash {axis} is negative ({e.value * 1000:+.2f} um): the control's backlash compensation "
                      "may be set too high (or the direction labels are swapped)")
    return None, None


def predict(diagnosis: Diagnosis, theta_deg, direction: str, radius: float | None = None) -> np.ndarray:
    """The deviation the fitted machine gives at theta (degrees) in a direction, without the set-up centre.

    A one-direction diagnosis cannot predict the other direction (its squareness and servo
    mismatch are not separated): that is a ValueError.
    """
    from .readers.ballbar import BallbarTrace

    values = diagnosis.parameters()
    if "apparent_squareness" in values and direction not in diagnosis.directions:
        raise ValueError(f"a diagnosis of the {diagnosis.directions[0]} trace alone cannot predict {direction}")
    theta = np.asarray(theta_deg, dtype=float)
    probe = BallbarTrace("<model>", radius or diagnosis.radius, direction, (0.0, 0.0), theta.ravel(),
                         np.zeros(theta.size))
    samples = ballbar_fit.Samples.of([probe])
    units = ballbar_fit.machine_errors(samples, list(values))
    reading = sum(e.value * (ex * samples.cos + ez * samples.sin) for e, (ex, ez) in zip(values.values(), units.values()))
    return np.asarray(reading, dtype=float).reshape(theta.shape)


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
    return values[close] - np.interp(where[close], ring, ring_values)
