"""The one-way rule of a G71/G72 contour: the contour read whole, its targets held to run one way
in the axes the cycle needs (:mod:`.monotone`), its plans held too, and the contour as written
checked at its end.

One phase of :class:`~postproc.compensate.rewrite.Rewriter`, as the interpreter keeps each of its
phases in a module of its own: the methods here work on the Rewriter's state and hold none of
their own."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..diagnostics import SafetyError
from ..interpret.motion import ARC, CONTOUR, LINE, RAPID, Move, Step
from . import monotone
from .edits import Entry, _cut_of, _rounded_up
from .segmenter import LINE_MODE, Cut, Plan, PlanError, Segmenter, Target, plan


@dataclass
class _OneWay:
    """A G71/G72 contour being written under its one-way rule (:mod:`.monotone`)."""

    cycle: str  #: "G71 type I"...
    cycle_line: int
    approach: Entry  #: the contour's first block, from the cycle's start point
    movable: str  #: the axes the approach may end elsewhere in ("" when its block cannot be rewritten)
    ways: dict[int, int | None]  #: axis -> the way the nominal runs: +1, -1, 0 (not at all), None (it turns)
    noise: float  #: mm; a turn back by less is none the control can command (half its least increment)
    start: tuple[float, float] | None = None  #: where the approach ends as written
    written: list[Cut] = field(default_factory=list)  #: the shape as written, after the approach
    steps: list[Step] = field(default_factory=list)  #: the step each written cut belongs to


class OneWayRule:
    """The one-way rule, mixed into :class:`~postproc.compensate.rewrite.Rewriter`."""

    def _settle_one_way(self, entries: list[Entry]) -> _OneWay:
        """The rule of a G71/G72 contour read whole, its targets held to it (:mod:`.monotone`).

        Each axis the cycle needs run one way is held over the whole contour, from where the
        approach ends (or, in an axis the approach may be moved in, from the first corrected
        point): where the corrected points run back, each is met halfway between the furthest
        value before it and the nearest after it, within the blocks written as they were. A
        target held off its corrected path by more than the tolerance refuses the run; one
        held within it is planned to keep within the tolerance of both, with a warning naming
        its block when the hold takes more than half the tolerance."""
        approach = entries[0]
        step = approach.step
        noise = self._noise(step)
        turn = monotone.written_turn([entry.step for entry in entries if entry.step.in_contour], noise)
        if turn is not None:
            raise SafetyError(f"{turn.said()}: the program cannot run as it is, refused; make the contour (its P..Q "
                              f"blocks) run one way in {monotone.name(turn.axis)}", monotone.at_geometry(self.file, turn.step))
        axes, carries, cycle = monotone.rule(step.cycle, {letter for letter, _ in step.block.codes})
        shape = [(entry, index, move) for entry in entries[1:] if entry.step.in_contour
                 for index, move in enumerate(entry.step.moves) if move.role == CONTOUR]
        drawn = [move for _, _, move in shape if move.kind in (LINE, ARC, RAPID)]
        nominal = [_cut_of(move) for move in drawn if move.known]
        ways = {axis: monotone.direction(nominal, axis, noise) for axis in axes}
        movable = carries if self._simple(approach) else ""
        one_way = _OneWay(cycle, step.cycle_line or step.block.line, approach, movable, ways, noise)
        ends = [move for move in step.moves if move.role == CONTOUR and move.known]
        if not ends or len(nominal) < len(drawn):
            return one_way  # a contour not known throughout: only what is written is checked
        start = (ends[-1].x1, ends[-1].z1)
        points: dict[tuple[int, int], np.ndarray] = {}  # (id of the edit, target index) -> its points as held
        for axis, way in ways.items():
            if way:
                self._hold_targets(shape, axis, way, None if "XZ"[axis] in movable else start[axis], points)
        edits = {id(edit): (entry, edit) for entry in entries for edit in entry.edits if edit is not None}
        tolerance = self._tolerance(step)
        for (key, index), held in points.items():
            entry, edit = edits[key]
            target = edit.targets[index]
            moved = np.any(held != target.points, axis=1)
            if not moved.any():
                continue
            off = monotone.off_path(held[moved], target.points)
            changed = [axis for axis in axes if np.any(held[:, axis] != target.points[:, axis])]
            names = "/".join(map(monotone.name, changed))
            where = monotone.at_geometry(self.file, entry.step)
            rule = f"the {cycle} cycle on line {one_way.cycle_line} needs its contour to run one way in " \
                   f"{' and '.join(map(monotone.name, axes))} (FANUC alarm {monotone.alarm(axes)})"
            if off > tolerance:
                raise SafetyError(
                    f"{rule}; held to run one way in {names}, this block would run {monotone.microns(off)} off its "
                    f"corrected path, more than the tolerance ({monotone.microns(tolerance)}): no one-way path "
                    f"within the tolerance follows the correction here; refused (a --tolerance above "
                    f"{_rounded_up(off)} mm may accept the one-way path; else leave this program uncompensated, or "
                    "correct the part with a tool offset)",
                    where)
            edit.targets[index] = Target.along(target.nominal, target.t, held - (target.points - target.d),
                                               target.points - target.d)
            edit.held[index] = target
            steps = self._steps(entry.step)
            # worth a word when it takes more than half the tolerance (the rest is the segmenter's) and
            # moves a word by more than rounding does (half a step)
            if off > max(tolerance, min(steps[axis] for axis in changed)) / 2.0:
                self.held.append((entry.step.block.line, off))
                self.reporter.warn(f"block held to run one way in {names}, as {rule}: it runs up to "
                                   f"{monotone.microns(off)} off its corrected path, within the tolerance", where)
        return one_way

    @staticmethod
    def _hold_targets(shape: list[tuple[Entry, int, Move]], axis: int, way: int, low: float | None,
                      points: dict[tuple[int, int], np.ndarray]) -> None:
        """Hold the targets of a contour's moves to run one way (``way``) in the axis, from ``low``
        (None: from the first corrected point on), all in one pass (:func:`monotone.held` over
        the whole contour); the blocks written as they were are bounds it keeps to. The targets
        it changes are put in ``points``, keyed by (id of the edit, target index)."""
        keys: list[tuple[int, int] | None] = []  # each part's target, or None for a block written as it was
        parts: list[np.ndarray] = []
        targets: dict[tuple[int, int], Target] = {}
        for entry, index, move in shape:
            edit = entry.edits[index]
            if edit is not None:
                for number, target in enumerate(edit.targets):
                    key = (id(edit), number)
                    targets[key] = target
                    keys.append(key)
                    parts.append(points[key][:, axis] if key in points else target.points[:, axis])
            elif move.known and move.kind in (LINE, ARC, RAPID):
                values = monotone.along(_cut_of(move), axis)
                follows = len(entry.step.moves) == 1 and move.kind in (LINE, RAPID)  # may start where the last one ends
                keys.append(None)
                parts.append(np.array(values[1:] if follows else values))
        if low is not None:
            keys.insert(0, None)
            parts.insert(0, np.array([low]))
        if not parts:
            return
        values = np.concatenate(parts)
        fixed = np.repeat([key is None for key in keys], [len(part) for part in parts])
        held = monotone.held(values, way, fixed)
        starts = np.cumsum([0] + [len(part) for part in parts[:-1]])
        for part in sorted(set(np.searchsorted(starts, np.flatnonzero(held != values), "right") - 1)):
            key = keys[part]
            if key is None:
                continue  # a block written as it was keeps its values (the check at the contour's end sees it)
            if key not in points:
                points[key] = targets[key].points.copy()
            points[key][:, axis] = held[starts[part] : starts[part] + len(parts[part])]

    def _hold_plans(self, entry: Entry) -> None:
        """Blocks planned for a held target may still run back a little (a chord's vertex standing
        off the target, an arc whose apex falls just inside it): such a plan is planned again in
        lines whose vertices are held to run one way, kept when it stays within the tolerance.
        What still turns back is refused at the contour's end."""
        ways = {axis: way for axis, way in self._one_way.ways.items() if way}
        noise = self._one_way.noise
        for edit in entry.edits:
            if edit is None or not ways:
                continue
            for index, (target, planned) in enumerate(zip(edit.targets, edit.plans)):
                cuts = planned.cuts
                if (len(cuts) == 1 and not cuts[0].is_arc) or not _turns_back(cuts, ways, noise):
                    continue  # one line runs one way
                limits = self._limits_for(entry.step)
                try:
                    chords = plan(target, limits, LINE_MODE)
                except PlanError:
                    continue
                cuts = monotone.clamp_vertices(chords.cuts, ways)
                if not cuts or _turns_back(cuts, ways, noise):
                    continue
                deviation = Segmenter(target, limits).measure(cuts)
                corrected = edit.held.get(index)
                if deviation <= limits.tolerance and (corrected is None or self._holds(cuts, corrected, limits)):
                    edit.plans[index] = Plan(cuts, deviation, chords.method + "+one-way")

    def _follow_contour(self, step: Step, cuts: list[Cut] | None) -> None:
        """Collect a G71/G72 contour as written; at its end, check the cycle's one-way rule."""
        one_way = self._one_way
        if one_way is None or not step.in_contour:
            return
        if cuts is None:  # written as it was: from wherever the previous block left the tool
            cuts = [_cut_of(m) for m in step.moves if m.role == CONTOUR and m.known and m.kind in (LINE, ARC, RAPID)]
            previous = one_way.written[-1].end if one_way.written else one_way.start
            if cuts and previous is not None and not cuts[0].is_arc:
                cuts[0] = cuts[0]._replace(x0=previous[0], z0=previous[1])
        if step.contour_start:
            one_way.start = cuts[-1].end if cuts else None
        else:
            one_way.written.extend(cuts)
            one_way.steps.extend([step] * len(cuts))
        if step.contour_end:
            self._one_way = None
            self._check_one_way(one_way)

    def _check_one_way(self, one_way: _OneWay) -> None:
        """The contour as written, from where its approach ends, must run one way in each axis
        the cycle needs (as the nominal one did); the block where it turns back is named."""
        written = one_way.written
        if not written:
            return
        start = one_way.start or written[0].start
        for axis, way in one_way.ways.items():
            if way is None:
                continue  # a contour not known throughout that turns back as written: the control's to judge
            if way == 0:  # the nominal does not move in the axis: either way will do, but one
                values = [start[axis]] + [value for cut in written for value in monotone.along(cut, axis)]
                way = next((1 if b > a else -1 for a, b in zip(values, values[1:]) if abs(b - a) > one_way.noise), 0)
                if not way:
                    continue
            turn = monotone.first_turn(start[axis], written, axis, way, one_way.noise)
            if turn is not None:
                index, reached, value = turn
                raise SafetyError(
                    f"the compensated contour of the {one_way.cycle} cycle on line {one_way.cycle_line} would turn back "
                    f"in {monotone.name(axis)} here, by {monotone.microns(abs(value - reached))}; the cycle needs it to "
                    f"run one way in {' and '.join(map(monotone.name, one_way.ways))} (FANUC alarm "
                    f"{monotone.alarm(tuple(one_way.ways))}): refused", monotone.at_geometry(self.file, one_way.steps[index]))


def _turns_back(cuts: list[Cut], ways: dict[int, int], noise: float) -> bool:
    return any(monotone.first_turn(cuts[0].start[axis], cuts, axis, way, noise) is not None
               for axis, way in ways.items())
