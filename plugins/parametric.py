"""parametric: per-axis error functions fitted to a ballbar test (Kakino), on every feed move.

Also home to :class:`ErrorFunctions`, what ``parametric`` and ``effective-angle`` share: the
test square, the extrapolation rule, and predicting the traces back from the model.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from postproc.ballbar_analysis import MAX_GAP_DEG, Estimate
from postproc.compensator import Compensator, Measurements, Option, Piece
from postproc.diagnostics import Location, MeasurementError, ModelError
from postproc.figures import figures
from postproc.hookspecs import hookimpl
from postproc.measurements.ballbar import BallbarTrace, pair


def circle_path(trace: BallbarTrace) -> dict[str, np.ndarray]:
    """The commanded test at a trace's samples: offsets (u, w) from the centre, the unit
    tangent (tx, tz) in the trace's direction and the direction each axis travels."""
    theta = np.radians(trace.angles)
    cos, sin = np.cos(theta), np.sin(theta)
    k = 1.0 if trace.cw else -1.0  # cw: theta increasing
    tx, tz = -k * sin, k * cos
    return {"cos": cos, "sin": sin, "u": trace.radius * cos, "w": trace.radius * sin, "tx": tx, "tz": tz,
            "dx": np.sign(np.round(tx, 12)), "dz": np.sign(np.round(tz, 12))}


def as_measured(trace: BallbarTrace) -> np.ndarray:
    """The trace with the reader's removed set-up centre put back (both runs share one mount)."""
    theta = np.radians(trace.angles)
    return trace.deviations + trace.setup_centre[0] * np.cos(theta) + trace.setup_centre[1] * np.sin(theta)


