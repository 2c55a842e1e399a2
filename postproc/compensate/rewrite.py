"""Applying corrections: targets through the segmenter into blocks, joined to the rest.

The rewriter streams the interpreted steps in batches (a bounded look-ahead): the pieces of
a batch's moves are corrected in one call, then the steps go through a window of one motion
step and the non-motion steps after it. When the next motion step arrives, the join between
the two is settled, then the window is written out:

- a move whose start moved (its correction is not zero there) gets the previous move's
  end point moved to meet it when that move is a plain line or rapid (as the source's
  Table 6.2 does for the G01 to the pole), else a short connecting G01 first;
- a move whose end moved leaves the next move to start from there: a line or rapid with
  both end coordinates absolute still ends where it did; one that omits an axis or moves
  incrementally gets its end written out absolutely; anything else (an arc, a cycle, a
  thread) gets a connecting G01 back to the nominal end first;
- a block whose motion mode the replacement no longer leaves in force (it relied on
  modal G03, say) gets that code written in front of it;
- a G71/G72 contour is read whole before it is written: its approach (the first block) is
  not corrected but ends where the corrected contour starts, in the axes it moves, and the
  contour is held to run one way as the cycle requires (:mod:`.monotone`), or refused.

Unchanged blocks are copied byte for byte. Every replacement is checked by reading its
text back through the interpreter and measuring the result against the target
(the self-check); a replacement that fails is a SafetyError and nothing is written.
"""

from __future__ import annotations

import math
import operator
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Callable, Iterable, Iterator

import numpy as np

from ..interpret import gcodes as G
from ..syntax.blocks import Block, Word
from ..diagnostics import Location, PostprocError, Reporter, SafetyError, UnplannableBlock
from ..machine import bounds
from ..machine.bounds import MAX_TOLERANCE
from ..machine.profile import MachineProfile
from .compensator import Piece
from .emitter import Style, Writer, with_motion_code
from .farthest import farthest, within
from . import monotone
from .request import Request
from ..geometry import Arc, Line, reversal_params_of, segment_of
from ..interpret.interpreter import Interpreter
from ..interpret.motion import ARC, CONTOUR, CORNER, LINE, RAPID, RUN, Move, Step
from ..syntax.reader import read_blocks
from ..machine.resolution import Grid
from .segmenter import (LINE_MODE, RADIUS_CHECK, RESOLUTION, TOLERANCE, Cut, Limits, Plan, PlanError, Segmenter,
                        Target, measure_bends, plan, sample_params)

JOIN = 1e-9  #: nominal points closer than this are the same point
#: What becomes of a block whose geometry words read macro variables (``X[#504+6.]``) when it
#: would be rewritten: the run is refused (the default), it is left uncompensated, or its values
#: are written as numbers (the block then no longer follows the variables).
REFUSE, KEEP, NUMBERS = "refuse", "keep", "numbers"
MACRO_VALUES = (REFUSE, KEEP, NUMBERS)
NAMED = 5  #: blocks named one by one in the warnings about macro values; the rest are counted
STEPS = (0.0005, 0.001)  #: the output grid's x and z steps (radius mm) of a metric diameter program
BATCH = 256  #: steps read ahead so that their pieces are corrected in one call


def sample_lines(parts: list[Piece]) -> None:
    """Sample the points of every straight piece in one array pass (``Line.point_at``'s
    arithmetic, point for point): a program of short lines has thousands of them."""
    straight = [piece for piece in parts if type(piece.segment) is Line and "points" not in piece.__dict__]
    if not straight:
        return
    counts = [len(piece.t) for piece in straight]
    lines = [piece.segment for piece in straight]
    start = np.repeat(np.array([(line.x0, line.z0) for line in lines]), counts, axis=0)
    delta = np.repeat(np.array([(line.x1 - line.x0, line.z1 - line.z0) for line in lines]), counts, axis=0)
    points = start + np.concatenate([piece.t for piece in straight])[:, None] * delta
    points.setflags(write=False)
    first = 0
    for piece, count in zip(straight, counts):
        piece.__dict__["points"] = points[first : first + count]  # what the cached property would compute
        first += count


def _travel(dx: float, dz: float, last: tuple[int, int], steps: tuple[float, float]) -> tuple[int, int]:
    """Which way each axis runs over a piece that moves it by (dx, dz): the sign of that travel,
    or the way the axis last ran when it travels less than half a step of the output grid
    (an axis the control does not move keeps its backlash where it was; so does one that
    only wanders by less, as an arc does about an apex it barely passes)."""
    x = (dx > 0.0) - (dx < 0.0) if abs(dx) >= steps[0] / 2.0 else last[0]
    z = (dz > 0.0) - (dz < 0.0) if abs(dz) >= steps[1] / 2.0 else last[1]
    return x, z


