"""A probe file read against a program's feed moves: what the probe compensators
(``omp-feedback``, ``tool-offset``) share, as a public helper for compensator plugins.

- :func:`chains_of`: the program's feed moves as run (a G70 contour at the G70), split into
  chains of connected moves of one tool, each with its features (:mod:`postproc.measure.features`);
- :class:`ProbeCompensator`: a compensator fitted from one probe file (and optionally a
  calibration): the datum check, the touched points, a saved model, and
  :meth:`~ProbeCompensator.probed_chains`: each touch assigned to the nearest feed segment
  facing its approach, so to the feature it lies on, and screened for the nub and outliers
  against the touches on that feature only (:func:`postproc.measure.probing.screen_by_feature`);
- :meth:`ProbedChain.evidence`: how many touches each feature has, so that a compensator can
  hold every feature to its minimum evidence and name the ones below it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Iterable

import numpy as np

from ..compensate.compensator import Compensator, Measurements
from ..diagnostics import Location, MeasurementError, SafetyError
from ..measure.features import Feature, features
from ..geometry import Profile, segment_of
from ..measure.readers.probe import ProbeFile
from ..interpret.motion import CORNER, REPLAY, RUN, Move
from ..measure.pretravel import fit_calibration
from ..measure.probing import (Deviations, Screened, check_datum, check_on_profile, profile_deviations,
                               screen_by_feature, touched_points)
from ..measure.screening import Screening

JOIN = 1e-6  #: mm: a move starting this close to where the previous one ended continues its chain
RUNS = (RUN, CORNER, REPLAY)  #: roles of moves the control runs where they stand (a G70 runs its contour)


def move_key(move: Move) -> tuple:
    """Which block a move is, whether run where it stands or replayed by G70 (same line, end, centre)."""
    return (move.line, move.x1, move.z1, move.xc, move.zc, move.cw)


@dataclass(frozen=True)
class Chain:
    """Feed moves run one after the other, each starting where the previous one ended, by one tool."""

    moves: tuple[Move, ...]
    profile: Profile
    features: tuple[Feature, ...]

    @property
    def tool(self) -> int | None:
        return self.moves[0].tool

    @property
    def lines(self) -> str:
        return f"lines {self.moves[0].line}-{self.moves[-1].line}"


def chains_of(moves: Iterable[Move]) -> list[Chain]:
    """The program's feed moves (as run: G70 contours at the G70) split into connected chains."""
    chains: list[list[Move]] = []
    for move in moves:
        if move.role not in RUNS or not move.is_feed or not move.known or segment_of(move).length == 0.0:
            continue
        last = chains[-1][-1] if chains else None
        if (last is not None and last.tool == move.tool
                and abs(move.x0 - last.x1) <= JOIN and abs(move.z0 - last.z1) <= JOIN):
            chains[-1].append(move)
        else:
            chains.append([move])
    result = []
    for chain in chains:
        profile = Profile(tuple(segment_of(m) for m in chain))
        result.append(Chain(tuple(chain), profile, features(profile, tuple(m.line for m in chain))))
    return result


@dataclass(frozen=True)
class Evidence:
    """The touches on one feature of a chain."""

    feature: Feature
    members: np.ndarray  #: the touches' places in their :class:`ProbedChain`
    rows: tuple[int, ...]  #: their data rows in the probe file

    @property
    def count(self) -> int:
        return len(self.members)

    def describe(self) -> str:
        """``the face on line 12 has 2 touches (rows 40, 41)``."""
        if not self.count:
            return f"{self.feature.describe()} has no touch"
        rows = ", ".join(str(r) for r in self.rows)
        return f"{self.feature.describe()} has {self.count} touch{'es' if self.count != 1 else ''} (row{'s' if self.count != 1 else ''} {rows})"


@dataclass(frozen=True)
class ProbedChain(Screened):
    """The touches that lie on one chain, against it, each screened against its own feature."""

    chain: Chain
    index: np.ndarray  #: the touches' places in the probe file
    rows: tuple[int, ...]  #: their data rows
    touched: np.ndarray  #: (n, 2) touched points, mm
    deviations: Deviations  #: along the outward normal, positive = material left; ``nearest.s`` along the chain
    screening: Screening
    side: float  #: +1 when the outward normal is the chain's left normal, -1 when its right
    feature: np.ndarray  #: index into ``chain.features`` of each touch's feature

    def evidence(self) -> list[Evidence]:
        """The touches on each feature of the chain, in order (features without touches too)."""
        return [Evidence(f, members, tuple(self.rows[i] for i in members))
                for f, members in ((f, np.flatnonzero(self.feature == k)) for k, f in enumerate(self.chain.features))]

    def covers(self, feature: Feature) -> bool:
        """Whether a feature reaches into the stretch between the first and the last touch."""
        first, last = self.span
        return feature.s1 > first + 1e-9 and feature.s0 < last - 1e-9

    @property
    def span(self) -> tuple[float, float]:
        """Arc length along the chain of the first and the last touch: the stretch they cover."""
        s = self.deviations.nearest.s
        return float(s.min()), float(s.max())

    def dropped(self) -> list[dict[str, Any]]:
        return [{"row": d.row, "kind": d.kind, "deviation_mm": d.deviation, "replacement_mm": d.replacement,
                 "how": d.how} for d in self.screening.dropped]


