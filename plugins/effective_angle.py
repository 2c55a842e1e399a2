"""effective-angle: per-axis error tables read off a ballbar test at the commanded angle, on every feed move."""

from __future__ import annotations

from typing import Any

import numpy as np

from postproc.compensator import Measurements
from postproc.diagnostics import ModelError
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
    left half of the ccw run. Each table averages the two halves that travel its way.
    """
    angles = np.concatenate([ccw.angles, cw.angles])
    r = ccw.radius
    theta = np.union1d(_fold_x(angles), [0.0, 180.0])[::-1]  # u increasing
    phi = np.union1d(_fold_z(angles), [-90.0, 90.0])
    cos, sin = np.cos(np.radians(theta)), np.sin(np.radians(phi))
    return {
        "x+": (r * cos, cos * 0.5 * (ccw.at(theta) + cw.at(-theta))),
        "x-": (r * cos, cos * 0.5 * (cw.at(theta) + ccw.at(-theta))),
        "z+": (r * sin, sin * 0.5 * (cw.at(phi) + ccw.at(180.0 - phi))),
        "z-": (r * sin, sin * 0.5 * (ccw.at(phi) + cw.at(180.0 - phi))),
    }


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

    What it needs: ``--ballbar`` with a CCW and a CW trace of one test, each round the whole
    circle. Outside the square the test circle spans the tables are held at their ends, with
    a warning naming the first block that goes there, unless ``--option extrapolate=true``:
    then each table goes on along the straight line fitted to its outer tenth.

    Example: the sample V40R test (``samples/ballbar/v40r-100-*.csv``) on the hemishell::

        G01 Z57.15 F0.08                becomes   G01 X0. Z57.15 F0.08
        G03 X114.3 Z0. I0. K-57.15                G03 X114.301 Z0. I0. K-57.151
        G01 X118.                                 G01 X118.001 Z0.
    """

    name = "effective-angle"

    def fit(self, measurements: Measurements) -> None:
        ccw, cw = self._traces(measurements)
        self.tables = tables(ccw, cw)
        self._score(ccw, cw)

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