def pieces(move: Move, last: tuple[int, int] = (0, 0), steps: tuple[float, float] = STEPS,
           turns: list[float] | None = None) -> list[Piece]:
    """A move split where an axis reverses, so direction-dependent corrections act per side.

    ``last`` is the direction each axis last travelled in before the move; ``steps`` the
    output grid's steps in x and z (radius mm). Only reversals the grid can see count
    (:func:`_turns`; ``turns``: what it gives for an arc move, when already worked out).
    """
    segment = segment_of(move)
    if isinstance(segment, Line):
        bounds = [0.0, 1.0]
    else:
        bounds = [0.0, *(_turns(segment, steps) if turns is None else turns), 1.0]
    result = []
    for a, b in zip(bounds, bounds[1:]):
        if isinstance(segment, Line) or (len(bounds) == 2 and segment.r1 is None):
            part = segment  # the whole move: part(0, 1) would be the same arc
        else:
            part = segment.part(a, b)
        (x0, z0), (x1, z1) = part.start, part.end
        last = _travel(x1 - x0, z1 - z0, last, steps)
        result.append(Piece(move, part, sample_params(part), *last))
    return result


def _turns(arc: Arc, steps: tuple[float, float], found: list[float] | None = None) -> list[float]:
    """The parameters where an axis of the arc reverses, as far as the output grid can see.

    A reversal counts when the axis travels at least half a grid step on either side of it
    (up to the arc's ends or the axis's next reversal) and leaves a piece of at least one
    step each way. Less is below what the control commands: an R arc whose end lies a hair
    past an apex (its centre, worked out from R, sits nanometres off the end's axis) turns
    the axis back by picometres, and a piece that short has no block of its own.

    ``found``: the arc's :meth:`Arc.reversal_params`, when already worked out.
    """
    if found is None:
        found = arc.reversal_params()
    if not found:
        return found
    length = arc.length
    shortest = max(steps) / length if length > 0.0 else math.inf
    theta0, sweep = arc.theta0, arc.sweep
    kept: list[float] = []
    previous = 0.0
    for index, t in enumerate(found):
        theta = theta0 + t * sweep
        axis = 0 if abs(math.sin(theta)) < 0.5 else 1  # x turns where sin(theta) = 0, z where cos(theta) = 0
        same = [u for u in found if u != t and (abs(math.sin(theta0 + u * sweep)) < 0.5) == (axis == 0)]
        before = max([u for u in same if u < t], default=0.0)
        after = min([u for u in same if u > t], default=1.0)
        cosine_or_sine = (math.cos, math.sin)[axis]

        def value(u: float) -> float:  # the axis about the centre at parameter u, the radius drifting on a spiral
            return cosine_or_sine(theta0 + u * sweep) * float(arc.radius_at(u))

        here = value(t)
        travel = min(abs(here - value(before)), abs(value(after) - here))
        following = found[index + 1] if index + 1 < len(found) else 1.0
        if travel >= steps[axis] / 2.0 and t - previous >= shortest and following - t >= shortest:
            kept.append(t)
            previous = t
    return kept


def travel_after(move: Move, last: tuple[int, int], steps: tuple[float, float] = STEPS,
                 turns: list[float] | None = None) -> tuple[int, int]:
    """The direction each axis last travelled in, once ``move`` has run: an arc's is that of
    its last piece (as :func:`pieces` splits it; ``turns`` as there).

    Worked out with floats, not the geometry's arrays: it runs for every move of the
    program, compensated or not."""
    if not move.known or move.kind not in (LINE, ARC, RAPID) or not move.exact:
        return (0, 0) if not move.known else last
    if move.xc is None:
        return _travel(move.x1 - move.x0, move.z1 - move.z0, last, steps)
    if (move.x0, move.z0) == (move.xc, move.zc) == (move.x1, move.z1):
        return last
    arc = segment_of(move)
    if arc.sweep == 0.0:
        return last
    if turns is None:
        turns = _turns(arc, steps)
    (x0, z0) = arc.part(turns[-1], 1.0).start if turns else (move.x0, move.z0)
    return _travel(move.x1 - x0, move.z1 - z0, last, steps)


