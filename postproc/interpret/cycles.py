"""Canned cycles with a P..Q contour (G70-G73): the contour captured, checked and replayed.

One phase of :class:`~postproc.interpret.interpreter.Interpreter`, as LinuxCNC's rs274ngc keeps
each phase of its interpreter in a file of its own: the methods here work on the Interpreter's
state and hold none of their own."""

from __future__ import annotations

from . import gcodes as G
from .motion import CYCLE, Move, RAPID, REPLAY, Step
from ..diagnostics import InterpretationError, Reporter, SafetyError
from ..syntax.blocks import BLOCK, Block
from .state import _Capture, _Contour, _Words


#: What a contour block may not command, by the meaning of its G code: a FANUC control takes,
#: between a G70-G73's P and Q, moves in G00-G03 and no one-shot (group 00) G code but the dwell
#: G04, no other group 01 code (threading, the single-pass cycles), no units (group 06) and no
#: call or return (see :meth:`ContourCycles._refuse_in_contour`). The rest of the words of such
#: a block (G40-G42, F, S, T, M08...) are taken.
_NOT_IN_CONTOUR = {
    G.DATA: ("data setting", "set the data before the cycle block or after the contour's last block"),
    G.MACRO_CALL: ("a macro call", "write the macro's moves into the contour blocks, or call it before the cycle "
                                   "block or after the contour's last block"),
    G.MODAL_MACRO: ("a modal macro call", "call the macro before the cycle block or after the contour's last block"),
    G.INCH: ("inch input (units)", "set the units before the cycle block"),
    G.METRIC: ("metric input (units)", "set the units before the cycle block"),
}
_ONE_SHOT_REMEDY = "put it before the cycle block or after the contour's last block"
_MOTION_REMEDY = "only G00, G01, G02 and G03 move in a contour: put it before the cycle block or after the contour's last block"
#: Codes the table reads as data (their words are no position) that FANUC files in other groups
#: than 00 (G22 stored stroke check, G26 spindle speed fluctuation detection) or whose group the
#: manuals do not settle (G91.1, G96.1-G96.4): left to the control.
_NOT_GROUP_00 = frozenset((220, 260, 911, 961, 962, 963, 964))
_CALLS = {98: ("a subprogram call", "write the subprogram's moves into the contour blocks, or call it before the "
                                    "cycle block or after the contour's last block"),
          198: ("a subprogram call from an external device", "write the subprogram's moves into the contour blocks, or "
                                                             "call it before the cycle block or after the contour's last block"),
          99: ("a return (the end of the program)", "end the program after the contour's last block")}


