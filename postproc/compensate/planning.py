"""Planning: the blocks for each target (the segmenter within the tolerance), kept long enough for
the control's look-ahead and nose radius offset, or the block refused with its remedy.

One phase of :class:`~postproc.compensate.rewrite.Rewriter`, as the interpreter keeps each of its
phases in a module of its own: the methods here work on the Rewriter's state and hold none of
their own."""

from __future__ import annotations

import math

import numpy as np

from ..diagnostics import Location, UnplannableBlock
from ..interpret.motion import ARC, LINE, RAPID, Step
from ..machine.resolution import Grid
from . import monotone
from .edits import BLOCK_TIME, CALL, INTERFERENCE, Edit, Entry, _as_it_is, call_word, last_along, _one_block_for_other_axes, _rounded_up, _where
from .segmenter import (LINE_MODE, RADIUS_CHECK, RESOLUTION, TOLERANCE, Cut, Limits, Plan, PlanError, Segmenter, Target,
                        plan)
from .batch_plans import batch_plans

_REMEDIES = {
    RESOLUTION: "more decimals (output_decimals_mm, output_decimals_inch in the machine profile) if the control's "
                "increment system takes them",
    RADIUS_CHECK: "the control's own limit as arc_radius_tolerance in the machine profile (FANUC parameter 3410)",
    BLOCK_TIME: "a smaller min_block_time_s in the machine profile, or a lower feed",
    INTERFERENCE: "the tool's own nose radius as nose_radius_mm in the machine profile",
}
_WORDS_OF = {RESOLUTION: "XZUW", RADIUS_CHECK: "RIK", TOLERANCE: "XZUW", BLOCK_TIME: "F", INTERFERENCE: "XZUW"}


