"""effective-angle: per-axis error tables read off a ballbar test at the commanded angle, on every feed move."""

from __future__ import annotations

from typing import Any

import numpy as np

from postproc import ballbar_fit
from postproc.ballbar_analysis import centred, tests
from postproc.compensator import Measurements
from postproc.diagnostics import Location, MeasurementError, ModelError
from postproc.hookspecs import hookimpl
from postproc.measurements.ballbar import BallbarTrace
from postproc_plugins.parametric import ErrorFunctions

TABLES = ("x+", "x-", "z+", "z-")  #: axis and direction of its travel
OUTER = 0.1  #: share of a table's span at each end whose straight line extrapolates it


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
                raise MeasurementError(f"{self.name} needs one ccw and one cw trace of each test; the circle of R "
                                       f"{test[0].radius:g} mm about ({test[0].centre[0]:g}, {test[0].centre[1]:g}) has "
                                       f"{' and '.join(t.direction + ' ' + t.path for t in test)}", Location(test[0].path))
            per_test.append((test[0].centre, tables(*test)))
        self.tables = merged(per_test, self.centre)
        for name, (offsets, _) in self.tables.items():
            if len(offsets) < 2:
                raise MeasurementError(f"{self.name}: the arcs measure no {name} table (the {name[0].upper()} axis "
                                       f"travelling {name[1]}); measure a longer arc", Location(traces[0].path))
        self._score(traces)

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
        return {**self._extent(), "fit": self.fit_figures,
                "tables": {name: {"offset_mm": offsets.tolist(), "error_mm": errors.tolist()}
                           for name, (offsets, errors) in self.tables.items()}}

    def load(self, model: dict[str, Any]) -> None:
        try:
            self._load_extent(model)
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


@hookimpl
def postproc_compensators():
    return [EffectiveAngle]
