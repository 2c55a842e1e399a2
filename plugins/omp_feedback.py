"""omp-feedback: the surface an earlier pass left, probed on the machine, reflected about the nominal."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Iterable

import numpy as np

from postproc.compensator import STOCK_MM, Option, Piece
from postproc.diagnostics import Location, MeasurementError
from postproc.measure.features import MIN_TOUCHES, Feature, owners
from postproc.measure.figures import figures
from postproc.geometry import Line, Profile
from postproc.hookspecs import hookimpl
from postproc.interpret.motion import Move
from postproc.corrections.probed import Evidence, ProbeCompensator, ProbedChain, move_key

END_SNAP = 0.01  #: mm: a touch this close to the end of its feature covers it to that end, whatever the spacing
SMOOTH_DEG = 10.0  #: a join where the tangent turns less than this is smooth: the error is interpolated across it
SLOPE_SIGMAS = 3.0  #: a line's fitted slope is kept only beyond this many standard errors
SLOPE_MM = 0.0005  #: and only when it changes the error by more than this over the feature
CORRECTED, THIN, OUTSIDE = "corrected", "too few touches", "outside the probed stretch"


def line_fit(s: np.ndarray, e: np.ndarray) -> tuple[float, float, str]:
    """(level at the mean s, slope, how): the error along a line feature as a straight line, its
    slope kept only where the touches show it (beyond SLOPE_SIGMAS standard errors and SLOPE_MM
    over their span), else their mean: a diameter stays a diameter, a face a face."""
    centre = float(s.mean())
    level = float(e.mean())
    spread = float(((s - centre) ** 2).sum())
    if len(s) < 3 or spread <= 0.0:
        return level, 0.0, "mean"
    slope = float(((s - centre) * (e - level)).sum() / spread)
    residual = e - level - slope * (s - centre)
    error = float(np.sqrt((residual @ residual) / (len(s) - 2) / spread))
    span = float(s.max() - s.min())
    if abs(slope) > SLOPE_SIGMAS * error and abs(slope) * span > SLOPE_MM:
        return level, slope, "straight line"
    return level, 0.0, "mean"


@dataclass(frozen=True)
class FeatureError:
    """The error along one feature, from its own touches: what ``omp-feedback`` takes out there."""

    feature: Feature
    s: np.ndarray  #: mm along the chain, increasing: the touches' places (touches at one place averaged)
    error: np.ndarray  #: mm along the outward normal at ``s``: deviation minus stock, cleaned (a line: fitted)
    start: float  #: mm along the chain where the correction starts: the feature's start, or its first touch
    end: float  #: and where it ends
    how: str  #: "interpolated" (an arc), "straight line" or "mean" (a line)
    slope: float = 0.0  #: a line's fitted slope, mm per mm along it

    @classmethod
    def of(cls, probed: ProbedChain, evidence: Evidence, stock: float) -> "FeatureError":
        """From the feature's touches: an arc's error interpolated between them, a line's fitted
        (:func:`line_fit`); the correction runs to the feature's ends, except where the chain's
        probed stretch ends inside it: there it covers the feature to its end only if the gap is
        no wider than its touches lie apart."""
        feature, members = evidence.feature, evidence.members
        near = probed.deviations.nearest.s[members]
        places, inverse = np.unique(np.round(near, 9), return_inverse=True)
        error = np.bincount(inverse, weights=probed.cleaned[members] - stock) / np.bincount(inverse)
        how, slope = "interpolated", 0.0
        if feature.radius is None:
            level, slope, how = line_fit(places, error)
            error = level + slope * (places - places.mean())
        spacing = (places[-1] - places[0]) / max(len(members) - 1, 1)
        reach = max(END_SNAP, spacing)
        first, last = probed.span
        start = feature.s0 if feature.s0 >= first - 1e-9 or places[0] - feature.s0 <= reach else float(places[0])
        end = feature.s1 if feature.s1 <= last + 1e-9 or feature.s1 - places[-1] <= reach else float(places[-1])
        return cls(feature, places, error, start, end, how, slope)

    def outer(self, at_end: bool) -> tuple[float, float]:
        """(s, e) of the outermost touch at one end."""
        k = -1 if at_end else 0
        return float(self.s[k]), float(self.error[k])

    def extended(self, at_end: bool) -> float:
        """The error at the feature's end: an arc's held, a line's fitted line carried on."""
        s, e = self.outer(at_end)
        return e + self.slope * ((self.feature.s1 if at_end else self.feature.s0) - s)


