"""error-map: a smooth error map over the working plane, fitted to ballbar tests, on every feed move."""

from __future__ import annotations

from typing import Any, Iterable, Sequence

import numpy as np

from postproc.measure import ballbar_fit, error_map
from postproc.measure.ballbar_analysis import Estimate, check_saved, paired, screen
from postproc.measure.parameters import check_fitted
from postproc.compensator import MAX_UNCERTAINTY_MM, STOCK_MM, Compensator, Measurements, Option, Piece
from postproc.diagnostics import Location, MeasurementError, ModelError, SafetyError
from postproc.measure.figures import figures
from postproc.hookspecs import hookimpl
from postproc.measure.readers.probe import ProbeFile
from postproc.interpret.motion import Move
from postproc.corrections.probed import ProbeCompensator
from postproc.measure.probing import check_datum

OTHERS = ("backlash_x", "backlash_z", "servo_mismatch")  #: fitted beside the field; servo mismatch is not applied
MOVES_REPORTED = 500  #: the report lists the uncertainty of at most this many corrected moves


class _Placer(ProbeCompensator):
    """Places a CMM's touches on the program's feed moves, screened per feature (postproc.corrections.probed)."""

    name = "error-map"


class ErrorMap(Compensator):
    """Fit a smooth error map e_x(x, z), e_z(x, z) and backlash to ballbar tests (any number, any arc); correct every feed move inside the measured region (docs/methods.md §16).

    What it corrects: the machine's position error wherever the tool goes inside the region
    the tests measured, including errors no per-axis function holds (a bowed Z slide moving X,
    a Z error that grows with X), with each axis's backlash by its direction of travel:

        e_x = f_x(x, z) - (b_x / 2) d_x,    e_z = f_z(x, z) - (b_z / 2) d_z

    f_x and f_z are cubic tensor-product B-splines over the box the tests span. The correction
    is minus the error.

    How it is fitted (:mod:`postproc.measure.error_map`): one penalised least-squares fit to every trace
    as measured (the removed set-up centres put back), the columns being the bar's reading of
    each basis function, the backlash, the servo mismatch (fitted so that it biases nothing,
    reported, not applied: it grows with the feed) and each test's set-up centre. Two
    roughness penalties keep the map smooth between the arcs: one on the bending of each error
    along each axis, one on how far the map departs from a sum of per-slide errors; REML
    chooses both weights. A ballbar cannot see a rigid motion of the map, so the map is zero
    at the first test's centre, where ``d e_z / d x`` is zero too (squareness taken as X error
    along Z, as ``parametric`` takes it); with tests about two centres only, one bending of the
    map (``(x^2 - z^2)/2, x z`` about their line) is not seen either and is left to the
    penalty (docs/methods.md §16.2).

    ``--probe``: deviations of a part this program cut, measured independently of the
    machine's axes (a CMM, in the probe file's form, docs/formats.md §5; an on-machine probe
    reads through the same axes, so the machine's errors cancel in its readings). They fix the
    rigid motion the ballbar cannot see (translation and rotation; a mode the part's normals
    cannot fix, a plain cylinder's Z, stays at the gauge, with a warning); the shape stays the
    ballbar's, so cutting effects in the part do not bend the map. ``stock=MM``: how far
    outside this program's profile the measured part was cut.

    What it needs (the minimum evidence): ``--ballbar`` with a CCW and a CW trace of each test
    (any number of tests; the traces of one circle share a set-up centre), each of at least 36
    samples over 90 deg of arc. The backlash, the servo mismatch and the map anywhere inside its
    support must come out with a 3-sigma within ``--option max-uncertainty=MM`` (0.005), or the
    fit is refused naming the arcs. Traces that read like swapped ccw/cw labels, a radius that
    is not the bar's, or a wrong unit are refused unless ``--force``.

    The support: the convex hull of every sample's commanded position (and of the probe's
    touches): inside it the map interpolates between measured arcs; a move that leaves it by
    more than 0.05 mm is refused (exit 4) naming its line, unless ``--option
    extrapolate=true``. The report gives the support, the fit's residual for each trace (the
    trace predicted back), the chosen weights and degrees of freedom, and the map's 1-sigma
    uncertainty at every corrected move.
    """

    name = "error-map"
    takes = ("ballbar", "probe")
    needs = ("ballbar",)
    options = (
        Option("extrapolate", bool, False, "correct moves outside the region the measurements support"),
        Option("max-uncertainty", float, ballbar_fit.EFFECT_LIMIT_MM,
               "largest 3-sigma (mm) of the backlash, the servo mismatch and the map inside its support", positive=True,
               largest_mm=MAX_UNCERTAINTY_MM),
        Option("stock", float, 0.0, "with --probe: how far outside this program's profile the measured part was cut",
               largest_mm=STOCK_MM),
        Option("residual", float, None, "with --probe: the largest RMS residual of the probed part after the map and a "
               "rigid motion, mm (default 3 x the probe file's repeatability_mm, or 0.003)", positive=True,
               largest_mm=0.1),
    )

    field: error_map.Field
    support: error_map.Support

    def fit(self, measurements: Measurements) -> None:
        traces = list(measurements.ballbar)
        ordered = [trace for test in paired(traces, self.name) for trace in test]
        screen(traces, self.context.reporter, self.context.force, self.name)
        samples = ballbar_fit.Samples.of(ordered)
        positions = np.column_stack([samples.x, samples.z])
        self._probe(measurements.probe)
        if self.probe is not None:
            positions = np.concatenate([positions, self.probe.touched()])
        self.support = error_map.Support.of(positions)
        basis = error_map.Basis.over(self.support.box())
        gauge = ordered[0].centre
        result = error_map.fit_map(samples, basis, ballbar_fit.machine_errors(samples, OTHERS), gauge)
        self.field, self.gauge = result.field, result.gauge
        self.parameters = {name: result.estimate(name) for name in OTHERS}
        if not self.context.force:
            check_fitted(self.name, self.parameters, Location(ordered[0].path))
        self.setup_centres = [tuple(float(v) for v in centre) for centre in result.centres]
        self.regularisation = {"chosen_by": "REML", "weight_main": result.weights[0],
                               "weight_interaction": result.weights[1], "effective_parameters": result.edf,
                               "residual_sigma_um": result.sigma * 1000.0}
        self.fit_figures = {trace.path: figures(result.residuals[samples.of_trace(i) & result.used]).as_dict()
                            for i, trace in enumerate(ordered)}
        self.fit_figures["all"] = figures(result.residuals[result.used]).as_dict()
        self._hold(ordered, samples, result.residuals)

    def _probe(self, probes: Sequence[ProbeFile]) -> None:
        """The CMM's touches, datum-checked; placed on the program when it is surveyed."""
        self.probe, self.rigid_motion, self.notes, self._rigid = None, None, [], None
        self.needs_survey = bool(probes)
        if not probes:
            return
        if len(probes) > 1:
            raise MeasurementError(f"{self.name} takes one probe file; {len(probes)} given", Location(probes[1].path))
        self.probe = probes[0]
        if len(self.probe.centres) < 3:
            raise MeasurementError(f"{self.name}: {len(self.probe.centres)} touches cannot fix a translation and a "
                                   "rotation; 3 at least", Location(self.probe.path))
        self.notes = check_datum(self.probe, self.context.force, self.context.reporter)

    def _hold(self, traces, samples: ballbar_fit.Samples, residuals: np.ndarray) -> None:
        """Refuse a fit whose backlash, servo mismatch or map (inside its support) is not determined,
        naming a spike in a trace when there is one (it is then the cause)."""
        limit = self.settings["max-uncertainty"]
        vague = [f"{ballbar_fit.label(name)} +-{3.0 * e.sigma * (0.5 if name.startswith('backlash') else 1.0) * 1000:.2f} um"
                 for name, e in self.parameters.items()
                 if 3.0 * e.sigma * (0.5 if name.startswith("backlash") else 1.0) > limit]
        worst, where = self.largest_sigma()
        if 3.0 * worst > limit:
            vague.append(f"the map +-{3.0 * worst * 1000:.2f} um at x {where[0]:.1f}, z {where[1]:.1f} mm")
        if vague:
            found = ballbar_fit.spike(samples, residuals)
            if found is not None:
                raise MeasurementError(f"{self.name}: the map is not determined, and the likely cause is a spike: "
                                       f"{found[0]}", found[1])
            raise MeasurementError(
                f"{self.name}: on {ballbar_fit.arcs_text(traces)}, {'; '.join(vague)} (3 sigma) "
                f"{'is' if len(vague) == 1 else 'are'} above {limit * 1000:g} um: measure "
                f"{ballbar_fit.more_evidence(traces, 'tests about more centres')} (--option max-uncertainty=MM allows "
                "more)", Location(traces[0].path))

    def largest_sigma(self) -> tuple[float, tuple[float, float]]:
        """The largest 1-sigma of either component at the uncertainty grid's points inside the support."""
        f = self.field
        x, z = np.meshgrid(f.grid_x, f.grid_z, indexing="ij")
        inside = self.support.outside(np.column_stack([x.ravel(), z.ravel()]), 0.0) == 0.0
        both = np.maximum(f.sigma_x, f.sigma_z).ravel()
        if not inside.any():
            return 0.0, self.gauge
        index = np.flatnonzero(inside)[int(np.argmax(both[inside]))]
        return float(both[index]), (float(x.ravel()[index]), float(z.ravel()[index]))

    # -- a cut part's deviations: the rigid motion the ballbar cannot see ---------------------------

    def survey(self, moves: Iterable[Move]) -> None:
        if self.probe is None:
            return
        placer = _Placer(self.context)
        placer.probe, placer.touched = self.probe, self.probe.touched()
        points, normals, deviations, directions = [], [], [], []
        for chain in placer.probed_chains(moves):
            near = chain.deviations.nearest
            points.append(near.foot)
            normals.append(chain.deviations.outward)
            deviations.append(chain.screening.deviation - self.settings["stock"])
            directions.append(axis_directions(chain.chain.profile.segments, near.index, near.param))
        points, normals = np.concatenate(points), np.concatenate(normals)
        deviations, directions = np.concatenate(deviations), np.concatenate(directions)
        # what the cut left: the map's error with the backlash of the way the cut went
        backlash = -0.5 * np.column_stack([self.parameters["backlash_x"].value * directions[:, 0],
                                           self.parameters["backlash_z"].value * directions[:, 1]])
        deviations = deviations - np.sum(backlash * normals, axis=1)
        motion, sigma, residuals, unfixed = error_map.rigid_fit(self.field, self.gauge, points, normals, deviations)
        self.rigid_motion = {"translation_x_mm": float(motion[0]), "translation_z_mm": float(motion[1]),
                             "rotation_rad": float(motion[2]),
                             "sigma": {"translation_x_mm": float(sigma[0]), "translation_z_mm": float(sigma[1]),
                                       "rotation_rad": float(sigma[2])},
                             "unfixed": list(unfixed), "touches": int(len(points)),
                             "residual_um": figures(residuals).as_dict()}
        self._check_fits(residuals, motion)
        self._rigid = error_map.rigid(self.field.basis, self.gauge) @ motion
        if unfixed:
            self.context.reporter.warn(
                f"{self.name}: the probed part's normals cannot fix {', '.join(unfixed)} of the map: "
                "that stays at the gauge (zero at the first test's centre); probe features facing other ways "
                "(a face and a diameter) to fix it", Location(self.probe.path))

    def _check_fits(self, residuals: np.ndarray, motion: np.ndarray) -> None:
        """The touches must be of a part this program cut: after the map and a rigid motion they
        lie within the probe's repeatability. A model keeps its probe file's touches, and laid
        on another program (a radius 50 um smaller) they read as a 50 um motion of the machine."""
        rms = float(np.sqrt(np.mean(np.square(residuals)))) if len(residuals) else 0.0
        allowed = self.settings["residual"]
        if allowed is None:
            allowed = 3.0 * self.probe.repeatability if self.probe.repeatability is not None else 0.003
        if rms <= allowed:
            return
        text = (f"{self.name}: the probed part's touches do not fit this program: after the map and a rigid motion "
                f"({motion[0] * 1000:+.2f} um in X, {motion[1] * 1000:+.2f} um in Z) an RMS residual of {rms * 1000:.2f} "
                f"um is left, beyond the {allowed * 1000:.2f} um allowed (--option residual at fit time): were they "
                "measured on a part this program cut?")
        self.context.refuse(text, "fit the map without --probe for other programs", Location(self.probe.path))

    # -- the correction -----------------------------------------------------------------------------

    def correct(self, piece: Piece) -> np.ndarray | None:
        return self.correct_many([piece])[0]

    def correct_many(self, pieces: Sequence[Piece]) -> list[np.ndarray | None]:
        counts = [len(piece.t) for piece in pieces]
        ends = np.cumsum(counts)
        points = np.concatenate([piece.points for piece in pieces]) if len(pieces) > 1 else pieces[0].points
        if not self.settings["extrapolate"]:
            outside = self.support.outside(points)
            if outside.any():
                first = int(np.flatnonzero(outside)[0])
                piece = pieces[int(np.searchsorted(ends, first, side="right"))]
                (x0, x1), (z0, z1) = self.support.box()
                raise SafetyError(
                    f"{self.name}: the move on line {piece.move.line} leaves the region the measurements support by "
                    f"{outside.max():.3f} mm at x {points[first, 0]:.3f}, z {points[first, 1]:.3f} (the hull of the "
                    f"tests' arcs, within x {x0:g} .. {x1:g}, z {z0:g} .. {z1:g} mm); measure there, compensate only the "
                    "blocks inside it (--region), or fit the map with --option extrapolate=true (a saved model "
                    "keeps the options it was fitted with)")
        field = self.field if self._rigid is None else self.field.shifted(self._rigid)
        e_x, e_z = field.errors(points[:, 0], points[:, 1])
        x_direction = np.repeat(np.array([piece.x_direction for piece in pieces], dtype=float), counts)
        z_direction = np.repeat(np.array([piece.z_direction for piece in pieces], dtype=float), counts)
        shift = np.column_stack([-(e_x - 0.5 * self.parameters["backlash_x"].value * x_direction),
                                 -(e_z - 0.5 * self.parameters["backlash_z"].value * z_direction)])
        sx, sz = self.field.sigma(points[:, 0], points[:, 1])
        largest = np.maximum.reduceat(np.maximum(sx, sz), np.concatenate([[0], ends[:-1]]))
        for piece, sigma in zip(pieces, largest.tolist()):
            line = piece.move.line
            self.uncertainty[line] = max(self.uncertainty.get(line, 0.0), sigma)
        return [shift[end - count: end] for end, count in zip(ends.tolist(), counts)]

    @property
    def uncertainty(self) -> dict[int, float]:
        """The largest 1-sigma of the map (either component, mm) on each corrected move, by line."""
        if "_uncertainty" not in self.__dict__:
            self._uncertainty: dict[int, float] = {}
        return self._uncertainty

    def predicted(self, trace) -> np.ndarray:
        """The reading the map predicts on a trace's commanded test, without a set-up centre."""
        samples = ballbar_fit.Samples.of([trace])
        e_x, e_z = self.field.errors(samples.x, samples.z)
        e_x = e_x - 0.5 * self.parameters["backlash_x"].value * samples.dx
        e_z = e_z - 0.5 * self.parameters["backlash_z"].value * samples.dz
        return e_x * samples.cos + e_z * samples.sin

    # -- saved models and reports -----------------------------------------------------------------

    def model(self) -> dict[str, Any]:
        saved = {"field": self.field.as_dict(), "gauge_mm": list(self.gauge),
                 "support_mm": self.support.vertices.tolist(),
                 "parameters": {name: [e.value, e.sigma] for name, e in self.parameters.items()},
                 "setup_centres_mm": [list(c) for c in self.setup_centres], "regularisation": self.regularisation,
                 "fit": self.fit_figures}
        if self.probe is not None:
            placer = _Placer(self.context)
            placer.probe, placer.touched, placer.notes = self.probe, self.probe.touched(), self.notes
            saved["probe"] = placer.model()
        return saved

    def load(self, model: dict[str, Any]) -> None:
        try:
            self.field = error_map.Field.from_dict(model["field"])
            self.gauge = (float(model["gauge_mm"][0]), float(model["gauge_mm"][1]))
            self.support = error_map.Support.of(np.asarray(model["support_mm"], dtype=float))
            self.parameters = {name: Estimate(float(model["parameters"][name][0]), float(model["parameters"][name][1]))
                               for name in OTHERS}
            self.setup_centres = [tuple(float(v) for v in c) for c in model.get("setup_centres_mm", [])]
            self.regularisation = dict(model.get("regularisation", {}))
            self.fit_figures = dict(model.get("fit", {}))
            self.probe, self.rigid_motion, self.notes, self._rigid = None, None, [], None
            self.needs_survey = "probe" in model
            if self.needs_survey:
                placer = _Placer(self.context)
                placer.load(model["probe"])
                self.probe, self.notes = placer.probe, placer.notes
        except (KeyError, IndexError, TypeError, ValueError) as exc:
            raise ModelError(f"{self.name}: the saved model is incomplete ({exc.__class__.__name__}: {exc})") from None
        check_saved(self.name, self.parameters)
        basis = self.field.basis
        (x0, x1), (z0, z1) = self.support.box()
        if x0 < basis.knots_x[0] or x1 > basis.knots_x[-1] or z0 < basis.knots_z[0] or z1 > basis.knots_z[-1]:
            raise ModelError(f"{self.name}: the saved model's support (x {x0:g} .. {x1:g}, z {z0:g} .. {z1:g} mm) "
                             "reaches beyond its map's knots: the model was edited; fit it again from the traces")

    def report(self) -> dict[str, Any]:
        fitted = {name: {"value": e.value, "sigma": e.sigma} for name, e in self.parameters.items()}
        fitted["servo_mismatch"]["applied"] = False
        worst, where = self.largest_sigma()
        (x0, x1), (z0, z1) = self.support.box()
        lines = sorted(self.uncertainty)[:MOVES_REPORTED]
        return {"parameters": fitted, "gauge_mm": {"x": self.gauge[0], "z": self.gauge[1]},
                "support_mm": {"hull": self.support.vertices.tolist(), "box": {"x": [x0, x1], "z": [z0, z1]}},
                "extrapolate": self.settings["extrapolate"], "regularisation": self.regularisation,
                "fit_residual_um": self.fit_figures, "setup_centres_mm": [{"x": x, "z": z} for x, z in self.setup_centres],
                "map_sigma_um": {"largest_in_support": worst * 1000.0, "at_mm": {"x": where[0], "z": where[1]}},
                "moves": [{"line": line, "sigma_um": self.uncertainty[line] * 1000.0} for line in lines],
                "probe": None if self.probe is None else {"file": self.probe.path, "notes": list(self.notes),
                                                          "rigid_motion": self.rigid_motion}}


def axis_directions(segments, index: np.ndarray, param: np.ndarray) -> np.ndarray:
    """Which way each axis travelled as the tool cut each place (segment, parameter) of a chain,
    (n, 2) of +1, -1: an axis standing still there (X along a diameter) keeps the way it last
    travelled along the chain, where its lost motion left it; 0 where the chain has not said."""
    result = np.zeros((len(index), 2))
    for row, (i, t) in enumerate(zip(np.asarray(index).tolist(), np.asarray(param, dtype=float).tolist())):
        for axis in range(2):
            places = [(i, t), (i, max(t - 1e-6, 0.0))] + [(j, 1.0) for j in range(i - 1, -1, -1)]
            for j, u in places:
                component = segments[j].direction_at(u)[axis]
                if abs(component) > 1e-9:
                    result[row, axis] = np.sign(component)
                    break
    return result


@hookimpl
def postproc_compensators():
    return [ErrorMap]
