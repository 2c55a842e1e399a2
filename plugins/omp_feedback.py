"""omp-feedback: the surface an earlier pass left, probed on the machine, reflected about the nominal.

Also home to what ``omp-feedback`` and ``tool-offset`` share: the chains of connected feed
moves a program is made of, and a probe file read against them (:class:`ProbedChain`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Iterable

import numpy as np

from postproc.compensator import Compensator, Measurements, Option, Piece
from postproc.diagnostics import Location, MeasurementError
from postproc.figures import figures
from postproc.geometry import Profile, segment_of
from postproc.hookspecs import hookimpl
from postproc.measurements.probe import ProbeFile
from postproc.motion import CORNER, REPLAY, RUN, Move
from postproc.pretravel import fit_calibration
from postproc.probing import Deviations, Screened, check_datum, profile_deviations, touched_points
from postproc.screening import Screening, screen

JOIN = 1e-6  #: mm: a move starting this close to where the previous one ended continues its chain
END_SNAP = 0.01  #: mm: a stretch stopping this close to the end of a move reaches it (a touch aimed at a
#: move's end lands a few micrometres either side of it)
RUNS = (RUN, CORNER, REPLAY)  #: roles of moves the control runs where they stand (a G70 runs its contour)


def move_key(move: Move) -> tuple:
    """Which block a move is, whether run where it stands or replayed by G70 (same line, end, centre)."""
    return (move.line, move.x1, move.z1, move.xc, move.zc, move.cw)


@dataclass(frozen=True)
class Chain:
    """Feed moves run one after the other, each starting where the previous one ended, by one tool."""

    moves: tuple[Move, ...]
    profile: Profile

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
    return [Chain(tuple(chain), Profile(tuple(segment_of(m) for m in chain))) for chain in chains]


@dataclass(frozen=True)
class ProbedChain(Screened):
    """The touches that lie on one chain, against it, screened for the nub and outliers."""

    chain: Chain
    index: np.ndarray  #: the touches' places in the probe file
    touched: np.ndarray  #: (n, 2) touched points, mm
    deviations: Deviations  #: along the outward normal, positive = material left; ``nearest.s`` along the chain
    screening: Screening
    side: float  #: +1 when the outward normal is the chain's left normal, -1 when its right

    def dropped(self) -> list[dict[str, Any]]:
        return [{"row": d.row, "kind": d.kind, "deviation_mm": d.deviation, "replacement_mm": d.replacement,
                 "how": d.how} for d in self.screening.dropped]


@dataclass(frozen=True)
class Stretch:
    """The error along the part of a chain the touches cover: what ``omp-feedback`` takes out."""

    profile: Profile  #: the chain's
    s: np.ndarray  #: mm along the chain, increasing
    error: np.ndarray  #: mm along the outward normal at ``s``: deviation minus stock, cleaned
    start: tuple[int, float]  #: (segment, parameter) of the first touch
    end: tuple[int, float]  #: and of the last
    side: float  #: as :attr:`ProbedChain.side`

    @classmethod
    def of(cls, probed: ProbedChain, stock: float) -> "Stretch":
        near, profile = probed.deviations.nearest, probed.chain.profile
        places, inverse = np.unique(np.round(near.s, 9), return_inverse=True)  # touches at one place: averaged
        error = np.bincount(inverse, weights=probed.cleaned - stock) / np.bincount(inverse)
        first, last = int(np.argmin(near.s)), int(np.argmax(near.s))
        return cls(profile, places, error, _snapped(profile, near.index[first], near.param[first], 0.0),
                   _snapped(profile, near.index[last], near.param[last], 1.0), probed.side)

    def s_at(self, index: int, param):
        """Arc length along the chain at parameters of segment ``index``."""
        return self.profile.offsets[index] + param * self.profile.segments[index].length

    def shift(self, index: int, points: np.ndarray) -> np.ndarray | None:
        """-e along the outward normal at points of segment ``index``; zero off the stretch; None off it all."""
        if not self.start[0] <= index <= self.end[0]:
            return None
        segment = self.profile.segments[index]
        t = np.clip(segment.param_of(points), 0.0, 1.0)
        inside = np.ones(len(t), dtype=bool)
        if index == self.start[0]:
            inside &= t >= self.start[1] - 1e-9
        if index == self.end[0]:
            inside &= t <= self.end[1] + 1e-9
        if not inside.any():
            return None
        tangent = segment.tangent_at(t)
        outward = self.side * np.column_stack([-tangent[:, 1], tangent[:, 0]])
        e = np.where(inside, np.interp(self.s_at(index, t), self.s, self.error), 0.0)
        return -e[:, None] * outward


class OmpFeedback(Compensator):
    """Reflect the profile about the nominal by the error an earlier pass left (docs/methods.md §9.6).

    What it corrects: everything that put the surface of an earlier pass of the same profile
    where it is: machine errors, tool setting, cutting deflection, as the on-machine probe
    saw them. Each touch is assigned to the nearest feed segment of the program (lines and
    arcs: any chain of connected feed moves, G70 contours as G70 runs them); its error is
    ``e = deviation - stock`` along the outward normal; ``e`` is interpolated along the
    chain's arc length between the touches, and the path moves by ``-e`` along the outward
    normal over the stretch the touches cover (from the first to the last; a stretch ending
    within 0.01 mm of the end of a move reaches it) and nowhere else.

    What it needs: ``--probe`` with one probe file taken on the earlier pass, and preferably
    ``--calibration`` (the pretravel on the sphere artifact; without it k = 0, with a
    warning). When the file has a datum probed before and after, a datum that moved by more
    than ``repeatability_mm`` refuses the run (exit 4; ``--force`` uses the points anyway).
    The nub at the pole and stray touches are dropped and replaced by the trend of their
    neighbours (docs/methods.md §9.5): each is warned about and listed in the report, with the four
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

    Where a stretch ends inside a move, the change comes in over the core's sample spacing
    (0.05 mm) next to the end touch.
    """

    name = "omp-feedback"
    takes = ("probe", "calibration")
    needs = ("probe",)
    needs_survey = True
    options = (Option("stock", float, 0.0, "how far outside this program's profile the probed pass was cut, mm"),)

    # ------------------------------------------------------------------ the probe file

    def fit(self, measurements: Measurements) -> None:
        probes = measurements.probe
        if len(probes) != 1:
            raise MeasurementError(f"{self.name} takes one probe file; {len(probes)} given", Location(probes[1].path))
        probe = self.probe = probes[0]
        reporter = self.context.reporter
        self.notes = check_datum(probe, self.context.force, reporter)
        calibration = fit_calibration(measurements.calibration) if measurements.calibration else None
        if calibration is not None:
            self.notes += calibration.report()
        self.touched, _ = touched_points(probe, calibration, reporter)
        self.probed: list[ProbedChain] = []
        self.stretches: list[Stretch] = []

    def model(self) -> dict[str, Any]:
        """The touched points (calibration applied, datum checked): all a program needs of the files."""
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
        self.probed, self.stretches = [], []

    def probed_chains(self, moves: Iterable[Move]) -> list[ProbedChain]:
        """Each touch on the nearest feed segment of any chain, then each chain's touches screened."""
        probe, points = self.probe, self.touched
        chains = chains_of(moves)
        if not chains:
            raise MeasurementError("the program has no feed moves to compare the probe points with",
                                   Location(probe.path))
        combined = Profile(tuple(segment for chain in chains for segment in chain.profile.segments))
        owner = np.repeat(np.arange(len(chains)), [len(chain.moves) for chain in chains])
        which = owner[profile_deviations(points, probe.approach, combined, probe).nearest.index]
        floor = probe.repeatability if probe.repeatability is not None else 0.002
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
            screening = screen(deviations.deviation, near.s, [probe.lines[i] for i in index],
                               axis_distance=np.abs(points[index, 0]), nub_zone=probe.stylus_radius, floor=floor,
                               path=probe.path, reporter=self.context.reporter)
            result.append(ProbedChain(chain, index, points[index], deviations, screening, float(sides[0])))
        return result

    # ------------------------------------------------------------------ the correction

    def survey(self, moves: Iterable[Move]) -> None:
        self.probed = self.probed_chains(moves)
        self.stretches = [Stretch.of(probed, self.settings["stock"]) for probed in self.probed]
        self._places: dict[tuple, list[tuple[int, int]]] = {}  # move -> (stretch, segment of its chain)
        for number, probed in enumerate(self.probed):
            for index, move in enumerate(probed.chain.moves):
                self._places.setdefault(move_key(move), []).append((number, index))

    def correct(self, piece: Piece) -> np.ndarray | None:
        for number, index in self._places.get(move_key(piece.move), ()):
            shift = self.stretches[number].shift(index, piece.points)
            if shift is not None:
                return shift
        return None

    def report(self) -> dict[str, Any]:
        stock = self.settings["stock"]
        chains = []
        for probed, stretch in zip(self.probed, self.stretches):
            chains.append({"moves": probed.chain.lines, "tool": probed.chain.tool, "points": len(probed.index),
                           "stretch_mm": [float(stretch.s_at(*stretch.start)), float(stretch.s_at(*stretch.end))],
                           "length_mm": probed.chain.profile.length,
                           "measured_error_um": figures(probed.deviation - stock).as_dict(),
                           "cleaned_error_um": figures(probed.cleaned - stock).as_dict(),
                           "dropped": probed.dropped()})
        return {"probe": self.probe.path, "stock_mm": stock, "notes": list(self.notes),
                "chains": chains}


def _snapped(profile: Profile, index: int, param: float, end: float) -> tuple[int, float]:
    """A stretch's end (segment, parameter), moved to the segment's ``end`` (0 or 1) when within END_SNAP of it."""
    length = profile.segments[index].length
    return int(index), (end if abs(end - param) * length <= END_SNAP else float(param))


@hookimpl
def postproc_compensators():
    return [OmpFeedback]
