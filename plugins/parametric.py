"""parametric: per-axis error functions fitted to ballbar tests (Kakino), on every feed move.

Also home to :class:`ErrorFunctions`, what ``parametric`` and ``effective-angle`` share: the
tests (any number, whole circles or partial arcs), the screening of the traces, the box the
arcs span and the extrapolation rule, and predicting the traces back from the model.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from postproc import ballbar_fit
from postproc.ballbar_analysis import Estimate, screen, tests
from postproc.compensator import Compensator, Measurements, Option, Piece
from postproc.diagnostics import Location, MeasurementError, ModelError
from postproc.figures import figures
from postproc.hookspecs import hookimpl
from postproc.measurements.ballbar import BallbarTrace


class ErrorFunctions(Compensator):
    """Per-axis error functions about a ballbar test's centre, applied to every feed move.

    Subclasses fit ``errors(u, w, x_direction, z_direction) -> (e_x, e_z)``: the error at
    offsets (u, w) = (x - xc, z - zc) from the (first) test's centre with each axis travelling
    the given way (+1, -1, or 0 for not known), all arrays of one value per point. The
    correction is minus the error.

    The tests: any number of traces; the traces of one circle (radius and centre) are one test
    on one mount, with their own set-up centre; a ccw and a cw trace are needed. Before the
    fit they are screened (:func:`postproc.ballbar_analysis.screen`): a machine parameter the
    arcs cannot determine within ``max-uncertainty`` refuses, naming the arc and the parameter;
    results no machine gives (swapped direction labels, a wrong radius or unit) refuse unless
    ``--force``. The box the arcs span (the x and z the bars reached) is where the functions
    are measured.
    """

    takes = ("ballbar",)
    needs = ("ballbar",)
    options = (
        Option("extrapolate", bool, False, "use the error functions beyond the box the test arcs span"),
        Option("max-uncertainty", float, ballbar_fit.EFFECT_LIMIT_MM,
               "largest 3-sigma effect (mm) of a fitted parameter the arcs must reach", positive=True),
    )

    centre: tuple[float, float]
    radius: float
    box: tuple[tuple[float, float], tuple[float, float]]
    fit_figures: dict[str, dict[str, float]]

    def errors(self, u, w, x_direction, z_direction) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError

    def _traces(self, measurements: Measurements) -> list[BallbarTrace]:
        """The traces, screened; sets the reference centre, radius and box."""
        traces = list(measurements.ballbar)
        if len(traces) < 2:
            raise MeasurementError(f"a CCW and a CW trace of one test are needed, {len(traces)} given",
                                   Location(traces[0].path if traces else "<ballbar>"))
        grouped = tests(traces)
        if len({t.direction for t in traces}) < 2:
            raise MeasurementError(f"{self.name} needs a ccw (G03) and a cw (G02) trace; all {len(traces)} are "
                                   f"{traces[0].direction}", Location(traces[-1].path))
        self.diagnosis = screen(traces, self.context.reporter, self.context.force, self.name)
        first = grouped[0][0]
        self.centre, self.radius, self._warned = first.centre, first.radius, False
        samples = ballbar_fit.Samples.of(traces)
        self.box = ((float(samples.x.min()), float(samples.x.max())), (float(samples.z.min()), float(samples.z.max())))
        return traces

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
            (x0, x1), (z0, z1) = self.box
            held_u = np.clip(u, x0 - self.centre[0], x1 - self.centre[0])
            held_w = np.clip(w, z0 - self.centre[1], z1 - self.centre[1])
            if not self._warned:
                outside = np.flatnonzero(np.maximum(np.abs(held_u - u), np.abs(held_w - w)) > 1e-9)
                if len(outside):
                    self._warned = True
                    first = pieces[int(np.searchsorted(ends, outside[0], side="right"))]
                    self.context.reporter.warn(
                        f"{self.name}: the move on line {first.move.line} leaves the box the test arcs span "
                        f"(x {x0:g} .. {x1:g}, z {z0:g} .. {z1:g} mm); its error functions are held at the box's "
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
        """The box the test arcs span, (x0, x1), (z0, z1): where the error functions are measured
        (the square of a whole circle)."""
        return self.box

    def predicted(self, trace: BallbarTrace) -> np.ndarray:
        """The trace the model predicts on the commanded test, without a set-up centre."""
        samples = ballbar_fit.Samples.of([trace])
        e_x, e_z = self.errors(samples.x - self.centre[0], samples.z - self.centre[1], samples.dx, samples.dz)
        return e_x * samples.cos + e_z * samples.sin

    def _score(self, traces: Sequence[BallbarTrace]) -> None:
        """Figures of the traces as measured minus the model's prediction, each test about its own
        least-squares centre (the set-up, which the model leaves out)."""
        samples = ballbar_fit.Samples.of(list(traces))
        residual = np.concatenate([ballbar_fit.as_measured(t) - self.predicted(t) for t in traces])
        residual = ballbar_fit.without_centres(samples, residual)
        directions = np.array([traces[i].direction for i in samples.trace])
        self.fit_figures = {d: figures(residual[directions == d]).as_dict() for d in ("ccw", "cw")}
        self.fit_figures["both"] = figures(residual).as_dict()

    def _extent(self) -> dict[str, Any]:
        (x0, x1), (z0, z1) = self.box
        return {"centre_mm": list(self.centre), "radius_mm": self.radius, "box_mm": {"x": [x0, x1], "z": [z0, z1]}}

    def _load_extent(self, model: dict[str, Any]) -> None:
        self.centre = (float(model["centre_mm"][0]), float(model["centre_mm"][1]))
        self.radius = float(model["radius_mm"])
        if not self.radius > 0:
            raise ValueError(f"radius_mm {self.radius} is not positive")
        box = model.get("box_mm")
        if box is None:  # a model saved before partial arcs: the square of the whole circle
            (xc, zc), r = self.centre, self.radius
            self.box = ((xc - r, xc + r), (zc - r, zc + r))
        else:
            self.box = ((float(box["x"][0]), float(box["x"][1])), (float(box["z"][0]), float(box["z"][1])))
            if not (self.box[0][0] <= self.box[0][1] and self.box[1][0] <= self.box[1][1]):
                raise ValueError("box_mm: each range must run from low to high")
        self.fit_figures = model.get("fit", {})
        self._warned = False

    def report(self) -> dict[str, Any]:
        (x0, x1), (z0, z1) = self.box
        return {**self._extent(), "square_mm": {"x": [x0, x1], "z": [z0, z1]},
                "extrapolate": self.settings["extrapolate"], "fit_residual_um": self.fit_figures}


# the physical model: each parameter's (e_x, e_z) per unit value
APPLIED = ("scaling_x_plus", "scaling_x_minus", "scaling_z_plus", "scaling_z_minus", "backlash_x", "backlash_z",
           "squareness")
FITTED = APPLIED + ("servo_mismatch",)
SIDES = {"x": ("scaling_x_plus", "scaling_x_minus"), "z": ("scaling_z_plus", "scaling_z_minus")}


def side_errors(u: np.ndarray, w: np.ndarray, one_side: set[str]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Unit errors of the scalings: per side of the centre, or one for an axis in ``one_side``."""
    zero = np.zeros_like(u)
    result = {}
    for axis, offset in (("x", u), ("z", w)):
        pair = [(offset, zero), (np.where(offset >= 0, offset, 0.0), zero), (np.where(offset < 0, offset, 0.0), zero)]
        if axis == "z":
            pair = [(b, a) for a, b in pair]
        if axis in one_side:
            result[f"scaling_{axis}"] = pair[0]
        else:
            result.update(zip(SIDES[axis], pair[1:]))
    return result


