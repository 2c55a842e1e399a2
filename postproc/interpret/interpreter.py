"""The FANUC lathe interpreter: blocks in, moves out, in program order.

It is a modal state machine over the blocks of one program (G-code system A by default,
B and C selectable). What it knows exactly becomes :class:`~postproc.interpret.motion.Move` values
in radius millimetres; what depends on data only the control has (a common variable, a
jump, a subprogram, a reference return) becomes a warning and an unknown position, never
a guess. The control's own alarms that can be seen in the text (an arc whose end radius
does not match, an R arc shorter than its chord, a P/Q label that is missing or
ambiguous) are errors with the block's position.

Canned cycles: G71/G72/G73 run their P..Q contour blocks as roughing passes, not in
sequence: the contour blocks are interpreted as a contour (role ``contour``) from the
cycle's start point and the program resumes after them at that start point. G70 runs
the contour again as the finishing path (role ``replay``), then returns to its start
point. What the control does not take between P and Q (a call, a return, G10, another one-shot
or group 01 code, the units) is an error at its word (``cycles``). A block behind ``/`` that
changes nothing the interpreter tracks keeps the position known; any other leaves it unknown. Single-pass cycles (G90/G92/G94 in system A) and G74/G75/G76 are one row each.
Threading (G32 in system A, G33 in B and C, G34, G35, G76, G92) is marked so that no
compensator touches it; its end point is known. A mode that cannot be modelled (polar or
cylindrical interpolation, mirror image, polygon turning) lets the blocks up to its cancel
code pass through uninterpreted.
"""

from __future__ import annotations

import re
from dataclasses import replace
from typing import Callable, Iterable, Iterator

from . import gcodes as G
from .corners import corner_moves
from .motion import ARC, CONTOUR, CYCLE, LINE, Modal, Move, RUN, Step
from ..diagnostics import CornerError, InterpretationError, Location, PostprocError, Reporter, SafetyError
from ..machine.bounds import travel
from ..machine.profile import DEFAULT, MachineProfile
from ..syntax.blocks import BLOCK, Block, HEADER
from ..syntax.fastpath import CanonicalLine
from ..syntax.source import LabelIndex
from .state import _Capture, _Contour, _MOTION_KIND, _UNMODELLED_REGION, _Uninterpretable, _WORDS_ARE_DATA, _Words
from .canonical import CanonicalLines
from .statements import MacroStatements
from .convert import WordConversion
from .arcs import MotionAndArcs
from .cycles import ContourCycles


#: What a block behind ``/`` must leave as it found it for the position to stay known after it.
_SWITCH_INDEPENDENT = ("x", "z", "modal", "_work", "_drilling", "_modal_macro", "_unmodelled", "_skip_until",
                       "_expect", "_capture", "_corner", "_fresh_corner", "variables")


