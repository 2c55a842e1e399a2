"""An end point beyond any lathe's travel is refused where the interpreter reads it
(postproc.machine.bounds.travel), on the fast path and the general path alike, before anything
samples the move."""

from __future__ import annotations

import dataclasses

import pytest
from hypothesis import given, strategies as st

from postproc.diagnostics import InterpretationError, Reporter
from postproc.interpret.interpreter import Interpreter
from postproc.machine.bounds import MAX_TRAVEL, travel
from postproc.machine.profile import DEFAULT
from postproc.syntax.reader import read_blocks
from postproc.syntax.source import Source

START = "%\nO1000\nG18 G21 G99 F0.1\nG00 X0. Z5.\n"


def _moves(text: str, fast: bool, profile=DEFAULT):
    with Source.from_text(text, "t.nc") as source:
        interpreter = Interpreter(profile, Reporter(), "t.nc", labels=lambda: source.labels, fast=fast)
        return [m for s in interpreter.run(read_blocks(source.lines(), source.name)) for m in s.moves]


def _block(axis: str, value: float, word: str) -> str:
    """A G01 putting ``axis`` at ``value`` mm (radius for x), with the word named ``word``."""
    if axis == "x":
        text = f"{2 * value:.4f}"  # diameter programming; U from x = 0
        return f"G01 {word}{text} Z-1.\n"
    text = f"{value - 5:.4f}" if word == "W" else f"{value:.4f}"
    return f"G01 X2. {word}{text}\n"


@pytest.mark.parametrize("fast", [True, False])
@given(axis_word=st.sampled_from([("x", "X"), ("x", "U"), ("z", "Z"), ("z", "W")]),
       value=st.floats(-3 * MAX_TRAVEL, 3 * MAX_TRAVEL, allow_nan=False), extra=st.booleans())
def test_an_end_point_is_refused_exactly_beyond_the_travel(fast, axis_word, value, extra):
    axis, word = axis_word
    text = START + _block(axis, value, word) + ("S500 M03\n" if extra else "")  # S: not the canonical form
    if abs(value) <= MAX_TRAVEL - 0.01:
        assert _moves(text, fast)[-1].kind == "line"
    elif abs(value) >= MAX_TRAVEL + 0.01:
        with pytest.raises(InterpretationError) as info:
            _moves(text, fast)
        error = info.value
        assert error.location.line == 5 and error.location.source[error.location.col - 1] == word  # at the word
        assert f"puts {axis} at" in error.message and "missing decimal point" in error.message
        assert f"{axis}_limits" in error.message


@pytest.mark.parametrize("fast", [True, False])
def test_stated_soft_limits_widen_the_travel_by_their_span(fast):
    profile = dataclasses.replace(DEFAULT, z_limits=(-20_000.0, 0.0))  # a 20 m roll lathe
    assert travel(profile.z_limits) == (-40_000.0, 20_000.0)
    assert _moves(START + "G01 X2. Z-19000.\n", fast, profile)[-1].z1 == -19_000.0
    with pytest.raises(InterpretationError, match="far beyond the machine profile's z_limits"):
        _moves(START + "G01 X2. Z-40001.\n", fast, profile)
    with pytest.raises(InterpretationError, match="beyond the travel of any lathe"):
        _moves(START + "G01 X2. Z-19000.\n", fast)


@pytest.mark.parametrize("fast", [True, False])
def test_increments_that_add_up_beyond_the_travel_are_refused_at_the_word_that_crosses(fast):
    text = START + "G01 W-4000.\n" * 2 + "G01 W-4000.\n"
    assert len(_moves(START + "G01 W-4000.\n" * 2, fast)) == 3
    with pytest.raises(InterpretationError) as info:
        _moves(text, fast)
    assert info.value.location.line == 7 and "W-4000. puts z at -11995 mm" in info.value.message