class Planning:
    """Planning, mixed into :class:`~postproc.compensate.rewrite.Rewriter`."""

    def _plan_edits(self, entry: Entry) -> None:
        """Plan the blocks of an edited step before its joins are settled. A move that cannot
        be held refuses the run; with ``keep_unplannable`` the whole block is left as it is
        instead (listed as a warning and in :attr:`unplannable`), and its neighbours join its
        nominal path as they join any block left alone."""
        step = entry.step
        try:
            for index, (move, edit) in enumerate(zip(step.moves, entry.edits)):
                if edit is None and move.kind != RAPID:  # written out, for it shares the block with a change
                    edit = entry.edits[index] = _as_it_is(move)
                if edit is not None:
                    edit.plans = [self._plan(step, target, edit.held.get(i), edit.presolved.get(i))
                                  for i, target in enumerate(edit.targets)]
            if entry.moving is not None:  # the count matters only to a block that moves another axis too
                _one_block_for_other_axes(entry, sum(len(plan.cuts) for edit in entry.edits if edit is not None
                                                     for plan in edit.plans), self.file)
            call = call_word(step.block)
            if call is not None:
                self._called_from_nominal(entry, call)
        except UnplannableBlock as exc:
            if not self.request.keep_unplannable:
                raise
            entry.edits = [None] * len(step.moves)
            entry.kept = True
            self.unplannable.append((step.block.line, exc.limit))
            self.reporter.warn(f"block left uncompensated (--keep-unplannable): {exc.cause}", exc.location)

    def _called_from_nominal(self, entry: Entry, word) -> None:
        """A block that moves, then calls or returns (``G01 Z-10. M98 P1000``): the program it
        passes to starts from the end of the move, which was written for the programmed end.
        No move back to it can stand between the two, so a correction that moves that end
        refuses the block (an incremental subprogram would run shifted by it)."""
        step = entry.step
        last = last_along(entry)
        if last is None:
            return
        move, edit = last
        nominal = (move.x1, move.z1)
        if edit is None or None in nominal or self._snap(step, edit.end) == self._snap(step, nominal):
            return
        block = step.block
        cause = (f"it calls or returns ({word.text}) after its move, and the correction moves the move's end, "
                 f"where the program it passes to was written to start")
        if self._ends_a_cycle(block):  # a contour before its G70-G73: the cycle, not yet read, would refuse the call
            remedy = (f"its label N{block.label} is the Q of a G70-G73 cycle, and a FANUC control takes no call or "
                      f"return between a cycle's P and Q (it stops with an alarm): move the call out of the contour")
        else:
            remedy = ("to go on, give the call a block of its own after the move (out of any G70-G73 contour, between "
                      "whose P and Q a FANUC control takes no call), or --keep-unplannable to leave such blocks "
                      "uncompensated")
        raise UnplannableBlock(f"block cannot be compensated: {cause} ({CALL}); {remedy}",
                               Location(self.file, block.line, word.col + 1, block.text), CALL, f"{cause} ({CALL})")

    def _presolve(self, batch: list[Entry]) -> None:
        """The one-block plans of the batch's targets, worked out together (:mod:`.batch_plans`),
        kept with each edit for :meth:`_plan`: a CAM program's moves, planned one by one, are
        most of the planning's time."""
        slots: list[tuple[Edit, int]] = []
        targets: list[Target] = []
        limits: list[Limits] = []
        for entry in batch:
            if not entry.motion or entry.refusal is not None:  # a refused step is never planned: a
                continue  # correction beyond the maximum may be of any size
            for edit in entry.edits:
                if edit is None:
                    continue
                within = self._limits_for(entry.step)
                for index, target in enumerate(edit.targets):
                    slots.append((edit, index))
                    targets.append(target)
                    limits.append(within)
        if not targets:
            return
        found = batch_plans(targets, limits, arcs=self.request.mode != LINE_MODE)
        for (edit, index), target, within, plan_found in zip(slots, targets, limits, found):
            if plan_found is not None:
                edit.presolved[index] = (target, within, plan_found)

    def _plan(self, step: Step, target: Target, corrected: Target | None = None,
              presolved: tuple[Target, Limits, Plan] | None = None) -> Plan:
        """The blocks for a target. ``corrected``: the target as corrected, before a cycle's
        one-way rule held it; the blocks must keep within the tolerance of that one too. They
        usually do when planned for the held target (a held point often slides along the
        path); if not, they are planned within what the holding left of the tolerance.
        ``presolved``: its plan as :meth:`_presolve` found it, used while the target and its
        limits are the ones it was found for."""
        limits = self._limits_for(step)
        try:
            if presolved is not None and presolved[0] is target and presolved[1] is limits:
                result = presolved[2]
            else:
                result = plan(target, limits, self.request.mode)
            if corrected is not None and not self._holds(result.cuts, corrected, limits):
                held = monotone.off_path(target.points, corrected.points)
                limits = self._limits_for(step, held)
                try:
                    result = plan(target, limits, self.request.mode)
                except PlanError as exc:
                    exc.args = (f"held to run one way as its cycle needs, the block runs {monotone.microns(held)} off "
                                f"its corrected path, which leaves {monotone.microns(limits.tolerance)} of the "
                                f"tolerance: {exc}",)
                    exc.needed = None if exc.needed is None else exc.needed + held
                    raise
        except PlanError as exc:
            raise self._unplannable(step, exc.limit, str(exc), exc.needed) from None
        if len(result.cuts) > 1:  # one block has no neighbour to merge with
            result = self._keep_long(result, target, limits, self._length_rule(step, result.cuts), step)
        return result

    @staticmethod
    def _holds(cuts: list[Cut], target: Target, limits: Limits) -> bool:
        return Segmenter(target, limits).measure(cuts) <= limits.tolerance

    def _limits_for(self, step: Step, held: float = 0.0) -> Limits:
        key = (self._tolerance(step) - held, step.modal.inch)
        limits = self._limits.get(key)
        if limits is None:
            limits = self._limits[key] = Limits(key[0], self._grid(step), self.profile.arc_radius_tolerance,
                                                self.profile.max_arc_radius)
        return limits

    def _unplannable(self, step: Step, limit: str, cause: str, needed: float | None) -> UnplannableBlock:
        """The refusal of a block that cannot be held: which limit stops it, where (the word it
        concerns, with a caret), and what would let it through."""
        remedies = []
        if limit in _REMEDIES:
            remedies.append(_REMEDIES[limit])
        if needed is not None and 0.0 < needed <= 0.1:
            remedies.append(f"--tolerance {_rounded_up(needed)} (the nearest plan for this block keeps within "
                            f"{needed * 1000:.2f} um)")
        remedies.append("--keep-unplannable to leave such blocks uncompensated")
        block = step.block
        word = next((w for w in block.words if w.letter in _WORDS_OF[limit]), None) or next(
            (w for w in block.words if w.letter in "XZUW"), None)
        location = Location(self.file, block.line, None if word is None else word.col + 1, block.text)
        return UnplannableBlock(f"block cannot be compensated: {cause} ({limit}); to go on, give " + ", or ".join(remedies),
                                location, limit, f"{cause} ({limit})")

    def _length_rule(self, step: Step, cuts: list[Cut]):
        """How long each block must be, and why: ``rule(cuts, i) -> (mm, reason)``.

        The control's look-ahead starves on blocks shorter than its minimum block time at the
        feed. Under G41/G42 the control shortens each block's offset path by r tan(phi/2) at a
        corner turning by phi (r the nose radius); a block shorter than what its two corners
        take away turns back, and the interference check alarms.
        """
        move = next((m for m in step.moves if m.kind in (LINE, ARC)), None)
        lookahead = 0.0
        if move is not None and move.feed is not None:
            feed = move.feed
            if move.per_rev:
                x = min(min(abs(c.x0), abs(c.x1)) for c in cuts)
                feed *= step.modal.rpm(x, self.profile.max_spindle_rpm)
            lookahead = feed * self.profile.min_block_time_s / 60.0
        comp = move.comp if move is not None and move.comp in (41, 42) else None
        nose = self.profile.nose_radius_mm

        def rule(cuts: list[Cut], i: int) -> tuple[float, str]:
            need, why = lookahead, "the minimum block time at this feed"
            if comp is not None and nose > 0:
                taken = nose * (_half_turn(cuts, i - 1, i) + _half_turn(cuts, i, i + 1))
                if taken > need:
                    need = taken
                    why = f"under G{comp} the nose radius offset of a shorter block turns back: interference alarm"
            return need, why

        return rule

    def _keep_long(self, result: Plan, target: Target, limits: Limits, rule, step: Step) -> Plan:
        """Merge blocks shorter than the rule allows; widen with a warning, or refuse."""
        cuts = list(result.cuts)
        if len(cuts) < 2 or all(cut.length >= rule(cuts, i)[0] for i, cut in enumerate(cuts)):
            return result
        segmenter = Segmenter(target, limits)
        shortest, reason = 0.0, ""
        while len(cuts) > 1:
            short = [i for i, cut in enumerate(cuts) if cut.length < rule(cuts, i)[0]]
            if not short:
                break
            i = short[0]
            shortest, reason = rule(cuts, i)
            j = i - 1 if i == len(cuts) - 1 or (i > 0 and cuts[i - 1].length < cuts[i + 1].length) else i + 1
            a, b = sorted((i, j))
            cuts[a : b + 1] = self._rebalanced(cuts[a], cuts[b], target, limits.grid, shortest)
        deviation = segmenter.measure(cuts)
        tolerance = limits.tolerance
        if deviation > 2.0 * tolerance:
            raise self._unplannable(
                step, INTERFERENCE if reason.startswith("under G4") else BLOCK_TIME,
                f"blocks shorter than {shortest * 1000:.1f} um ({reason}) are needed to keep within "
                f"{tolerance * 1000:.2f} um; merging them would leave {deviation * 1000:.2f} um", deviation)
        if deviation > tolerance:
            self.reporter.warn(
                f"blocks merged to keep them longer than {shortest * 1000:.1f} um ({reason}): "
                f"tolerance widened to {deviation * 1000:.2f} um here", _where(self.file, step))
        return Plan(cuts, deviation, result.method + "+merged", widened=deviation > tolerance)

    @staticmethod
    def _rebalanced(first: Cut, second: Cut, target: Target, grid: Grid, shortest: float) -> list[Cut]:
        """Two neighbouring blocks, one too short: the shared vertex moved to the target halfway
        between their outer ends when both halves are then long enough, else one block."""
        if first.length + second.length >= 2.0 * shortest and not first.is_arc and not second.is_arc:
            ends = np.array([first.start, second.end])
            index = [int(np.argmin(np.hypot(*(target.points - end).T))) for end in ends]
            middle = grid.snap(*target.points[(index[0] + index[1]) // 2].tolist())
            halves = [Cut(*first.start, *middle), Cut(*middle, *second.end)]
            if all(cut.length >= shortest for cut in halves):
                return halves
        return [Cut(first.x0, first.z0, second.x1, second.z1)]


def _half_turn(cuts: list[Cut], a: int, b: int) -> float:
    """tan(phi / 2) of the turn phi from block a into block b (0 outside the list)."""
    if a < 0 or b >= len(cuts):
        return 0.0
    t1 = _tangent(cuts[a], end=True)
    t2 = _tangent(cuts[b], end=False)
    phi = abs(math.atan2(t1[0] * t2[1] - t1[1] * t2[0], t1[0] * t2[0] + t1[1] * t2[1]))
    return math.tan(min(phi, 3.0) / 2.0)


def _tangent(cut: Cut, end: bool) -> tuple[float, float]:
    if not cut.is_arc:
        length = cut.length or 1.0
        return ((cut.x1 - cut.x0) / length, (cut.z1 - cut.z0) / length)
    x, z = (cut.x1, cut.z1) if end else (cut.x0, cut.z0)
    rx, rz = x - cut.xc, z - cut.zc
    norm = math.hypot(rx, rz) or 1.0
    return (-rz / norm, rx / norm) if cut.cw else (rz / norm, -rx / norm)
