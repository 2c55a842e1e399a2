"""Macro B: the expression and statement values of the syntax tree, and their evaluation.

The interpreter evaluates an expression only where every variable it reads has a value
known at that point of the program. Common variables (#100-, #500-), system variables
and anything assigned inside control flow are values only the control has: evaluation
then gives :data:`UNKNOWN`, and the block that needed it is passed through untouched.

FANUC semantics kept here: angles in degrees; ``ATAN[a]/[b]`` is the two-argument
arctangent in 0..360 degrees; ``ROUND`` rounds half away from zero; ``FIX`` drops the
fraction and ``FUP`` raises it (both away from zero for ``FUP``); a vacant variable
(``#0``, or never assigned) reads as 0 in arithmetic but is not equal to 0 in ``EQ``/``NE``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, Union

from ..diagnostics import MacroValueError


class _Unknown:
    """The value of an expression that depends on data only the control has."""

    __slots__ = ()

    def __repr__(self) -> str:
        return "UNKNOWN"


UNKNOWN = _Unknown()
MAX_VALUE = 1e47  #: the largest magnitude a macro variable holds (FANUC)
VACANT = None  #: a variable with no value (FANUC ``<vacant>``)


@dataclass(frozen=True, slots=True)
class Number:
    value: float
    text: str  #: as written, spaces removed


@dataclass(frozen=True, slots=True)
class Variable:
    index: "int | Expr"  #: ``#100`` has 100; ``#[#1+1]`` has the expression
    name: str | None = None  #: ``#_UI`` style system variable names


@dataclass(frozen=True, slots=True)
class Negate:
    sign: str  #: ``-`` or ``+``
    operand: "Expr"


@dataclass(frozen=True, slots=True)
class Binary:
    op: str  #: ``+ - * / OR XOR AND MOD``
    left: "Expr"
    right: "Expr"


@dataclass(frozen=True, slots=True)
class Comparison:
    op: str  #: ``EQ NE GT GE LT LE``
    left: "Expr"
    right: "Expr"


@dataclass(frozen=True, slots=True)
class Call:
    function: str  #: upper case; ``ATAN2`` for ``ATAN[a]/[b]``
    args: tuple["Expr", ...]


Expr = Union[Number, Variable, Negate, Binary, Comparison, Call]


@dataclass(frozen=True, slots=True)
class Assignment:
    target: Variable
    value: Expr


@dataclass(frozen=True, slots=True)
class IfGoto:
    condition: Expr
    target: Expr


@dataclass(frozen=True, slots=True)
class IfThen:
    condition: Expr
    then: Assignment


@dataclass(frozen=True, slots=True)
class WhileDo:
    condition: Expr
    loop: int


@dataclass(frozen=True, slots=True)
class DoLoop:
    loop: int


@dataclass(frozen=True, slots=True)
class EndLoop:
    loop: int


@dataclass(frozen=True, slots=True)
class Goto:
    target: Expr


@dataclass(frozen=True, slots=True)
class Output:
    """``DPRNT[...]``, ``BPRNT[...]``, ``POPEN``, ``PCLOS``: data output, no motion."""

    text: str


Statement = Union[Assignment, IfGoto, IfThen, WhileDo, DoLoop, EndLoop, Goto, Output]

#: Statements after which the control may continue elsewhere than the next block.
CONTROL_FLOW = (IfGoto, WhileDo, DoLoop, EndLoop, Goto)


def _round_half_away(value: float) -> float:
    return math.copysign(math.floor(abs(value) + 0.5), value)


def _atan2_degrees(y: float, x: float) -> float:
    angle = math.degrees(math.atan2(y, x))
    return angle + 360.0 if angle < 0 else angle


_FUNCTIONS = {
    "SIN": lambda a: math.sin(math.radians(a)),
    "COS": lambda a: math.cos(math.radians(a)),
    "TAN": lambda a: math.tan(math.radians(a)),
    "ASIN": lambda a: math.degrees(math.asin(a)),
    "ACOS": lambda a: math.degrees(math.acos(a)),
    "ATAN": lambda a: math.degrees(math.atan(a)),
    "ATN": lambda a: math.degrees(math.atan(a)),
    "ATAN2": _atan2_degrees,
    "SQRT": math.sqrt,
    "SQR": math.sqrt,
    "ABS": abs,
    "ROUND": _round_half_away,
    "RND": _round_half_away,
    "FIX": lambda a: float(math.trunc(a)),
    "FUP": lambda a: float(math.trunc(a) + (0 if a == math.trunc(a) else math.copysign(1, a))),
    "LN": math.log,
    "EXP": math.exp,
    "POW": math.pow,
    "ADP": lambda a: a,
}


def _number(value: "float | None") -> float:
    return 0.0 if value is None else value


def evaluate(expr: Expr, variables: Mapping[int, "float | None"]) -> "float | None | _Unknown":
    """The value of ``expr``; :data:`UNKNOWN` when it reads a variable not in ``variables``.

    ``variables`` maps variable numbers to their known values (``None`` for vacant).
    ``#0`` is always vacant. Raises :class:`MacroValueError` where the control would alarm.
    """
    kind = type(expr)
    if kind is Number:
        return _in_range(expr.value)
    if kind is Variable:
        if expr.name is not None:
            return UNKNOWN
        index = expr.index
        if not isinstance(index, int):
            value = evaluate(index, variables)
            if value is UNKNOWN:
                return UNKNOWN
            index = int(_round_half_away(_number(value)))
        if index == 0:
            return VACANT
        return variables.get(index, UNKNOWN)
    if kind is Negate:
        value = evaluate(expr.operand, variables)
        if value is UNKNOWN:
            return UNKNOWN
        return -_number(value) if expr.sign == "-" else _number(value)
    if kind is Comparison:
        left = evaluate(expr.left, variables)
        right = evaluate(expr.right, variables)
        if left is UNKNOWN or right is UNKNOWN:
            return UNKNOWN
        return 1.0 if _compare(expr.op, left, right) else 0.0
    if kind is Binary:
        left = evaluate(expr.left, variables)
        right = evaluate(expr.right, variables)
        if left is UNKNOWN or right is UNKNOWN:
            return UNKNOWN
        return _in_range(_binary(expr.op, _number(left), _number(right)))
    if kind is Call:
        args = [evaluate(arg, variables) for arg in expr.args]
        if any(arg is UNKNOWN for arg in args):
            return UNKNOWN
        function = _FUNCTIONS.get(expr.function)
        if function is None:
            raise MacroValueError(f"{expr.function} is not a function the interpreter evaluates")
        try:
            return _in_range(float(function(*[_number(arg) for arg in args])))
        except (ValueError, TypeError, OverflowError) as exc:
            raise MacroValueError(f"{expr.function} of {args} cannot be evaluated ({exc})") from None
    raise TypeError(f"not an expression: {expr!r}")


def _in_range(value: float) -> float:
    """A value the control holds: within +-10^47, as a macro variable (else FANUC alarm PS0111)."""
    if not abs(value) <= MAX_VALUE:
        raise MacroValueError(f"calculated data overflow: {value:g} is beyond +-1e47 (FANUC alarm PS0111)")
    return value


def _compare(op: str, left: "float | None", right: "float | None") -> bool:
    if op in ("EQ", "NE"):
        equal = left == right if (left is None or right is None) else math.isclose(left, right, abs_tol=1e-9)
        return equal if op == "EQ" else not equal
    a, b = _number(left), _number(right)
    return {"GT": a > b, "GE": a >= b, "LT": a < b, "LE": a <= b}[op]


def _binary(op: str, a: float, b: float) -> float:
    if op == "+":
        return a + b
    if op == "-":
        return a - b
    if op == "*":
        return a * b
    if op == "/":
        if b == 0:
            raise MacroValueError("division by zero (FANUC alarm PS0112)")
        return a / b
    if op == "MOD":
        if b == 0:
            raise MacroValueError("MOD by zero")
        return math.fmod(a, b)
    bits_a, bits_b = int(a), int(b)
    if op == "AND":
        return float(bits_a & bits_b)
    if op == "OR":
        return float(bits_a | bits_b)
    if op == "XOR":
        return float(bits_a ^ bits_b)
    raise MacroValueError(f"unknown operator {op}")


def variables_read(expr: Expr) -> bool:
    """Whether ``expr`` reads any variable (a constant expression reads none)."""
    kind = type(expr)
    if kind is Number:
        return False
    if kind is Variable:
        return True
    if kind is Negate:
        return variables_read(expr.operand)
    if kind in (Binary, Comparison):
        return variables_read(expr.left) or variables_read(expr.right)
    if kind is Call:
        return any(variables_read(arg) for arg in expr.args)
    raise TypeError(f"not an expression: {expr!r}")
