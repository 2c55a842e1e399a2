"""Applying corrections: targets through the segmenter into blocks, joined to the rest.

The rewriter streams the interpreted steps in batches (a bounded look-ahead): the pieces of
a batch's moves are corrected in one call, then the steps go through a window of one motion
step and the non-motion steps after it. When the next motion step arrives, the join between
the two is settled, then the window is written out (past WINDOW non-motion steps, the text
of those that rely on nothing the join decides goes to a temporary file, :mod:`.stretch`, so
that memory stays flat however long the stretch, and the join waits for the next move all
the same):

- a move whose start moved (its correction is not zero there) gets the previous move's
  end point moved to meet it when that move is a plain line or rapid (as the source's
  Table 6.2 does for the G01 to the pole), else a short connecting G01 first;
- a move whose end moved leaves the next move to start from there: a line or rapid with
  both end coordinates absolute still ends where it did; one that omits an axis or moves
  incrementally gets its end written out absolutely; anything else (an arc, a cycle, a
  thread) gets a connecting G01 back to the nominal end first;
- a move with a corrected start and no corrected move before it to meet (the program's first,
  the first after G50 or a call, the first after a cycle, which goes back to its start point, or
  after a shift by G50 U/W, before which a corrected move goes back to its nominal end) is met
  from its nominal start, where the tool stands, by a connecting G01;
- a block whose motion mode the replacement no longer leaves in force (it relied on
  modal G03, say) gets that code written in front of it;
- a G71/G72 contour is read whole before it is written: its approach (the first block) is
  not corrected but ends where the corrected contour starts, in the axes it moves, and the
  contour is held to run one way as the cycle requires (:mod:`.monotone`), or refused.

Unchanged blocks are copied byte for byte. Every replacement is checked by reading its
text back through the interpreter and measuring the result against the target
(the self-check); a replacement that fails is a SafetyError and nothing is written.

The driver and its state are here; each phase is a mixin in a module of its own, as the
interpreter's are: :mod:`.correcting`, :mod:`.joining`, :mod:`.planning`, :mod:`.writing`,
:mod:`.one_way` and :mod:`.self_check`, over the records they share (:mod:`.edits`).
"""

from __future__ import annotations

from typing import Callable, Iterable, Iterator

import numpy as np

from ..diagnostics import Location, PostprocError, Reporter
from ..interpret.interpreter import Interpreter
from ..interpret.motion import Move, Step
from ..syntax.blocks import Word
from ..syntax.source import LabelIndex
from ..machine import bounds
from ..machine.bounds import MAX_TOLERANCE
from ..machine.profile import MachineProfile
from ..machine.resolution import Grid
from . import monotone
from .compensator import Piece
from .emitter import Writer
from .correcting import Correcting, STEPS, _travel, _turns, pieces, sample_lines, travel_after
from .edits import (_INCREMENTAL_OF, ALONG, KEEP, MACRO_VALUES, NAMED, NUMBERS, REFUSE, Edit, Entry, call_word, macro_word,
                    restarts)
from .joining import Joining
from .one_way import OneWayRule, _OneWay
from .planning import Planning
from .request import Request
from .segmenter import Limits
from .self_check import AT_NOMINAL, SelfCheck
from .stretch import SAME, Spool, Stretch
from .writing import Writing

__all__ = ["BATCH", "Corrector", "Edit", "Entry", "KEEP", "MACRO_VALUES", "NAMED", "NUMBERS", "Piece", "REFUSE",
           "Rewriter", "STEPS", "WINDOW", "macro_word", "pieces", "sample_lines", "travel_after", "_travel", "_turns"]

BATCH = 256  #: steps read ahead so that their pieces are corrected in one call
#: Non-motion steps held in memory behind a motion step, at most, before the text of those that
#: rely on nothing its join decides goes to the spool (:mod:`.stretch`): memory stays flat
#: however long the stretch, and the join still waits for the next move
WINDOW = 4096


