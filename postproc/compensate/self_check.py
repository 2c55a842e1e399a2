"""The self-check: every replacement read back through the interpreter as the control will read it
and measured against what was planned, and held near the programmed path whatever the options.

One phase of :class:`~postproc.compensate.rewrite.Rewriter`, as the interpreter keeps each of its
phases in a module of its own: the methods here work on the Rewriter's state and hold none of
their own."""

from __future__ import annotations

import operator
from typing import Iterator
from dataclasses import replace

from ..diagnostics import PostprocError, Reporter, SafetyError
from ..geometry import segment_of
from ..interpret.interpreter import Interpreter
from ..interpret.motion import ARC, CONTOUR, LINE, RAPID, Step
from ..syntax.fastpath import CanonicalLine, canonical_line
from ..syntax.reader import read_blocks
from .edits import ALONG, JOIN, Entry, _cut_of, _where, restarts
from .farthest import farthest, within
from .segmenter import Cut


#: Where the tool stands when the program as written has it there: at the start of the program, after a
#: block that names the position (G50) or calls or returns (a corrected move before it goes back first)
AT_NOMINAL = "at nominal"


class SelfCheck:
    """The self-check, mixed into :class:`~postproc.compensate.rewrite.Rewriter`."""

    def _self_check(self, entry: Entry, lines: list[str], cuts: list[Cut]) -> None:
        """Read the replacement back as the control will and check it is what was measured.

        Each plan's deviation from its target was measured on the control's model of its
        blocks (end points on the grid, arcs about the centre their rounded I and K give).
        Reading the written text back through the interpreter must give exactly those
        blocks; then the measured deviation is the deviation of what the control will run.
        """
        step = entry.step
        first = cuts[0]
        stands = self._where_the_tool_stands(step)
        if stands is not None and self._off_the_grid_point(step, (first.x0, first.z0), stands):
            raise SafetyError(
                f"self-check: the replacement starts at x {first.x0:.4f} z {first.z0:.4f} (a radius, and z), and the "
                f"blocks before it leave the tool at x {stands[0]:.4f} z {stands[1]:.4f}; no program was written (a "
                f"fault of the planner: please report it with the program)", _where(self.file, step))
        checker = self._checker
        if checker is None:
            checker = self._checker = Interpreter(replace(self.profile, name="self-check"), Reporter(),
                                                  self.file)
        checker.x, checker.z = first.x0, first.z0
        checker.modal = checker.with_motion(step.modal, self.mode_now)
        try:
            got = _read_back(checker, lines)
        except PostprocError as exc:  # the replacement must parse and interpret; anything else is a bug (exit 5)
            raise SafetyError(f"self-check: the replacement does not read back ({exc.message})",
                              _where(self.file, step)) from None
        if len(got) != len(cuts):
            raise SafetyError(f"self-check: {len(cuts)} moves planned, {len(got)} read back", _where(self.file, step))
        for index, (planned, cut) in enumerate(zip(cuts, got) if got != cuts else ()):
            if cut == planned:
                continue
            if None in cut[:4]:
                raise SafetyError(
                    f"self-check: block {index + 1} of the {len(cuts)} that replace this one reads back as a move "
                    f"{'from' if None in cut[:2] else 'to'} an unknown position, planned {planned}: a word the "
                    "replacement keeps on its first block (a subprogram call or return, another work coordinate "
                    "system) leaves the position unknown after it; give the move a block of its own",
                    _where(self.file, step))
            if max(map(abs, map(operator.sub, _numbers(planned), _numbers(cut)))) > 1e-9:
                raise SafetyError(f"self-check: a block reads back as {cut}, planned {planned}", _where(self.file, step))
        tolerance = self._tolerance(step)
        for edit in entry.edits:
            for planned in (edit.plans if edit is not None else ()):
                allowed = max(tolerance, planned.deviation if planned.widened else tolerance)
                if not planned.deviation <= allowed * (1 + 1e-9):
                    raise SafetyError(
                        f"self-check: the replacement runs {planned.deviation * 1000:.2f} um from the intended path "
                        f"(tolerance {tolerance * 1000:.2f} um)", _where(self.file, step))

    def _where_the_tool_stands(self, step: Step) -> tuple[float, float] | None:
        """Where the blocks written before the step leave the tool, when that is known and the
        step's first move starts from there: the replacement's first cut must start at that
        point, so that the joins the rewriter made are read back too, not only each block's own
        moves. A move that does not start where the last one ended (a cycle's start point, a shift
        by G50 U/W, a jump) starts where the program has the tool, if the last move ended where the
        program has it. None where the control, not the program, decides (a cycle's contour) or
        nothing is known."""
        moves = step.moves
        if not moves or moves[0].role not in ALONG or None in (moves[0].x0, moves[0].z0):
            return None
        first = moves[0]
        tool = self._tool
        if tool == AT_NOMINAL:
            return (first.x0, first.z0)
        if tool is None or first.role == CONTOUR:
            return None
        last, end = tool
        if last.role == CONTOUR:  # the cycle leaves the tool at its start point, where the program has it
            return (first.x0, first.z0)
        if None in (last.x1, last.z1):
            return None
        if abs(last.x1 - first.x0) > JOIN or abs(last.z1 - first.z0) > JOIN:  # a shift (G50 U/W), a jump
            return (first.x0, first.z0) if end is None or not self._off_the_grid_point(step, end, (last.x1, last.z1)) else None
        return end if end is not None else (first.x0, first.z0)

    def _off_the_grid_point(self, step: Step, point: tuple[float, float], stands: tuple[float, float]) -> bool:
        """Whether a planned start is not where the tool stands: more than half an output step off
        in an axis (a program's own coordinates may hold more decimals than its output is written
        with: the plan starts at the nearest point of the grid)."""
        x_step, z_step = self._steps(step)
        return abs(point[0] - stands[0]) > x_step / 2 + 1e-9 or abs(point[1] - stands[1]) > z_step / 2 + 1e-9

    def _written(self, step: Step, cuts: list[Cut] | None) -> None:
        """Follow where the tool stands after the step as written (``cuts``: its replacement, or
        None for the block as it was)."""
        if restarts(step):
            self._tool = AT_NOMINAL  # a corrected move before it went back to its nominal end
        elif step.moves:
            self._tool = (step.moves[-1], (cuts[-1].x1, cuts[-1].z1) if cuts else None)

    def _near_nominal(self, entry: Entry, cuts: list[Cut]) -> None:
        """No written cut may run further from the moves it replaces than the largest correction
        plus the tolerance (:mod:`postproc.compensate.farthest`), whatever the options: the tolerance counts
        at most :data:`bounds.MAX_TOLERANCE` here, a widened plan's at most twice that, and one
        output step is allowed for the rounding of connecting moves."""
        step = entry.step
        tolerance, slack = self._allowance(step)
        nominal = []
        for move, edit in zip(step.moves, entry.edits or [None] * len(step.moves)):
            if edit is not None:  # the pieces the targets were made of: the move itself
                nominal += [target.nominal for target in edit.targets]
                for planned in edit.plans:
                    if planned.widened:
                        tolerance = max(tolerance, min(planned.deviation, 2.0 * tolerance))
            elif move.known and move.kind in (LINE, ARC, RAPID):
                nominal.append(segment_of(move))
        allowed = self.largest + tolerance + slack
        for cut in cuts:
            for segment in nominal:
                if within(cut, segment, allowed):
                    break
            else:
                distance = min(farthest(cut, segment) for segment in nominal)
                raise SafetyError(
                    f"the replacement would run {distance * 1000:.1f} um from the programmed path, more than the "
                    f"largest correction ({self.largest * 1000:.2f} um) plus the tolerance ({tolerance * 1000:.2f} um) "
                    "allow: refused", _where(self.file, step))


