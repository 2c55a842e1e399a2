"""The fast path of the interpreter: an ordinary block's canonical line turned into its step
by the same rules as the general path, with the modal state memoised.

One phase of :class:`~postproc.interpret.interpreter.Interpreter`, as LinuxCNC's rs274ngc keeps
each phase of its interpreter in a file of its own: the methods here work on the Interpreter's
state and hold none of their own."""

from __future__ import annotations

from dataclasses import replace

from . import gcodes as G
from .motion import LINE, Modal, Move, RAPID, RUN, Step
from ..syntax.blocks import Block
from .state import INCH, _FAST_LENGTHS, _FAST_LETTERS, _FAST_MODES, _FAST_MOTION, _FLOW_M, _MAX_DIGITS, _UNSIGNED, _new_move


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