class ProbeCompensator(Compensator):
    """A compensator fitted from one probe file and optionally a calibration (docs/methods.md §9).

    Subclasses survey the program with :meth:`probed_chains`. The datum is checked when the
    file is read: a datum that moved by more than ``repeatability_mm`` refuses the run
    (exit 4; ``--force`` uses the points anyway), once the touches are found on the program's
    profile (a file in another unit is named as such first) or when the model is saved."""

    takes = ("probe", "calibration")
    needs = ("probe",)
    needs_survey = True
    #: the datum check's refusal (the datum moved), held until the touches meet the program
    unstable: SafetyError | None = None

    def fit(self, measurements: Measurements) -> None:
        probes = measurements.probe
        if len(probes) != 1:
            raise MeasurementError(f"{self.name} takes one probe file; {len(probes)} given", Location(probes[1].path))
        probe = self.probe = probes[0]
        reporter = self.context.reporter
        try:
            self.notes = check_datum(probe, self.context.force, reporter)
        except SafetyError as refusal:
            # A file in another unit (a printout headed G 20 whose numbers are mm) makes its datum
            # seem to move: that is named first, where the touches meet the program
            # (probed_chains); without a program (a model to save) the refusal stands at once.
            self.unstable, self.notes = refusal, []
        calibration = fit_calibration(measurements.calibration) if measurements.calibration else None
        if calibration is not None:
            self.notes += calibration.report()
        self.touched, _ = touched_points(probe, calibration, None if self.unstable else reporter)
        self.probed: list[ProbedChain] = []

    def model(self) -> dict[str, Any]:
        """The touched points (calibration applied, datum checked): all a program needs of the files.

        :raises SafetyError: the datum moved (and not ``--force``)."""
        if self.unstable is not None:
            raise self.unstable
        probe = self.probe
        return {"probe": probe.path, "stylus_radius_mm": probe.stylus_radius, "repeatability_mm": probe.repeatability,
                "rows": list(probe.lines), "touched_mm": self.touched.tolist(), "approach": probe.approach.tolist(),
                "notes": list(self.notes)}

    def load(self, model: dict[str, Any]) -> None:
        self.touched = np.array(model["touched_mm"], dtype=float).reshape(-1, 2)
        approach = np.array(model["approach"], dtype=float).reshape(-1, 2)
        stylus = float(model["stylus_radius_mm"])
        self.probe = ProbeFile(model["probe"], stylus, self.touched - stylus * approach, approach,
                               tuple(model["rows"]), repeatability=model["repeatability_mm"])
        self.notes = list(model["notes"])
        self.probed = []

    def probed_chains(self, moves: Iterable[Move]) -> list[ProbedChain]:
        """Each touch on the nearest feed segment of any chain, then each chain's touches screened per feature."""
        probe, points = self.probe, self.touched
        chains = chains_of(moves)
        if not chains:
            raise MeasurementError("the program has no feed moves to compare the probe points with",
                                   Location(probe.path))
        combined = Profile(tuple(segment for chain in chains for segment in chain.profile.segments))
        owner = np.repeat(np.arange(len(chains)), [len(chain.moves) for chain in chains])
        found = profile_deviations(points, probe.approach, combined, probe)
        check_on_profile(found, probe, points, combined, abs(self.settings.get("stock") or 0.0))
        if self.unstable is not None:
            raise self.unstable
        which = owner[found.nearest.index]
        result = []
        for number in np.unique(which):
            chain, index = chains[number], np.nonzero(which == number)[0]
            deviations = profile_deviations(points[index], probe.approach[index], chain.profile)
            near = deviations.nearest
            left = chain.profile.left_normals(near.index, near.param)
            sides = np.sign(np.sum(left * deviations.outward, axis=1))
            if np.any(sides != sides[0]):
                raise MeasurementError(f"the touches on the feed moves of {chain.lines} approach them from both "
                                       "sides: which side is material is not clear", Location(probe.path))
            feature, screening = screen_by_feature(deviations, chain.features, probe, points[index], index,
                                                   reporter=self.context.reporter)
            result.append(ProbedChain(chain, index, tuple(probe.lines[i] for i in index), points[index], deviations,
                                      screening, float(sides[0]), feature))
        return result

    def thin(self, probed: list[ProbedChain], minimum: int, consequence: str) -> list[Evidence]:
        """Warn of each feature in a chain's probed stretch with fewer than ``minimum`` touches.

        ``consequence`` says what becomes of such a feature (``left as programmed``...). A
        feature with no touch outside the stretch the touches cover is not probed at all and
        not warned about. Returns the features warned about.
        """
        found = []
        for chain in probed:
            for evidence in chain.evidence():
                if evidence.count >= minimum or not (evidence.count or chain.covers(evidence.feature)):
                    continue
                self.context.reporter.warn(
                    f"{self.name}: {evidence.describe()}; at least {minimum} per feature are needed to screen them for "
                    f"the nub and outliers: {consequence} (probe it at {minimum} points or more: "
                    "'postproc probe-program' spreads them so)", Location(self.probe.path))
                found.append(evidence)
        return found

    def report(self) -> dict[str, Any]:
        return {"probe": self.probe.path, "notes": list(self.notes)}


def rows_text(rows: Iterable[int]) -> str:
    return ", ".join(str(r) for r in rows)
