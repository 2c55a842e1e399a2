"""Writing: a step's replacement blocks (or the block as it was, byte for byte), its macro words by
the policy asked for, the machine's soft limits; each replacement checked before it is given out.

One phase of :class:`~postproc.compensate.rewrite.Rewriter`, as the interpreter keeps each of its
phases in a module of its own: the methods here work on the Rewriter's state and hold none of
their own."""

from __future__ import annotations

import math

import numpy as np

from ..diagnostics import Location, SafetyError
from ..interpret import gcodes as G
from ..interpret.motion import RAPID, Step
from ..syntax.blocks import Block, Word
from .edits import NAMED, NUMBERS, REFUSE, Entry, _as_it_is, _group, _one_block_for_other_axes, _where, call_word, macro_word
from .emitter import Style, with_motion_code, writer_for
from .segmenter import Cut


_NO_XZIK = (None,) * 4  #: a canonical block's X Z I K, none written


class Writing:
    """Writing, mixed into :class:`~postproc.compensate.rewrite.Rewriter`."""

    def _write(self, entry: Entry) -> list[str]:
        """The lines written for a step: the block as it was, or its replacement, checked."""
        step = entry.step
        block = step.block
        before, known = self.original_mode, self.known_mode
        self.original_mode = step.modal.motion
        if step.modal.motion is not None:
            self.known_mode = step.modal.motion
        if not entry.edited and entry.retarget is None:
            fields = block.fields
            sets_mode, relies = self._motion_words(block)
            if relies and self.mode_now is not None:
                wanted = step.modal.motion  # the mode the program as written runs this block in
                if wanted is None:  # how the program reaches it decides: a jump's target, after an unknown code
                    if known is not None and self.mode_now != known:
                        self._mode_unknown(step, known)
                elif self.mode_now != wanted:
                    self._mode_outside_region(step, wanted)
                    writer = writer_for(self._grid(step), self.profile.gcode_system, step.modal.absolute)
                    if block.delete is None:  # a block the control may skip leaves the mode as it was
                        self.mode_now = wanted
                    return [with_motion_code(block, writer.code(wanted, Style.of(block)))]
            if (sets_mode and block.delete is None) or self.mode_now is None:
                self.mode_now = step.modal.motion
            # (a code behind '/' leaves the mode written before: skipped, that stays; run, it is the block's)
            elif fields is None and (call := call_word(block)) is not None:
                if self.mode_now != before and before is not None:
                    self._mode_into_call(step, call, before)
                self.mode_now = None  # what the called program leaves in force (or the caller, after M99)
            self._follow_contour(step, None)
            if step.contour_end:
                self.mode_now = None  # the cycle gives back the mode it found, whatever its contour ended in
            self._written(step, None)
            return [block.raw]
        if self.request.macro_values == NUMBERS:
            word = macro_word(block)
            if word is not None:
                self._said_macro(block, word, "its macro values are written as numbers (--macro-values numbers): "
                                              "the block no longer follows the variables it reads")
        cuts = self._cuts(entry)
        if entry.moving is not None:
            _one_block_for_other_axes(entry, len(cuts), self.file, joined=True)  # joins may have split it
        self._within_limits(step, cuts)
        self._arcs_the_control_runs(step, cuts)
        modal = step.modal
        key = (modal.inch, modal.absolute, entry.axes)
        writer = self._writers.get(key)
        if writer is None:
            writer = self._writers[key] = writer_for(self._grid(step), self.profile.gcode_system, modal.absolute,
                                                     entry.axes)
        label_last = step.contour_end or self._ends_a_cycle(block)
        lines, mode = writer.replacement(block, cuts, self.mode_now, label_last=label_last)
        if len(lines) > 1 and block.label is not None:
            self._one_place_for_the_label(step, label_last)
        self._self_check(entry, lines, cuts)
        self._near_nominal(entry, cuts)
        self._written(step, cuts)
        self._follow_contour(step, cuts)
        self.mode_now = None if step.contour_end else mode  # a cycle gives back the mode it found
        self.replaced += 1
        self.emitted += len(lines)
        return lines

    def _motion_words(self, block: Block) -> tuple[bool, bool]:
        """Whether the block's own G code sets the motion mode, and whether it relies on the
        mode in force (it names an axis or arc word and no G code of its own that moves)."""
        fields = block.fields
        if fields is not None:  # a canonical block: G00-G03 at most, read from its fields
            sets_mode = fields[1] is not None
            return sets_mode, not sets_mode and fields[2:6] != _NO_XZIK
        codes = [value for letter, value in block.codes if letter == "G"]
        system = self.profile.gcode_system
        sets_mode = any(_group(value, system) == G.MOTION for value in codes)
        return sets_mode, (any(letter in "XZUWIK" for letter, _ in block.codes) and not sets_mode
                           and not any(_group(value, system) == G.ONE_SHOT for value in codes))

    def _ends_a_cycle(self, block: Block) -> bool:
        """Whether the block's label is a G70-G73 cycle's Q anywhere in the program: the cycle
        runs its blocks through the one so labelled, so a replacement of several blocks carries
        the label on its last (on its first, G70 would stop after the first piece)."""
        return block.label is not None and int(block.label) in self.labels.cycle_ends

    def _one_place_for_the_label(self, step: Step, last: bool) -> None:
        """A replaced block split into several carries its label on one of them: the first for
        a jump's target or a cycle's P (the run enters there), the last for a cycle's Q (the run
        goes through it). A label wanted at both ends, or named by an expression (``Q[#1]``,
        ``GOTO #2``: any label may be it), cannot be placed: refused."""
        labels = self.labels
        number = int(step.block.label)
        entered = (number in labels.goto_targets or number in labels.cycle_starts or labels.computed_goto
                   or None in labels.cycle_starts)
        left = last or None in labels.cycle_ends
        if not (entered and left):
            return
        block = step.block
        raise SafetyError(
            f"this block is replaced by several, and its label N{block.label} is wanted on the first of them (a jump or "
            f"a cycle's P enters there, or a label an expression gives may) and on the last (a cycle's Q runs through "
            f"it): give the move a block of its own between two labelled ones, or a wider --tolerance that keeps it "
            f"one block", Location(self.file, block.line, block.words[0].col + 1 if block.words else None, block.text))

    def _mode_into_call(self, step: Step, word: Word, mode: int) -> None:
        """A call or return written where the replacement before it left another motion mode in
        force than the program had (a corrected arc ends with a G01 back to its nominal end, or
        was written as lines): the program it passes to goes on in that mode, and a block there
        that relies on the mode it inherits (``X.. Z.. R..`` under G02) would run otherwise.
        Said, not refused: most programs state their moves' G codes."""
        block = step.block
        returns = word.letter == "M" and type(word.value) is str and int(float(word.value)) == 99
        where = "returns to a program that goes on" if returns else "passes to a program that starts"
        then = "the caller's next move" if returns else "the called program's first move"
        self.reporter.warn(
            f"{word.text} {where} with {_code(self.mode_now)} in force, where the program as written had {_code(mode)} "
            f"(the compensated move before it ends so): a block there that relies on the motion mode it inherits "
            f"would run otherwise; give {then} a G code of its own",
            Location(self.file, block.line, word.col + 1, block.text))

    def _mode_unknown(self, step: Step, mode: int) -> None:
        """A block relying on the modal motion code where the interpreter cannot tell which mode
        is in force (a jump's target, reached from more than one place; after a code it does not
        follow), right after a replacement that left another mode in force than the program had:
        writing the old mode in front would be a guess for the other ways in, leaving it as it
        was would run it in the new mode. Refused, with the block's own G code as the remedy."""
        block = step.block
        raise SafetyError(
            f"this block relies on the modal motion code, and which one is in force depends on how the program "
            f"reaches it (a jump's target, or after a block postproc does not follow); the compensated block before "
            f"it leaves {_code(self.mode_now)} in force where the program as written had {_code(mode)}: write the "
            f"block's own G code in the program",
            Location(self.file, block.line, block.words[0].col + 1 if block.words else None, block.text))

    def _mode_outside_region(self, step: Step, mode: int) -> None:
        """A block outside --region that relies on a motion mode a join inside the region no
        longer leaves in force: writing the mode's code in front of it would change a block the
        region leaves alone, so the run is refused with the block to add to the region."""
        if not step.moves or self.inside(step, step.moves[0]):
            return
        block = step.block
        raise SafetyError(
            f"this block, outside --region, relies on modal {_code(mode)}, and the join written at the end of the "
            f"region leaves {_code(self.mode_now)} in force: the block would need {_code(mode)} written in front of "
            f"it; widen --region to take this block in",
            Location(self.file, block.line, block.words[0].col + 1 if block.words else None, block.text))

    def _cuts(self, entry: Entry) -> list[Cut]:
        """The cuts that replace a step, each plan's share recorded for the self-check."""
        step = entry.step
        if entry.retarget is not None:  # a new start is written only when the block's end depends on it
            move = step.moves[0]
            a = self._snap(step, entry.retarget[0] or self._where_the_tool_stands(step) or (move.x0, move.z0))
            b = self._snap(step, entry.retarget[1] or (move.x1, move.z1))
            return [Cut(a[0], a[1], b[0], b[1], rapid=move.kind == RAPID)]
        cuts: list[Cut] = []
        last = None  # the last cut added

        def add(cut: Cut | None) -> None:
            nonlocal last
            if cut is None:
                return
            if last is not None and (last.x1, last.z1) != (cut.x0, cut.z0):  # pieces that do not meet: a connecting move
                self._no_join_under_nose_offset(step, (last.x1, last.z1), (cut.x0, cut.z0))
                last = Cut(last.x1, last.z1, cut.x0, cut.z0)
                cuts.append(last)
            if (cut.x0, cut.z0) != (cut.x1, cut.z1):
                cuts.append(cut)
                last = cut

        worst = self.worst
        for index, (move, edit) in enumerate(zip(step.moves, entry.edits)):
            if edit is None:
                if move.kind == RAPID:
                    a, b = self._snap(step, (move.x0, move.z0)), self._snap(step, (move.x1, move.z1))
                    add(Cut(a[0], a[1], b[0], b[1], rapid=True))
                    continue
                edit = entry.edits[index] = _as_it_is(move)  # written out, for it shares the block with a change
            add(edit.lead_in)
            if not edit.plans:
                edit.plans = [self._plan(step, target, edit.held.get(i)) for i, target in enumerate(edit.targets)]
            spans = edit.spans
            for planned in edit.plans:
                if planned.deviation > worst:
                    worst = planned.deviation
                pieces = planned.cuts
                add(pieces[0])
                first = len(cuts) - 1
                for cut in pieces[1:]:
                    add(cut)
                spans.append((first, len(cuts)))
            add(edit.lead_out)
        self.worst = worst
        return cuts

    def _macro_kept(self, entry: Entry, follower: Entry | None = None) -> bool:
        """Whether a block whose geometry reads macro variables is to be left as it is (KEEP),
        or the run refused (REFUSE, the error raised in program order); False when it may be
        rewritten (NUMBERS, or no such word). ``follower``: the block that is left uncompensated
        instead, for a corner block that would have to be written out to meet it."""
        word = macro_word(entry.step.block)
        policy = self.request.macro_values
        if word is None or policy == NUMBERS:
            return False
        block = entry.step.block
        where = Location(self.file, block.line, word.col + 1, block.text)
        if policy == REFUSE:
            if follower is not None:
                raise _macro_refusal(word, where, f" (its corner meets the compensated block on line "
                                                  f"{follower.step.block.line})")
            if entry.refusal is None:
                entry.refusal = _macro_refusal(word, where, "")
            return True
        kept = follower or entry
        kept.kept = True
        self.unplannable.append((kept.step.block.line, "macro values"))
        reason = (f"the corner of line {block.line}, whose {word.text} reads a macro variable, meets it"
                  if follower is not None else f"{word.text} reads a macro variable")
        self._said_macro(kept.step.block, word if follower is None else None,
                         f"block left uncompensated (--macro-values keep): {reason}")
        return True

    def _said_macro(self, block: Block, word, message: str) -> None:
        """One of the blocks the macro-value policy acted on: the first few are named."""
        self.macro_lines.append(block.line)
        if len(self.macro_lines) <= NAMED:
            col = word.col if word is not None else (block.words[0].col if block.words else 0)
            self.reporter.warn(message, Location(self.file, block.line, col + 1, block.text))

    def _within_limits(self, step: Step, cuts: list[Cut]) -> None:
        """A compensated move must stay inside the machine's soft limits (the profile's)."""
        profile = self.profile
        if profile.x_limits is None and profile.z_limits is None:
            return
        for axis, limits, name in ((0, profile.x_limits, "x"), (1, profile.z_limits, "z")):
            if limits is None:
                continue
            values = np.concatenate([cut.sample(1.0)[:, axis] for cut in cuts])
            low, high = float(values.min()), float(values.max())
            if low < limits[0] or high > limits[1]:
                beyond = low if low < limits[0] else high
                raise SafetyError(
                    f"the compensated move reaches {name} = {beyond:.4f} mm, beyond the soft limit "
                    f"{limits[0]:g} .. {limits[1]:g} mm of the machine profile",
                    _where(self.file, step))


    def _arcs_the_control_runs(self, step: Step, cuts: list[Cut]) -> None:
        """Every arc written keeps to what the control runs: its radius within the profile's
        largest (a grid step to spare: the segmenter holds the fitted centre to it, not the
        rounded one) and its end radius within the radius check of its start's. The segmenter
        plans no other arc; this holds whatever planned it."""
        profile = self.profile
        grid = self._grid(step)
        largest = profile.max_arc_radius + grid.step * grid.unit
        for cut in cuts:
            if cut.xc is None:
                continue
            r0 = math.hypot(cut.x0 - cut.xc, cut.z0 - cut.zc)
            r1 = math.hypot(cut.x1 - cut.xc, cut.z1 - cut.zc)
            if max(r0, r1) > largest or abs(r1 - r0) > profile.arc_radius_tolerance:
                raise SafetyError(
                    f"a compensated arc of radius {r0:.4f} mm (end radius {r1:.4f} mm) is beyond what the machine "
                    f"profile lets the control run: max_arc_radius {profile.max_arc_radius:g} mm, "
                    f"arc_radius_tolerance {profile.arc_radius_tolerance:g} mm; no program was written (a fault of the "
                    f"planner: please report it with the program)", _where(self.file, step))


def _macro_refusal(word, where: Location, detail: str) -> SafetyError:
    return SafetyError(
        f"{word.text} reads a macro variable: compensating this block{detail} writes its value as a number, and "
        "the block would no longer follow the variable; give --macro-values keep to leave such blocks "
        "uncompensated, or --macro-values numbers to write them as numbers (the compensated program then holds "
        "only for the values the program gives its variables)", where)


def _code(mode: int) -> str:
    """The G code of a motion mode (the interpreter keeps G33 as 330)."""
    return f"G{mode // 10:02d}" if mode % 10 == 0 else f"G{mode / 10:g}"
