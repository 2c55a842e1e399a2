"""The motion IR: what the interpreter makes of the blocks.

Conventions (docs/formats.md §1): radius coordinates ``x`` (program X / 2 in diameter mode) and
``z``, in millimetres whatever the program's units, in the active work coordinate system.
About an arc centre ``(xc, zc)``, ``theta`` is measured from +X towards +Z:
``x = xc + r cos(theta)``, ``z = zc + r sin(theta)``; G02 (``cw``) runs with theta
increasing, G03 (``ccw``) with theta decreasing. A coordinate the interpreter cannot know
(after G28, or from a value only the control has) is ``None``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

from ..syntax.blocks import Block

RAPID = "rapid"
LINE = "line"
ARC = "arc"
THREAD = "thread"
CYCLE = "cycle"

# Roles of a move in the program's flow.
RUN = "run"  #: executed where it stands
CONTOUR = "contour"  #: a P..Q contour block of G71/G72/G73: defined here, not run in sequence
REPLAY = "replay"  #: a contour move run again by G70 (its line is the contour block's)
CORNER = "corner"  #: the chamfer or fillet a ``,C``/``,R`` word inserts


class Move(NamedTuple):
    """One motion, in radius millimetres.

    Immutable like the other geometric values, but a named tuple rather than a frozen
    dataclass: a program makes one per block, and a tuple is built several times faster.
    Change one with ``move._replace(...)``.
    """

    kind: str  #: rapid, line, arc, thread or cycle
    line: int  #: 1-based line of the block that commands it
    x0: float | None
    z0: float | None
    x1: float | None
    z1: float | None
    xc: float | None = None  #: arc centre
    zc: float | None = None
    cw: bool | None = None  #: arcs: True for G02 (theta increasing), False for G03
    role: str = RUN
    feed: float | None = None  #: F in force, mm/min or mm/rev (see ``per_rev``)
    per_rev: bool = True  #: G99 (A) / G95 (B, C) in force
    comp: int = 40  #: cutter compensation in force: 40, 41 or 42
    tool: int | None = None  #: tool number (T0303 -> 3)
    exact: bool = True  #: geometry known exactly as the control will run it
    offset: int | None = None  #: tool offset number in force (T0312 -> 12)

    @property
    def known(self) -> bool:
        """Start and end both known."""
        return None not in (self.x0, self.z0, self.x1, self.z1)

    @property
    def is_feed(self) -> bool:
        """A cutting move a compensator may change (lines and arcs, not threads or rapids)."""
        return self.kind in (LINE, ARC)

    @property
    def direction(self) -> str | None:
        if self.cw is None:
            return None
        return "cw" if self.cw else "ccw"


_tuple_new = tuple.__new__


def move_under(modal: "Modal", kind: str, line: int, x0: float | None, z0: float | None, x1: float | None,
               z1: float | None, xc: float | None = None, zc: float | None = None, cw: bool | None = None,
               role: str = RUN, exact: bool = True) -> Move:
    """The move from (x0, z0) to (x1, z1) that a block commands under ``modal``: its feed, feed
    mode, cutter compensation, tool and offset are the modal state's. The interpreter's one
    way to make a move: it makes one per block, so the tuple is built directly, without the
    named tuple's keyword-handling ``__new__``."""
    return _tuple_new(Move, (kind, line, x0, z0, x1, z1, xc, zc, cw, role, modal.feed, modal.per_rev, modal.comp,
                             modal.tool, exact, modal.offset))


@dataclass(frozen=True, slots=True)
class Modal:
    """The modal state after a block: shared between blocks until something changes."""

    motion: int | None = None  #: G code x10 of group 01 (0, 10, 20, 30, 320, 900...), None if unknown
    inch: bool = False  #: G20 in force
    absolute: bool = True  #: G90 in systems B and C; always True in system A
    per_rev: bool = True
    comp: int = 40
    plane: int = 18
    feed: float | None = None
    tool: int | None = None
    offset: int | None = None  #: tool offset number (T0303 -> 3)
    spindle: float | None = None  #: S in force: rpm, or surface speed under G96
    css: bool = False  #: G96 constant surface speed in force
    clamp: float | None = None  #: spindle speed limit (G50 S in system A)

    def rpm(self, x: float, limit: float) -> float:
        """Spindle speed at radius ``x`` (mm): the surface speed's rpm under G96, clamped."""
        top = min(self.clamp or limit, limit)
        if self.spindle is None:
            return top
        if not self.css:
            return min(self.spindle, top)
        surface = self.spindle * (304.8 if self.inch else 1000.0)  # mm per minute
        diameter = 2.0 * abs(x)
        return top if diameter == 0 else min(surface / (3.141592653589793 * diameter), top)


@dataclass(slots=True)
class Step:
    """A block and the moves it commands, in program order."""

    block: Block
    moves: tuple[Move, ...]
    modal: Modal  #: state after the block
    interpreted: bool = True  #: False when the block could not be interpreted (it passes through)
    in_contour: bool = False  #: the block belongs to a P..Q cycle contour
    contour_end: bool = False  #: the block is its contour's last (the Q label the cycle looks for)
    cycle_line: int | None = None  #: for a contour block, the line of the cycle that runs it
    cycle: str | None = None  #: for a contour block, what its cycle does (gcodes.ROUGH_TURN for a G71...)
    contour_start: bool = False  #: the block is its contour's first (the P label): the approach from the start point
    shared: bool = False  #: the block is in a local subprogram called from more than one place
    #: the block names the coordinates of where the tool stands (G50 X/Z, G92 in systems B and C,
    #: a preset G50.3/G92.1): the frame it sets follows wherever the tool was sent before it
    names_position: bool = False