#: The corrections wanted for a run of pieces, in order: an (n, 2) array or None for each.
Corrector = Callable[[list[Piece]], "list[np.ndarray | None]"]


@dataclass
class Edit:
    """What becomes of one move: the targets of its pieces and the cuts planned for them."""

    move: Move
    targets: list[Target]
    plans: list[Plan] = field(default_factory=list)
    lead_in: Cut | None = None  #: connecting move before the first target
    lead_out: Cut | None = None  #: connecting move after the last target
    spans: list[tuple[int, int]] = field(default_factory=list)  #: each plan's cuts in the block's cut list
    #: target index -> the target as corrected, before a cycle's one-way rule held it
    held: dict[int, Target] = field(default_factory=dict)

    @property
    def start(self) -> tuple[float, float]:
        return self.targets[0].start

    @property
    def end(self) -> tuple[float, float]:
        return self.targets[-1].end


@dataclass
class Entry:
    step: Step
    edits: list[Edit | None] = field(default_factory=list)  #: one per move of the step
    retarget: tuple[tuple[float, float] | None, tuple[float, float] | None] | None = None  #: new (start, end)
    refusal: PostprocError | None = None  #: found while correcting the batch, raised when the step is reached
    kept: bool = False  #: left as it is (keep_unplannable): its neighbours meet it, it does not move to meet them
    axes: str = "XZ"  #: the axes its replacement is written with (a type I cycle's approach: one)
    moving: Word | None = None  #: its first word that moves another axis (C, Y...): the block is never split

    @property
    def edited(self) -> bool:
        return any(edit is not None for edit in self.edits)

    @cached_property
    def motion(self) -> bool:
        """Whether the step moves the tool along the program (asked of every step several times)."""
        return any(move.role in (RUN, CONTOUR, CORNER) for move in self.step.moves)


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


