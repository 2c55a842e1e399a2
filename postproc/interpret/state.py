"""The interpreter's shared ground: the control's format rules, the fast path's spellings, and the
small records its phases pass between them (a block's words, a contour being read)."""

from __future__ import annotations

from dataclasses import dataclass, field

from . import gcodes as G
from .motion import ARC, CYCLE, LINE, Modal, Move, RAPID, THREAD
from ..syntax.blocks import Block

INCH = 25.4

# The fast path: the spellings of G00-G03 it takes, the letters it handles.
_FAST_MOTION = {spelling: mode for mode, spellings in ((0, ("0", "00", "000")), (10, ("1", "01", "001")),
                                                     (20, ("2", "02", "002")), (30, ("3", "03", "003")))
                for spelling in spellings}
_FAST_MODES = frozenset((0, 10, 20, 30))
_FAST_LETTERS = frozenset("XZUWIKRFS")
_FAST_LENGTHS = frozenset("XZUWIKR")
_FLOW_M = frozenset(("2", "02", "002", "30", "030", "98", "098", "99", "099"))



def feed_rate(value: float, inch: bool) -> float:
    """The F word's value as a feed in millimetres (per minute or per revolution): an inch
    program's F is in inches."""
    return value * INCH if inch else value


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
    meaning: str | None = None  #: what the cycle does (gcodes.ROUGH_TURN for a G71...)
    moves: list[Move] = field(default_factory=list)
    start: tuple[float | None, float | None] = (None, None)


@dataclass
class _Capture:
    """The contour being read after its cycle block."""

    contour: _Contour
    resume: Modal
    resume_at: tuple[float | None, float | None]
    started: bool = False

