"""Joins: how the end of one motion step meets the start of the next once either moved (the
previous line moved to meet it, a connecting G01, or an end point written out absolutely).

One phase of :class:`~postproc.compensate.rewrite.Rewriter`, as the interpreter keeps each of its
phases in a module of its own: the methods here work on the Rewriter's state and hold none of
their own."""

from __future__ import annotations

from ..diagnostics import Location, UnplannableBlock
from ..interpret import gcodes as G
from ..interpret.motion import ARC, CONTOUR, LINE, RAPID, RUN, Step
from ..syntax.blocks import Block
from .edits import ALONG, INTERFERENCE, JOIN, NUMBERS, Entry, _as_it_is, _group, last_along, macro_word
from .segmenter import Cut



class Joining:
    """Joins, mixed into :class:`~postproc.compensate.rewrite.Rewriter`."""

    def _join(self, previous: Entry, entry: Entry | None) -> None:
        """Settle how the last move of ``previous`` meets the first move of ``entry``."""
        if entry is None:  # the program ends: nothing follows from the nominal end
            return
        moves = previous.step.moves  # a motion step's: one of them runs along the program, most often the one
        if len(moves) == 1:
            last_move, last_edit = moves[0], previous.edits[0]
        else:
            last_move = [m for m in moves if m.role in ALONG][-1]
            last_edit = previous.edits[moves.index(last_move)]
        moves = entry.step.moves
        if len(moves) == 1:
            first_move, first_edit = moves[0], entry.edits[0]
        else:
            first_move = next(m for m in moves if m.role in ALONG)
            first_edit = entry.edits[moves.index(first_move)]
        connected = (
            None not in (last_move.x1, last_move.z1, first_move.x0, first_move.z0)
            and abs(last_move.x1 - first_move.x0) < JOIN
            and abs(last_move.z1 - first_move.z0) < JOIN
            and (last_move.role == CONTOUR) == (first_move.role == CONTOUR)
        )
        if first_edit is not None and self._has_corner(previous.step.block) and not previous.edited:
            if self._macro_kept(previous, entry):  # the corner cannot be written out: the follower stays too
                entry.edits = [None] * len(entry.step.moves)
                first_edit = None
            else:
                self._explicit(previous)
                last_edit = previous.edits[previous.step.moves.index(last_move)]
        if not connected:  # the next move does not start from here (a cycle's start point, a shift, a jump)
            moved = last_move.role != CONTOUR and self._moved_end(last_move, last_edit, entry)
            if (moved and None not in (first_move.x0, first_move.z0) and previous.moving is None
                    and not self._under_nose_offset(previous.step)):
                # the next move starts from a known point the shift between (G50 U/W) carries the correction to: the
                # tool goes back where the program has it (a jump's target starts from nowhere known: nothing to meet)
                last_edit.lead_out = self._connector(last_edit.end, (last_move.x1, last_move.z1), previous.step)
                moved = False
            if first_edit is not None and not moved:
                self._from_nominal_start(entry)  # the tool stands where the program as written has it
            return
        nominal = (last_move.x1, last_move.z1)
        if last_edit is None and first_edit is None:
            return
        if last_edit is not None and first_edit is not None:
            first_edit.lead_in = self._connector(last_edit.end, first_edit.start, entry.step)  # None when they meet
            return
        if first_edit is not None:  # only the following move changed: meet its new start
            if self._simple(previous) and not previous.step.contour_start:
                self._retarget(previous, end=first_edit.start)
            elif self._one_way is not None and previous is self._one_way.approach and self._one_way.movable:
                axes = self._one_way.movable  # the approach ends at the new start in the axes it moves
                end = tuple(first_edit.start[axis] if "XZ"[axis] in axes else nominal[axis] for axis in (0, 1))
                self._retarget(previous, end=end)
                previous.axes = axes
                first_edit.lead_in = self._connector(end, first_edit.start, entry.step)
            else:
                first_edit.lead_in = self._connector(nominal, first_edit.start, entry.step)
            return
        # only the previous move changed: the following one starts where it ends now
        if last_edit.end == nominal:
            return
        if not self._simple(entry):
            last_edit.lead_out = self._connector(last_edit.end, nominal, previous.step)
        elif self._end_would_move(entry, last_edit.end, nominal):
            self._retarget(entry, start=last_edit.end)

    def _moved_end(self, move, edit, entry: Entry) -> bool:
        """Whether the move ends off its nominal end on the output grid (its correction there)."""
        if edit is None:
            return False
        grid = self._grid(entry.step)
        return grid.snap(*edit.end) != grid.snap(move.x1, move.z1) if None not in (move.x1, move.z1) else True

    def _from_nominal_start(self, entry: Entry) -> None:
        """A motion step with no motion step before it to join to (the program's first, the first
        after a block that names where the tool stands or that calls or returns), or whose start is
        not the last move's end while the tool stands where the program has it (the start point a
        G70-G73 cycle goes back to, a shift by G50 U/W after a move that ends where it did), starts
        where the program as written has the tool: the nominal start of its first move along the
        program. A corrected start is met from there by a connecting G01, as after a move left as
        it was."""
        moves = entry.step.moves
        first = next((index for index, move in enumerate(moves) if move.role in ALONG), None)
        if first is None:
            return
        move, edit = moves[first], entry.edits[first]
        if edit is None or move.role == CONTOUR or None in (move.x0, move.z0):
            return
        edit.lead_in = self._connector((move.x0, move.z0), edit.start, entry.step)

    def _back_to_nominal(self, previous: Entry, before: Step) -> None:
        """The tool goes back to the nominal end of ``previous`` before a block that names the
        coordinates of where it stands (G50 X/Z, G92 in systems B and C, a preset: named at the
        corrected end, the frame would carry that correction, a constant shift of every block
        after it) or that calls or returns (the program it passes to was written for the
        nominal end). Nothing is joined across such a block. ``before``: that block, for the
        refusal of a join under G41/G42. After a cycle's contour the tool stands at the cycle's
        start point, not at the contour's end: nothing goes back."""
        last = last_along(previous)
        if last is None:
            return
        last_move, last_edit = last
        if last_edit is None or None in (last_move.x1, last_move.z1) or last_move.role == CONTOUR:
            return
        last_edit.lead_out = self._connector(last_edit.end, (last_move.x1, last_move.z1), previous.step,
                                             self._before(before))

    @staticmethod
    def _before(block_step: Step) -> str:
        """Why a move goes back to its nominal end, as a refusal under G41/G42 says it."""
        what = "which names where the tool stands" if block_step.names_position else "which calls or returns"
        return f" (back to the programmed end before line {block_step.block.line}, {what})"

    def _simple(self, entry: Entry) -> bool:
        """A block with one plain line or rapid that can be rewritten with other end points."""
        step = entry.step
        return (
            not entry.kept
            and len(step.moves) == 1
            and self.inside(step, step.moves[0])
            and step.moves[0].kind in (LINE, RAPID)
            and step.moves[0].exact
            and step.moves[0].known
            and step.moves[0].role in (RUN, CONTOUR)
            and step.interpreted
            and step.block.delete is None
            and not self._has_corner(step.block)
            and step.block.statement is None
            and (self.request.macro_values == NUMBERS or macro_word(step.block) is None)
            and (step.block.fields is not None  # canonical: no G code but G00-G03
                 or not any(letter == "G" and _group(value, self.profile.gcode_system) in (G.ONE_SHOT, None)
                            for letter, value in step.block.codes))
        )

    def _end_would_move(self, entry: Entry, start, nominal) -> bool:
        """Whether the block, started from ``start`` instead of ``nominal``, would end elsewhere.

        It does when an axis that moved is omitted from the block or given incrementally
        (U/W, or X/Z under G91 in systems B and C).
        """
        letters = {letter for letter, _ in entry.step.block.codes}
        absolute = entry.step.modal.absolute
        grid = self._grid(entry.step)
        moved_x = grid.x_word(start[0]) != grid.x_word(nominal[0])
        moved_z = grid.z_word(start[1]) != grid.z_word(nominal[1])
        fixed_x = "X" in letters and absolute
        fixed_z = "Z" in letters and absolute
        return (moved_x and not fixed_x) or (moved_z and not fixed_z)

    @staticmethod
    def _retarget(entry: Entry, start=None, end=None) -> None:
        old_start, old_end = entry.retarget or (None, None)
        entry.retarget = (start or old_start, end or old_end)

    @staticmethod
    def _has_corner(block: Block) -> bool:
        return block.fields is None and any(letter in (",C", ",R") for letter, _ in block.codes)

    def _explicit(self, entry: Entry) -> None:
        """Write a corner block's geometry out, so the control no longer computes the corner."""
        entry.edits = [_as_it_is(move) if move.kind in (LINE, ARC) and move.known else None for move in entry.step.moves]

    def _connector(self, start, end, step: Step, why: str = "") -> Cut | None:
        """The connecting G01 from ``start`` to ``end``, written with ``step``'s block; None
        when they are one point on the output grid. ``why``: what needs it, for a refusal."""
        if start == end:  # one point, on the grid or not (the corrections of two pieces at the point they share)
            return None
        grid = self._grid(step)  # _snap's, looked up once for both ends
        a, b = grid.snap(*start), grid.snap(*end)
        if a == b:
            return None
        self._no_join_under_nose_offset(step, a, b, why)
        return Cut(a[0], a[1], b[0], b[1])

    def _under_nose_offset(self, step: Step) -> bool:
        """Whether the control offsets the step's block by the tool's nose radius (G41/G42 in
        force or set or cancelled by the block, and a nose radius in the profile)."""
        block = step.block
        return self.profile.nose_radius_mm > 0.0 and (step.modal.comp in (41, 42) or (block.fields is None and any(
            letter == "G" and type(value) is str and value.lstrip("0") in ("40", "41", "42")
            for letter, value in block.codes)))

    def _no_join_under_nose_offset(self, step: Step, a, b, why: str = "") -> None:
        """Under G41/G42 the control offsets every block by the nose radius and joins the offset
        paths at their intersections; a join of a few micrometres across the path (the
        correction jumps, as it does at an axis reversal) has its offset path run backwards
        (interference alarm PS0041, or a gouge of the order of the nose radius with the check
        off), and a G41/G42/G40 carried by it starts or cancels the offset along a direction it
        does not have. Such a join is refused, never written: the planner keeps its own blocks
        long enough (:meth:`~postproc.compensate.planning.Planning._length_rule`), a join cannot be."""
        if not self._under_nose_offset(step):
            return
        nose = self.profile.nose_radius_mm
        block = step.block
        length = ((b[0] - a[0]) ** 2 + (b[1] - a[1]) ** 2) ** 0.5
        word = next((w for w in block.words if w.letter in "XZUW"), None) or (block.words[0] if block.words else None)
        raise UnplannableBlock(
            f"block cannot be compensated: under tool nose radius compensation (G41/G42) the corrected path needs "
            f"a join of {length * 1000:.1f} um here{why}, and the control would offset it by the nose radius "
            f"({nose:g} mm) into a path that runs backwards (interference alarm PS0041, or a gouge); compensate a "
            f"program written for the tool's nose centre (G40), or state nose_radius_mm = 0 in the machine "
            f"profile if the control does not offset this tool",
            Location(self.file, block.line, None if word is None else word.col + 1, block.text),
            INTERFERENCE, f"a {length * 1000:.1f} um join under G41/G42 ({INTERFERENCE})")
