"""The one-way rule of a G71/G72 contour: which axes must run one way, held and checked.

A FANUC control roughs a G71 (G72) contour by cutting it in layers across X (Z); it
refuses a finishing shape that does not increase or decrease monotonously (alarm PS0064
for the plane's first axis, Z under G18; PS0329 for the second, X). Which axes are held
depends on the cycle's type, which the contour's first block (P, the approach from the
cycle's start point A to the contour's start A') tells:

- G71 type I, the approach moves X only: the shape A' to B must run one way in X and in Z;
- G71 type II, the approach moves X and Z: one way in Z only (X may dip into pockets);
- G72 the same with the axes swapped: type I (approach in Z only) in both, type II in X.

The approach itself is not part of the shape: it runs from the start point to A' at each
pass. A compensated contour may still have to start elsewhere than the nominal A'; the
approach then ends there instead, in the axes it moves (a type I approach keeps moving one
axis only, or the cycle would become type II). Where a correction would make the shape run
back, the corrected path is held at the one-way bound instead (:func:`held`): a point
sliding along the corrected path changes nothing; one held off it by more than the
tolerance cannot be written, and the run is refused.

A contour that breaks the rule as written (the control alarms on the program as it is) is
found by :func:`written_turn`: ``check`` warns of it (:mod:`.contours`, fed the contour
blocks only), ``compensate`` refuses it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..diagnostics import Location
from ..geometry import segment_of
from ..interpret import gcodes as G
from ..interpret.motion import ARC, CONTOUR, LINE, RAPID, Move, Step
from .segmenter import Cut

#: the cycles whose contour must run one way
ONE_WAY_CYCLES = G.ONE_WAY_CYCLES
AXES = "XZ"
NOISE = 1e-7  #: mm; a change smaller than this is arithmetic, not motion
ALARMS = {0: "PS0329", 1: "PS0064"}  #: X is the second axis of the G18 plane, Z the first


def rule(cycle: str | None, approach_letters: set[str]) -> tuple[tuple[int, ...], str, str]:
    """The axes (0 for X, 1 for Z) the cycle's contour must run one way in, the letters its
    approach may be written with, and the cycle's name with its type."""
    if cycle == G.ROUGH_TURN:
        if approach_letters & {"Z", "W"}:
            return (1,), "XZ", "G71 type II"
        return (0, 1), "X", "G71 type I"
    if approach_letters & {"X", "U"}:
        return (0,), "XZ", "G72 type II"
    return (0, 1), "Z", "G72 type I"


def direction(cuts: list[Cut], axis: int, noise: float = NOISE) -> int | None:
    """+1 or -1 when the path runs one way along the axis, 0 when it does not move, None when
    it turns back (by more than ``noise``, mm)."""
    values = [value for cut in cuts for value in along(cut, axis)]
    steps = np.diff(values) if len(values) > 1 else np.zeros(1)
    rising, falling = bool(np.any(steps > noise)), bool(np.any(steps < -noise))
    if rising and falling:
        return None
    return 1 if rising else (-1 if falling else 0)


def along(cut: Cut, axis: int) -> list[float]:
    """The axis's values over the cut, in order: its start, where an arc reverses the axis (its
    apex: the control runs the arc there and back) and its end."""
    values = [cut.start[axis]]
    if cut.is_arc:
        arc = segment_of(cut)
        params = arc.reversal_params()
        if params:
            values += [float(value) for value in arc.point_at(np.array(params))[:, axis]]
    values.append(cut.end[axis])
    return values


def first_turn(start: float, cuts: list[Cut], axis: int, way: int,
               noise: float = NOISE) -> tuple[int, float, float] | None:
    """The first cut that runs the axis back against ``way`` (+1 or -1) from ``start`` on, by
    more than ``noise`` (mm), with the value the axis had reached and the one it turns back
    to; None when none does.

    The control commands positions in its least increment: an arc whose apex passes its end
    by less than half of one (its centre rounded to I and K, a hair off the end's axis) turns
    back by nothing it can command. The rewriter counts from there; block ends, on the grid,
    turn back by a whole increment or not at all."""
    reached = start
    for index, cut in enumerate(cuts):
        for value in along(cut, axis):
            if (value - reached) * way < -noise:
                return index, reached, value
            if (value - reached) * way > 0:
                reached = value
    return None


def held(values: np.ndarray, way: int, fixed: np.ndarray) -> np.ndarray:
    """The values held to run one way (``way`` +1 or -1), as near them as can be, the values
    ``fixed`` marks (blocks written as they were, where the approach ends) kept as they are
    and as bounds for the others. Where the values run back, each is met halfway between the
    furthest value before it and the nearest after it: the least largest change (the
    L-infinity isotonic fit, half what stopping at the furthest value reached would take).
    Values that run one way already come back exactly as they were."""
    signed = values * way
    before = np.maximum.accumulate(signed)
    after = np.minimum.accumulate(signed[::-1])[::-1]
    result = (before + after) / 2.0
    if fixed.any():
        floor = np.maximum.accumulate(np.where(fixed, signed, -np.inf))
        ceiling = np.minimum.accumulate(np.where(fixed, signed, np.inf)[::-1])[::-1]
        result = np.where(fixed, signed, np.minimum(np.maximum(result, floor), ceiling))
    return result * way


