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
point. Single-pass cycles (G90/G92/G94 in system A) and G74/G75/G76 are one row each.
Threading (G32 in system A, G33 in B and C, G34, G35, G76, G92) is marked so that no
compensator touches it; its end point is known. A mode that cannot be modelled (polar or
cylindrical interpolation, mirror image, polygon turning) lets the blocks up to its cancel
code pass through uninterpreted.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Iterable, Iterator

from . import gcodes as G
from ..syntax.blocks import BLOCK, HEADER, Block
from .corners import corner_moves
from ..diagnostics import CornerError, InterpretationError, Location, Reporter, SafetyError
from ..syntax.fastpath import canonical_block
from .motion import ARC, CONTOUR, CYCLE, LINE, RAPID, REPLAY, RUN, THREAD, Modal, Move, Step
from ..machine.profile import DEFAULT, MachineProfile
from ..syntax.source import LabelIndex

if TYPE_CHECKING:
    from ..syntax import macro

INCH = 25.4

# The fast path: the spellings of G00-G03 it takes, the letters it handles.
_FAST_MOTION = {spelling: mode for mode, spellings in ((0, ("0", "00", "000")), (10, ("1", "01", "001")),
                                                     (20, ("2", "02", "002")), (30, ("3", "03", "003")))
                for spelling in spellings}
_FAST_MODES = frozenset((0, 10, 20, 30))
_FAST_LETTERS = frozenset("XZUWIKRFS")
_FAST_LENGTHS = frozenset("XZUWIKR")
_new_move = tuple.__new__  # Move(...) without its Python-level __new__: one per block
_FLOW_M = frozenset(("2", "02", "002", "30", "030", "98", "098", "99", "099"))

# The control's format rules for numbers as written.
_MAX_DIGITS = 9  #: significant digits a word may carry
_UNSIGNED = frozenset("GMTSFLD")  #: addresses that take no negative sign
_WHOLE = frozenset("MT")  #: addresses that take no decimal point
_MACRO_CALLS = frozenset(("65", "065", "66", "066"))

#: Addresses whose plain numbers are lengths: without a decimal point they count least
#: input increments (unless calculator-type input is set).
_LENGTH_ADDRESSES = frozenset("XZUWIKR") | {",C", ",R"}
#: One-shot codes whose length words are no position of the tool (see _note_literals).
_WORDS_ARE_DATA = frozenset((G.DWELL, G.DATA, G.MACRO_CALL, G.CORNER_ARC, G.ROUGH_TURN, G.ROUGH_FACE, G.PATTERN,
                             G.FINISH))
_MOTION_KIND = {G.G00: RAPID, G.G01: LINE, G.G02: ARC, G.G03: ARC, G.G32: THREAD, G.VARIABLE_LEAD: THREAD,
                G.CIRCULAR_THREAD: THREAD}
_UNMODELLED_REGION = -1  #: _skip_until while a mode that cannot be modelled is in force, up to its cancel code
_CYCLE_KIND = {G.TURN_CYCLE: CYCLE, G.FACE_CYCLE: CYCLE, G.THREAD_CYCLE: THREAD}
#: The words that make a G02/G03 block an arc: the end point on any axis (C, Y, B, A and their
#: incremental H, V), the centre, the radius. An arc in G17 or G19 moves X or Z on its way to it.
_ARC_WORDS = frozenset("XZUWCYBAHVIJKR")


class _Uninterpretable(Exception):
    """The block cannot be interpreted; the message says why, the column where."""

    def __init__(self, message: str, col: int | None = None, unknown_axes: str = "XZ", target=None):
        super().__init__(message)
        self.message = message
        self.col = col
        self.unknown_axes = unknown_axes
        self.target = target  #: the end point as far as it is known, for a motion block


@dataclass
class _Words:
    """A block's words, evaluated: lengths in radius mm, the rest as written."""

    g: list[int] = field(default_factory=list)
    m: list[int] = field(default_factory=list)
    values: dict[str, float] = field(default_factory=dict)
    unknown: dict[str, str] = field(default_factory=dict)  #: letter -> why its value is unknown
    literals: list[tuple[str, bool]] = field(default_factory=list)  #: length words written as numbers: (letter, point)


@dataclass
class _Contour:
    """A P..Q contour: its blocks, kept to be run again by G70."""

    p: int
    q: int
    cycle_line: int
    blocks: list[Block] = field(default_factory=list)
    moves: list[Move] = field(default_factory=list)
    start: tuple[float | None, float | None] = (None, None)


@dataclass
class _Capture:
    """The contour being read after its cycle block."""

    contour: _Contour
    resume: Modal
    resume_at: tuple[float | None, float | None]
    started: bool = False