def _read_back(checker: Interpreter, lines: list[str]) -> list[Cut]:
    """The cuts the control runs for the written lines, read as a program's lines are: a canonical
    line by the interpreter's fast path (:meth:`~postproc.interpret.canonical.CanonicalLines.canonical_motion`,
    taken while the state is steady and the line keeps to its rules, as :meth:`Interpreter.tally`
    takes it), every other line as a block by :meth:`Interpreter.step`. The fast path's cut is
    :func:`_cut_of` of the move its step would hold, read from the state it leaves, without the
    step and the move made for it."""
    cuts: list[Cut] = []
    new = tuple.__new__  # a cut made as move_under makes a move: by tuple's own constructor
    canonical_motion = checker.canonical_motion
    steady = checker._steady()
    for line in _lines_read(lines):
        if type(line) is CanonicalLine:
            if steady:  # a canonical line changes none of what _steady reads
                x0, z0 = checker.x, checker.z
                moved = canonical_motion(line)
                if moved is not None:
                    if moved:
                        motion = checker.modal.motion
                        if motion < 20:
                            cuts.append(new(Cut, (x0, z0, checker.x, checker.z, None, None, None, motion == 0)))
                        else:
                            xc, zc = checker._centre
                            cuts.append(new(Cut, (x0, z0, checker.x, checker.z, xc, zc, motion == 20, False)))
                    continue
            line = line.block()
        cuts += map(_cut_of, checker.step(line).moves)
        steady = checker._steady()
    return cuts


def _lines_read(lines: list[str]) -> tuple | Iterator:
    """``read_blocks(lines, light=True)``: a replacement of one canonical line (most are) made here
    as the CanonicalLine the reader gives, without its generator; any other by the reader itself
    (for two lines or more its generator costs no more than a loop here)."""
    if len(lines) == 1:
        raw = lines[0]
        match = canonical_line(raw)
        if match is not None:
            return (CanonicalLine((1, raw, match.groups())),)
    return read_blocks(lines, "<replacement>", light=True)


def _numbers(cut: Cut) -> tuple[float, ...]:
    return (cut.x0, cut.z0, cut.x1, cut.z1, cut.xc or 0.0, cut.zc or 0.0, float(bool(cut.cw)), float(cut.rapid))
