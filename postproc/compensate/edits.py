"""What becomes of each step the rewriter writes: the records its phases share (an :class:`Entry`
per step, an :class:`Edit` per corrected move), the macro-value policy, and the small helpers
more than one phase uses.

Below the phases of :class:`~postproc.compensate.rewrite.Rewriter`, as
:mod:`postproc.interpret.state` is below the interpreter's."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ..diagnostics import Location, PostprocError, UnplannableBlock
from ..geometry import segment_of
from ..interpret import gcodes as G
from ..interpret.motion import ARC, CONTOUR, CORNER, RAPID, RUN, Move, Step
from ..syntax.blocks import Block, Word
from .segmenter import Cut, Limits, Plan, Target, sample_params

#: What becomes of a block whose geometry words read macro variables (``X[#504+6.]``) when it
#: would be rewritten: the run is refused (the default), it is left uncompensated, or its values
#: are written as numbers (the block then no longer follows the variables).
REFUSE, KEEP, NUMBERS = "refuse", "keep", "numbers"
MACRO_VALUES = (REFUSE, KEEP, NUMBERS)
ALONG = (RUN, CONTOUR, CORNER)  #: the roles of the moves that run along the program
JOIN = 1e-9  #: mm: nominal points closer than this are the same point
NAMED = 5  #: blocks named one by one in the warnings about macro values; the rest are counted


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
    #: target index -> (the target, its limits, its plan) when planned with its batch (:mod:`.batch_plans`)
    presolved: dict[int, tuple[Target, Limits, Plan]] = field(default_factory=dict)

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
        edits = self.edits
        if len(edits) == 1:  # a step of one move, most steps: asked of every step several times
            return edits[0] is not None
        return any(edit is not None for edit in edits)

    @cached_property
    def motion(self) -> bool:
        """Whether the step moves the tool along the program (asked of every step several times)."""
        return any(move.role in (RUN, CONTOUR, CORNER) for move in self.step.moves)


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


#: The M codes that call a program (M98, M198: a subprogram, the second on an external device) or
#: return from one (M99), and the G codes that call a macro (G65; G66 and G66.1, modal), keyed as
#: the interpreter keys them (G65 is 650): ``M0098`` and ``G0065`` are calls too.
_CALL_M = frozenset((98, 99, 198))
_CALL_G = frozenset((650, 660, 661))


def call_word(block: Block) -> Word | None:
    """The block's word that calls a program or returns from one (M98, M198, G65, G66, G66.1,
    M99, however written), or None. An M word whose value a macro variable gives (``M[#1]``)
    may be one, and is taken for one. The program it passes to runs from wherever the tool stands:
    it was written for the nominal end of the move before it, and an incremental one would run
    shifted by that move's correction."""
    if block.fields is not None:  # canonical: N G00-G03 X Z I K R F only
        return None
    for word in block.words:
        letter, value = word.letter, word.value
        if letter not in ("M", "G"):
            continue
        if type(value) is not str:
            if letter == "M":
                return word
            continue
        number = float(value)
        if (int(number) in _CALL_M) if letter == "M" else (G.code_key(number) in _CALL_G):
            return word
    return None


def restarts(step: Step) -> bool:
    """Whether what runs after the block starts from where the program left the tool: a block
    that names the coordinates of where the tool stands (G50 X/Z, G92 in systems B and C, a
    preset), or one that calls a program or returns from one (M98, M198, G65, G66, M99). The tool
    goes back to the nominal end of a corrected move before it, and nothing is joined across it."""
    return step.names_position or call_word(step.block) is not None


def last_along(entry: Entry) -> tuple[Move, Edit | None] | None:
    """The step's last move along the program (a cutting move, not an approach or retract), with
    its edit; None for a step with none: where the tool ends, for the blocks after it."""
    moves = entry.step.moves
    along = [index for index, move in enumerate(moves) if move.role in ALONG]
    return (moves[along[-1]], entry.edits[along[-1]]) if along else None


#: The incremental address of another axis (FANUC G-code system A): H for C, V for Y.
_INCREMENTAL_OF = {"H": "C", "V": "Y"}

#: The limit a block moving another axis meets when its correction needs more than one block.
OTHER_AXIS = "another axis in the block"
#: The limit a block meets when it calls or returns after a move whose end was corrected.
CALL = "a call in the block"
BLOCK_TIME, INTERFERENCE = "minimum block time", "nose radius interference check"  #: limits a block may meet



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


def _cut_of(move: Move) -> Cut:
    if move.kind == ARC:
        return Cut(move.x0, move.z0, move.x1, move.z1, move.xc, move.zc, move.cw)
    return Cut(move.x0, move.z0, move.x1, move.z1, rapid=move.kind == RAPID)


def _group(value, system: str) -> str | None:
    """The kind of a G word's code (gcodes.MOTION, ONE_SHOT...), or None when it is not known."""
    if type(value) is not str:
        return None
    entry = G.SYSTEMS[system].get(G.code_key(float(value)))
    return None if entry is None else entry[0]
