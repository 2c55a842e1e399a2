"""The fast path of the interpreter: a block that can take it (G00-G03, axis words, F, S, M)
read without the general machinery, by the same rules, with the modal state memoised.

Two kinds of block take it. A canonical block (:mod:`postproc.syntax.fastpath`) is read from
its fields, without walking its words; any other ordinary block has its words walked into
the same fields. Both then go through :meth:`CanonicalLines.canonical_motion`, the fast
path's one set of rules: when it must leave a block to the general path (which warns or
alarms), the modal changes, the end point (the general path's
:meth:`~postproc.interpret.arcs.MotionAndArcs._end_point`, written out), the arc centre (the
general path's own), the feed (:func:`~postproc.interpret.state.feed_rate`) and the move
(:func:`~postproc.interpret.motion.move_under`).
``tests/interpret/test_interpreter_fast.py`` holds both routes to the general path's steps,
modal states, warnings and alarms.

One phase of :class:`~postproc.interpret.interpreter.Interpreter`, as LinuxCNC's rs274ngc keeps
each phase of its interpreter in a file of its own: the methods here work on the Interpreter's
state and hold none of their own."""

from __future__ import annotations

from dataclasses import replace

from .motion import ARC, LINE, Modal, RAPID, RUN, Step, move_under
from ..syntax.blocks import Block
from ..syntax.fastpath import CanonicalLine
from .state import INCH, _FAST_LENGTHS, _FAST_LETTERS, _FAST_MODES, _FAST_MOTION, _FLOW_M, _MAX_DIGITS, _UNSIGNED, feed_rate

