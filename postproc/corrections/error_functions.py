"""Per-axis error functions fitted to ballbar tests, applied to every feed move: a public
helper for compensator plugins (``parametric`` and ``effective-angle`` are built on it).

:class:`ErrorFunctions` is a :class:`~postproc.compensate.compensator.Compensator` that leaves one method
to its subclass, ``errors(u, w, x_direction, z_direction)``, and does the rest: takes the tests
(any number, whole circles or partial arcs), screens the traces, keeps the box the arcs span
and the extrapolation rule, corrects every piece's points in one array pass, predicts the
traces back from the model and scores the fit. It imports the contract and the ballbar
analysis only, never the engine, so a shop's plugin may subclass it; the analysis and the fit
only where traces are read, so that a run applying a saved model does not import them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from ..compensate.compensator import MAX_UNCERTAINTY_MM, Compensator, Measurements, Option, Piece
from ..diagnostics import Location, MeasurementError
from ..measure.parameters import EFFECT_LIMIT_MM, bar_length_problem

if TYPE_CHECKING:  # a saved model's run reads no trace
    from ..measure.readers.ballbar import BallbarTrace

__all__ = ["ErrorFunctions"]


class ErrorFunctions(Compensator):
    """Per-axis error functions about a ballbar test's centre, applied to every feed move.

    Subclasses fit ``errors(u, w, x_direction, z_direction) -> (e_x, e_z)``: the error at
    offsets (u, w) = (x - xc, z - zc) from the (first) test's centre with each axis travelling
    the given way (+1, -1, or 0 for not known), all arrays of one value per point. The
    correction is minus the error.

    The tests: any number of traces; the traces of one circle (radius and centre) are one test
    on one mount, with their own set-up centre; a ccw and a cw trace are needed. Before the
    fit they are screened (:func:`postproc.measure.ballbar_analysis.screen`): a machine parameter the
    arcs cannot determine within ``max-uncertainty`` refuses, naming the arc and the parameter;
    results no machine gives (swapped direction labels, a wrong radius or unit) refuse unless
    ``--force``. The box the arcs span (the x and z the bars reached) is where the functions
    are measured.
    """

    takes = ("ballbar",)
    needs = ("ballbar",)
    options = (
        Option("extrapolate", bool, False, "use the error functions beyond the box the test arcs span"),
        Option("max-uncertainty", float, EFFECT_LIMIT_MM,
               "largest 3-sigma effect (mm) of a fitted parameter the arcs must reach", positive=True,
               largest_mm=MAX_UNCERTAINTY_MM),
    )

    centre: tuple[float, float]
    radius: float
    box: tuple[tuple[float, float], tuple[float, float]]
    fit_figures: dict[str, dict[str, float]]
    _warned = False  #: whether this program was warned of its moves outside the box

    def errors(self, u, w, x_direction, z_direction) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError

    def _traces(self, measurements: Measurements) -> list[BallbarTrace]:
        """The traces, screened; sets the reference centre, radius and box."""
        from ..measure import ballbar_fit  # the fitting: a saved model's run loads without it
        from ..measure.ballbar_analysis import screen, tests

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
        self.centre, self.radius = first.centre, first.radius
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
        from ..measure import ballbar_fit  # the fitting: a saved model's run loads without it

        samples = ballbar_fit.Samples.of([trace])
        e_x, e_z = self.errors(samples.x - self.centre[0], samples.z - self.centre[1], samples.dx, samples.dz)
        return e_x * samples.cos + e_z * samples.sin

    def _score(self, traces: Sequence[BallbarTrace]) -> None:
        """Figures of the traces as measured minus the model's prediction, each test about its own
        least-squares centre (the set-up, which the model leaves out)."""
        from ..measure import ballbar_fit  # only where traces are fitted, not for a saved model
        from ..measure.figures import figures

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
        if bar_length_problem(self.radius):
            raise ValueError(f"radius_mm {self.radius:g} is {bar_length_problem(self.radius)}")
        box = model.get("box_mm")
        if box is None:  # a model saved before partial arcs: the square of the whole circle
            (xc, zc), r = self.centre, self.radius
            self.box = ((xc - r, xc + r), (zc - r, zc + r))
        else:
            self.box = ((float(box["x"][0]), float(box["x"][1])), (float(box["z"][0]), float(box["z"][1])))
            if not (self.box[0][0] <= self.box[0][1] and self.box[1][0] <= self.box[1][1]):
                raise ValueError("box_mm: each range must run from low to high")
        self.fit_figures = model.get("fit", {})

    def start(self) -> None:
        """A new program (a batch's next, a library's pipeline's next, after one refused half
        way too) is warned of its own moves outside the box."""
        self._warned = False

    def report(self) -> dict[str, Any]:
        (x0, x1), (z0, z1) = self.box
        return {**self._extent(), "square_mm": {"x": [x0, x1], "z": [z0, z1]},
                "extrapolate": self.settings["extrapolate"], "fit_residual_um": self.fit_figures}
