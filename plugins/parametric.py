"""parametric: per-axis error functions fitted to ballbar tests (Kakino), on every feed move.

What it shares with ``effective-angle`` (the tests, their screening, the box the arcs span,
the extrapolation rule, predicting the traces back) is :mod:`postproc.corrections.error_functions`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from postproc.measure.parameters import Estimate, check_fitted, check_saved
from postproc.compensator import Measurements
from postproc.diagnostics import Location, ModelError
from postproc.corrections.error_functions import ErrorFunctions
from postproc.hookspecs import hookimpl

if TYPE_CHECKING:  # imported where traces are fitted: a saved model's run loads without the fit
    from postproc.measure import ballbar_fit


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
    from postproc.measure import ballbar_fit  # the fitting: a saved model's run loads without it

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
    set-up centres put back; :mod:`postproc.measure.ballbar_fit`), the columns being the bar's reading
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
        from postproc.measure import ballbar_fit  # the fitting: a saved model's run loads without it

        traces = self._traces(measurements)
        samples = ballbar_fit.Samples.of(traces)
        limit = self.settings["max-uncertainty"]
        result, self.joined = fit_sides(samples, samples.x - self.centre[0], samples.z - self.centre[1], limit)
        ballbar_fit.require(result, limit=limit)
        fitted = result.estimates()
        for axis in self.joined:
            fitted.update(dict.fromkeys(SIDES[axis], fitted.pop(f"scaling_{axis}")))
        self.parameters = {name: fitted[name] for name in FITTED}
        if not self.context.force:  # --force applies traces refused for a wrong radius or unit, as it says
            check_fitted(self.name, self.parameters, Location(traces[0].path))
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
        check_saved(self.name, self.parameters)

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