class CanonicalLines:
    """The fast path, mixed into :class:`~postproc.interpret.interpreter.Interpreter`."""

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

    def canonical_step(self, block: Block) -> Step | None:
        """The step of a canonical block, or None to take the general path."""
        label = block.fields[0]
        if label is not None:
            self._arrive(label)  # before the move's start is read: a jump may arrive here
        x0, z0 = self.x, self.z
        moved = self.canonical_motion(block)
        return None if moved is None else self._fast_step(block, moved, x0, z0)

    def _arrive(self, label: str) -> None:
        """A block with this sequence number may be a jump's target: forget what only one path knew."""
        if self._jumps is not False and self._is_jump_target(int(label)):
            self._forget()

    def canonical_motion(self, line: Block | CanonicalLine, fields: tuple | None = None, u: bool = False,
                         w: bool = False, spindle: float | None = None, plain: str | None = None) -> int | None:
        """Interpret a canonical line from its fields, without making its step: the number of
        moves it commands (1 or 0), or None (the state as it was) for a block the general path
        must take because it would warn or alarm: a G01-G03 move without a feed or with F0
        (:meth:`_need_feed`), I, K or R where they are no arc's, an arc outside G18 or from an
        unknown position. All that the tally needs, so ``line`` may be the reader's
        :class:`~postproc.syntax.fastpath.CanonicalLine`; the step path (:meth:`_fast_step`)
        reads the move from the state it leaves: the end point, the motion mode and, for an
        arc, ``_centre``.

        The fast path's one set of rules: :meth:`_ordinary` brings its blocks here too, as
        ``fields`` in the canonical layout (N G X Z I K R F, numbers read but not yet in inches)
        with what the canonical form cannot say: ``u``/``w``, the X/Z value is a U/W word;
        ``spindle``, the block's S; ``plain``, its first length word without a decimal point."""
        label, g, x, z, i, k, r, f = line.fields if fields is None else fields
        if label is not None and self._jumps is not False:
            self._arrive(label)
        modal = self.modal
        motion = modal.motion if g is None else _FAST_MOTION[g]
        if motion not in _FAST_MODES:
            return None
        inch = modal.inch
        feed = modal.feed if f is None else feed_rate(float(f), inch)
        if x is None and z is None:
            if i is not None or k is not None or r is not None:
                return None
            moved = 0
        elif motion == 10:  # G01
            if not feed or i is not None or k is not None or r is not None:
                return None
            moved = 1
        elif motion != 0 and (not feed or modal.plane != 18 or self.x is None or self.z is None):
            return None
        else:
            moved = 1
        if plain is not None:  # seldom: is any other length word of the block written with its point?
            self._note_units(line, plain, any("." in v for l, v in line.codes if l in _FAST_LENGTHS))
        elif moved and not self._pointed:  # every length word of the block has its point
            self._note_units(line, None, True)
        if feed != modal.feed:
            modal = self._with(modal, "feed", feed)
        if spindle is not None and spindle != modal.spindle:
            modal = self._with(modal, "spindle", spindle)
        if motion != modal.motion:
            found = self._memo.get((id(modal), "motion", motion))  # _with's memo, looked up without a call
            modal = found[1] if found is not None and found[0] is modal else self._with(modal, "motion", motion)
        self.modal = modal
        if not moved:
            return 0
        scale = INCH if inch else 1.0
        x1, z1 = self.x, self.z
        # _end_point's rule, written out: a call per block costs the tally a tenth of its time
        if x is not None:
            x = float(x) * scale * self._diameter
            x1 = (None if x1 is None else x1 + x) if u or not modal.absolute else x
            if x1 is not None and not self._x_travel[0] <= x1 <= self._x_travel[1]:
                self._beyond_travel(line, "U" if u else "X", "x", x1)
        if z is not None:
            z = float(z) * scale
            z1 = (None if z1 is None else z1 + z) if w or not modal.absolute else z
            if z1 is not None and not self._z_travel[0] <= z1 <= self._z_travel[1]:
                self._beyond_travel(line, "W" if w else "Z", "z", z1)
        if motion >= 20:  # G02, G03
            values = {}
            if i is not None:
                values["I"] = float(i) * scale
            if k is not None:
                values["K"] = float(k) * scale
            if r is not None:
                values["R"] = float(r) * scale
            self._centre = self._arc_centre(line, values, motion == 20, x1, z1)
        self.x, self.z = x1, z1
        return 1

    def _ordinary(self, block: Block) -> Step | None:
        """An ordinary block that is not canonical (plain numbers, U and W, S and M words, other
        spellings) with its words walked, then taken by :meth:`canonical_motion`; or None to
        take the general path."""
        modal = self.modal
        profile = self.profile
        g = None
        values: dict[str, float] = {}
        plain = None  # the first length word without a decimal point (and not 0)
        for letter, value in block.codes:
            if letter == "G":
                if g is not None or value not in _FAST_MOTION:
                    return None
                g = value
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
            if letter in _FAST_LENGTHS and "." not in value:
                if plain is None and number != 0.0:
                    plain = letter
                if not profile.calculator_input:
                    number *= profile.increment(modal.inch)
            values[letter] = number
        get = values.get
        if "U" in values:
            if "X" in values:
                return None
            x, u = values["U"], True
        else:
            x, u = get("X"), False
        if "W" in values:
            if "Z" in values:
                return None
            z, w = values["W"], True
        else:
            z, w = get("Z"), False
        x0, z0 = self.x, self.z
        moved = self.canonical_motion(block, (None, g, x, z, get("I"), get("K"), get("R"), get("F")), u, w,
                                      get("S"), plain)
        return None if moved is None else self._fast_step(block, moved, x0, z0)

    def _fast_step(self, block: Block, moved: int, x0: float | None, z0: float | None) -> Step:
        """The step of a block the fast path took, from (x0, z0): its move, if any, to where
        :meth:`canonical_motion` left the tool, under the modal state now in force."""
        if moved:
            modal = self.modal
            motion = modal.motion
            x1, z1 = self.x, self.z
            if motion < 20:
                move = move_under(modal, RAPID if motion == 0 else LINE, block.line, x0, z0, x1, z1, None, None, None,
                                  RUN, x1 is not None and z1 is not None)
            else:
                xc, zc = self._centre
                move = move_under(modal, ARC, block.line, x0, z0, x1, z1, xc, zc, motion == 20, RUN,
                                  x1 is not None and z1 is not None)
            moves = (move,)
        else:
            moves = ()
        step = Step(block, moves, self.modal)
        if self._shared:
            step.shared = True
        return step