def off_path(points: np.ndarray, path: np.ndarray) -> float:
    """How far the farthest of ``points`` lies from the polyline ``path`` (mm)."""
    if len(points) == 0:
        return 0.0
    a, b = path[:-1], path[1:]
    ab = b - a
    length2 = np.einsum("ij,ij->i", ab, ab)
    length2[length2 == 0.0] = 1.0
    worst = 0.0
    for chunk in range(0, len(points), 256):  # points x segments at most 256 rows at a time
        p = points[chunk : chunk + 256, None, :]
        t = np.clip(np.einsum("kij,ij->ki", p - a, ab) / length2, 0.0, 1.0)
        nearest = a + t[:, :, None] * ab
        worst = max(worst, float(np.sqrt(((p - nearest) ** 2).sum(axis=2)).min(axis=1).max()))
    return worst


def microns(value_mm: float) -> str:
    return f"{value_mm * 1000:.2f} um"


def name(axis: int) -> str:
    return AXES[axis]


def alarm(axes: tuple[int, ...]) -> str:
    return "/".join(ALARMS[axis] for axis in sorted(axes, reverse=True))


def clamp_vertices(cuts: list[Cut], axes: dict[int, int]) -> list[Cut]:
    """Line cuts whose inner vertices are held to run one way in the given axes (axis -> way):
    each keeps within the furthest value reached before it and the value the last cut ends
    at. The ends stay where they are, and grid values stay on the grid (a held value is one
    of them)."""
    first, last = cuts[0].start, cuts[-1].end
    reached = list(first)
    vertices = [list(first)]
    for cut in cuts[:-1]:
        vertex = [cut.x1, cut.z1]
        for axis, way in axes.items():
            signed = min(max(vertex[axis] * way, reached[axis] * way), last[axis] * way)
            vertex[axis] = reached[axis] = signed * way
        vertices.append(vertex)
    vertices.append(list(last))
    result = [Cut(a[0], a[1], b[0], b[1]) for a, b in zip(vertices, vertices[1:])]
    return [cut for cut in result if cut.start != cut.end]


@dataclass(frozen=True, slots=True)
class Turn:
    """Where a G71/G72 contour as written turns back in an axis its cycle needs run one way."""

    step: Step  #: the contour block that turns back
    axis: int
    reached: float  #: the value the axis had reached (mm)
    value: float  #: the value it turns back to
    cycle: str  #: "G71 type I"...
    axes: tuple[int, ...]  #: the axes the cycle needs run one way

    def said(self) -> str:
        """The rule, the cycle, how far the contour turns back and the alarm the control raises."""
        by = abs(self.value - self.reached)
        return (f"the {self.cycle} cycle on line {self.step.cycle_line} needs its contour to run one way in "
                f"{' and '.join(map(name, self.axes))}; as written it turns back in {name(self.axis)} here, by "
                f"{microns(by) if by < 0.1 else f'{by:.3f} mm'}: the control stops the cycle on it with alarm "
                f"{ALARMS[self.axis]}")


def _cut(move: Move) -> Cut:
    return Cut(move.x0, move.z0, move.x1, move.z1, move.xc, move.zc, move.cw if move.kind == ARC else None)


def written_turn(steps: list[Step], noise: float = NOISE) -> Turn | None:
    """Where a G71/G72 contour as written (its steps from the approach, P, to Q) first turns back,
    by more than ``noise`` (mm), in an axis its cycle's type needs run one way, from where the
    approach ends and the way it first moves in that axis; None when it runs one way, or when a
    move of it is not known (a macro value only the control knows: the control's to judge)."""
    approach = steps[0]
    axes, _, cycle = rule(approach.cycle, {letter for letter, _ in approach.block.codes})
    cuts: list[Cut] = []
    owners: list[Step] = []
    for step in steps[1:]:
        for move in step.moves:
            if move.role == CONTOUR and move.kind in (LINE, ARC, RAPID):
                if not move.known:
                    return None
                cuts.append(_cut(move))
                owners.append(step)
    if not cuts:
        return None
    for axis in axes:
        values = [value for cut in cuts for value in along(cut, axis)]
        way = next((1 if value > values[0] else -1 for value in values if abs(value - values[0]) > noise), 0)
        turn = first_turn(values[0], cuts, axis, way, noise) if way else None
        if turn is not None:
            index, reached, value = turn
            return Turn(owners[index], axis, reached, value, cycle, axes)
    return None


def at_geometry(file: str, step: Step) -> Location:
    """A block's first geometry word (X, Z, U or W), for a message about where it runs."""
    block = step.block
    word = next((w for w in block.words if w.letter in "XZUW"), None)
    return Location(file, block.line, None if word is None else word.col + 1, block.text)