class Interpreter(CanonicalLines, MacroStatements, WordConversion, MotionAndArcs, ContourCycles):
    """Interprets one program. Use :meth:`run` once."""

    def __init__(
        self,
        profile: MachineProfile = DEFAULT,
        reporter: Reporter | None = None,
        file: str = "<program>",
        labels=None,
        reread=None,
        fast: bool = True,
        refuse_ambiguous_units: bool = False,
        rewriting: bool = False,
    ):
        self.profile = profile
        self.reporter = reporter if reporter is not None else Reporter()
        self.file = file
        self._labels = labels  # the program's LabelIndex, or a callable that scans for it on first use
        self._fast = fast  # ordinary blocks take the fast path (tests compare it with the general one)
        self._refuse_units = refuse_ambiguous_units  # a program that mixes decimal points with plain numbers
        self.rewriting = rewriting  # the steps are for compensation: what cannot be written safely is refused
        self._memo: dict[tuple, tuple[Modal, Modal]] = {}
        self._interned: dict[Modal, Modal] = {}
        self._jumps: bool | None = None  # whether any label may be a jump target
        self._reread = reread  # callable(first_line, last_line) -> Iterable[Block], for contours placed earlier
        self.table = G.SYSTEMS[profile.gcode_system]
        self._diameter = 0.5 if profile.diameter_x else 1.0  # program X to radius
        self._x_travel, self._z_travel = travel(profile.x_limits), travel(profile.z_limits)  # end points beyond: refused
        self.x: float | None = None
        self.z: float | None = None
        self.modal = Modal(motion=G.G00, inch=False, absolute=True, per_rev=True)
        self.variables: dict[int, float | None] = {}
        self.contours: dict[tuple[int, int, int], _Contour] = {}  #: by P, Q and the P block's line
        self._capture: _Capture | None = None
        self._expect: tuple[_Contour, Modal, tuple] | None = None
        self._skip_until: int | None = None  # label ending a region that cannot be interpreted (or _UNMODELLED_REGION)
        self._drilling = False
        self._modal_macro = False
        self._unmodelled: str | None = None  # the mode in force whose moves cannot be modelled (gcodes.UNMODELLED)
        self._pointed = False  # a length word with a decimal point was read
        self._plain: tuple[Block, str, bool] | None = None  # the first length word without one (and not 0), inch
        self._units_said = False
        self._pending: list[Step] = []  # steps held while a corner waits for its next move
        self._corner: tuple[Step, int, str, float] | None = None  # (step, move index, corner word, size)
        self._work: int | None = None  # G54..G59 in force; None until the program names one
        self._fresh_corner: tuple[int, str, float] | None = None
        self._feed_warned = False
        self._shared = False  # inside a local subprogram called from several places
        self._centre: tuple[float, float] | None = None  # the centre of the fast path's last arc

    def run(self, blocks: Iterable[Block]) -> Iterator[Step]:
        canonical_step = self.canonical_step
        steady = self._steady()
        for block in blocks:
            if block.fields is not None and steady:  # a canonical block changes none of what _steady reads
                step = canonical_step(block)
                if step is not None:
                    yield step
                    continue
            yield from self._general(block)
            steady = self._steady()
        self._finish()

    def tally(self, blocks: Iterable[Block | CanonicalLine],
              contours: Callable[[Step], None] | None = None) -> tuple[int, int]:
        """Interpret every block and count blocks and moves, keeping no step: all that
        ``check`` and an identity run need. Takes the reader's light stream
        (``read_blocks(..., light=True)``): a canonical line becomes a block only when
        the general path needs one. ``contours`` is given each step of a cycle's P..Q contour
        (always read by the general path), and no other."""
        canonical_motion = self.canonical_motion
        steady = self._steady()
        count = moves = 0
        for block in blocks:
            if type(block) is CanonicalLine:
                if steady:  # a canonical block changes none of what _steady reads
                    moved = canonical_motion(block, block[2])  # its fields, read without the property
                    if moved is not None:
                        count += 1
                        moves += moved
                        continue
                block = block.block()
            for step in self._general(block):
                count += 1
                moves += len(step.moves)
                if step.in_contour and contours is not None:
                    contours(step)
            steady = self._steady()
        self._finish()
        return count, moves

    def _general(self, block: Block) -> list[Step]:
        """Interpret a block by the general path; the steps now ready, in order (a step
        with a corner word waits for the next move)."""
        self._fresh_corner = None
        step = self._step(block)
        fresh = self._fresh_corner
        ready = []
        if self._corner is not None:
            self._pending.append(step)
            if self._join_corner(step) and fresh is not None:
                self._corner = (step, *fresh)
        elif fresh is not None:
            self._corner = (step, *fresh)
            self._pending.append(step)
        else:
            ready.append(step)
        if self._corner is None and self._pending:
            ready += self._pending
            self._pending = []
        return ready

    def _finish(self) -> None:
        if self._corner is not None:
            step, _, kind, _ = self._corner
            raise InterpretationError(
                f"corner {kind} needs a following G01/G02/G03 move (FANUC alarm PS0051)",
                self._location(step.block, self._col(step.block, kind)),
            )

    def _steady(self) -> bool:
        """Whether a canonical block may take the shortest route: no contour being read or
        awaited, no region skipped, no corner waiting, no drilling or modal macro in force."""
        return (
            self._fast
            and self._corner is None
            and self._capture is None
            and self._expect is None
            and self._skip_until is None
            and not self._drilling
            and not self._modal_macro
        )

    def _join_corner(self, step: Step) -> bool:
        """Cut the held corner with this step's first move; False while still waiting."""
        held, index, kind, size = self._corner
        where = self._location(held.block, self._col(held.block, kind))
        following = [i for i, move in enumerate(step.moves) if move.role in (RUN, CONTOUR)]
        if not following:
            if step.block.codes or step.block.statement is not None:
                raise InterpretationError(
                    f"corner {kind} must be followed directly by a G01/G02/G03 move (FANUC alarm PS0051)", where
                )
            return False
        j = following[0]
        first, second = held.moves[index], step.moves[j]
        if second.kind not in (LINE, ARC) or not (second.exact and first.exact):
            raise InterpretationError(f"corner {kind} must be followed by a G01/G02/G03 move (FANUC alarm PS0051)", where)
        if not (first.known and second.known):  # from an unknown position the way into the corner is unknown
            held.moves = held.moves[:index] + (first._replace(x1=None, z1=None, exact=False),) + held.moves[index + 1 :]
            step.moves = step.moves[:j] + (second._replace(x0=None, z0=None, exact=False),) + step.moves[j + 1 :]
            self._corner = None
            return True
        try:
            shortened, corner, rest = corner_moves(first, second, kind, size)
        except CornerError as exc:
            raise InterpretationError(str(exc), where) from None
        held.moves = held.moves[:index] + (shortened, corner) + held.moves[index + 1 :]
        step.moves = step.moves[:j] + (rest,) + step.moves[j + 1 :]
        self._corner = None
        return True

    def step(self, block: Block) -> Step:
        """Interpret one block in the current state (no corner words: :meth:`run` handles those)."""
        return self._step(block)

    def _step(self, block: Block) -> Step:
        if block.kind != BLOCK:
            if block.kind == HEADER:
                self._enter_program(block)
            return Step(block, (), self.modal, interpreted=block.kind != BLOCK)
        skip = self._skip_until
        if skip is not None:
            if skip != _UNMODELLED_REGION:
                step = Step(block, (), self.modal, interpreted=False)
                if block.label == skip:
                    self._skip_until = None
                    self.x = self.z = None
                return step
            if not self._leaves_unmodelled(block):
                return Step(block, (), self.modal, interpreted=False)
        if self._expect is not None and (block.codes or block.statement is not None or block.label is not None):
            self._start_expected_contour(block)
        in_contour = self._capture is not None
        if in_contour:
            contour = self._capture.contour
            self._refuse_in_contour(block, contour.p, contour.q, contour.cycle_line, contour.meaning)
        if block.label is not None and self._is_jump_target(block.label):
            self._forget()  # a jump may arrive here
        if (
            self._fast
            and not in_contour
            and block.statement is None
            and block.delete is None
            and not self._drilling
            and not self._modal_macro
        ):
            step = self._ordinary(block) if block.fields is None else self.canonical_step(block)
            if step is not None:
                step.shared = self._shared
                return step
        try:
            if block.delete is not None and block.codes:
                step = self._optional_block(block)
            elif block.statement is not None:
                step = self._statement(block)
            else:
                step = self._words_step(block)
        except _Uninterpretable as exc:
            step = self._uninterpretable(block, exc)
        if in_contour:
            step.in_contour = True
            step.cycle_line = self._capture.contour.cycle_line
            step.cycle = self._capture.contour.meaning
            step.contour_start = not self._capture.contour.blocks
            step.contour_end = self._contour_block(block)
        step.shared = self._shared
        return step

    def _optional_block(self, block: Block) -> Step:
        """A block behind the block delete ``/``: the control runs it or skips it by the operator's
        switch. Run here on trial: one that moves nothing and leaves every position, mode, frame and
        modal value as it found them (``/M09``, ``/M01``, ``/G04 U1.``) leaves the tool where it
        was either way, and the position stays known. Any other (a move, a G or M code that
        changes a mode, units, the frame, a feed, a tool, a call) makes what follows depend on the
        switch: it passes through uninterpreted, the position unknown after it and, for one that
        gives a motion code, the motion mode too, so that no block written later leans on a mode
        the switch decides."""
        saved = dict(self.__dict__)
        reporter, trial = self.reporter, Reporter()
        self.reporter = trial
        try:
            step = self._words_step(block)
        except (_Uninterpretable, PostprocError):
            step = None
        finally:
            self.reporter = reporter
        if step is not None and not step.moves and step.interpreted and all(
                getattr(self, name) == saved[name] for name in _SWITCH_INDEPENDENT):
            for warning in trial.warnings:
                reporter.warn(warning.message, warning.location)
            return step
        self.__dict__.update(saved)
        step = self._uninterpretable(block, _Uninterpretable("block delete: whether the control runs this block "
                                                             "depends on its switch"))
        if any(letter == "G" and (type(value) is not str or self._other_motion(G.code_key(float(value))))
               for letter, value in block.codes):
            self.modal = step.modal = replace(self.modal, motion=None)
        return step

    def _other_motion(self, key: int) -> bool:
        """Whether the G code ``key`` commands a motion mode other than the one in force."""
        kind, meaning = self.table.get(key, (None, None))
        return kind is None or (kind == G.MOTION and meaning != self.modal.motion)  # an unknown code may be one

    def _enter_program(self, block: Block) -> None:
        """An O number starts a program; a local subprogram called from several places is
        run with as many start points and states: its blocks are not compensated."""
        match = re.match(r"[\s%]*[Oo:]\s*([0-9]+)", block.text)  # "%O1200" where the control reads on after %
        self._shared = False
        if match is None:
            return
        number = int(match.group(1))
        calls = self.labels.calls.get(number, 0)
        if calls > 1:
            self._shared = True
            self.reporter.warn(
                f"O{number} is called from {calls} places: its blocks are not compensated",
                self._location(block, 0),
            )

    def _leaves_unmodelled(self, block: Block) -> bool:
        """Whether the block ends the unmodelled mode in force (its cancel code, G07.1 with its
        axis at 0, or the end of the program); the position is then unknown."""
        ends = False
        for letter, value in block.codes:
            if type(value) is not str:
                continue
            if letter == "M" and value.isdigit() and int(value) in (2, 30):
                ends = True
            elif letter == "G":
                kind, meaning = self.table.get(G.code_key(float(value)), (None, None))
                if meaning == self._unmodelled and (kind == G.CANCEL or (
                        kind == G.UNMODELLED and any(float(v) == 0.0 for l, v in block.codes
                                                     if l != "G" and type(v) is str))):
                    ends = True
        if ends:
            self._unmodelled = self._skip_until = None
            self.x = self.z = None
        return ends

    @staticmethod
    def _cancels_cylindrical(words: _Words) -> bool:
        """G07.1 C0 (the rotary axis given as 0) ends cylindrical interpolation."""
        return any(value == 0.0 for letter, value in words.values.items() if letter not in "FSTMPQ")

    def _note_literals(self, block: Block, literals: list[tuple[str, bool]], one_shot: str | None) -> None:
        """The general path's share of :meth:`_note_units`: the axis words of a block that moves
        or places the tool, and I, K, R, ,C, ,R of a motion block (not a cycle's parameters,
        a dwell, data or a macro call's arguments)."""
        if one_shot in _WORDS_ARE_DATA:
            return
        plain, pointed = None, False
        for letter, point in literals:
            if one_shot is not None and letter not in "XZUW":
                continue
            if point:
                pointed = True
            elif plain is None:
                plain = letter
        if plain is not None or (pointed and not self._pointed):
            self._note_units(block, plain, pointed)

    def _note_units(self, block: Block | CanonicalLine, plain: str | None, pointed: bool) -> None:
        """Calculator-type input (FANUC parameter 3401 bit 0, DPI) reads X118 as 118 mm; the
        default reads it in least input increments, 0.118 mm (IS-B). Nothing in a program says
        which of the two it was written for, and a rewritten block is written with decimal
        points, which mean the same under both: so a plain word changes meaning on one of the
        two controls once its neighbours are rewritten. Unless the machine profile states
        ``calculator_input``, the first plain word (a whole program of them too) is a warning,
        or a refusal where blocks are to be rewritten."""
        if pointed:
            self._pointed = True
        if plain is not None and self._plain is None:
            self._plain = (block, plain, self.modal.inch)
        if self._plain is None or self._units_said or self.profile.calculator_input is not None:
            return
        self._units_said = True
        block, letter, inch = self._plain
        # the plain literal itself: the block may give the same address again as an expression (Z-#1 Z1)
        word = next((w for w in block.words if w.letter == letter and type(w.value) is str and "." not in w.value),
                    block.word(letter))
        increment = self.profile.increment(inch)
        unit = "in" if inch else "mm"
        as_written = float(word.value)
        message = (f"{word.text} has no decimal point: read in least input "
                   f"increments ({self.profile.input_increment}) it is {as_written * increment:g} {unit}; on a control "
                   f"with calculator-type input (parameter 3401 bit 0, DPI) it is {as_written:g} {unit}")
        where = self._location(block, word.col)
        if self._refuse_units:
            raise SafetyError(f"{message}: state which in the machine profile, calculator_input = true or false",
                              where)
        self.reporter.warn(f"{message}; read as the FANUC default, in increments (calculator_input = true in the "
                           "machine profile for the other)", where)

    def _uninterpretable(self, block: Block, exc: _Uninterpretable) -> Step:
        col = exc.col if exc.col is not None else self._first_col(block)
        self.reporter.warn(
            f"block cannot be interpreted: {exc.message}; it passes through unchanged",
            self._location(block, col),
        )
        moves: tuple[Move, ...] = ()
        motion = self.modal.motion
        if exc.target is not None:
            end_x, end_z = exc.target
        else:
            end_x = None if "X" in exc.unknown_axes else self.x
            end_z = None if "Z" in exc.unknown_axes else self.z
        if any(code[0] in "XZUW" for code in block.codes):
            kind = _MOTION_KIND.get(motion, LINE) if isinstance(motion, int) else CYCLE
            moves = (Move(kind, block.line, self.x, self.z, end_x, end_z, role=self._role(), exact=False),)
        self.x, self.z = end_x, end_z
        return Step(block, moves, self.modal, interpreted=False)

    def _forget(self) -> None:
        """Control flow may arrive with other values: forget what only one path knew."""
        self.variables = {}
        self.x = self.z = None
        self.modal = replace(self.modal, motion=None)

    @property
    def labels(self) -> LabelIndex:
        if self._labels is None:
            self._labels = LabelIndex()
        elif callable(self._labels):
            self._labels = self._labels()
        return self._labels

    def _is_jump_target(self, label: int) -> bool:
        if self._jumps is None:
            self._jumps = bool(self.labels.goto_targets) or self.labels.computed_goto
        return self._jumps and (label in self.labels.goto_targets or self.labels.computed_goto)

    def _location(self, block: Block | CanonicalLine, col: int) -> Location:
        return Location(self.file, block.line, col + 1, block.text)

    @classmethod
    def _col(cls, block: Block | CanonicalLine, letter: str, occurrence: int = 1) -> int:
        """Where the word a message is about stands; a word the block lacks (a G02 in force
        from an earlier block, a missing R) is placed at the block's first word."""
        seen = 0
        for word in block.words:
            if word.letter == letter:
                seen += 1
                if seen == occurrence:
                    return word.col
        return cls._first_col(block)

    @staticmethod
    def _first_col(block: Block) -> int:
        words = block.words
        if words:
            return words[0].col
        return len(block.text) - len(block.text.lstrip())


def interpret(blocks: Iterable[Block], **kwargs) -> Iterator[Step]:
    return Interpreter(**kwargs).run(blocks)