class Rewriter:
    """Streams steps to output text, replacing the moves the corrector changes."""

    def __init__(self, steps: Iterable[Step], corrector: Corrector, profile: MachineProfile, request: Request,
                 reporter: Reporter, file: str = "<program>", selects: Callable[[Step, Move], bool] | None = None):
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
        #: whether a block lies in the region, not counting it as selected; a block outside is never rewritten
        self.inside = getattr(selects, "contains", None) or self.selects
        self.mode_now = None  # motion mode the control is in after what was written
        self.original_mode = None  # motion mode the original program had at this point
        self.largest = 0.0  #: largest correction applied, mm
        self.replaced = 0  #: blocks replaced
        self.emitted = 0  #: blocks written for them
        self.worst = 0.0  #: largest measured deviation from a target, mm
        self.unplannable: list[tuple[int, str]] = []  #: (line, limit) of each block left uncompensated
        self.macro_lines: list[int] = []  #: blocks whose macro values were written as numbers, or kept for them
        self.held: list[tuple[int, float]] = []  #: (line, mm off the corrected path) of each block a cycle's one-way rule held
        self._one_way: _OneWay | None = None  # the G71/G72 contour being written, and its rule
        self._pending: list[Entry] | None = None  # a G71/G72 contour's entries, held until its last block is read
        self._window: list[Entry] = []  # the last motion step and the steps after it, not yet written
        self._previous: Entry | None = None  # the last motion step
        self._last_travel: tuple[int, int] = (0, 0)  # direction each axis last travelled in
        self._checker: Interpreter | None = None  # reads replacements back (the self-check)
        self._grids: dict[bool, Grid] = {}  # by inch
        self._allowances: dict[bool, tuple[float, float]] = {}  # for the last check, by inch
        self._grid_steps: dict[bool, tuple[float, float]] = {}  # by inch
        self._limits: dict[tuple[float, bool], Limits] = {}  # by tolerance and inch
        self._others = frozenset(profile.axes) - {"X", "Z"}  # the machine's other axes
        self._other_values: dict[str, float] = {}  # where each other axis was last sent, as written (absolute)

    # ------------------------------------------------------------------ streaming

    def run(self) -> Iterator[str]:
        self._window, self._previous, self._pending = [], None, None
        self.mode_now = self.original_mode = None
        for batch in self._corrected(self.steps):
            for entry in batch:
                if self._others:
                    entry.moving = self._moving_word(entry.step)
                if self._pending is None and entry.step.contour_start and entry.step.cycle in monotone.ONE_WAY_CYCLES:
                    self._pending = []
                if self._pending is not None:  # a G71/G72 contour is settled as a whole, then written
                    self._pending.append(entry)
                    if entry.step.contour_end or not entry.step.in_contour:
                        yield from self._release()
                elif entry.refusal is None and not entry.motion:
                    self._window.append(entry)
                else:
                    yield from self._take(entry)
        if self._pending is not None:
            yield from self._release()
        if self._previous is not None:
            self._join(self._previous, None)
        yield from self._flush(self._window)
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
        if block.statement is not None or not step.interpreted or any(
                (letter, value) in _CALLS for letter, value in block.codes):
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

    def _take(self, entry: Entry) -> Iterator[str]:
        """One step in program order: a motion step is planned, joined to the motion step
        before it, and the window before it written out."""
        if entry.refusal is not None:
            raise entry.refusal
        if not entry.motion:
            self._window.append(entry)
            return
        if entry.edited:
            self._plan_edits(entry)
            if self._one_way is not None and entry.step.in_contour:
                self._hold_plans(entry)
        if self._previous is not None:
            self._join(self._previous, entry)
        yield from self._flush(self._window)
        self._window = [entry]
        self._previous = entry

    def _release(self) -> Iterator[str]:
        entries, self._pending = self._pending, None
        self._one_way = self._settle_one_way(entries)
        for entry in entries:
            yield from self._take(entry)

    def _corrected(self, steps: Iterable[Step]) -> Iterator[list[Entry]]:
        """The steps in batches of at most BATCH, each motion step with its edits: the pieces
        of a whole batch go to the corrector in one call (a bounded look-ahead)."""
        batch: list[Entry] = []
        alarm = None
        try:
            for step in steps:
                batch.append(Entry(step))
                if len(batch) == BATCH:
                    self._correct(batch)
                    yield batch
                    batch = []
        except PostprocError as exc:  # the blocks before it are written first: an error there comes first
            alarm = exc
        if batch:
            self._correct(batch)
            yield batch
        if alarm is not None:
            raise alarm

    # ------------------------------------------------------------------ corrections

    def _candidate(self, step: Step, move: Move) -> bool:
        return (
            step.interpreted
            and not step.shared
            and move.kind in (LINE, ARC)
            and move.exact
            and move.known
            and (move.kind == ARC or (move.x0, move.z0) != (move.x1, move.z1))  # a line of no length: nothing to move
            and move.role in (RUN, CONTOUR, CORNER)
            and step.block.delete is None
            and not (step.contour_start and step.cycle in monotone.ONE_WAY_CYCLES)  # the approach: it meets the shape
            and self.selects(step, move)
        )

    def _correct(self, batch: list[Entry]) -> None:
        """Give each motion step of the batch its edits (None for a move left as it is)."""
        wanted: list[tuple[Entry, int, list[Piece]]] = []
        turns = self._turns_of(batch)
        for entry in batch:
            if not entry.motion:
                continue
            step = entry.step
            entry.edits = [None] * len(step.moves)
            steps = self._steps(step)
            for index, move in enumerate(step.moves):
                mine = turns.get(id(move))
                if self._candidate(step, move):
                    wanted.append((entry, index, pieces(move, self._last_travel, steps, mine)))
                if move.role in (RUN, CONTOUR, CORNER):
                    self._last_travel = travel_after(move, self._last_travel, steps, mine)
        if not wanted:
            return
        every = [piece for _, _, parts in wanted for piece in parts]
        sample_lines(every)
        shifts = self.corrector(every)
        given = [shift for shift in shifts if shift is not None]
        if given:  # the largest correction of each corrected piece, in one pass
            starts = np.cumsum([0] + [len(shift) for shift in given[:-1]])
            joined = np.concatenate(given) if len(given) > 1 else given[0]
            sizes = iter(np.maximum.reduceat(np.hypot(joined[:, 0], joined[:, 1]), starts).tolist())
        first = 0
        lines: list[Target] = []  # the straight targets, for measure_bends
        for entry, index, parts in wanted:
            mine = shifts[first : first + len(parts)]
            first += len(parts)
            if all(shift is None for shift in mine):
                continue
            targets, largest = [], 0.0
            for piece, shift in zip(parts, mine):
                if shift is None:
                    shift = np.zeros((len(piece.t), 2))
                else:
                    size = next(sizes)
                    if size > self.max_correction and entry.refusal is None:  # raised in program order
                        entry.refusal = SafetyError(f"a correction of {size:.4f} mm exceeds the maximum correction "
                                                    f"{self.max_correction:g} mm (--max-correction)",
                                                    Location(self.file, piece.move.line))
                    largest = max(largest, size)
                targets.append(Target.along(piece.segment, piece.t, shift, piece.points))
            moved = largest > 0.0
            if moved and (entry.kept or self._macro_kept(entry)):
                continue  # left as it is: its correction is not applied
            self.largest = max(self.largest, largest)
            if moved:
                edit = Edit(parts[0].move, _merge_continuous(targets, self._tolerance(entry.step) / 10.0))
                entry.edits[index] = edit
                if type(edit.targets[0].nominal) is Line:
                    lines.append(edit.targets[0])
        measure_bends(lines)

    def _turns_of(self, batch: list[Entry]) -> dict[int, list[float]]:
        """:func:`_turns` of every arc move of the batch's motion steps (by ``id`` of the move),
        their reversal parameters found in one array pass: :func:`pieces` and
        :func:`travel_after` both need them, for every arc of the program."""
        arcs: list[Arc] = []
        owners: list[tuple[Move, tuple[float, float]]] = []
        for entry in batch:
            if not entry.motion:
                continue
            steps = self._steps(entry.step)
            for move in entry.step.moves:
                if move.kind == ARC and move.xc is not None and move.known and move.exact:
                    arcs.append(segment_of(move))
                    owners.append((move, steps))
        return {id(move): _turns(arc, steps, found)
                for (move, steps), arc, found in zip(owners, arcs, reversal_params_of(arcs))}

    # ------------------------------------------------------------------ joins

    def _join(self, previous: Entry, entry: Entry | None) -> None:
        """Settle how the last move of ``previous`` meets the first move of ``entry``."""
        moves = [m for m in previous.step.moves if m.role in (RUN, CONTOUR, CORNER)]
        last_move = moves[-1]
        last_edit = previous.edits[previous.step.moves.index(last_move)]
        if entry is None:  # the program ends: nothing follows from the nominal end
            return
        firsts = [m for m in entry.step.moves if m.role in (RUN, CONTOUR, CORNER)]
        first_move = firsts[0]
        first_edit = entry.edits[entry.step.moves.index(first_move)]
        connected = (
            None not in (last_move.x1, last_move.z1, first_move.x0, first_move.z0)
            and abs(last_move.x1 - first_move.x0) < JOIN
            and abs(last_move.z1 - first_move.z0) < JOIN
            and (last_move.role == CONTOUR) == (first_move.role == CONTOUR)
        )
        if self._has_corner(previous.step.block) and first_edit is not None and not previous.edited:
            if self._macro_kept(previous, entry):  # the corner cannot be written out: the follower stays too
                entry.edits = [None] * len(entry.step.moves)
                first_edit = None
            else:
                self._explicit(previous)
                last_edit = previous.edits[previous.step.moves.index(last_move)]
        if not connected:  # the next move does not start from here (a contour's end, a jump): nothing to join
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

    def _connector(self, start, end, step: Step) -> Cut | None:
        a, b = self._snap(step, start), self._snap(step, end)
        if a == b:
            return None
        return Cut(a[0], a[1], b[0], b[1])

    # ------------------------------------------------------------------ units and limits

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

    # ------------------------------------------------------------------ writing

    def _flush(self, window: list[Entry]) -> Iterator[str]:
        for entry in window:
            yield from self._write(entry)

    def _write(self, entry: Entry) -> Iterator[str]:
        step = entry.step
        block = step.block
        before = self.original_mode
        self.original_mode = step.modal.motion
        if not entry.edited and entry.retarget is None:
            fields = block.fields
            if fields is not None:  # a canonical block: G00-G03 at most, read from its fields
                sets_mode = fields[1] is not None
                relies = not sets_mode and any(value is not None for value in fields[2:6])  # X Z I K
            else:
                codes = [value for letter, value in block.codes if letter == "G"]
                sets_mode = any(_group(value, self.profile.gcode_system) == G.MOTION for value in codes)
                relies = (
                    any(letter in "XZUWIK" for letter, _ in block.codes)
                    and not sets_mode
                    and not any(_group(value, self.profile.gcode_system) == G.ONE_SHOT for value in codes)
                )
            if relies and self.mode_now is not None and before is not None and self.mode_now != before:
                writer = Writer(self._grid(step), self.profile.gcode_system, step.modal.absolute)
                yield with_motion_code(block, writer.code(before, Style.of(block)))
                self.mode_now = before
                return
            if sets_mode or self.mode_now is None:
                self.mode_now = step.modal.motion
            self._follow_contour(step, None)
            yield block.raw
            return
        if self.request.macro_values == NUMBERS:
            word = macro_word(block)
            if word is not None:
                self._said_macro(block, word, "its macro values are written as numbers (--macro-values numbers): "
                                              "the block no longer follows the variables it reads")
        cuts = self._cuts(entry)
        _one_block_for_other_axes(entry, len(cuts), self.file, joined=True)  # joins may have split it
        self._within_limits(step, cuts)
        writer = Writer(self._grid(step), self.profile.gcode_system, step.modal.absolute, entry.axes)
        lines, mode = writer.replacement(block, cuts, self.mode_now, label_last=step.contour_end)
        self._self_check(entry, lines, cuts)
        self._near_nominal(entry, cuts)
        self._follow_contour(step, cuts)
        self.mode_now = mode
        self.replaced += 1
        self.emitted += len(lines)
        yield from lines

    def _cuts(self, entry: Entry) -> list[Cut]:
        """The cuts that replace a step, each plan's share recorded for the self-check."""
        step = entry.step
        if entry.retarget is not None:
            move = step.moves[0]
            a = self._snap(step, entry.retarget[0] or (move.x0, move.z0))
            b = self._snap(step, entry.retarget[1] or (move.x1, move.z1))
            return [Cut(a[0], a[1], b[0], b[1], rapid=move.kind == RAPID)]
        cuts: list[Cut] = []

        def add(cut: Cut | None) -> None:
            if cut is None:
                return
            if cuts and cuts[-1].end != cut.start:  # pieces that do not meet: a connecting move
                cuts.append(Cut(*cuts[-1].end, *cut.start))
            if cut.start != cut.end:
                cuts.append(cut)

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
            for planned in edit.plans:
                self.worst = max(self.worst, planned.deviation)
                add(planned.cuts[0])
                first = len(cuts) - 1
                for cut in planned.cuts[1:]:
                    add(cut)
                edit.spans.append((first, len(cuts)))
            add(edit.lead_out)
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
                    edit.plans = [self._plan(step, target, edit.held.get(i)) for i, target in enumerate(edit.targets)]
            _one_block_for_other_axes(entry, sum(len(plan.cuts) for edit in entry.edits if edit is not None
                                                 for plan in edit.plans), self.file)
        except UnplannableBlock as exc:
            if not self.request.keep_unplannable:
                raise
            entry.edits = [None] * len(step.moves)
            entry.kept = True
            self.unplannable.append((step.block.line, exc.limit))
            self.reporter.warn(f"block left uncompensated (--keep-unplannable): {exc.cause}", exc.location)

    def _plan(self, step: Step, target: Target, corrected: Target | None = None) -> Plan:
        """The blocks for a target. ``corrected``: the target as corrected, before a cycle's
        one-way rule held it; the blocks must keep within the tolerance of that one too. They
        usually do when planned for the held target (a held point often slides along the
        path); if not, they are planned within what the holding left of the tolerance."""
        limits = self._limits_for(step)
        try:
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

    def _within_limits(self, step: Step, cuts: list[Cut]) -> None:
        """A compensated move must stay inside the machine's soft limits (the profile's)."""
        for axis, limits, name in ((0, self.profile.x_limits, "x"), (1, self.profile.z_limits, "z")):
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

    # ------------------------------------------------------------------ cycle contours

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
        axes, carries, cycle = monotone.rule(step.cycle, {letter for letter, _ in step.block.codes})
        shape = [(entry, index, move) for entry in entries[1:] if entry.step.in_contour
                 for index, move in enumerate(entry.step.moves) if move.role == CONTOUR]
        drawn = [move for _, _, move in shape if move.kind in (LINE, ARC, RAPID)]
        nominal = [_cut_of(move) for move in drawn if move.known]
        noise = self._noise(step)
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
            where = _at_geometry(self.file, entry.step)
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
                continue  # the nominal contour turns back already: the control alarms on the program as it was
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
                    f"{monotone.alarm(tuple(one_way.ways))}): refused", _at_geometry(self.file, one_way.steps[index]))

    # ------------------------------------------------------------------ self-check

    def _self_check(self, entry: Entry, lines: list[str], cuts: list[Cut]) -> None:
        """Read the replacement back as the control will and check it is what was measured.

        Each plan's deviation from its target was measured on the control's model of its
        blocks (end points on the grid, arcs about the centre their rounded I and K give).
        Reading the written text back through the interpreter must give exactly those
        blocks; then the measured deviation is the deviation of what the control will run.
        """
        step = entry.step
        first = cuts[0]
        checker = self._checker
        if checker is None:
            checker = self._checker = Interpreter(replace(self.profile, name="self-check"), Reporter(),
                                                  self.file)
        checker.x, checker.z = first.x0, first.z0
        checker.modal = checker.with_motion(step.modal, self.mode_now)
        moves: list[Move] = []
        try:
            for block in read_blocks(lines, "<replacement>"):
                moves.extend(checker.step(block).moves)
        except PostprocError as exc:  # the replacement must parse and interpret; anything else is a bug (exit 5)
            raise SafetyError(f"self-check: the replacement does not read back ({exc.message})",
                              _where(self.file, step)) from None
        if len(moves) != len(cuts):
            raise SafetyError(f"self-check: {len(cuts)} moves planned, {len(moves)} read back", _where(self.file, step))
        for planned, move in zip(cuts, moves):
            got = _cut_of(move)
            if got != planned and max(map(abs, map(operator.sub, _numbers(planned), _numbers(got)))) > 1e-9:
                raise SafetyError(f"self-check: a block reads back as {got}, planned {planned}", _where(self.file, step))
        tolerance = self._tolerance(step)
        for edit in entry.edits:
            for planned in (edit.plans if edit is not None else ()):
                allowed = max(tolerance, planned.deviation if planned.widened else tolerance)
                if not planned.deviation <= allowed * (1 + 1e-9):
                    raise SafetyError(
                        f"self-check: the replacement runs {planned.deviation * 1000:.2f} um from the intended path "
                        f"(tolerance {tolerance * 1000:.2f} um)", _where(self.file, step))

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
            if not any(within(cut, segment, allowed) for segment in nominal):
                distance = min(farthest(cut, segment) for segment in nominal)
                raise SafetyError(
                    f"the replacement would run {distance * 1000:.1f} um from the programmed path, more than the "
                    f"largest correction ({self.largest * 1000:.2f} um) plus the tolerance ({tolerance * 1000:.2f} um) "
                    "allow: refused", _where(self.file, step))


