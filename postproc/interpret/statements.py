"""Macro B statements as the interpreter meets them: assignments, and what it cannot follow.

One phase of :class:`~postproc.interpret.interpreter.Interpreter`, as LinuxCNC's rs274ngc keeps
each phase of its interpreter in a file of its own: the methods here work on the Interpreter's
state and hold none of their own."""

from __future__ import annotations

from typing import TYPE_CHECKING

from .motion import Step
from ..diagnostics import InterpretationError
from ..syntax.blocks import Block

if TYPE_CHECKING:
    from ..syntax import macro


class MacroStatements:
    """Macro B statements, mixed into :class:`~postproc.interpret.interpreter.Interpreter`."""

    def _statement(self, block: Block) -> Step:
        from ..syntax import macro
        from ..syntax.macro import UNKNOWN

        statement = block.statement
        kind = type(statement)
        if kind is macro.Assignment or kind is macro.IfThen:
            assignment = statement if kind is macro.Assignment else statement.then
            condition = True if kind is macro.Assignment else self._evaluate(statement.condition, block)
            if condition is UNKNOWN or (condition and block.delete is not None):
                # whether it is made depends on the data, or on the block delete switch: either value may follow
                target = self._variable_number(assignment.target, block)
                if target is None:
                    self.variables = {}
                else:
                    self.variables.pop(target, None)
            elif condition:
                self._assign(assignment, block)
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
