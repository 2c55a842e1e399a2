"""Motion and arcs: a motion block's end point, its move, an arc's centre as the control finds it.

One phase of :class:`~postproc.interpret.interpreter.Interpreter`, as LinuxCNC's rs274ngc keeps
each phase of its interpreter in a file of its own: the methods here work on the Interpreter's
state and hold none of their own."""

from __future__ import annotations

import math

from . import gcodes as G
from .motion import ARC, CONTOUR, LINE, Move, RAPID, RUN, Step, THREAD, move_under
from ..diagnostics import InterpretationError
from ..machine.bounds import beyond_travel
from ..syntax.blocks import Block
from ..syntax.fastpath import CanonicalLine
from .state import _CYCLE_KIND, _MOTION_KIND, _Uninterpretable, _Words


#: Words that change a motion block's path when the lathe lacks the axis they would name: the
#: letter, that axis, what the control makes of it instead (FANUC parameter 3405 bit 4, CCR:
#: chamfer, corner R and direct drawing dimensions without a comma). Read as nothing, ``X50. A150.``
#: would become a move along X alone, and a corrected block would drop the angle the control
#: computes Z from: the block passes through uninterpreted instead.
_PATH_WORDS = (
    ("C", "C", "a chamfer by parameter 3405 bit 4, or a C axis"),
    ("A", "A", "the angle of direct drawing dimension programming (parameter 3405 bit 4), or an A axis"),
    ("H", "C", "the C axis moved incrementally, on a lathe whose profile has no C axis"),
)


class MotionAndArcs:
    """Motion and arcs, mixed into :class:`~postproc.interpret.interpreter.Interpreter`."""

    def _end_point(self, x: float | None, x_incremental: bool, z: float | None,
                   z_incremental: bool) -> tuple[float | None, float | None]:
        """Where a move from the current position ends (radius mm), given the X and Z a block
        names (mm; X as the program writes it, a diameter on a diameter-programmed lathe;
        None for an axis it names no end on), each absolute or incremental (U and W, or X and
        Z under G91). None where the position is unknown and the word incremental. The fast
        path writes this rule out in :meth:`~postproc.interpret.canonical.CanonicalLines.canonical_motion`
        (a call per block costs the tally a tenth of its time); ``tests/interpret/test_interpreter_fast.py``
        holds the two to the same end points."""
        x1, z1 = self.x, self.z
        if x is not None:
            x *= self._diameter
            x1 = (None if x1 is None else x1 + x) if x_incremental else x
        if z is not None:
            z1 = (None if z1 is None else z1 + z) if z_incremental else z
        return x1, z1

    def _target(self, words: _Words, block: Block) -> tuple[float | None, float | None]:
        """The end point the block's X/Z/U/W words name (radius mm), None where unknown: X and Z
        in the distance mode in force, U and W incremental. An end point beyond the travel any
        lathe has (or far beyond the profile's soft limits) is refused here, before anything
        samples the move (:meth:`_beyond_travel`)."""
        values = words.values
        incremental = not self.modal.absolute
        if "X" in values:
            x, x_incremental = values["X"], incremental
        else:
            x, x_incremental = values.get("U"), True
        if "Z" in values:
            z, z_incremental = values["Z"], incremental
        else:
            z, z_incremental = values.get("W"), True
        x, z = self._end_point(x, x_incremental, z, z_incremental)
        if x is not None and not self._x_travel[0] <= x <= self._x_travel[1]:
            self._beyond_travel(block, "X" if "X" in values else "U", "x", x)
        if z is not None and not self._z_travel[0] <= z <= self._z_travel[1]:
            self._beyond_travel(block, "Z" if "Z" in values else "W", "z", z)
        if "X" in words.unknown or "U" in words.unknown:
            x = None
        if "Z" in words.unknown or "W" in words.unknown:
            z = None
        return x, z

    def _beyond_travel(self, block: Block | CanonicalLine, letter: str, axis: str, value: float) -> None:
        """Refuse an end point outside the travel (:func:`~postproc.machine.bounds.travel`)."""
        span = self._x_travel if axis == "x" else self._z_travel
        word = next((w.text for w in block.words if w.letter == letter), letter)
        raise InterpretationError(beyond_travel(word, axis, value, span, f"{axis}_limits",
                                                getattr(self.profile, f"{axis}_limits") is not None),
                                  self._location(block, self._col(block, letter)))

    def _role(self) -> str:
        return CONTOUR if self._capture is not None else RUN

    def _move(self, kind: str, block: Block, x1, z1, xc=None, zc=None, cw=None, exact: bool = True) -> Move:
        return move_under(self.modal, kind, block.line, self.x, self.z, x1, z1, xc, zc, cw, self._role(), exact)

    def _motion(self, block: Block, words: _Words) -> Step:
        motion = self.modal.motion
        if motion is None:
            raise _Uninterpretable("the motion mode (G00/G01/G02/G03) is not known here")
        values = words.values
        x1, z1 = self._target(words, block)
        unknown = [letter for letter in words.unknown if letter not in "FS"]
        if unknown:
            raise _Uninterpretable(
                f"{', '.join(unknown)}: a value only known when the program runs",
                self._col(block, unknown[0]),
                unknown_axes="".join(a for a, v in (("X", x1), ("Z", z1)) if v is None),
                target=(x1, z1),
            )
        for letter, axis, meaning in _PATH_WORDS:
            if letter in values and axis not in self.profile.axes:
                raise _Uninterpretable(f"{letter} in a motion block: {meaning}", self._col(block, letter))
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
        raise InterpretationError(f"{what} (FANUC alarm PS0011)", self._location(block, self._col(block, "F")))

    def _arc(self, block: Block, values: dict[str, float], cw: bool, x1, z1) -> Step:
        xc, zc = self._arc_centre(block, values, cw, x1, z1)
        move = self._move(ARC, block, x1, z1, xc=xc, zc=zc, cw=cw)
        self.x, self.z = x1, z1
        step = Step(block, (move,), self.modal)
        self._note_corner(step, block, values)
        return step

    def _arc_centre(self, block: Block | CanonicalLine, values: dict[str, float], cw: bool, x1,
                    z1) -> tuple[float, float]:
        """The centre of the arc from here to (x1, z1) that the block's I and K or R (``values``,
        radius mm) give, or the control's alarm."""
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
