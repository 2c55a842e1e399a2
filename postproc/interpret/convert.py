"""Words and modal groups: a block's words evaluated, checked and applied to the modal state;
the one-shot codes (dwell, data setting, reference return, program flow).

One phase of :class:`~postproc.interpret.interpreter.Interpreter`, as LinuxCNC's rs274ngc keeps
each phase of its interpreter in a file of its own: the methods here work on the Interpreter's
state and hold none of their own."""

from __future__ import annotations

from dataclasses import replace

from . import gcodes as G
from .motion import CYCLE, LINE, Modal, RAPID, Step, THREAD
from ..diagnostics import InterpretationError
from ..syntax.blocks import Block
from .state import INCH, _ARC_WORDS, _LENGTH_ADDRESSES, _MACRO_CALLS, _MAX_DIGITS, _UNMODELLED_REGION, _UNSIGNED, _Uninterpretable, _WHOLE, _Words, feed_rate


class WordConversion:
    """Words, modal groups and one-shot codes, mixed into :class:`~postproc.interpret.interpreter.Interpreter`."""

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
                    f"FANUC alarm PS0010 on a control without it){G.elsewhere(key, self.profile.gcode_system)}",
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
                modal = self._modal_setting(modal, meaning, key, words)
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

        if 98 in words.m or 99 in words.m or 30 in words.m or 2 in words.m or 198 in words.m:
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

    def _modal_setting(self, modal: Modal, meaning, key: int, words: _Words) -> Modal:
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
            system = (key, words.values.get("P")) if key == 541 else key  # G54.1 P1..P300: P names the system
            if self._work != system:
                if self._work is not None:
                    self.x = self.z = None  # another work coordinate system: where are we in it?
                self._work = system
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
            feed = feed_rate(values["F"], modal.inch)
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

    def _one_shot(self, block: Block, words: _Words, meaning: str) -> Step:
        values = words.values
        if meaning in (G.DWELL, G.DATA, G.CORNER_ARC):  # G39's I and K give a direction, not a position
            if meaning == G.DATA and 100 in words.g and self._shifts_work_coordinates(words):
                self._forget_shifted_axes(words)
            return Step(block, (), self.modal)
        if meaning == G.COORDINATE:
            if "S" in values:
                self.modal = replace(self.modal, clamp=values["S"])
            # The tool stays; its coordinates become those a move with these words would end at:
            # U and W added to the old ones (G50 W-5.), X and Z named in G90. X or Z under G91
            # (G92 in systems B and C) is read by controls either way, as new coordinates or as a
            # shift: the position on that axis is unknown, not guessed.
            x, z = self._target(words, block)
            if not self.modal.absolute:
                x = None if "X" in values or "X" in words.unknown else x
                z = None if "Z" in values or "Z" in words.unknown else z
            self.x, self.z = x, z
            return Step(block, (), self.modal, names_position=self.modal.absolute and ("X" in values or "Z" in values))
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
            x1, z1 = self._target(words, block)
            move = self._move(RAPID, block, x1, z1, exact=None not in (x1, z1))
            self.x, self.z = x1, z1
            return Step(block, (move,), self.modal)
        if meaning in (G.SKIP, G.AUTO_OFFSET):
            if meaning == G.SKIP:  # G31 moves at the F in force until the signal (G36, G37: by parameter)
                self._need_feed(block, words, LINE, meaning)
            x1, z1 = self._target(words, block)
            move = self._move(LINE, block, None if x1 != self.x else x1, None if z1 != self.z else z1, exact=False)
            self.x, self.z = move.x1, move.z1
            return Step(block, (move,), self.modal)
        if meaning in (G.LOCAL, G.PRESET):
            self.x = self.z = None
            return Step(block, (), self.modal, names_position=meaning == G.PRESET)
        if meaning == G.MACRO_CALL:
            self.reporter.warn(
                "macro call G65: what the macro does is not interpreted; the position and the motion mode are "
                "unknown until a block gives G00-G03 and both X and Z absolute",
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

    @staticmethod
    def _shifts_work_coordinates(words: _Words) -> bool:
        """G10 L2 (G54-G59, P0 the external offset), G10 L20 (G54.1 Pn) and G10 P0 without L (the
        lathe's workpiece shift) move a work coordinate system, perhaps the one in force: the tool
        stays where it is, and its coordinates change by the old offset, which only the control knows."""
        if "L" in words.unknown:
            return True
        level = words.values.get("L")
        return level in (2, 20) or (level is None and words.values.get("P") == 0)

    def _forget_shifted_axes(self, words: _Words) -> None:
        named = words.values.keys() | words.unknown.keys()
        if named & {"X", "U"}:
            self.x = None
        if named & {"Z", "W"}:
            self.z = None

    def _reference_return(self, block: Block, words: _Words) -> Step:
        values = words.values
        named = [axis for axis, letters in (("X", "XU"), ("Z", "ZW")) if any(l in values for l in letters)]
        if not named:
            named = ["X", "Z"]  # G28 alone: Haas and most controls send every axis home
        moves = []
        mid_x, mid_z = self._target(words, block)
        if (mid_x, mid_z) != (self.x, self.z):
            moves.append(self._move(RAPID, block, mid_x, mid_z, exact=None not in (mid_x, mid_z)))
            self.x, self.z = mid_x, mid_z
        end_x = None if "X" in named else self.x
        end_z = None if "Z" in named else self.z
        moves.append(self._move(RAPID, block, end_x, end_z, exact=False))
        self.x, self.z = end_x, end_z
        return Step(block, tuple(moves), self.modal)

    def _program_flow(self, block: Block, words: _Words) -> Step:
        if 98 in words.m or 198 in words.m:  # M198: the subprogram is on an external device or the data server
            call = 98 if 98 in words.m else 198
            self.reporter.warn(
                f"subprogram call M{call}: what the subprogram does is not interpreted; the position and the motion "
                "mode are unknown until a block gives G00-G03 and both X and Z absolute",
                self._location(block, self._col(block, "M")),
            )
            step = self._motion(block, words) if self._has_axis(words) else Step(block, (), self.modal)
            self._after_call()
            return step
        step = self._motion(block, words) if self._has_axis(words) else Step(block, (), self.modal)
        # M99 returns to a caller (or jumps back in a main program), M30 and M02 end the program:
        # what follows is reached from elsewhere, or is another program (a local subprogram).
        self._forget()
        return step

    def _after_call(self) -> None:
        """The subprogram or macro ran moves of its own and may leave another motion mode."""
        self._forget()