class ErrorFunctions(Compensator):
    """Per-axis error functions about a ballbar test's centre, applied to every feed move.

    Subclasses fit ``errors(u, w, x_direction, z_direction) -> (e_x, e_z)``: the error at
    offsets (u, w) = (x - xc, z - zc) from the test centre with each axis travelling the
    given way (+1, -1, or 0 for not known), all arrays of one value per point. The correction
    is minus the error.
    """

    takes = ("ballbar",)
    needs = ("ballbar",)
    options = (Option("extrapolate", bool, False, "use the error functions beyond the square the test circle spans"),)

    centre: tuple[float, float]
    radius: float
    fit_figures: dict[str, dict[str, float]]

    def errors(self, u, w, x_direction, z_direction) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError

    def _traces(self, measurements: Measurements) -> tuple[BallbarTrace, BallbarTrace]:
        ccw, cw = pair(measurements.ballbar)
        for trace in (ccw, cw):
            if trace.max_gap() > MAX_GAP_DEG:
                raise MeasurementError(f"{self.name} needs a trace round the whole circle; this one has a gap of "
                                       f"{trace.max_gap():.1f} deg (at most {MAX_GAP_DEG:g})", Location(trace.path))
        self.centre, self.radius, self._warned = ccw.centre, ccw.radius, False
        return ccw, cw

    def correct(self, piece: Piece) -> np.ndarray | None:
        return self.correct_many([piece])[0]

    def correct_many(self, pieces: Sequence[Piece]) -> list[np.ndarray | None]:
        """All the pieces' points in one array: the error functions depend on each point and
        its piece's directions alone."""
        counts = [len(piece.t) for piece in pieces]
        ends = np.cumsum(counts)
        points = np.concatenate([piece.points for piece in pieces]) if len(pieces) > 1 else pieces[0].points
        u, w = points[:, 0] - self.centre[0], points[:, 1] - self.centre[1]
        if not self.settings["extrapolate"]:
            held_u, held_w = np.clip(u, -self.radius, self.radius), np.clip(w, -self.radius, self.radius)
            if not self._warned:
                outside = np.flatnonzero(np.maximum(np.abs(held_u - u), np.abs(held_w - w)) > 1e-9)
                if len(outside):
                    self._warned = True
                    first = pieces[int(np.searchsorted(ends, outside[0], side="right"))]
                    (x0, x1), (z0, z1) = self.square()
                    self.context.reporter.warn(
                        f"{self.name}: the move on line {first.move.line} leaves the square the test circle spans "
                        f"(x {x0:g} .. {x1:g}, z {z0:g} .. {z1:g} mm); its error functions are held at the square's "
                        "edge there (--option extrapolate=true extrapolates them)")
            u, w = held_u, held_w
        x_direction = np.repeat(np.array([piece.x_direction for piece in pieces], dtype=float), counts)
        z_direction = np.repeat(np.array([piece.z_direction for piece in pieces], dtype=float), counts)
        e_x, e_z = self.errors(u, w, x_direction, z_direction)
        shift = np.empty((len(u), 2))  # each column broadcast to the samples, negated
        np.negative(e_x, out=shift[:, 0])
        np.negative(e_z, out=shift[:, 1])
        return [shift[end - count : end] for end, count in zip(ends.tolist(), counts)]

    def square(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """The square the test circle spans: where the error functions are measured."""
        (xc, zc), r = self.centre, self.radius
        return (xc - r, xc + r), (zc - r, zc + r)

    def predicted(self, trace: BallbarTrace) -> np.ndarray:
        """The trace the model predicts on the commanded test, without a set-up centre."""
        path = circle_path(trace)
        e_x, e_z = self.errors(path["u"], path["w"], path["dx"], path["dz"])
        return e_x * path["cos"] + e_z * path["sin"]

    def _score(self, ccw: BallbarTrace, cw: BallbarTrace) -> None:
        """Figures of the traces as measured minus the model's prediction, about one common
        least-squares centre (the set-up, which the model leaves out)."""
        traces = (ccw, cw)
        residual = np.concatenate([as_measured(t) - self.predicted(t) for t in traces])
        theta = np.radians(np.concatenate([t.angles for t in traces]))
        harmonic = np.column_stack([np.cos(theta), np.sin(theta)])
        centre, *_ = np.linalg.lstsq(harmonic, residual, rcond=None)
        residual = residual - harmonic @ centre
        split = len(ccw.angles)
        self.fit_figures = {"ccw": figures(residual[:split]).as_dict(), "cw": figures(residual[split:]).as_dict(),
                            "both": figures(residual).as_dict()}

    def _extent(self) -> dict[str, Any]:
        return {"centre_mm": list(self.centre), "radius_mm": self.radius}

    def _load_extent(self, model: dict[str, Any]) -> None:
        self.centre = (float(model["centre_mm"][0]), float(model["centre_mm"][1]))
        self.radius = float(model["radius_mm"])
        self.fit_figures = model.get("fit", {})
        self._warned = False

    def report(self) -> dict[str, Any]:
        (x0, x1), (z0, z1) = self.square()
        return {**self._extent(), "square_mm": {"x": [x0, x1], "z": [z0, z1]},
                "extrapolate": self.settings["extrapolate"], "fit_residual_um": self.fit_figures}


# the physical model: each parameter's (e_x, e_z) per unit value
APPLIED = ("scaling_x_plus", "scaling_x_minus", "scaling_z_plus", "scaling_z_minus", "backlash_x", "backlash_z",
           "squareness")
FITTED = APPLIED + ("servo_mismatch",)


def unit_errors(u, w, dx, dz, tx=0.0) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """(e_x, e_z) of each parameter at unit value, at offsets (u, w) with axis directions (dx, dz)
    and unit tangent x component tx."""
    u, w = np.asarray(u, dtype=float), np.asarray(w, dtype=float)
    zero = np.zeros(np.broadcast(u, w).shape)
    return {
        "scaling_x_plus": (zero + np.where(u >= 0, u, 0.0), zero),
        "scaling_x_minus": (zero + np.where(u < 0, u, 0.0), zero),
        "scaling_z_plus": (zero, zero + np.where(w >= 0, w, 0.0)),
        "scaling_z_minus": (zero, zero + np.where(w < 0, w, 0.0)),
        "backlash_x": (zero - 0.5 * np.asarray(dx, dtype=float), zero),  # lags b/2 behind its command
        "backlash_z": (zero, zero - 0.5 * np.asarray(dz, dtype=float)),
        "squareness": (zero + w, zero),
        "servo_mismatch": (zero - np.asarray(tx, dtype=float), zero),  # X lags Z by m along the path
    }


class Parametric(ErrorFunctions):
    """Fit per-axis error functions to a CCW and a CW ballbar trace; correct every feed move (docs/methods.md §7.2).

    What it corrects: the machine's position errors by axis, wherever the tool goes (lines
    and arcs of any radius). With (u, w) = (x - xc, z - zc) about the test centre and each
    axis's direction of travel d = +1 or -1 (0 when not known: no backlash term):

        e_x = a_x+ u (u >= 0) or a_x- u (u < 0)  +  s w  -  (b_x / 2) d_x
        e_z = a_z+ w (w >= 0) or a_z- w (w < 0)           -  (b_z / 2) d_z

    a: scaling (actual minus nominal per unit length), which may differ on either side of
    the centre (constant per quadrant, eq. 6.11); b: backlash, the full step at a reversal
    (the axis lags its command by b/2, eq. 6.12-6.13); s: squareness (the X error per unit
    Z). The correction is minus the error. The errors are zero at the test centre (apart
    from backlash): a constant is the ballbar's set-up centre, which is not a machine error.

    How it is fitted: one linear least-squares fit to both traces as measured (the
    removed set-up centres put back), the columns being the bar's reading of each
    parameter's per-axis error, ``e_x cos + e_z sin``, plus the set-up centre and the
    servo mismatch m (X lagging Z along the path: ``e_x -= m v_x / |v|``). m is fitted so it
    does not bias the backlash, and reported, but not applied: it grows with the feed,
    which in G96/G99 programs only the control knows. The report gives every parameter
    with its 1-sigma uncertainty and the figures of the traces minus the model's prediction.

    What it needs: ``--ballbar`` with a CCW and a CW trace of one test, each round the whole
    circle. Outside the square the test circle spans the model is not extrapolated: the
    error functions are held at the square's edge, with a warning naming the first block
    that goes there, unless ``--option extrapolate=true``.

    Example: the sample V40R test (``samples/ballbar/v40r-100-*.csv``: +30/-20 ppm scaling,
    4/3 um backlash) on the hemishell; X reverses at the pole, so the arc starts b_x/2 out::

        G01 Z57.15 F0.08                becomes   G01 X-0.001 Z62. F0.08
        G03 X114.3 Z0. I0. K-57.15                X0. Z57.15
        G01 X118.                                 G01 X0.004 Z57.15
                                                  G03 X114.3 Z-0.001 I-0.003 K-57.151
                                                  G01 X118. Z-0.001
    """

    name = "parametric"

    def fit(self, measurements: Measurements) -> None:
        ccw, cw = self._traces(measurements)
        design, measured = [], []
        for trace in (ccw, cw):
            path = circle_path(trace)
            units = unit_errors(path["u"], path["w"], path["dx"], path["dz"], path["tx"])
            columns = [units[name][0] * path["cos"] + units[name][1] * path["sin"] for name in FITTED]
            design.append(np.column_stack([*columns, path["cos"], path["sin"]]))  # + the set-up centre
            measured.append(as_measured(trace))
        design, measured = np.concatenate(design), np.concatenate(measured)
        solution, *_ = np.linalg.lstsq(design, measured, rcond=None)
        residual = measured - design @ solution
        variance = float(residual @ residual) / (len(measured) - design.shape[1])
        sigma = np.sqrt(np.diag(np.linalg.inv(design.T @ design)) * variance)
        estimates = [Estimate(float(v), float(s)) for v, s in zip(solution, sigma)]
        self.parameters = dict(zip(FITTED, estimates))
        self.setup_centre = (estimates[-2], estimates[-1])
        self._score(ccw, cw)

    def errors(self, u, w, x_direction, z_direction) -> tuple[np.ndarray, np.ndarray]:
        """The sum over APPLIED of each parameter times its :func:`unit_errors`, written out:
        it runs for every piece of every move. ``min(u, 0)`` is ``u - max(u, 0)``, exactly."""
        p = self.parameters
        u, w = np.asarray(u, dtype=float), np.asarray(w, dtype=float)
        u_plus, w_plus = np.maximum(u, 0.0), np.maximum(w, 0.0)
        e_x = (p["scaling_x_plus"].value * u_plus + p["scaling_x_minus"].value * (u - u_plus)
               - 0.5 * p["backlash_x"].value * np.asarray(x_direction, dtype=float) + p["squareness"].value * w)
        e_z = (p["scaling_z_plus"].value * w_plus + p["scaling_z_minus"].value * (w - w_plus)
               - 0.5 * p["backlash_z"].value * np.asarray(z_direction, dtype=float))
        return e_x, e_z

    def model(self) -> dict[str, Any]:
        return {**self._extent(), "parameters": {name: [e.value, e.sigma] for name, e in self.parameters.items()},
                "setup_centre_mm": [[e.value, e.sigma] for e in self.setup_centre], "fit": self.fit_figures}

    def load(self, model: dict[str, Any]) -> None:
        try:
            self._load_extent(model)
            self.parameters = {name: Estimate(float(model["parameters"][name][0]), float(model["parameters"][name][1]))
                               for name in FITTED}
            self.setup_centre = tuple(Estimate(float(v), float(s)) for v, s in model["setup_centre_mm"])
        except (KeyError, IndexError, TypeError, ValueError) as exc:
            raise ModelError(f"{self.name}: the saved model is incomplete ({exc.__class__.__name__}: {exc})") from None

    def report(self) -> dict[str, Any]:
        fitted = {name: {"value": e.value, "sigma": e.sigma} for name, e in self.parameters.items()}
        fitted["servo_mismatch"]["applied"] = False
        return {**super().report(), "parameters": fitted,
                "setup_centre_mm": {"x": self.setup_centre[0].value, "z": self.setup_centre[1].value}}


@hookimpl
def postproc_compensators():
    return [Parametric]