def fit_sides(samples: ballbar_fit.Samples, u: np.ndarray, w: np.ndarray,
              limit: float) -> tuple[ballbar_fit.JointFit, dict[str, str]]:
    """The joint fit with a scaling per side of the centre, except on an axis where a side is not
    seen or too little of it to fit on its own (3-sigma effect over ``limit``): that axis gets one
    scaling for both sides. Returns the fit and why each such axis was joined."""
    joined: dict[str, str] = {}
    others = ballbar_fit.machine_errors(samples, ("backlash_x", "backlash_z", "squareness", "servo_mismatch"))
    while True:
        try:
            result = ballbar_fit.fit(samples, side_errors(u, w, set(joined)) | others)
        except ballbar_fit.Inseparable as exc:
            side = next((name for name in exc.names for axis, pair in SIDES.items()
                         if name in pair and axis not in joined), None)
            if side is None:
                raise
            joined[side[8]] = f"{ballbar_fit.label(side)} is not seen by the arcs"
            continue
        vague = [(result.effect(name), name) for axis, pair in SIDES.items() if axis not in joined for name in pair
                 if 3.0 * result.effect(name) > limit]
        if not vague:
            return result, joined
        effect, side = max(vague)
        reach = float(result.reach[result.names.index(side)])
        joined[side[8]] = (f"the arcs reach {reach:.0f} mm on the {'+' if side.endswith('plus') else '-'} side only: on "
                           f"its own {ballbar_fit.label(side)} would be +-{3.0 * effect * 1000:.2f} um (3 sigma)")