BLOCK_TIME, INTERFERENCE = "minimum block time", "nose radius interference check"
_REMEDIES = {
    RESOLUTION: "more decimals (output_decimals_mm, output_decimals_inch in the machine profile) if the control's "
                "increment system takes them",
    RADIUS_CHECK: "the control's own limit as arc_radius_tolerance in the machine profile (FANUC parameter 3410)",
    BLOCK_TIME: "a smaller min_block_time_s in the machine profile, or a lower feed",
    INTERFERENCE: "the tool's own nose radius as nose_radius_mm in the machine profile",
}
_WORDS_OF = {RESOLUTION: "XZUW", RADIUS_CHECK: "RIK", TOLERANCE: "XZUW", BLOCK_TIME: "F", INTERFERENCE: "XZUW"}


def _one_block_for_other_axes(entry: Entry, count: int, file: str, joined: bool = False) -> None:
    """Refuse to split a block that also moves another axis of the machine (C, Y, B...).

    Its X and Z are corrected and may become several blocks; the other axis's word would then
    stand on the first of them alone, so that axis would finish its whole move in the first
    piece (two turns of C in a few microns of X) instead of moving with X and Z to the end.
    No share of it along the pieces is what the program meant either (a C axis in
    interpolation with X and Z follows the block's own path, not the corrected pieces), so
    such a block is written as one block or not at all. ``count``: the blocks planned for it;
    ``joined``: counted after the joins with its neighbours, too late to leave it as it is."""
    word = entry.moving
    if word is None or count <= 1:
        return
    block = entry.step.block
    cause = (f"its {word.letter} move would stand on the first of the {count} blocks that replace it, "
             f"and {word.letter} would finish its whole move there")
    remedy = f"give the {word.letter} move a block of its own in the program"
    if joined:  # its corrected start or end meets a neighbour's through a block of its own
        cause += " (one of them joins it to its neighbour's corrected path)"
    else:
        remedy += ", or a wider --tolerance that keeps this block one move, or --keep-unplannable to leave such " \
                  "blocks uncompensated"
    raise UnplannableBlock(
        f"block cannot be compensated: {cause} ({OTHER_AXIS}); to go on, {remedy}",
        Location(file, block.line, word.col + 1, block.text), OTHER_AXIS, f"{cause} ({OTHER_AXIS})")