class ChainErrors:
    """The correction along one probed chain: each feature from its own touches, or left alone.

    Where two corrected features meet at a corner, both are carried to where the moved
    features meet (their tangent lines at the corner, each moved by its own error along its
    own normal), so the path turns there with no step and no axis turning back; across a
    smooth join (a tangent join, or a turn under 10 deg, where the error does not step) the
    error is interpolated between the nearest touches on either side. A corrected feature
    meeting one left alone at a corner is carried onto the other's nominal line. Points slide
    along the features to get there: that moves no surface.
    """

    def __init__(self, probed: ProbedChain, stock: float, minimum: int):
        self.probed = probed
        self.profile: Profile = probed.chain.profile
        self.side = probed.side
        self.status: list[str] = []
        self.errors: list[FeatureError | None] = []
        for evidence in probed.evidence():
            if evidence.count >= minimum:
                self.errors.append(FeatureError.of(probed, evidence, stock))
                self.status.append(CORRECTED)
            else:
                self.errors.append(None)
                self.status.append(THIN if evidence.count or probed.covers(evidence.feature) else OUTSIDE)
        found = probed.chain.features
        self.owner = owners(found)
        count = len(found)
        # per feature: the knots its error is interpolated through, and where each end meets its neighbour
        self.knots: list[tuple[np.ndarray, np.ndarray] | None] = []
        self.ends: list[list[np.ndarray | None]] = [[None, None] for _ in range(count)]
        for k, mine in enumerate(self.errors):
            if mine is None:
                self.knots.append(None)
            elif mine.how != "interpolated":  # a line: its fitted line, end to end
                feature = found[k]
                self.knots.append((np.array([feature.s0, feature.s1]),
                                   np.array([mine.extended(False), mine.extended(True)])))
            else:
                self.knots.append(self._arc_knots(k, mine, found))
        for k in range(count - 1):
            self._corner(k, found[k], found[k + 1])

    def _arc_knots(self, k: int, mine: FeatureError, found: tuple[Feature, ...]) -> tuple[np.ndarray, np.ndarray]:
        """An arc's error through its touches, on to each end: across a smooth join to the
        neighbour (a line's fitted value at the join, an arc's nearest touch), else held."""
        s, e = list(mine.s), list(mine.error)
        for at_end, other in ((False, k - 1), (True, k + 1)):
            feature = found[k]
            edge = feature.s1 if at_end else feature.s0
            neighbour = self.errors[other] if 0 <= other < len(found) else None
            angle = feature.turn_out if at_end else feature.turn_in
            if neighbour is not None and angle is not None and abs(angle) < math.radians(SMOOTH_DEG):
                if neighbour.how == "interpolated":
                    place, value = neighbour.outer(not at_end)
                else:
                    place, value = edge, neighbour.extended(not at_end)
            else:
                place, value = edge, mine.extended(at_end)
            if at_end:
                s.append(place)
                e.append(value)
            else:
                s.insert(0, place)
                e.insert(0, value)
        return np.array(s), np.array(e)

    def _outward(self, index: int, param: float) -> np.ndarray:
        return self.side * self.profile.left_normals(np.array([index]), np.array([param]))[0]

    def _error_at(self, k: int, s: float) -> float:
        s_knots, e_knots = self.knots[k]
        return float(np.interp(s, s_knots, e_knots))

    def _corner(self, k: int, before: Feature, after: Feature) -> None:
        """Where features ``k`` and ``k + 1`` meet once moved: both ends' displacement.

        At a sharp corner each keeps its own error and the two moved tangent lines meet; across
        a smooth join with an arc the errors agree there, and the point moves along the mean
        of the two normals; a feature left alone stays on its nominal line."""
        mine, theirs = self.errors[k], self.errors[k + 1]
        reaches_a = mine is not None and mine.end == before.s1
        reaches_b = theirs is not None and theirs.start == after.s0
        if not (reaches_a or reaches_b):
            return
        angle = before.turn_out
        n_a, n_b = self._outward(before.stop - 1, 1.0), self._outward(after.first, 0.0)
        e_a = self._error_at(k, before.s1) if reaches_a else 0.0
        e_b = self._error_at(k + 1, after.s0) if reaches_b else 0.0
        sharp = abs(angle) >= math.radians(SMOOTH_DEG)
        if not sharp and (mine is None or theirs is None or not (reaches_a and reaches_b)):
            return  # nearly parallel: a moved feature and one left alone do not meet; the core joins them
        if sharp or (mine.how != "interpolated" and theirs.how != "interpolated" and abs(math.sin(angle)) > 1e-3):
            meet = np.linalg.solve(np.array([n_a, n_b]), -np.array([e_a, e_b]))
        else:  # the same error on both sides: along the mean of the two normals, as far as both need
            meet = -0.5 * (e_a + e_b) * (n_a + n_b) / (1.0 + float(n_a @ n_b))
        self.ends[k][1] = meet
        self.ends[k + 1][0] = meet

    def shift(self, index: int, points: np.ndarray) -> np.ndarray | None:
        """-e along the outward normal at points of segment ``index``, plus the slide along the
        feature that takes its ends to where it meets its neighbours; zero off the corrected
        stretch of its feature; None when none of the points is on it."""
        k = int(self.owner[index])
        found, ends = self.errors[k], self.ends[k]
        segment = self.profile.segments[index]
        if found is None and (isinstance(segment, Line) or ends == [None, None]):
            return None  # a line left alone: its start or end may move along it, which the core does
        t = np.clip(segment.param_of(points), 0.0, 1.0)
        s = self.profile.offsets[index] + t * segment.length
        tangent = segment.tangent_at(t)
        outward = self.side * np.column_stack([-tangent[:, 1], tangent[:, 0]])
        if found is None:
            inside = np.ones(len(s), dtype=bool)
            e = np.zeros(len(s))
        else:
            inside = (s >= found.start - 1e-9) & (s <= found.end + 1e-9)
            if not inside.any():
                return None
            e = np.where(inside, np.interp(s, *self.knots[k]), 0.0)
        feature = self.probed.chain.features[k]
        slide = np.zeros(len(s))
        for at_end, meet in enumerate(ends):
            if meet is not None:  # the meeting point's share along the feature, growing towards its end
                share = (s - feature.s0) / feature.length if at_end else (feature.s1 - s) / feature.length
                edge = self.profile.segments[feature.stop - 1 if at_end else feature.first]
                slide += share * float(meet @ np.asarray(edge.direction_at(float(at_end))))
        return np.where(inside[:, None], -e[:, None] * outward + slide[:, None] * tangent, 0.0)


