"""Commanded tool paths in time: where the command is at any moment, and samples of it.

The virtual machine needs the whole history of a path, not only the stretch it cuts: lost
motion depends on the direction each axis last travelled, servo lag on where the command
was a moment ago (evaluated exactly from the timeline, not interpolated between samples).
Moves of interest are sampled densely; the others only where they start, end and reverse
an axis (enough for the lost motion, which is exact at monotonic pieces).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..diagnostics import Location, ProgramError
from ..geometry import Arc, Segment, segment_of
from ..interpret.motion import RAPID, Move
from .config import Simulation


@dataclass(frozen=True)
class Timeline:
    """Segments run one after another, each at its own constant speed."""

    segments: tuple[Segment, ...]
    starts: np.ndarray  #: seconds at which each segment starts
    durations: np.ndarray  #: seconds each takes (> 0)

    @classmethod
    def of(cls, segments: list[Segment], speeds_mm_min: list[float]) -> "Timeline":
        durations = np.array([60.0 * s.length / v for s, v in zip(segments, speeds_mm_min)], dtype=float)
        starts = np.concatenate([[0.0], np.cumsum(durations)[:-1]]) if durations.size else np.zeros(0)
        return cls(tuple(segments), starts, durations)

    def at(self, time) -> np.ndarray:
        """The commanded position at each time; before the start the first, after the end the last."""
        time = np.asarray(time, dtype=float)
        index = np.clip(np.searchsorted(self.starts, time, side="right") - 1, 0, len(self.segments) - 1)
        param = np.clip((time - self.starts[index]) / self.durations[index], 0.0, 1.0)
        points = np.empty((time.size, 2))
        for i in np.unique(index):
            mask = index == i
            points[mask] = self.segments[i].point_at(param[mask])
        return points

    def sample(self, index: int, param: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Points and times at parameters of one segment."""
        return self.segments[index].point_at(param), self.starts[index] + param * self.durations[index]


@dataclass(frozen=True)
class Commanded:
    """A commanded path's samples, in time order (each segment samples both its ends)."""

    timeline: Timeline
    points: np.ndarray  #: (n, 2) x, z in radius mm
    time: np.ndarray  #: seconds from the start, non-decreasing
    move: np.ndarray  #: index of the move (or timeline segment) each sample lies on
    param: np.ndarray  #: 0 at that move's start, 1 at its end


def speed(move: Move, simulation: Simulation, program: str = "<program>") -> float:
    """A move's speed in mm/min: rapids at the rapid rate, feeds per revolution at the spindle speed."""
    if move.kind == RAPID:
        return simulation.rapid_mm_min
    if move.feed is None or move.feed <= 0:
        raise ProgramError("a feed move without a feed: the virtual machine cannot time it", Location(program, move.line))
    return move.feed * simulation.cut.spindle_rpm if move.per_rev else move.feed


def sample(moves: list[Move], dense: set[int], step: float, simulation: Simulation, program: str = "<program>") -> Commanded:
    """The moves in order (zero-length ones skipped), those in ``dense`` sampled at most ``step`` mm apart."""
    kept = [i for i, move in enumerate(moves) if segment_of(move).length > 0.0]
    segments = [segment_of(moves[i]) for i in kept]
    timeline = Timeline.of(segments, [speed(moves[i], simulation, program) for i in kept])
    points, times, owners, params = [], [], [], []
    for k, (index, segment) in enumerate(zip(kept, segments)):
        count = max(2, math.ceil(segment.length / step) + 1) if index in dense else 2
        param = np.linspace(0.0, 1.0, count)
        if isinstance(segment, Arc):
            param = np.union1d(param, segment.reversal_params())
        where, when = timeline.sample(k, param)
        points.append(where)
        times.append(when)
        owners.append(np.full(param.size, index))
        params.append(param)
    if not points:
        return Commanded(timeline, np.zeros((0, 2)), np.zeros(0), np.zeros(0, dtype=int), np.zeros(0))
    return Commanded(timeline, np.concatenate(points), np.concatenate(times), np.concatenate(owners),
                     np.concatenate(params))