#: M98/M99 and G65/G66 (as the reader keys G codes): a call or return, after which the other axes' places are unknown
_CALLS = {("M", "98"), ("M", "99"), ("G", 650), ("G", 660)}

#: The incremental address of another axis (FANUC G-code system A): H for C, V for Y.
_INCREMENTAL_OF = {"H": "C", "V": "Y"}

#: The limit a block moving another axis meets when its correction needs more than one block.
OTHER_AXIS = "another axis in the block"


_REWRITTEN = frozenset("GXZUWIKR") | {",C", ",R", ",A"}  #: words a replacement writes anew (the rest as written)


def macro_word(block: Block):
    """The first word a replacement would write anew (geometry, motion code) whose value reads
    a macro variable (``X[#504+6.]``), or None. A constant expression (``X[2*10.]``) reads none:
    written as a number it means what it meant."""
    if block.fields is not None:  # a canonical block: plain numbers only
        return None
    if all(type(value) is str for _, value in block.codes):
        return None
    from ..syntax.macro import variables_read

    for word in block.words:
        if word.letter in _REWRITTEN and type(word.value) is not str and variables_read(word.value):
            return word
    return None


def _macro_refusal(word, where: Location, detail: str) -> SafetyError:
    return SafetyError(
        f"{word.text} reads a macro variable: compensating this block{detail} writes its value as a number, and "
        "the block would no longer follow the variable; give --macro-values keep to leave such blocks "
        "uncompensated, or --macro-values numbers to write them as numbers (the compensated program then holds "
        "only for the values the program gives its variables)", where)