class Parametric(ErrorFunctions):
    """Fit per-axis error functions to ballbar tests (CCW and CW, any arc); correct every feed move (docs/methods.md §7).

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

    How it is fitted: one linear least-squares fit to every trace as measured (the removed
    set-up centres put back; :mod:`postproc.ballbar_fit`), the columns being the bar's reading
    of each parameter's per-axis error, ``e_x cos + e_z sin``, plus each test's set-up centre
    and the servo mismatch m (X lagging Z along the path: ``e_x -= m v_x / |v|``). m is fitted
    so it does not bias the backlash, and reported, but not applied: it grows with the feed,
    which in G96/G99 programs only the control knows. On a partial arc the centre is fitted
    with the model, never before it. A side of the centre an arc does not reach, or reaches
    too little to fit on its own (3-sigma effect over ``max-uncertainty``), gets the other
    side's scaling: one scaling for that axis, said in the report (``one_scaling``). The report
    gives every parameter with its 1-sigma uncertainty and the figures of the traces minus the
    model's prediction.

    What it needs (the minimum evidence): ``--ballbar`` with a CCW and a CW trace; any number
    of tests (traces of another radius or centre are another test with its own set-up centre,
    fitted together). Each trace has at least 36 samples over at least 90 deg of arc (a whole
    circle, or a lathe's partial arc, ISO 13041-6); every fitted parameter must come out with
    a 3-sigma effect within ``--option max-uncertainty=MM`` (default 0.005: scaling within
    50 ppm at 100 mm, backlash within 10 um), or the run is refused naming the arc and the
    parameter (a 90 deg arc usually is: measure 180 deg or more). Traces that read like
    swapped ccw/cw labels, a radius that is not the bar's, or a wrong unit are refused unless
    ``--force``. Outside the box the arcs span (the x and z the bar reached: the test circle's
    square for a whole circle) the model is not extrapolated: the error functions are held at
    the box's edge, with a warning naming the first block that goes there, unless
    ``--option extrapolate=true``.

    Example: the sample V40R test (``samples/ballbar/v40r-100-*.csv``: +80/-100 ppm scaling,
    4/3 um backlash) on the hemishell; X reverses at the pole, so the arc starts b_x/2 out::

        G01 Z57.15 F0.08                becomes   G01 X-0.001 Z62.005 F0.08
        G03 X114.3 Z0. I0. K-57.15                X0. Z57.154
        G01 X118.                                 G01 X0.004 Z57.154
                                                  G03 X114.294 Z-0.001 I-0.005 K-57.15
                                                  G01 X117.994 Z-0.001
    """

    name = "parametric"

    def fit(self, measurements: Measurements) -> None:
        traces = self._traces(measurements)
        samples = ballbar_fit.Samples.of(traces)
        limit = self.settings["max-uncertainty"]
        result, self.joined = fit_sides(samples, samples.x - self.centre[0], samples.z - self.centre[1], limit)
        ballbar_fit.require(result, limit=limit)
        fitted = result.estimates()
        for axis in self.joined:
            fitted.update(dict.fromkeys(SIDES[axis], fitted.pop(f"scaling_{axis}")))
        self.parameters = {name: fitted[name] for name in FITTED}
        self.setup_centres = [result.centre(mount) for mount in range(len(samples.groups))]
        self.setup_centre = self.setup_centres[0]
        self._score(traces)

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
                "setup_centre_mm": [[e.value, e.sigma] for e in self.setup_centre],
                "setup_centres_mm": [[[e.value, e.sigma] for e in centre] for centre in self.setup_centres],
                "one_scaling": self.joined, "fit": self.fit_figures}

    def load(self, model: dict[str, Any]) -> None:
        try:
            self._load_extent(model)
            self.parameters = {name: Estimate(float(model["parameters"][name][0]), float(model["parameters"][name][1]))
                               for name in FITTED}
            self.setup_centre = tuple(Estimate(float(v), float(s)) for v, s in model["setup_centre_mm"])
            self.setup_centres = [tuple(Estimate(float(v), float(s)) for v, s in centre)
                                  for centre in model.get("setup_centres_mm", [model["setup_centre_mm"]])]
            self.joined = {str(axis): str(why) for axis, why in dict(model.get("one_scaling", {})).items()}
        except (KeyError, IndexError, TypeError, ValueError) as exc:
            raise ModelError(f"{self.name}: the saved model is incomplete ({exc.__class__.__name__}: {exc})") from None
        if not all(np.isfinite([e.value for e in self.parameters.values()])):
            raise ModelError(f"{self.name}: the saved model has parameters that are not finite numbers")

    def report(self) -> dict[str, Any]:
        fitted = {name: {"value": e.value, "sigma": e.sigma} for name, e in self.parameters.items()}
        fitted["servo_mismatch"]["applied"] = False
        for axis, why in self.joined.items():
            for name in SIDES[axis]:
                fitted[name]["one_scaling_for_the_axis"] = why
        return {**super().report(), "parameters": fitted,
                "setup_centre_mm": {"x": self.setup_centre[0].value, "z": self.setup_centre[1].value},
                "setup_centres_mm": [{"x": x.value, "z": z.value} for x, z in self.setup_centres]}


@hookimpl
def postproc_compensators():
    return [Parametric]