class Interpreter:
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
    ):
        self.profile = profile
        self.reporter = reporter if reporter is not None else Reporter()
        self.file = file
        self._labels = labels  # the program's LabelIndex, or a callable that scans for it on first use
        self._fast = fast  # ordinary blocks take the fast path (tests compare it with the general one)
        self._refuse_units = refuse_ambiguous_units  # a program that mixes decimal points with plain numbers
        self._memo: dict[tuple, tuple[Modal, Modal]] = {}
        self._interned: dict[Modal, Modal] = {}
        self._jumps: bool | None = None  # whether any label may be a jump target
        self._reread = reread  # callable(first_line, last_line) -> Iterable[Block], for contours placed earlier
        self.table = G.SYSTEMS[profile.gcode_system]
        self._diameter = 0.5 if profile.diameter_x else 1.0  # program X to radius
        self.x: float | None = None
        self.z: float | None = None
        self.modal = Modal(motion=G.G00, inch=False, absolute=True, per_rev=True)
        self.variables: dict[int, float | None] = {}
        self.contours: dict[tuple[int, int], _Contour] = {}
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

    # ------------------------------------------------------------------ driving

    def run(self, blocks: Iterable[Block]) -> Iterator[Step]:
        canonical = self._canonical
        steady = self._steady()
        for block in blocks:
            fields = block.fields
            if fields is not None and steady:  # a canonical block changes none of what _steady reads
                step = canonical(block, fields, True)
                if step is not None:
                    yield step
                    continue
            yield from self._general(block)
            steady = self._steady()
        self._finish()

    def tally(self, blocks: Iterable[Block | tuple]) -> tuple[int, int]:
        """Interpret every block and count blocks and moves, keeping no step: all that
        ``check`` and an identity run need. Takes the reader's light stream
        (``read_blocks(..., light=True)``): a canonical line becomes a block only when
        the general path or an alarm needs one."""
        canonical = self._canonical
        steady = self._steady()
        count = moves = 0
        for block in blocks:
            if type(block) is tuple:
                if steady:  # a canonical block changes none of what _steady reads
                    moved = canonical(block, block[3], False)
                    if moved is not None:
                        count += 1
                        moves += moved
                        continue
                block = canonical_block(*block)
            for step in self._general(block):
                count += 1
                moves += len(step.moves)
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
        try:
            shortened, corner, rest = corner_moves(first, second, kind, size)
        except CornerError as exc:
            raise InterpretationError(str(exc), where) from None
        held.moves = held.moves[:index] + (shortened, corner) + held.moves[index + 1 :]
        step.moves = step.moves[:j] + (rest,) + step.moves[j + 1 :]
        self._corner = None
        return True

    # ------------------------------------------------------------------ one block

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
            step = self._ordinary(block) if block.fields is None else self._canonical(block, block.fields)
            if step is not None:
                step.shared = self._shared
                return step
        try:
            if block.delete is not None and block.codes:
                raise _Uninterpretable("block delete: whether the control runs this block depends on its switch")
            if block.statement is not None:
                step = self._statement(block)
            else:
                step = self._words_step(block)
        except _Uninterpretable as exc:
            step = self._uninterpretable(block, exc)
        if in_contour:
            step.in_contour = True
            step.cycle_line = self._capture.contour.cycle_line
            step.contour_end = self._contour_block(block)
        step.shared = self._shared
        return step

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

    def _note_units(self, block: Block | tuple, plain: str | None, pointed: bool) -> None:
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

    # ------------------------------------------------------------------ the fast path

    def _with(self, modal: Modal, name: str, value) -> Modal:
        """``replace(modal, name=value)``, remembered: programs switch between few states."""
        key = (id(modal), name, value)
        found = self._memo.get(key)
        if found is not None and found[0] is modal:
            return found[1]
        changed = replace(modal, **{name: value})
        changed = self._interned.setdefault(changed, changed)  # equal states become one object
        if len(self._memo) > 4096:
            self._memo.clear()
            self._interned.clear()
        self._memo[key] = (modal, changed)
        return changed

    def with_motion(self, modal: Modal, motion) -> Modal:
        """``modal`` in the motion mode ``motion``, remembered like every change of state."""
        return modal if modal.motion == motion else self._with(modal, "motion", motion)

    def _ordinary(self, block: Block) -> Step | None:
        """An ordinary block (G00-G03, axis words, F, S, M) interpreted without the general
        machinery, or None to take the general path. ``tests/interpret/test_interpreter_fast.py`` checks
        that both give the same steps, modal states and warnings."""
        modal = self.modal
        motion = modal.motion
        profile = self.profile
        inch = modal.inch
        values: dict[str, float] = {}
        motion_given = False
        plain = None  # the first length word without a decimal point (and not 0)
        for letter, value in block.codes:
            if letter == "G":
                mode = _FAST_MOTION.get(value)
                if mode is None or motion_given:
                    return None
                motion, motion_given = mode, True
                continue
            if type(value) is not str:
                return None
            if letter == "M":
                if value in _FLOW_M or not value.isdigit():
                    return None
                continue
            if letter not in _FAST_LETTERS or letter in values:
                return None
            if value[0] == "-" and letter in _UNSIGNED or len(value) > _MAX_DIGITS:
                return None  # the general path says what the control would
            number = float(value)
            if letter in _FAST_LENGTHS:
                if "." not in value:
                    if plain is None and number != 0.0:
                        plain = letter
                    if not profile.calculator_input:
                        number *= profile.increment(inch)
                if inch:
                    number *= INCH
            values[letter] = number
        if motion not in _FAST_MODES:
            return None
        has_x = "X" in values or "U" in values
        has_z = "Z" in values or "W" in values
        if ("X" in values and "U" in values) or ("Z" in values and "W" in values):
            return None
        feed = modal.feed
        if "F" in values:
            feed = values["F"] * (INCH if inch else 1.0)
        if has_x or has_z:
            if motion == G.G01:
                if feed is None or feed == 0.0 or "R" in values or "I" in values or "K" in values:
                    return None
            elif motion != G.G00:
                if feed is None or feed == 0.0 or modal.plane != 18 or self.x is None or self.z is None:
                    return None
        elif "I" in values or "K" in values or "R" in values:
            return None
        # commit the modal changes
        if plain is not None:  # seldom: is any other length word of the block written with its point?
            self._note_units(block, plain, any("." in v for l, v in block.codes if l in _FAST_LENGTHS))
        elif not self._pointed and (has_x or has_z):  # every length word of the block has its point
            self._note_units(block, None, True)
        if feed != modal.feed:
            modal = self._with(modal, "feed", feed)
        if "S" in values and values["S"] != modal.spindle:
            modal = self._with(modal, "spindle", values["S"])
        if motion != modal.motion:
            modal = self._with(modal, "motion", motion)
        self.modal = modal
        if not (has_x or has_z):
            return Step(block, (), modal)
        diameter = 0.5 if profile.diameter_x else 1.0
        x, z = self.x, self.z
        x1, z1 = x, z
        absolute = modal.absolute
        if "X" in values:
            x1 = values["X"] * diameter if absolute else (None if x is None else x + values["X"] * diameter)
        elif "U" in values:
            x1 = None if x is None else x + values["U"] * diameter
        if "Z" in values:
            z1 = values["Z"] if absolute else (None if z is None else z + values["Z"])
        elif "W" in values:
            z1 = None if z is None else z + values["W"]
        if motion == G.G02 or motion == G.G03:
            return self._arc(block, values, motion == G.G02, x1, z1)
        move = Move(RAPID if motion == G.G00 else LINE, block.line, x, z, x1, z1, None, None, None, RUN, modal.feed,
                    modal.per_rev, modal.comp, modal.tool, x1 is not None and z1 is not None, modal.offset)
        self.x, self.z = x1, z1
        return Step(block, (move,), modal)

    def _canonical(self, block: Block | tuple, fields: tuple, keep: bool = True) -> Step | int | None:
        """A canonical block (:mod:`postproc.syntax.fastpath`), read from its fields: the same
        result as :meth:`_ordinary`, without walking its words. None to take the general
        path; with ``keep`` False, the number of moves instead of the step, and ``block``
        may be the reader's light tuple."""
        label, g, x, z, i, k, r, f = fields
        if label is not None and self._jumps is not False and self._is_jump_target(int(label)):
            self._forget()  # a jump may arrive here
        modal = self.modal
        motion = modal.motion if g is None else _FAST_MOTION[g]
        if motion not in _FAST_MODES:
            return None
        inch = modal.inch
        feed = modal.feed if f is None else (float(f) * INCH if inch else float(f))
        if x is None and z is None:
            if i is not None or k is not None or r is not None:
                return None
        elif motion == 10:
            if feed is None or feed == 0.0 or i is not None or k is not None or r is not None:
                return None
        elif motion != 0 and (feed is None or feed == 0.0 or modal.plane != 18 or self.x is None or self.z is None):
            return None
        if feed != modal.feed:
            modal = self._with(modal, "feed", feed)
        if motion != modal.motion:
            modal = self._with(modal, "motion", motion)
        self.modal = modal
        if x is None and z is None:
            return self._shared_step(block, (), modal) if keep else 0
        if not self._pointed:  # a canonical length always has its decimal point
            self._note_units(block, None, True)
        scale = INCH if inch else 1.0
        x0, z0 = self.x, self.z
        if x is None:
            x1 = x0
        elif modal.absolute:
            x1 = float(x) * scale * self._diameter
        else:
            x1 = None if x0 is None else x0 + float(x) * scale * self._diameter
        if z is None:
            z1 = z0
        elif modal.absolute:
            z1 = float(z) * scale
        else:
            z1 = None if z0 is None else z0 + float(z) * scale
        if motion >= 20:
            values = {}
            if i is not None:
                values["I"] = float(i) * scale
            if k is not None:
                values["K"] = float(k) * scale
            if r is not None:
                values["R"] = float(r) * scale
            if not keep:  # block may still be the reader's tuple: an alarm makes it a block
                self._arc_centre(block, values, motion == 20, x1, z1)
                self.x, self.z = x1, z1
                return 1
            step = self._arc(block, values, motion == 20, x1, z1)
            step.shared = self._shared
            return step
        self.x, self.z = x1, z1
        if not keep:
            return 1
        move = _new_move(Move, (RAPID if motion == 0 else LINE, block.line, x0, z0, x1, z1, None, None, None, RUN,
                                modal.feed, modal.per_rev, modal.comp, modal.tool, x1 is not None and z1 is not None,
                                modal.offset))
        return self._shared_step(block, (move,), modal)

    def _shared_step(self, block: Block, moves: tuple[Move, ...], modal: Modal) -> Step:
        step = Step(block, moves, modal)
        if self._shared:
            step.shared = True
        return step

    # ------------------------------------------------------------------ macro statements

    # Macro values exist only in blocks the grammar read, which imported the macro module:
    # these methods import it where they need it, and a program without macros never does.

    def _statement(self, block: Block) -> Step:
        from ..syntax import macro
        from ..syntax.macro import UNKNOWN

        statement = block.statement
        kind = type(statement)
        if kind is macro.Assignment:
            self._assign(statement, block)
        elif kind is macro.IfThen:
            condition = self._evaluate(statement.condition, block)
            if condition is UNKNOWN:
                target = self._variable_number(statement.then.target, block)
                if target is None:
                    self.variables = {}
                else:
                    self.variables.pop(target, None)
            elif condition:
                self._assign(statement.then, block)
        elif kind is macro.IfGoto:
            condition = self._evaluate(statement.condition, block)
            if condition is not UNKNOWN and condition:
                self._forget()  # the jump is taken
        elif kind is macro.Goto:
            self._forget()  # the jump is taken
        elif kind in (macro.WhileDo, macro.DoLoop, macro.EndLoop):
            self._forget()  # a loop may run again
        return Step(block, (), self.modal)

    def _assign(self, assignment: macro.Assignment, block: Block) -> None:
        from ..syntax.macro import UNKNOWN

        number = self._variable_number(assignment.target, block)
        value = self._evaluate(assignment.value, block)
        if number is None:
            self.variables = {}  # an indirect target we cannot resolve may be any variable
            return
        if number == 0 or (number >= 1000 and number not in range(1, 1000)):
            return  # #0 cannot be set; system variables act on the control, not on the path
        if value is UNKNOWN:
            self.variables.pop(number, None)
        else:
            self.variables[number] = value

    def _variable_number(self, variable: macro.Variable, block: Block) -> int | None:
        from ..syntax.macro import UNKNOWN

        if variable.name is not None:
            return None
        if isinstance(variable.index, int):
            return variable.index
        value = self._evaluate(variable.index, block)
        if value is UNKNOWN or value is None:
            return None
        return int(round(value))

    def _evaluate(self, expr, block: Block):
        from ..syntax import macro

        try:
            return macro.evaluate(expr, self.variables)
        except macro.MacroValueError as exc:
            raise InterpretationError(f"macro expression: {exc}", self._location(block, self._first_col(block))) from None

    # ------------------------------------------------------------------ words

    def _collect(self, block: Block) -> _Words:
        words = _Words()
        profile = self.profile
        inch = self.modal.inch
        calculator = profile.calculator_input
        increment = profile.increment(inch)
        scale = INCH if inch else 1.0
        macro_call = False
        arguments = any(letter == "G" and value in _MACRO_CALLS for letter, value in block.codes)
        for letter, value in block.codes:
            if type(value) is str:
                argument = arguments and letter != "G"  # a G65/G66 argument: any number, passed as written
                if not argument:
                    self._check_format(block, letter, value)
                number = float(value)
                point = argument or "." in value
            else:
                from ..syntax.macro import UNKNOWN, VACANT

                number = self._evaluate(value, block)
                if number is UNKNOWN:
                    words.unknown[letter] = "its value is only known when the program runs"
                    continue
                if number is VACANT:
                    continue  # a vacant variable: the control acts as if the word were absent
                point = True
            if letter == "G":
                key = G.code_key(number)
                words.g.append(key)
                if key in (650, 660):
                    macro_call = True
                continue
            if letter == "M":
                words.m.append(int(number))
                continue
            if letter in _LENGTH_ADDRESSES:
                if type(value) is str and not argument and (point or number != 0.0):
                    words.literals.append((letter, point))
                if not point and not calculator:
                    number *= increment
                number *= scale
            if letter in words.values and not macro_call:
                raise InterpretationError(
                    f"address {letter} appears twice in one block",
                    self._location(block, self._col(block, letter, 2)),
                )
            words.values[letter] = number
        return words

    def _check_format(self, block: Block, letter: str, value: str) -> None:
        """The control's format alarms for a number as written (PS0003, PS0006, PS0007)."""
        unsigned = value.lstrip("+-")
        if "." in unsigned:
            unsigned = unsigned.rstrip("0")
        digits = unsigned.replace(".", "").lstrip("0")  # the significant digits
        if len(digits) > _MAX_DIGITS:
            raise InterpretationError(f"{letter}{value}: more than {_MAX_DIGITS} digits (FANUC alarm PS0003)",
                                      self._location(block, self._col(block, letter)))
        if value.startswith("-") and letter in _UNSIGNED:
            raise InterpretationError(f"{letter}{value}: address {letter} takes no sign (FANUC alarm PS0006)",
                                      self._location(block, self._col(block, letter)))
        if "." in value and letter in _WHOLE:
            raise InterpretationError(f"{letter}{value}: address {letter} takes no decimal point (FANUC alarm PS0007)",
                                      self._location(block, self._col(block, letter)))

    def _words_step(self, block: Block) -> Step:
        if not block.codes:
            return Step(block, (), self.modal)
        words = self._collect(block)
        if "G" in words.unknown:
            self.modal = replace(self.modal, motion=None)
            raise _Uninterpretable("a G code whose value is only known when the program runs", self._col(block, "G"))
        for letter in ("T", "F", "S", "M", "P", "Q"):
            if letter in words.unknown and letter not in "FS":
                raise _Uninterpretable(f"{letter} value is only known when the program runs", self._col(block, letter))
        return self._apply(block, words)

    def _apply(self, block: Block, words: _Words) -> Step:
        table = self.table
        one_shot = None
        modal = self.modal
        motion = modal.motion
        for key in words.g:
            entry = table.get(key)
            if entry is None:
                self.modal = replace(self.modal, motion=None)
                raise _Uninterpretable(
                    f"{G.code_name(key)} is not a G code this interpreter knows (G-code system {self.profile.gcode_system}; "
                    "FANUC alarm PS0010 on a control without it)",
                    self._col(block, "G"),
                )
            kind, meaning = entry
            if kind == G.MOTION:
                motion = meaning
                self._drilling = False
            elif kind == G.ONE_SHOT:
                if one_shot is not None:
                    raise InterpretationError(
                        f"two G codes of group 00 in one block ({G.code_name(one_shot[0])} and {G.code_name(key)})",
                        self._location(block, self._col(block, "G", 2)),
                    )
                one_shot = (key, meaning)
            elif kind == G.MODAL:
                modal = self._modal_setting(modal, meaning, key)
            elif kind == G.CANCEL and one_shot is None:
                one_shot = (key, G.DATA)  # "G50.1 X0.": the words name the mode's axes, they are no move
            elif kind == G.UNMODELLED and not (meaning == G.CYLINDRICAL and self._cancels_cylindrical(words)):
                self._unmodelled, self._skip_until = meaning, _UNMODELLED_REGION
                self.modal = replace(self.modal, motion=None)
                raise _Uninterpretable(f"{G.code_name(key)} ({meaning}) is not modelled: the blocks up to its cancel "
                                       "code pass through uninterpreted, and positions are unknown until an absolute "
                                       "move after it", self._col(block, "G"))
        modal = self._tool_and_feed(modal, block, words)
        if motion != modal.motion:
            modal = replace(modal, motion=motion)
        if modal != self.modal:
            self.modal = modal
        self._check_addresses(block, words, one_shot)
        if words.literals:
            self._note_literals(block, words.literals, None if one_shot is None else one_shot[1])

        if 98 in words.m or 99 in words.m or 30 in words.m or 2 in words.m:
            return self._program_flow(block, words)
        if one_shot is not None:
            return self._one_shot(block, words, one_shot[1])
        if self._modal_macro and self._has_axis(words):
            raise _Uninterpretable("a modal macro call (G66) runs with this move")
        if self._drilling and self._has_axis(words):
            self._need_feed(block, words, CYCLE, G.DRILL)
            raise _Uninterpretable("a drilling cycle (G83-G89) is not modelled")
        if self._has_axis(words) or any(letter in words.unknown for letter in "XZUW"):
            return self._motion(block, words)
        if self.modal.motion in (G.G02, G.G03):
            if "I" in words.values or "K" in words.values:
                return self._motion(block, words)  # a full circle: the end is the start
            if self.modal.plane != 18 and any(letter in _ARC_WORDS for letter in words.values):
                return self._motion(block, words)  # an arc in another plane moves X or Z on its way: say so
        return Step(block, (), self.modal)

    def _modal_setting(self, modal: Modal, meaning, key: int) -> Modal:
        if meaning == G.INCH:
            return replace(modal, inch=True)
        if meaning == G.METRIC:
            return replace(modal, inch=False)
        if meaning == G.ABSOLUTE:
            return replace(modal, absolute=True)
        if meaning == G.INCREMENTAL:
            return replace(modal, absolute=False)
        if meaning == G.PER_MINUTE:
            return replace(modal, per_rev=False)
        if meaning == G.PER_REV:
            return replace(modal, per_rev=True)
        if meaning in (G.COMP_OFF, G.COMP_LEFT, G.COMP_RIGHT):
            return replace(modal, comp=key // 10)
        if meaning in (G.PLANE_XY, G.PLANE_ZX, G.PLANE_YZ):
            return replace(modal, plane=key // 10)
        if meaning == G.WORK:
            if self._work != key:
                if self._work is not None:
                    self.x = self.z = None  # another work coordinate system: where are we in it?
                self._work = key
            return modal
        if meaning == G.DRILL:
            self._drilling = True
            return modal
        if meaning == G.DRILL_CANCEL:
            self._drilling = False
            return modal
        if meaning == G.CSS_ON:
            return replace(modal, css=True)
        if meaning == G.CSS_OFF:
            return replace(modal, css=False)
        if meaning == G.MODAL_MACRO:
            self._modal_macro = True
            return modal
        if meaning == G.MODAL_MACRO_CANCEL:
            self._modal_macro = False
            return modal
        return modal

    def _tool_and_feed(self, modal: Modal, block: Block, words: _Words) -> Modal:
        values = words.values
        if "F" in values:
            feed = values["F"] * (INCH if modal.inch else 1.0)
            if feed != modal.feed:
                modal = replace(modal, feed=feed)
        if "S" in values and not self._clamps_spindle(words):
            if values["S"] != modal.spindle:
                modal = replace(modal, spindle=values["S"])
        if "T" in values:
            t = int(values["T"])
            tool, offset = (t // 100, t % 100) if t >= 100 else (t, None)
            if (tool, offset) != (modal.tool, modal.offset):
                modal = replace(modal, tool=tool, offset=offset)
        return modal

    def _clamps_spindle(self, words: _Words) -> bool:
        """G50 S (G92 S in systems B and C) sets the spindle speed limit, not the speed."""
        return any(self.table.get(key, (None, None))[1] == G.COORDINATE for key in words.g)

    def _check_addresses(self, block: Block, words: _Words, one_shot) -> None:
        if one_shot is not None and one_shot[1] in (G.MACRO_CALL, G.DATA):
            return
        for letter in ("Y", "V", "B"):
            if letter in words.values and letter not in self.profile.axes:
                raise InterpretationError(
                    f"address {letter}: this lathe has no {letter} axis (axes {', '.join(self.profile.axes)}; FANUC alarm PS0009)",
                    self._location(block, self._col(block, letter)),
                )
        if "X" in words.values and "U" in words.values:
            raise InterpretationError("X and U both given for the X axis", self._location(block, self._col(block, "U")))
        if "Z" in words.values and "W" in words.values:
            raise InterpretationError("Z and W both given for the Z axis", self._location(block, self._col(block, "W")))

    @staticmethod
    def _has_axis(words: _Words) -> bool:
        values = words.values
        return "X" in values or "Z" in values or "U" in values or "W" in values

    # ------------------------------------------------------------------ positions

    def _target(self, words: _Words) -> tuple[float | None, float | None]:
        """The end point the block's X/Z/U/W words name (radius mm), None where unknown."""
        values = words.values
        diameter = 0.5 if self.profile.diameter_x else 1.0
        incremental = not self.modal.absolute
        x, z = self.x, self.z
        if "X" in values:
            value = values["X"] * diameter
            x = (None if x is None else x + value) if incremental else value
        elif "U" in values:
            x = None if x is None else x + values["U"] * diameter
        if "Z" in values:
            value = values["Z"]
            z = (None if z is None else z + value) if incremental else value
        elif "W" in values:
            z = None if z is None else z + values["W"]
        if "X" in words.unknown or "U" in words.unknown:
            x = None
        if "Z" in words.unknown or "W" in words.unknown:
            z = None
        return x, z

    def _role(self) -> str:
        return CONTOUR if self._capture is not None else RUN

    def _move(self, kind: str, block: Block, x1, z1, xc=None, zc=None, cw=None, exact: bool = True) -> Move:
        modal = self.modal
        return _new_move(Move, (kind, block.line, self.x, self.z, x1, z1, xc, zc, cw, self._role(), modal.feed,
                                modal.per_rev, modal.comp, modal.tool, exact, modal.offset))

    # ------------------------------------------------------------------ motion

    def _motion(self, block: Block, words: _Words) -> Step:
        motion = self.modal.motion
        if motion is None:
            raise _Uninterpretable("the motion mode (G00/G01/G02/G03) is not known here")
        values = words.values
        x1, z1 = self._target(words)
        unknown = [letter for letter in words.unknown if letter not in "FS"]
        if unknown:
            raise _Uninterpretable(
                f"{', '.join(unknown)}: a value only known when the program runs",
                self._col(block, unknown[0]),
                unknown_axes="".join(a for a, v in (("X", x1), ("Z", z1)) if v is None),
                target=(x1, z1),
            )
        if isinstance(motion, str):
            self._need_feed(block, words, _CYCLE_KIND[motion], motion)
            return self._single_cycle(block, words, motion, x1, z1)
        kind = _MOTION_KIND[motion]
        self._need_feed(block, words, kind, motion)
        if motion in (G.G02, G.G03):
            if self.modal.plane != 18:
                raise _Uninterpretable(f"an arc in plane G{self.modal.plane}, not the lathe's ZX plane (G18)")
            return self._arc(block, words.values, motion == G.G02, x1, z1)
        for letter in ("R", "I", "K", ",A") if motion == G.G01 else ():
            if letter in values:
                raise _Uninterpretable(
                    f"{letter} in a G01 block (chamfering or corner R by the control's parameter 3405, or direct drawing)",
                    self._col(block, letter[-1]),
                )
        if "C" in values and "C" not in self.profile.axes:
            raise _Uninterpretable("C in a motion block: chamfering by parameter, or a C axis", self._col(block, "C"))
        move = self._move(kind, block, x1, z1, exact=None not in (x1, z1))
        self.x, self.z = x1, z1
        step = Step(block, (move,), self.modal)
        self._note_corner(step, block, values)
        return step

    def _need_feed(self, block: Block, words: _Words, kind: str, meaning) -> None:
        """A cutting move, a cycle's cut or a thread runs at the F in force (a thread's lead):
        F0 is the control's alarm PS0011, wherever it was set; no F at all yet is a warning (the
        control runs at the F an earlier program left, or alarms). A rapid needs none; a thread
        whose lead an E word gives needs no F. ``meaning``: the motion mode or one-shot meaning
        of the code that cuts (named in the message)."""
        if kind == RAPID or "F" in words.unknown or (kind == THREAD and words.values.get("E")):
            return
        feed = self.modal.feed
        if feed is None:
            if not self._feed_warned:
                self._feed_warned = True
                what = "threading" if kind == THREAD else "feed move"
                self.reporter.warn(f"{what} before any F word: the control uses the F an earlier program left, or "
                                   "alarms (PS0011)", self._location(block, self._first_col(block)))
            return
        if feed != 0.0:
            return
        if kind in (LINE, ARC):
            what = "feed move with feed rate F0"
        else:
            what = f"{'threading with lead' if kind == THREAD else 'cycle with feed rate'} F0"
            key = next((key for key in words.g if self.table.get(key, (None, None))[1] == meaning), None)
            if key is None and any(entry == (G.MOTION, meaning) for entry in self.table.values()):
                key = G.motion_code(self.profile.gcode_system, meaning)  # modal: the code in force
            if key is not None:
                what = f"{G.code_name(key)}: {what}"
        col = self._col(block, "F")
        raise InterpretationError(f"{what} (FANUC alarm PS0011)",
                                  self._location(block, self._first_col(block) if col is None else col))

    def _arc(self, block: Block, values: dict[str, float], cw: bool, x1, z1) -> Step:
        xc, zc = self._arc_centre(block, values, cw, x1, z1)
        move = self._move(ARC, block, x1, z1, xc=xc, zc=zc, cw=cw)
        self.x, self.z = x1, z1
        step = Step(block, (move,), self.modal)
        self._note_corner(step, block, values)
        return step

    def _arc_centre(self, block: Block | tuple, values: dict[str, float], cw: bool, x1, z1) -> tuple[float, float]:
        """The centre of the arc from here to (x1, z1), or the control's alarm (``block`` may
        be the reader's light tuple: only an alarm reads it)."""
        if None in (self.x, self.z, x1, z1):
            self.x, self.z = x1, z1
            raise _Uninterpretable("an arc from or to a position that is not known", None,
                                   unknown_axes="".join(a for a, v in (("X", x1), ("Z", z1)) if v is None))
        x0, z0 = self.x, self.z
        tolerance = self.profile.arc_radius_tolerance
        if "R" in values:
            radius = values["R"]
            chord = math.hypot(x1 - x0, z1 - z0)
            if chord == 0.0:
                raise InterpretationError("R arc whose end point is its start point: the control cannot place it",
                                          self._location(block, self._col(block, "R")))
            if radius == 0.0:
                raise InterpretationError("R arc of radius 0 (FANUC alarm PS0023)", self._location(block, self._col(block, "R")))
            half = chord / 2.0
            if half > abs(radius) + tolerance:
                raise InterpretationError(
                    f"R arc too short: the chord {chord:.4f} mm exceeds twice the radius {abs(radius):.4f} mm "
                    f"(FANUC alarm PS0020)",
                    self._location(block, self._col(block, "R")),
                )
            height = math.sqrt(max(radius * radius - half * half, 0.0))
            # Left of the chord in the (x, z) plane is where theta grows: a G02 arc of at
            # most 180 degrees turns about a centre on that side.
            left = 1.0 if cw else -1.0
            if radius < 0:
                left = -left
            ux, uz = (x1 - x0) / chord, (z1 - z0) / chord
            xc = (x0 + x1) / 2.0 - left * height * uz
            zc = (z0 + z1) / 2.0 + left * height * ux
        else:
            if "I" not in values and "K" not in values:
                raise InterpretationError("G02/G03 without R or I/K (FANUC alarm PS0022)",
                                          self._location(block, self._col(block, "G")))
            xc = x0 + values.get("I", 0.0)
            zc = z0 + values.get("K", 0.0)
            r0 = math.hypot(x0 - xc, z0 - zc)
            r1 = math.hypot(x1 - xc, z1 - zc)
            if r0 == 0.0:
                raise InterpretationError("arc of radius 0: I and K are both zero", self._location(block, self._col(block, "I")))
            if abs(r0 - r1) > tolerance:
                raise InterpretationError(
                    f"arc end point is off the circle: radius {r0:.4f} mm at the start, {r1:.4f} mm at the end "
                    f"(limit {tolerance} mm, FANUC alarm PS0020)",
                    self._location(block, self._col(block, "I") if "I" in values else self._col(block, "K")),
                )
        return xc, zc

    def _note_corner(self, step: Step, block: Block, values: dict) -> None:
        """Remember a ,C or ,R word: the corner is cut when the next move is known."""
        for kind in (",C", ",R"):
            if kind in values:
                self._fresh_corner = (len(step.moves) - 1, kind, values[kind])

    def _single_cycle(self, block: Block, words: _Words, cycle: str, x1, z1) -> Step:
        kind = _CYCLE_KIND[cycle]
        move = self._move(kind, block, self.x, self.z, exact=None not in (self.x, self.z, x1, z1))
        return Step(block, (move,), self.modal)

    # ------------------------------------------------------------------ one-shot codes

    def _one_shot(self, block: Block, words: _Words, meaning: str) -> Step:
        values = words.values
        if meaning in (G.DWELL, G.DATA, G.CORNER_ARC):  # G39's I and K give a direction, not a position
            return Step(block, (), self.modal)
        if meaning == G.COORDINATE:
            if "S" in values:
                self.modal = replace(self.modal, clamp=values["S"])
            if any(letter in values for letter in "XZ") or any(letter in words.unknown for letter in "XZ"):
                x, z = self.x, self.z
                diameter = 0.5 if self.profile.diameter_x else 1.0
                if "X" in values:
                    x = values["X"] * diameter
                if "Z" in values:
                    z = values["Z"]
                if "X" in words.unknown:
                    x = None
                if "Z" in words.unknown:
                    z = None
                self.x, self.z = x, z
            return Step(block, (), self.modal)
        if meaning in (G.HOME, G.HOME2):
            return self._reference_return(block, words)
        if meaning == G.MACHINE:
            named = [axis for axis, letters in (("X", "XU"), ("Z", "ZW")) if any(l in values for l in letters)]
            x1 = None if "X" in named else self.x
            z1 = None if "Z" in named else self.z
            move = self._move(RAPID, block, x1, z1, exact=False)
            self.x, self.z = x1, z1
            return Step(block, (move,), self.modal)
        if meaning == G.REF_CHECK:
            x1, z1 = self._target(words)
            move = self._move(RAPID, block, x1, z1, exact=None not in (x1, z1))
            self.x, self.z = x1, z1
            return Step(block, (move,), self.modal)
        if meaning in (G.SKIP, G.AUTO_OFFSET):
            if meaning == G.SKIP:  # G31 moves at the F in force until the signal (G36, G37: by parameter)
                self._need_feed(block, words, LINE, meaning)
            x1, z1 = self._target(words)
            move = self._move(LINE, block, None if x1 != self.x else x1, None if z1 != self.z else z1, exact=False)
            self.x, self.z = move.x1, move.z1
            return Step(block, (move,), self.modal)
        if meaning in (G.LOCAL, G.PRESET):
            self.x = self.z = None
            return Step(block, (), self.modal)
        if meaning == G.MACRO_CALL:
            self.reporter.warn(
                "macro call G65: what the macro does is not interpreted; position unknown until the next absolute move",
                self._location(block, self._col(block, "G")),
            )
            self._after_call()
            return Step(block, (), self.modal, interpreted=False)
        if meaning in G.CONTOUR_CYCLES:
            return self._contour_cycle(block, words, meaning)
        if meaning in (G.FACE_PECK, G.GROOVE, G.THREAD_MULTI):
            if not self._has_axis(words):
                return Step(block, (), self.modal)  # the first block of the two-block format: parameters only
            kind = THREAD if meaning == G.THREAD_MULTI else CYCLE
            self._need_feed(block, words, kind, meaning)
            move = self._move(kind, block, self.x, self.z, exact=None not in (self.x, self.z))
            return Step(block, (move,), self.modal)
        raise AssertionError(meaning)

    def _reference_return(self, block: Block, words: _Words) -> Step:
        values = words.values
        named = [axis for axis, letters in (("X", "XU"), ("Z", "ZW")) if any(l in values for l in letters)]
        if not named:
            named = ["X", "Z"]  # G28 alone: Haas and most controls send every axis home
        moves = []
        mid_x, mid_z = self._target(words)
        if (mid_x, mid_z) != (self.x, self.z):
            moves.append(self._move(RAPID, block, mid_x, mid_z, exact=None not in (mid_x, mid_z)))
            self.x, self.z = mid_x, mid_z
        end_x = None if "X" in named else self.x
        end_z = None if "Z" in named else self.z
        moves.append(self._move(RAPID, block, end_x, end_z, exact=False))
        self.x, self.z = end_x, end_z
        return Step(block, tuple(moves), self.modal)

    def _program_flow(self, block: Block, words: _Words) -> Step:
        if 98 in words.m:
            self.reporter.warn(
                "subprogram call M98: what the subprogram does is not interpreted; "
                "position unknown until the next absolute move",
                self._location(block, self._col(block, "M")),
            )
            step = self._motion(block, words) if self._has_axis(words) else Step(block, (), self.modal)
            self._after_call()
            return step
        step = self._motion(block, words) if self._has_axis(words) else Step(block, (), self.modal)
        if 99 in words.m:
            self.x = self.z = None
            self.variables = {}
        else:  # M30, M02: the program ends; what follows is another program (a local subprogram)
            self.x = self.z = None
            self.variables = {}
            self.modal = replace(self.modal, motion=None)
        return step

    def _after_call(self) -> None:
        self.x = self.z = None
        self.variables = {}

    # ------------------------------------------------------------------ contour cycles

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
        recorded = self.contours.get((p, q))
        if p_line > block.line:
            contour = _Contour(p, q, block.line, start=start)
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
            recorded = self._reread_contour(p, q, p_line, q_line, block)
        if meaning == G.FINISH:
            moves = self._replay(recorded, block)
        return Step(block, moves, self.modal)

    def _label_line(self, block: Block, letter: str, label: int, name: str) -> int:
        count = self.labels.counts.get(label, 0)
        if count == 0:
            raise InterpretationError(
                f"{name} {letter}{label}: no block N{label} in the program (FANUC alarm PS0060)",
                self._location(block, self._col(block, letter)),
            )
        if count > 1:
            lines = self.labels.lines[label]
            raise InterpretationError(
                f"{name} {letter}{label}: N{label} stands on {count} blocks (lines {lines[0]}, {lines[1]}...); "
                "the contour is ambiguous",
                self._location(block, self._col(block, letter)),
            )
        return self.labels.lines[label][0]

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
        self.contours[(contour.p, contour.q)] = contour

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

    def _reread_contour(self, p: int, q: int, p_line: int, q_line: int, block: Block) -> _Contour:
        """A contour placed before its cycle that no earlier cycle recorded: read it again."""
        if self._reread is None:
            raise InterpretationError(f"contour N{p}..N{q} cannot be read again here", self._location(block, self._col(block, "P")))
        contour = _Contour(p, q, block.line, blocks=list(self._reread(p_line, q_line)))
        self.contours[(p, q)] = contour
        return contour

    def _replay(self, contour: _Contour, block: Block) -> tuple[Move, ...]:
        """G70: run the contour's blocks from here as the finishing path, then return."""
        start = (self.x, self.z)
        saved_modal = self.modal
        replay = Interpreter(self.profile, Reporter(), self.file, self.labels)
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

    # ------------------------------------------------------------------ positions in messages

    def _location(self, block: Block | tuple, col: int | None) -> Location:
        line, text = (block[0], block[1]) if type(block) is tuple else (block.line, block.text)
        return Location(self.file, line, None if col is None else col + 1, text)

    @staticmethod
    def _col(block: Block | tuple, letter: str, occurrence: int = 1) -> int | None:
        if type(block) is tuple:  # the reader's light tuple of a canonical line
            block = canonical_block(*block)
        seen = 0
        for word in block.words:
            if word.letter == letter:
                seen += 1
                if seen == occurrence:
                    return word.col
        return None

    @staticmethod
    def _first_col(block: Block) -> int:
        words = block.words
        if words:
            return words[0].col
        return len(block.text) - len(block.text.lstrip())


def interpret(blocks: Iterable[Block], **kwargs) -> Iterator[Step]:
    return Interpreter(**kwargs).run(blocks)