def _rounded_up(tolerance: float) -> str:
    """A tolerance (mm) a little above ``tolerance``, written with two significant digits."""
    digits = 1 - math.floor(math.log10(tolerance))
    return f"{math.ceil(tolerance * 1.001 * 10**digits) / 10**digits:g}"


def _as_it_is(move: Move) -> Edit:
    """An edit that writes a move out as it is (it shares its block with a change)."""
    segment = segment_of(move)
    t = sample_params(segment)
    return Edit(move, [Target(segment, t, np.zeros((len(t), 2)))])


def _where(file: str, step: Step) -> Location:
    """Where a replaced block stands, for an error about it."""
    return Location(file, step.block.line, None, step.block.text)


def _at_geometry(file: str, step: Step) -> Location:
    """A block's first geometry word (X, Z, U or W), for an error about where it runs."""
    block = step.block
    word = next((w for w in block.words if w.letter in "XZUW"), None)
    return Location(file, block.line, None if word is None else word.col + 1, block.text)


def _cut_of(move: Move) -> Cut:
    if move.kind == ARC:
        return Cut(move.x0, move.z0, move.x1, move.z1, move.xc, move.zc, move.cw)
    return Cut(move.x0, move.z0, move.x1, move.z1, rapid=move.kind == RAPID)


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


