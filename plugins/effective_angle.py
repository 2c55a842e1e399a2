"""effective-angle: per-axis error tables read off a ballbar test at the commanded angle, on every feed move."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from postproc.compensator import Measurements, Piece
from postproc.diagnostics import Location, MeasurementError, ModelError
from postproc.corrections.error_functions import ErrorFunctions
from postproc.geometry import Line
from postproc.hookspecs import hookimpl

if TYPE_CHECKING:  # a saved model's run reads no trace
    from postproc.measure.readers.ballbar import BallbarTrace

TABLES = ("x+", "x-", "z+", "z-")  #: axis and direction of its travel
OUTER = 0.1  #: share of a table's span at each end whose straight line extrapolates it
REFERENCE = ("scaling_x", "scaling_z", "backlash_x", "backlash_z", "squareness")  #: the physical model's parameters
WORSE_UM = 0.05  #: a predicted figure this much above the uncompensated one counts as worse


def _fold_x(angles: np.ndarray) -> np.ndarray:
    """Angles in [0, 180]: theta and -theta have the same x (rounded, so both traces' samples coincide)."""
    return np.round(np.abs((angles + 180.0) % 360.0 - 180.0), 9)


def _fold_z(angles: np.ndarray) -> np.ndarray:
    """Angles in [-90, 90]: theta and 180 - theta have the same z."""
    turned = (angles + 90.0) % 360.0
    return np.round(np.where(turned > 180.0, 360.0 - turned, turned) - 90.0, 9)


def tables(ccw: BallbarTrace, cw: BallbarTrace) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """(offset from the centre, error) of each axis and direction of travel, offsets increasing.

    The trace at theta says e_x = dev cos(theta) at u = r cos(theta), e_z = dev sin(theta) at
    w = r sin(theta) (eq. 6.7-6.10). X travels + on the upper half of the ccw run and the lower
    half of the cw run, - on the other two; Z travels + on the right half of the cw run and the
    left half of the ccw run. Each table averages the two halves that travel its way where both
    were measured, takes the one that was where only one was (a partial arc), and has no entry
    where neither was.
    """
    angles = np.concatenate([ccw.angles, cw.angles])
    r = ccw.radius
    theta = np.union1d(_fold_x(angles), [0.0, 180.0])[::-1]  # u increasing
    phi = np.union1d(_fold_z(angles), [-90.0, 90.0])
    cos, sin = np.cos(np.radians(theta)), np.sin(np.radians(phi))
    found = {
        "x+": (r * cos, cos * _mean(ccw.at(theta), cw.at(-theta))),
        "x-": (r * cos, cos * _mean(cw.at(theta), ccw.at(-theta))),
        "z+": (r * sin, sin * _mean(cw.at(phi), ccw.at(180.0 - phi))),
        "z-": (r * sin, sin * _mean(ccw.at(phi), cw.at(180.0 - phi))),
    }
    return {name: (offsets[np.isfinite(errors)], errors[np.isfinite(errors)]) for name, (offsets, errors) in found.items()}


def _mean(first: np.ndarray, second: np.ndarray) -> np.ndarray:
    """The mean of two halves where both were measured, the one that was elsewhere, NaN where neither."""
    return np.where(np.isnan(first), second, np.where(np.isnan(second), first, 0.5 * (first + second)))


def merged(per_test: list[tuple[tuple[float, float], dict[str, tuple[np.ndarray, np.ndarray]]]],
           centre: tuple[float, float]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Several tests' tables as one per axis and direction, offsets about ``centre``: at each
    offset the mean of the tests that measured it (each interpolated within its own span)."""
    result = {}
    for name in TABLES:
        axis = 0 if name.startswith("x") else 1
        shifted = [(offsets + test_centre[axis] - centre[axis], errors)
                   for test_centre, found in per_test for offsets, errors in [found[name]] if len(offsets)]
        if not shifted:
            result[name] = (np.zeros(0), np.zeros(0))
            continue
        grid = np.unique(np.concatenate([offsets for offsets, _ in shifted]))
        stack = np.array([np.where((grid >= offsets[0]) & (grid <= offsets[-1]), np.interp(grid, offsets, errors), np.nan)
                          for offsets, errors in shifted])
        counts = np.isfinite(stack).sum(axis=0)
        result[name] = (grid, np.nansum(stack, axis=0) / np.maximum(counts, 1))
    return result


class EffectiveAngle(ErrorFunctions):
    """Tabulate per-axis errors from a CCW and a CW ballbar trace; correct every feed move (docs/methods.md §7.1).

    What it corrects: the machine's position errors by axis, read off the ballbar with the
    effective-angle assumption (eq. 6.7-6.10): the reading at theta came from the command at
    theta, so the radial deviation dev splits into e_x = dev cos(theta) at
    x = xc + r cos(theta) and e_z = dev sin(theta) at z = zc + r sin(theta). The tables are
    interpolated linearly; the correction is minus the error, on lines and arcs alike.

    How the halves and directions combine: every x occurs twice on the circle (at theta and
    -theta) and in two runs. The X table is kept separately for each direction of X travel,
    so that backlash keeps its sign: X travels + on the upper half of the CCW run and on the
    lower half of the CW run, and the + table is the average of those two halves (the -
    table likewise of the other two). Z alike: + on the right half of the CW run and the left
    half of the CCW run. A piece whose axis direction is not known takes the mean of both
    tables. The tables see only what the bar sees along its radius, so e_x near x = xc (and
    e_z near z = zc) reads zero whatever the axis does there, and the other axis's errors
    leak in between: the method is generic but not exact (Table 6.7). The report gives the
    figures of the traces minus what the tables predict for them.

    Partial arcs and several tests: a table has entries only where an arc measured it (each
    half where it was captured, the mean of both where both were); the traces of each test are
    centred with the set-up centre fitted jointly with the machine model (a separate circle
    fit is biased on a partial arc); several tests (each a CCW and a CW trace of one circle)
    give one table per axis and direction, the mean of the tests where they overlap.

    An axis that stands still during a move keeps the backlash of its last direction of
    travel, so it takes that direction's table (the direction each piece carries); only
    where no move before has told which way it last went does it take the mean of both.

    Predicted on each program: the per-axis error model fitted to the same traces (the
    parametric diagnosis of ``postproc ballbar``: scaling, backlash, squareness) stands in
    for the machine; along every corrected feed move inside the box the arcs span, the error
    normal to the move is summed as the program stands and as the tables leave it (length
    weighted). If the four figures (mean, mean |e|, RMS, sigma) say the tables would leave
    the moves worse than no compensation in any of them, a warning gives both sets of
    predicted figures (the other axis's error leaking into each table, docs/methods.md §7.1;
    ``parametric`` has no such spread).

    What it needs (the minimum evidence): ``--ballbar`` with a CCW and a CW trace of each test,
    at least 36 samples over at least 90 deg of arc each, screened as parametric's are (a
    machine parameter the arcs cannot determine within ``max-uncertainty`` refuses, naming
    the arc; swapped labels, a wrong radius or unit refuse unless ``--force``), and every one of
    the four tables measured somewhere. Outside the box the arcs span the tables are held at
    their ends, with a warning naming the first block that goes there, unless
    ``--option extrapolate=true``: then each table goes on along the straight line fitted to
    its outer tenth.

    Example: the sample V40R test (``samples/ballbar/v40r-100-*.csv``) on the hemishell::

        G01 Z57.15 F0.08                becomes   G01 X0. Z57.15 F0.08
        G03 X114.3 Z0. I0. K-57.15                G03 X114.301 Z0. I0. K-57.151
        G01 X118.                                 G01 X118.001 Z0.
    """

    name = "effective-angle"

    def fit(self, measurements: Measurements) -> None:
        from postproc.measure import ballbar_fit  # the fitting: a saved model's run loads without it
        from postproc.measure.ballbar_analysis import centred, paired, tests

        paired(list(measurements.ballbar), self.name)
        traces = self._traces(measurements)
        limit = self.settings["max-uncertainty"]
        for index, centre in enumerate(self.diagnosis.centres):
            worst = max(3.0 * e.sigma for e in centre)
            if worst > limit:
                test = tests(traces)[index]
                raise MeasurementError(f"{self.name}: on {ballbar_fit.arcs_text(test)}, the set-up centre is not "
                                       f"determined (+-{worst * 1000:.2f} um, 3 sigma; at most {limit * 1000:g} um): "
                                       "measure a longer arc", Location(test[0].path))
        per_test = []
        for test in tests(centred(traces, self.diagnosis)):
            if [t.direction for t in test] != ["ccw", "cw"]:
                raise MeasurementError(f"{self.name} takes one ccw and one cw trace of each test, no repeats; "
                                       f"{ballbar_fit.test_text(test)}", Location(test[0].path))
            per_test.append((test[0].centre, tables(*test)))
        self.tables = merged(per_test, self.centre)
        for name, (offsets, _) in self.tables.items():
            if len(offsets) < 2:
                raise MeasurementError(f"{self.name}: the arcs measure no {name} table (the {name[0].upper()} axis "
                                       f"travelling {name[1]}); measure a longer arc", Location(traces[0].path))
        self._score(traces)
        self.reference = {name: getattr(self.diagnosis, name).value for name in REFERENCE}
        self.prediction = Prediction()

    def correct_many(self, pieces: Sequence[Piece]) -> list[np.ndarray | None]:
        shifts = super().correct_many(pieces)
        if self.reference is not None:
            self.prediction.add(pieces, shifts, self.reference, self.centre, self.box)
        return shifts

    def start(self) -> None:
        """A new program: its own prediction, whatever the last one left."""
        self.prediction = Prediction()

    def finish(self) -> None:
        """Warn when the tables are predicted to leave this program worse than no compensation."""
        super().finish()
        before, after = self.prediction.figures()
        if before is None:
            return
        worse = [name for name in ("mean", "mean |e|", "RMS", "sigma")
                 if abs(after[name]) > abs(before[name]) + WORSE_UM]
        if worse:
            shown = ", ".join(f"{name} {before[name]:+.2f} -> {after[name]:+.2f} um" if name == "mean" else
                              f"{name} {before[name]:.2f} -> {after[name]:.2f} um" for name in before)
            self.context.reporter.warn(
                f"{self.name}: predicted to leave this program's feed moves worse than no compensation in "
                f"{' and '.join(worse)} ({shown}, normal to the moves inside the box the test arcs span, with the "
                "parametric fit of the same traces as the machine): the tables mix each axis's error with the "
                "other's; parametric has no such spread")

    def _lookup(self, table: str, at: np.ndarray) -> np.ndarray:
        offsets, errors = self.tables[table]
        values = np.interp(at, offsets, errors)
        if self.settings["extrapolate"]:
            reach = OUTER * (offsets[-1] - offsets[0])
            for beyond, outer in ((at < offsets[0], offsets <= offsets[0] + reach),
                                  (at > offsets[-1], offsets >= offsets[-1] - reach)):
                if np.any(beyond):
                    slope, level = np.polyfit(offsets[outer], errors[outer], 1)
                    values = np.where(beyond, slope * at + level, values)
        return values

    def errors(self, u, w, x_direction, z_direction) -> tuple[np.ndarray, np.ndarray]:
        result = []
        for axis, at, direction in (("x", u, x_direction), ("z", w, z_direction)):
            plus, minus = self._lookup(axis + "+", at), self._lookup(axis + "-", at)
            result.append(np.where(np.asarray(direction) > 0, plus,
                                   np.where(np.asarray(direction) < 0, minus, 0.5 * (plus + minus))))
        return result[0], result[1]

    def model(self) -> dict[str, Any]:
        return {**self._extent(), "fit": self.fit_figures, "reference": self.reference,
                "tables": {name: {"offset_mm": offsets.tolist(), "error_mm": errors.tolist()}
                           for name, (offsets, errors) in self.tables.items()}}

    def load(self, model: dict[str, Any]) -> None:
        try:
            self._load_extent(model)
            self.reference = _reference_of(model.get("reference"), self.name)
            self.prediction = Prediction()
            self.tables = {name: (np.array(model["tables"][name]["offset_mm"], dtype=float),
                                  np.array(model["tables"][name]["error_mm"], dtype=float)) for name in TABLES}
        except (KeyError, TypeError, ValueError) as exc:
            raise ModelError(f"{self.name}: the saved model is incomplete ({exc.__class__.__name__}: {exc})") from None
        for name, (offsets, errors) in self.tables.items():
            if offsets.ndim != 1 or offsets.shape != errors.shape or offsets.size < 2 or np.any(np.diff(offsets) < 0):
                raise ModelError(f"{self.name}: the saved table {name} is not a table of increasing offsets")

    def report(self) -> dict[str, Any]:
        largest = {name: float(np.max(np.abs(errors))) for name, (_, errors) in self.tables.items()}
        return {**super().report(), "largest_error_mm": largest}


def _reference_of(saved: Any, name: str) -> dict[str, float] | None:
    if saved is None:
        return None
    try:
        return {key: float(saved[key]) for key in REFERENCE}
    except (KeyError, TypeError, ValueError) as exc:
        raise ModelError(f"{name}: the saved reference model is incomplete ({exc.__class__.__name__}: {exc})") from None


def _normals(pieces: Sequence[Piece], points: np.ndarray, counts: list[int]) -> np.ndarray:
    """The unit normal to the left of the direction of travel at every point of the pieces, in one
    array pass: a line's from its direction, an arc's towards its centre for G02, away for G03."""
    rows = []
    for piece in pieces:
        segment = piece.segment
        if type(segment) is Line:
            tx, tz = segment.direction
            rows.append((0.0, 0.0, -tz, tx, 0.0))
        else:
            rows.append((segment.xc, segment.zc, 0.0, 0.0, -1.0 if segment.sweep > 0 else 1.0))
    each = np.repeat(np.array(rows), counts, axis=0)
    radial = points - each[:, :2]
    length = np.hypot(radial[:, 0], radial[:, 1])
    arc = each[:, 4] != 0.0
    scale = np.where(arc, each[:, 4] / np.where(arc, length, 1.0), 0.0)
    return radial * scale[:, None] + each[:, 2:4]


class Prediction:
    """The error normal to the corrected moves, summed as the program stands and as the tables
    leave it, on the reference machine, weighted by length: about every SPACING mm along each
    piece, 3 to SPOTS points (both errors are smooth along a piece; every sample of the core's
    would cost more than the correction)."""

    SPACING = 1.0  #: mm
    SPOTS = 65

    def __init__(self):
        self.sums = np.zeros((2, 4))  # (before, after) x (weight, sum, sum |e|, sum e^2)

    def add(self, pieces: Sequence[Piece], shifts: list[np.ndarray | None], reference: dict[str, float],
            centre: tuple[float, float], box: tuple[tuple[float, float], tuple[float, float]]) -> None:
        chosen, taken, spots, lengths = [], [], [], []
        for piece, shift in zip(pieces, shifts):
            if shift is None:
                continue
            n = len(piece.t)
            wanted = min(max(3, math.ceil(piece.segment.length / self.SPACING) + 1), self.SPOTS)
            rows = slice(0, n, max(1, (n - 1) // (wanted - 1)))
            chosen.append(piece)
            taken.append((piece.points[rows], shift[rows]))
            spots.append(len(range(*rows.indices(n))))
            lengths.append(piece.segment.length)
        if not chosen:
            return
        counts = spots
        points = np.concatenate([p for p, _ in taken])
        shift = np.concatenate([s for _, s in taken])
        weight = np.repeat(np.array(lengths) / np.array(spots), counts)
        u, w = points[:, 0] - centre[0], points[:, 1] - centre[1]
        (x0, x1), (z0, z1) = box
        inside = (points[:, 0] >= x0) & (points[:, 0] <= x1) & (points[:, 1] >= z0) & (points[:, 1] <= z1)
        if not inside.any():
            return
        dx = np.repeat([float(piece.x_direction) for piece in chosen], counts)
        dz = np.repeat([float(piece.z_direction) for piece in chosen], counts)
        e_x = reference["scaling_x"] * u + reference["squareness"] * w - 0.5 * reference["backlash_x"] * dx
        e_z = reference["scaling_z"] * w - 0.5 * reference["backlash_z"] * dz
        normal = _normals(chosen, points, counts)
        before = e_x * normal[:, 0] + e_z * normal[:, 1]
        after = before + np.einsum("ij,ij->i", shift, normal)
        weight = weight * inside
        for row, e in enumerate((before * 1000.0, after * 1000.0)):
            self.sums[row] += (weight.sum(), weight @ e, weight @ np.abs(e), weight @ (e * e))

    def figures(self) -> tuple[dict[str, float] | None, dict[str, float] | None]:
        """(before, after): mean, mean |e|, RMS and sigma in um, or None when nothing was summed."""
        if self.sums[0, 0] <= 0.0:
            return None, None
        found = []
        for total, plain, absolute, square in self.sums:
            mean, rms = plain / total, float(np.sqrt(square / total))
            found.append({"mean": mean, "mean |e|": absolute / total, "RMS": rms,
                          "sigma": float(np.sqrt(max(rms * rms - mean * mean, 0.0)))})
        return found[0], found[1]


@hookimpl
def postproc_compensators():
    return [EffectiveAngle]