#: The corrections wanted for a run of pieces, in order: an (n, 2) array or None for each.
Corrector = Callable[[list[Piece]], "list[np.ndarray | None]"]


class Rewriter(Correcting, Joining, Planning, Writing, OneWayRule, SelfCheck):
    """Streams steps to output text, replacing the moves the corrector changes."""

    def __init__(self, steps: Iterable[Step], corrector: Corrector, profile: MachineProfile, request: Request,
                 reporter: Reporter, file: str = "<program>", selects: Callable[[Step, Move], bool] | None = None,
                 labels: LabelIndex | None = None):
        """``profile``: the machine the program runs on (its grid, limits and control rules, and
        how the self-check reads the replacement back); ``request``: what this run was asked for
        (tolerance, mode, maximum correction, the choices for blocks that cannot be held or read
        macro variables); its measurements and compensators are the corrector's business."""
        self.steps = steps
        self.corrector = corrector
        self.profile = profile
        self.request = request
        self.max_correction = bounds.in_force(request.tolerance, request.max_correction, profile)  # mm
        self.reporter = reporter
        self.file = file
        self.selects = selects or (lambda step, move: True)
        self.labels = labels or LabelIndex()  #: where the control may jump, and the cycles' P and Q labels
        #: whether a block lies in the region, not counting it as selected; a block outside is never rewritten
        self.inside = getattr(selects, "contains", None) or self.selects
        self.mode_now = None  # motion mode the control is in after what was written
        self.original_mode = None  # motion mode the original program had at this point
        self.known_mode = None  # the last motion mode the interpreter knew the original program to be in
        self.largest = 0.0  #: largest correction applied, mm
        self.replaced = 0  #: blocks replaced
        self.emitted = 0  #: blocks written for them
        self.worst = 0.0  #: largest measured deviation from a target, mm
        self.unplannable: list[tuple[int, str]] = []  #: (line, limit) of each block left uncompensated
        self.macro_lines: list[int] = []  #: blocks whose macro values were written as numbers, or kept for them
        self.held: list[tuple[int, float]] = []  #: (line, mm off the corrected path) of each block a cycle's one-way rule held
        self._one_way: _OneWay | None = None  # the G71/G72 contour being written, and its rule
        self._pending: list[Entry] | None = None  # a G71/G72 contour's entries, held until its last block is read
        self._window: list[Entry | Stretch] = []  # the last motion step and the steps after it, not yet written
        self._spool = Spool(file)  # the text of the window's stretches
        self._spilled = 0  # the window's first items that the spool has been offered
        self._previous: Entry | None = None  # the last motion step
        self._last_travel: tuple[int, int] = (0, 0)  # direction each axis last travelled in
        self._checker: Interpreter | None = None  # reads replacements back (the self-check)
        #: where the blocks written so far leave the tool, for the self-check: the last motion step's last move
        #: and the end of its last cut as written (None: as programmed), AT_NOMINAL, or None (not known)
        self._tool: tuple[Move, tuple[float, float] | None] | str | None = AT_NOMINAL
        self._grids: dict[bool, Grid] = {}  # by inch
        self._writers: dict[tuple[bool, bool, str], Writer] = {}  # by inch, absolute and axes
        self._allowances: dict[bool, tuple[float, float]] = {}  # for the last check, by inch
        self._grid_steps: dict[bool, tuple[float, float]] = {}  # by inch
        self._limits: dict[tuple[float, bool], Limits] = {}  # by tolerance and inch
        self._others = frozenset(profile.axes) - {"X", "Z"}  # the machine's other axes
        self._other_values: dict[str, float] = {}  # where each other axis was last sent, as written (absolute)

    # ------------------------------------------------------------------ streaming

    def run(self) -> Iterator[str]:
        self._window, self._previous, self._pending, self._spilled = [], None, None, 0
        self._tool = AT_NOMINAL
        self.mode_now = self.original_mode = self.known_mode = None
        others = bool(self._others)
        one_way = monotone.ONE_WAY_CYCLES
        for batch in self._corrected(self.steps):
            for entry in batch:
                step = entry.step
                if others:
                    entry.moving = self._moving_word(step)
                if self._pending is None and step.contour_start and step.cycle in one_way:
                    self._pending = []
                if self._pending is not None:  # a G71/G72 contour is settled as a whole, then written
                    self._pending.append(entry)
                    if step.contour_end or not step.in_contour:
                        yield from self._release()
                elif entry.refusal is None and not entry.motion and not restarts(step):
                    self._window.append(entry)
                    if len(self._window) - self._spilled > WINDOW:
                        if self._previous is None:  # no join waits: written now
                            window, self._window, self._spilled = self._window, [], 0
                            yield from self._flush(window)
                        else:
                            self._spill()
                else:
                    yield from self._flush(self._take(entry))  # each written as its lines are asked for
        if self._pending is not None:
            yield from self._release()
        if self._previous is not None:
            self._join(self._previous, None)
        yield from self._flush(self._window)
        self._spool.close()
        if len(self.macro_lines) > NAMED:
            done = ("left uncompensated" if self.request.macro_values == KEEP
                    else "written with their macro values as numbers")
            self.reporter.warn(f"{len(self.macro_lines)} blocks in all {done} (--macro-values "
                               f"{self.request.macro_values}); the first {NAMED} are named above", Location(self.file))

    def _moving_word(self, step: Step) -> Word | None:
        """The first word of the block that moves another axis of the machine, in program order:
        a value that differs from where the axis was last sent, any incremental value but 0
        (H for C, V for Y), any expression. A CAM post's ``Y0.`` on every block moves nothing."""
        block = step.block
        if block.fields is not None:  # canonical: N G X Z I K R F only
            return None
        if block.statement is not None or not step.interpreted or call_word(block) is not None:
            self._other_values.clear()  # a jump or a call: where the axes stand is no longer known
        moving = None
        for word in block.words:
            letter = _INCREMENTAL_OF.get(word.letter, word.letter)
            if letter not in self._others:
                continue
            number = float(word.value) if type(word.value) is str else None
            incremental = word.letter in _INCREMENTAL_OF or not step.modal.absolute
            if number is None or (number != 0.0 if incremental else self._other_values.get(letter) != number):
                moving = moving or word
            if number is not None and not incremental:
                self._other_values[letter] = number
            elif number != 0.0:
                self._other_values.pop(letter, None)
        return moving


    def _take(self, entry: Entry) -> list[Entry]:
        """One step in program order: a motion step is planned and joined to the motion step
        before it; the window before it is given back, to be written out."""
        if entry.refusal is not None:
            raise entry.refusal
        if not entry.motion:
            if restarts(entry.step):
                if self._previous is not None:  # the frame it names, the program it calls, are the program's
                    self._back_to_nominal(self._previous, entry.step)
                self._previous = None
            self._window.append(entry)
            return []
        if entry.edited:
            self._plan_edits(entry)
            if self._one_way is not None and entry.step.in_contour:
                self._hold_plans(entry)
        if self._previous is not None:
            self._join(self._previous, entry)
        else:
            self._from_nominal_start(entry)
        window, self._window, self._previous, self._spilled = self._window, [entry], entry, 0
        return window

    def _spill(self) -> None:
        """The window past WINDOW steps: the text of each step after its motion step that is
        written as it was read whatever the join decides (one that moves nothing, relies on no
        motion mode and is no block of a cycle's contour) goes to the spool, with what writing
        it does to the motion modes; any other stays in the window, in its place. Each step is
        offered once: the window's first ``_spilled`` items have been."""
        window = self._window
        start = max(self._spilled, 1)
        kept: list[Entry | Stretch] = window[:start]
        stretch = kept[-1] if type(kept[-1]) is Stretch else None
        spool = self._spool
        for item in window[start:]:
            if not item.step.in_contour and not (words := self._motion_words(item.step.block))[1]:
                if stretch is None:
                    stretch = Stretch()
                    kept.append(stretch)
                spool.write(item.step.block.raw)
                stretch.add(item.step.modal.motion, words[0] and item.step.block.delete is None)  # as _write
                continue
            stretch = None  # a step that stays: the next stretch starts after it
            kept.append(item)
        self._window, self._spilled = kept, len(kept)

    def _release(self) -> Iterator[str]:
        entries, self._pending = self._pending, None
        self._one_way = self._settle_one_way(entries)
        for entry in entries:
            yield from self._flush(self._take(entry))

    def _corrected(self, steps: Iterable[Step]) -> Iterator[list[Entry]]:
        """The steps in batches of at most BATCH, each motion step with its edits: the pieces
        of a whole batch go to the corrector in one call (a bounded look-ahead)."""
        batch: list[Entry] = []
        alarm = None
        try:
            for step in steps:
                entry = Entry(step)
                moves = step.moves  # Entry.motion, as the cached property would find it, without its lock
                entry.__dict__["motion"] = (moves[0].role in ALONG or any(move.role in ALONG for move in moves)
                                            if moves else False)
                batch.append(entry)
                if len(batch) == BATCH:
                    self._correct(batch)
                    self._presolve(batch)
                    yield batch
                    batch = []
        except PostprocError as exc:  # the blocks before it are written first: an error there comes first
            alarm = exc
        if batch:
            self._correct(batch)
            self._presolve(batch)
            yield batch
        if alarm is not None:
            raise alarm

    # ------------------------------------------------------------------ units and limits

    @property
    def inch_grids(self) -> tuple[bool, ...]:
        """The units (True: inch) whose output grid the corrected blocks needed."""
        return tuple(self._grids)

    def _grid(self, step: Step) -> Grid:
        inch = step.modal.inch
        grid = self._grids.get(inch)
        if grid is None:
            grid = self._grids[inch] = self.profile.grid(inch)
        return grid

    def _steps(self, step: Step) -> tuple[float, float]:
        """The output grid's x and z steps (radius mm) in the step's units."""
        inch = step.modal.inch
        steps = self._grid_steps.get(inch)
        if steps is None:
            grid = self._grid(step)
            steps = self._grid_steps[inch] = (grid.x_step, grid.z_step)
        return steps

    def _noise(self, step: Step) -> float:
        """Half the least increment of the output (mm, the smaller of X's, a radius, and Z's)."""
        return min(self._steps(step)) / 2.0

    def _allowance(self, step: Step) -> tuple[float, float]:
        """The tolerance the last check counts (at most MAX_TOLERANCE) and one output step in mm
        (the larger of X's, a radius, and Z's), by the program's units."""
        inch = step.modal.inch
        found = self._allowances.get(inch)
        if found is None:
            grid = self._grid(step)
            found = self._allowances[inch] = (min(self._tolerance(step), MAX_TOLERANCE), max(grid.x_step, grid.z_step))
        return found

    def _tolerance(self, step: Step) -> float:
        if self.request.tolerance is not None:
            return self.request.tolerance
        return self.profile.default_tolerance(step.modal.inch)

    def _snap(self, step: Step, point) -> tuple[float, float]:
        return self._grid(step).snap(*point)

    # ------------------------------------------------------------------ writing out

    def _flush(self, window: list[Entry | Stretch]) -> Iterator[str]:
        """A window written out, each stretch's text read back from the spool in its place."""
        stretched = False
        for item in window:
            if type(item) is Stretch:
                yield from self._spool.lines(item.blocks)
                self.mode_now = item.after(self.mode_now)
                self.original_mode = item.original
                if item.known is not SAME:
                    self.known_mode = item.known
                stretched = True
            else:
                yield from self._write(item)
        if stretched:
            self._spool.empty()