def _turns_back(cuts: list[Cut], ways: dict[int, int], noise: float) -> bool:
    return any(monotone.first_turn(cuts[0].start[axis], cuts, axis, way, noise) is not None
               for axis, way in ways.items())


def _numbers(cut: Cut) -> tuple[float, ...]:
    return (cut.x0, cut.z0, cut.x1, cut.z1, cut.xc or 0.0, cut.zc or 0.0, float(bool(cut.cw)), float(cut.rapid))


def _group(value, system: str) -> str | None:
    """The kind of a G word's code (gcodes.MOTION, ONE_SHOT...), or None when it is not known."""
    if type(value) is not str:
        return None
    entry = G.SYSTEMS[system].get(G.code_key(float(value)))
    return None if entry is None else entry[0]


def _merge_continuous(targets: list[Target], gap: float) -> list[Target]:
    """Pieces of one arc whose corrections meet are planned as one target."""
    merged = [targets[0]]
    for target in targets[1:]:
        last = merged[-1]
        if (
            isinstance(last.nominal, Arc)
            and isinstance(target.nominal, Arc)
            and math.dist(last.end, target.start) <= gap
        ):
            a, b = last.nominal, target.nominal
            end = b.end_radius
            whole = Arc(a.xc, a.zc, a.r, a.theta0, a.sweep + b.sweep, None if abs(end - a.r) < 1e-12 else end)
            share = a.sweep / whole.sweep
            t = np.concatenate([last.t * share, share + target.t[1:] * (1 - share)])
            d = np.concatenate([last.d, target.d[1:]])
            merged[-1] = Target(whole, t, d)
        else:
            merged.append(target)
    return merged