class OmpFeedback(ProbeCompensator):
    """Reflect the profile about the nominal by the error an earlier pass left (docs/methods.md §9.6, §4).

    What it corrects: everything that put the surface of an earlier pass of the same profile
    where it is: machine errors, tool setting, cutting deflection, as the on-machine probe
    saw them. Each touch is assigned to the nearest feed segment of the program (lines and
    arcs: any chain of connected feed moves, G70 contours as G70 runs them), so to the
    feature it lies on (a line or an arc; features meet at corners, where the tangent turns,
    or at tangent joins). Its error is ``e = deviation - stock`` along the outward normal.

    Per feature, never across a corner: the error a cut leaves steps at a corner (a tool set
    long in X makes a diameter big and leaves a face alone), so each feature is corrected from
    its own touches only. They are screened for the nub and stray touches against each other
    (``postproc.measure.screening``). Along an arc ``e`` is interpolated between them; along a line it
    is fitted with a straight line, whose slope is kept only where the touches show it (beyond
    3 standard errors and 0.5 um over their span), else their mean: a diameter stays a
    diameter and a face a face, so an axis that stood still still does (no backlash turned
    over, a G71 contour still one way). The path moves by ``-e`` along the feature's own
    outward normal (a face along Z, a diameter along X), out to the feature's ends: at a corner
    both features are carried to where they meet once moved, so the path turns there without
    a step or an axis turning back; across a smooth join (tangent, or turning under 10 deg) an
    arc's error runs on to its neighbour's. The correction covers the stretch the touches cover
    (from the first to the last touch) and nowhere else; where that stretch ends inside a
    feature, it reaches the feature's end only when the gap is no wider than the feature's
    touches lie apart (0.01 mm at least).

    Minimum evidence: 3 touches per feature, the fewest among which one bad touch shows. A
    feature in the probed stretch with fewer (none, or 1 or 2 that cannot be screened) is left
    as programmed, with a warning naming it and its rows; when no feature has 3, the run is
    refused (exit 3). ``postproc probe-program`` gives every feature at least 3.

    What it needs: ``--probe`` with one probe file taken on the earlier pass, and preferably
    ``--calibration`` (the pretravel on the sphere artifact; without it k = 0, with a
    warning). When the file has a datum probed before and after, a datum that moved by more
    than ``repeatability_mm`` refuses the run (exit 4; ``--force`` uses the points anyway).
    Each dropped touch (the nub at the pole, a stray one) is warned about and listed in the
    report with what replaced it; the report gives, per chain and per feature, the four
    figures of the error as measured and as cleaned.

    Options: ``stock=MM`` (default 0): how far outside this program's profile the earlier
    pass was cut; 0 when the same path is cut again.

    Example: the sample files (``samples/probe/``: the surface reads 11.5 um high on average,
    the nub at the pole 28 um) on ``samples/programs/hemishell.nc``, stock 0::

        G01 Z57.15 F0.08                      G01 X0. Z57.143 F0.08
        G03 X114.3 Z0. I0. K-57.15      ->    G03 X80.556 Z40.526 I-0.011 K-57.15
                                              X95.883 Z31.085 I-40.334 K-40.571
                                              X109.606 Z16.166 I-47.98 K-31.104
                                              X114.278 Z0. I-54.89 K-16.184

    Where the correction ends inside a move, it comes in over the core's sample spacing
    (0.05 mm) next to the end touch.
    """

    name = "omp-feedback"
    minimum = MIN_TOUCHES
    options = (Option("stock", float, 0.0, "how far outside this program's profile the probed pass was cut, mm",
                      largest_mm=STOCK_MM),)

    def survey(self, moves: Iterable[Move]) -> None:
        self.probed = self.probed_chains(moves)
        thin = self.thin(self.probed, self.minimum, "left as programmed")
        self.chains = [ChainErrors(probed, self.settings["stock"], self.minimum) for probed in self.probed]
        if not any(CORRECTED in chain.status for chain in self.chains):
            where = "; ".join(evidence.describe() for evidence in thin)
            raise MeasurementError(f"no feature of the profile has the {self.minimum} touches {self.name} needs to "
                                   f"screen them for the nub and outliers ({where}): probe each feature at "
                                   f"{self.minimum} points or more ('postproc probe-program' spreads them so)",
                                   Location(self.probe.path))
        self._places: dict[tuple, list[tuple[int, int]]] = {}  # move -> (chain, segment of its chain)
        for number, probed in enumerate(self.probed):
            for index, move in enumerate(probed.chain.moves):
                self._places.setdefault(move_key(move), []).append((number, index))

    def correct(self, piece: Piece) -> np.ndarray | None:
        for number, index in self._places.get(move_key(piece.move), ()):
            shift = self.chains[number].shift(index, piece.points)
            if shift is not None:
                return shift
        return None

    def report(self) -> dict[str, Any]:
        stock = self.settings["stock"]
        chains = []
        for probed, chain in zip(self.probed, getattr(self, "chains", [])):
            corrected = [found for found in chain.errors if found is not None]
            chains.append({"moves": probed.chain.lines, "tool": probed.chain.tool, "points": len(probed.index),
                           "stretch_mm": [min(f.start for f in corrected), max(f.end for f in corrected)]
                           if corrected else [], "length_mm": probed.chain.profile.length,
                           "measured_error_um": figures(probed.deviation - stock).as_dict(),
                           "cleaned_error_um": figures(probed.cleaned - stock).as_dict(),
                           "dropped": probed.dropped(),
                           "features": [_feature_report(probed, evidence, status, found, stock)
                                        for evidence, status, found in zip(probed.evidence(), chain.status,
                                                                           chain.errors)]})
        return {**super().report(), "stock_mm": stock, "minimum_touches_per_feature": self.minimum, "chains": chains}


def _feature_report(probed: ProbedChain, evidence: Evidence, status: str, found: FeatureError | None,
                    stock: float) -> dict[str, Any]:
    feature = evidence.feature
    entry: dict[str, Any] = {"feature": feature.describe(), "lines": list(feature.lines or ()), "kind": feature.kind,
                             "s_mm": [feature.s0, feature.s1], "touches": evidence.count, "rows": list(evidence.rows),
                             "status": status}
    if evidence.count:
        members = evidence.members
        entry["measured_error_um"] = figures(probed.deviation[members] - stock).as_dict()
        entry["cleaned_error_um"] = figures(probed.cleaned[members] - stock).as_dict()
    if found is not None:
        entry["corrected_mm"] = [found.start, found.end]
    return entry


@hookimpl
def postproc_compensators():
    return [OmpFeedback]