class ContourCycles:
    """Contour cycles, mixed into :class:`~postproc.interpret.interpreter.Interpreter`."""

    def _refuse_in_contour(self, block: Block, p: int, q: int, cycle_line: int, meaning: str) -> None:
        """Refuse a contour block with what a multiple repetitive cycle does not take between its P
        and Q (the finishing shape program).

        The FANUC lathe manuals (Series 16i/18i/21i-T, 0i-TD/TF and 30i/31i/32i-A/B, "Multiple
        repetitive cycle", the notes and limitations of G71, G72 and G73, which G70 finishes) list
        what cannot be specified in the blocks from the sequence number P to Q: one-shot (group 00)
        G codes other than G04 (dwell); group 01 codes other than G00, G01, G02 and G03 (threading,
        the single-pass cycles); group 06 codes (inch and metric input); M98 and M99. The control
        stops with an alarm there ("improper G code in G71-G73", PS0066, for a G code). A macro
        call (G65, and G66/G66.1, which makes each move a call) is a one-shot or modal call like
        M98 (M198: from an external device). Even on a control set to accept one, what the called
        program cuts is a part of the contour postproc cannot see: a contour compensated without it
        would not be the one the cycle runs. So each of these is an error at its word, in every
        cycle, whether the contour follows the cycle or stands before it, and behind ``/`` too (the
        switch decides whether the control reads it). G04, G40-G42, F, S, T and the M codes of the
        machine (M08...) are taken: the roughing cycles ignore F, S and T in the contour, G70 runs
        them."""
        for word in block.words:
            if type(word.value) is not str:
                continue  # a value only the run gives: the block is not interpreted (a warning says so)
            if word.letter == "M":
                number = int(float(word.value))
                if number not in _CALLS:
                    continue
                what, remedy = _CALLS[number]
                code = f"M{number:02d}"
            elif word.letter == "G":
                key = G.code_key(float(word.value))
                kind, code_meaning = self.table.get(key, (None, None))
                code = G.code_name(key)
                if key in _NOT_GROUP_00:
                    continue
                if code_meaning in _NOT_IN_CONTOUR:
                    what, remedy = _NOT_IN_CONTOUR[code_meaning]
                elif kind == G.ONE_SHOT and code_meaning != G.DWELL:
                    what, remedy = f"a one-shot (group 00) G code ({G.describe(code_meaning)})", _ONE_SHOT_REMEDY
                elif kind == G.MOTION and code_meaning not in (G.G00, G.G01, G.G02, G.G03):
                    what, remedy = f"a group 01 code other than G00-G03 ({G.describe(code_meaning)})", _MOTION_REMEDY
                else:
                    continue
            else:
                continue
            name = G.code_name(next(key for key, (_, means) in self.table.items() if means == meaning))
            raise InterpretationError(
                f"{word.text.strip()}: {what} in the contour N{p}..N{q} of the {name} on line {cycle_line}: a FANUC "
                f"control takes no {code} between a multiple repetitive cycle's P and Q (it stops with an alarm), and "
                f"what it would add to the contour cannot be seen here; {remedy}",
                self._location(block, word.col))

    def _program_end_in_contour(self, block: Block, p: int, p_line: int, q: int, meaning: str) -> None:
        """A Q found only after the end of the program that runs the cycle: when the block that
        ends it is an M99 inside the contour, that is the mistake to name."""
        if self._reread is None or self.labels.in_program_of(q, block.line):
            return
        _, _, last = self.labels.program_of(block.line)
        if last is None or last < p_line or not any(line > last for line in self.labels.lines.get(q, ())):
            return
        for end in self._reread(last, last):
            if end.kind == BLOCK:
                self._refuse_in_contour(end, p, q, block.line, meaning)

    def _contour_cycle(self, block: Block, words: _Words, meaning: str) -> Step:
        values = words.values
        name = G.code_name(next(key for key in words.g if self.table[key][1] == meaning))
        if "P" not in values or "Q" not in values:
            if meaning == G.FINISH:
                raise InterpretationError(f"{name} needs P and Q: the first and last blocks of its contour",
                                          self._location(block, self._col(block, "G")))
            return Step(block, (), self.modal)  # first block of the two-block format: depth and retract only
        if meaning != G.FINISH:  # roughing runs at the cycle's F (G70 at the F of its contour blocks)
            self._need_feed(block, words, CYCLE, meaning)
        p, q = int(values["P"]), int(values["Q"])
        p_line = self._label_line(block, "P", p, name)
        self._program_end_in_contour(block, p, p_line, q, meaning)
        q_line = self._label_line(block, "Q", q, name)
        if q_line < p_line:
            raise InterpretationError(f"{name}: Q{q} (line {q_line}) comes before P{p} (line {p_line})",
                                      self._location(block, self._col(block, "Q")))
        start = (self.x, self.z)
        cycle_move = self._move(CYCLE, block, self.x, self.z, exact=None not in start)
        if meaning != G.FINISH:
            moves: tuple[Move, ...] = (cycle_move,)
        else:
            moves = ()
        recorded = self.contours.get((p, q, p_line))  # by its place: each program of a file has its own N10
        if p_line > block.line:
            contour = _Contour(p, q, block.line, start=start, meaning=meaning)
            self._expect = (contour, self.modal, start, name, meaning)
            if meaning == G.FINISH:
                return Step(block, (), self.modal)
            return Step(block, moves, self.modal)
        if q_line > block.line:
            self.reporter.warn(
                f"{name}: its contour N{p}..N{q} runs from line {p_line} to line {q_line}, around the cycle block; "
                "the blocks up to N{q} are not interpreted".replace("{q}", str(q)),
                self._location(block, self._col(block, "P")),
            )
            self._skip_until = q
            return Step(block, moves, self.modal, interpreted=False)
        if recorded is None:
            recorded = self._reread_contour(p, q, p_line, q_line, block, meaning)
        elif meaning in G.ONE_WAY_CYCLES and recorded.meaning != meaning:
            self._roughed_twice(block, name, recorded)
        if meaning == G.FINISH:
            moves = self._replay(recorded, block)
        return Step(block, moves, self.modal)

    def _roughed_twice(self, block: Block, name: str, recorded: _Contour) -> None:
        """A G71/G72 roughing a contour another kind of cycle ran first. Compensation holds a
        contour to the one-way rule of the cycle it follows (:mod:`postproc.compensate.monotone`);
        the contour was written under the other cycle's rule (or none, after a G73 or a G70),
        and the rules differ in the axes they hold (G71 type II holds Z, G72 type II holds X):
        the written contour may turn back where this cycle alarms (PS0064). Refused when
        compensating; as it stands, the program is the control's to judge."""
        if not self.rewriting:
            return
        other = {G.ROUGH_TURN: "G71", G.ROUGH_FACE: "G72", G.PATTERN: "G73", G.FINISH: "G70"}.get(recorded.meaning, "another cycle")
        raise SafetyError(
            f"{name}: its contour N{recorded.p}..N{recorded.q} was run first by the {other} on line "
            f"{recorded.cycle_line}; a compensated contour is held to the one-way rule of the cycle that runs it "
            f"first, so under this {name} it may turn back (FANUC alarm PS0064): give each cycle a contour of its own",
            self._location(block, self._col(block, "P")))

    def _label_line(self, block: Block, letter: str, label: int, name: str) -> int:
        """The line of the block N``label`` that the cycle's P or Q names. The control looks for
        it only in the program that runs the cycle (its O number to its M30, M02 or M99): an N
        of the same number in another program of the file is not found there (PS0060), and two
        in the program make the contour ambiguous."""
        if self.labels.counts.get(label, 0) == 0:
            unread = self.labels.unread.get(label)
            if unread is not None:
                raise InterpretationError(
                    f"{name} {letter}{label}: N{label} stands only after the end of the tape (line {unread}, after the "
                    f"closing '%'), where the control reads nothing (FANUC alarm PS0060): move that '%' after the "
                    f"program's last block, or the contour before it",
                    self._location(block, self._col(block, letter)),
                )
            raise InterpretationError(
                f"{name} {letter}{label}: no block N{label} in the program (FANUC alarm PS0060)",
                self._location(block, self._col(block, letter)),
            )
        lines = self.labels.in_program_of(label, block.line)  # each program of the file numbers its own blocks
        if not lines:
            program, first, last = self.labels.program_of(block.line)
            elsewhere = self.labels.lines[label]
            span = f"lines {first} to {last}" if last is not None else f"line {first} to the end"
            raise InterpretationError(
                f"{name} {letter}{label}: no block N{label} in {program} ({span}), the program that runs the cycle; "
                f"N{label} stands only outside it (line {elsewhere[0]}{', ...' if len(elsewhere) > 1 else ''}), where "
                f"the control does not look (FANUC alarm PS0060): give the contour's blocks these numbers in {program}",
                self._location(block, self._col(block, letter)),
            )
        if len(lines) > 1:
            raise InterpretationError(
                f"{name} {letter}{label}: N{label} stands on {len(lines)} blocks (lines {lines[0]}, {lines[1]}...); "
                "the contour is ambiguous",
                self._location(block, self._col(block, letter)),
            )
        return lines[0]

    def _start_expected_contour(self, block: Block) -> None:
        contour, modal, start, name, meaning = self._expect
        self._expect = None
        if block.label != contour.p:
            self.reporter.warn(
                f"{name} (line {contour.cycle_line}): its contour N{contour.p}..N{contour.q} does not follow the "
                f"cycle block; the blocks up to N{contour.q} are not interpreted",
                self._location(block, self._first_col(block)),
            )
            self._skip_until = contour.q
            return
        self._capture = _Capture(contour, modal, start)
        self.contours[(contour.p, contour.q, block.line)] = contour

    def _contour_block(self, block: Block) -> bool:
        """Keep a contour block; after its Q block, resume at the cycle's start point."""
        capture = self._capture
        capture.contour.blocks.append(block)
        if block.label != capture.contour.q:
            return False
        self._capture = None
        self.modal = capture.resume
        self.x, self.z = capture.resume_at
        return True

    def _reread_contour(self, p: int, q: int, p_line: int, q_line: int, block: Block, meaning: str) -> _Contour:
        """A contour placed before its cycle that no earlier cycle recorded: read it again."""
        if self._reread is None:
            raise InterpretationError(f"contour N{p}..N{q} cannot be read again here", self._location(block, self._col(block, "P")))
        contour = _Contour(p, q, block.line, blocks=list(self._reread(p_line, q_line)))
        for read in contour.blocks:
            if read.kind == BLOCK:
                self._refuse_in_contour(read, p, q, block.line, meaning)
        self.contours[(p, q, p_line)] = contour
        return contour

    def _replay(self, contour: _Contour, block: Block) -> tuple[Move, ...]:
        """G70: run the contour's blocks from here as the finishing path, then return."""
        start = (self.x, self.z)
        saved_modal = self.modal
        replay = type(self)(self.profile, Reporter(), self.file, self.labels)  # an Interpreter
        replay.x, replay.z = start
        replay.modal = self.modal
        replay.variables = dict(self.variables)
        replay._work = self._work
        moves: list[Move] = []
        for step in replay.run(contour.blocks):
            for move in step.moves:
                moves.append(move._replace(role=REPLAY))
        end = (replay.x, replay.z)
        if end != start:
            moves.append(Move(RAPID, block.line, end[0], end[1], start[0], start[1], feed=saved_modal.feed,
                              per_rev=saved_modal.per_rev, comp=saved_modal.comp, tool=saved_modal.tool,
                              exact=None not in start + end))
        self.x, self.z = start
        return tuple(moves)
