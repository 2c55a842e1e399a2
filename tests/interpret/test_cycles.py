"""The contour cycles G70-G73 (postproc/interpret/cycles.py): what a contour between P and Q may
hold, in every cycle, whichever way the code is written."""

from __future__ import annotations

import pytest

from support.interpret import moves, steps
from postproc.diagnostics import InterpretationError

# A roughing cycle (or G70) and its contour; {inside} is a block placed between P and Q.
_AFTER = """O0001
G18 G21 G99
T0101
G00 X60. Z2.
{cycle}
N10 G00 X20.
G01 Z-10. F0.1
{inside}
G01 X40. Z-20.
N20 X62.
G00 X100. Z50.
M30
"""
_CYCLES = {
    "G71": "G71 U1. R0.5\nG71 P10 Q20 U0.4 W0.1 F0.3",
    "G72": "G72 W1. R0.5\nG72 P10 Q20 U0.4 W0.1 F0.3",
    "G73": "G73 U2. W2. R3\nG73 P10 Q20 U0.4 W0.1 F0.3",
    "G70": "G70 P10 Q20",
}

#: (block inside the contour, the word the error points at, what the message calls it)
_REFUSED = [
    ("M98 P2000", "M98", "a subprogram call"),
    ("M98P2000", "M98", "a subprogram call"),
    ("M98 P2000 L3", "M98", "a subprogram call"),
    ("M98 P32000", "M98", "a subprogram call"),
    ("M0098 P2000", "M0098", "a subprogram call"),
    ("M 98 P2000", "M 98", "a subprogram call"),
    ("m98 p2000", "m98", "a subprogram call"),
    ("M08 M98 P2000", "M98", "a subprogram call"),
    ("P2000 M98", "M98", "a subprogram call"),
    ("/M98 P2000", "M98", "a subprogram call"),
    ("M198 P2000", "M198", "a subprogram call from an external device"),
    ("M99", "M99", "a return"),
    ("M99 P10", "M99", "a return"),
    ("G65 P9010 A1. B2.", "G65", "a macro call"),
    ("G65P9010", "G65", "a macro call"),
    ("G065 P9010 X10. Z-5.", "G065", "a macro call"),
    ("G66 P9010 A1.", "G66", "a modal macro call"),
    ("G66.1 P9010", "G66.1", "a modal macro call"),
    ("G10 P0 X1. Z2.", "G10", "data setting"),
    ("G10 L2 P1 Z-100.", "G10", "data setting"),
    ("G10 P1 U0.02", "G10", "data setting"),
    ("G28 U0.", "G28", "a one-shot (group 00) G code"),
    ("G50 X100. Z50.", "G50", "a one-shot (group 00) G code"),
    ("G53 X100.", "G53", "a one-shot (group 00) G code"),
    ("G31 Z-15. F0.1", "G31", "a one-shot (group 00) G code"),
    ("G32 Z-15. F1.5", "G32", "a group 01 code other than G00-G03"),
    ("G90 X30. Z-15. F0.2", "G90", "a group 01 code other than G00-G03"),
    ("G20", "G20", "inch input"),
    ("G21", "G21", "metric input"),
    ("G71 U1. R0.5", "G71", "a one-shot (group 00) G code"),
]


@pytest.mark.parametrize("cycle", sorted(_CYCLES))
@pytest.mark.parametrize("inside, word, what", _REFUSED)
def test_a_code_the_control_refuses_between_p_and_q_is_an_error_at_its_word(cycle, inside, word, what):
    program = _AFTER.format(cycle=_CYCLES[cycle], inside=inside)
    line = program.splitlines().index("G01 Z-10. F0.1") + 2
    with pytest.raises(InterpretationError) as info:
        steps(program)
    error = info.value
    assert (error.location.line, error.location.col) == (line, inside.index(word) + 1), str(error)
    assert error.message.startswith(f"{word}: {what}"), error.message
    assert f"in the contour N10..N20 of the {cycle} on line" in error.message
    assert "between a multiple repetitive cycle's P and Q" in error.message
    assert "before the cycle block" in error.message or "after the contour's last block" in error.message


@pytest.mark.parametrize("cycle", sorted(_CYCLES))
@pytest.mark.parametrize("inside", ["G04 U1.", "G04 P500", "M08", "M09", "S800", "T0202", "G40", "G42 X30.",
                                    "F0.05", "G01 X30. F0.05", "G02 X24. Z-12. R2.", "M01", "(M98 P2000)"])
def test_what_a_contour_may_hold_is_taken(cycle, inside):
    program = _AFTER.format(cycle=_CYCLES[cycle], inside=inside)
    first = program.splitlines().index("N10 G00 X20.") + 1
    contour = [s for s in steps(program) if s.in_contour]
    assert [s.block.line for s in contour] == list(range(first, first + 5))


@pytest.mark.parametrize("system, cycle, code", [("B", "G71", "G20"), ("C", "G73", "G70"), ("C", "G73", "G71"),
                                                 ("C", "G74", "G20"), ("B", "G71", "G92 X100. Z50."),
                                                 ("C", "G73", "G33 Z-15. F1.5")])
def test_the_codes_are_read_in_the_profiles_g_code_system(system, cycle, code):
    """System C's inch and metric input are G70 and G71, its roughing cycles G73-G75 (G20 is
    its turning cycle); system B sets coordinates with G92."""
    program = _AFTER.format(cycle=f"{cycle} U1. R0.5\n{cycle} P10 Q20 U0.4 W0.1 F0.3", inside=code)
    with pytest.raises(InterpretationError) as info:
        steps(program, gcode_system=system)
    assert info.value.location.line == 9 and info.value.message.startswith(code.split()[0])


def test_a_code_in_a_contour_placed_before_its_cycle_is_refused_when_the_cycle_reads_it():
    program = ("O0001\nG18 G21 G99\nG00 X60. Z2.\nM98 P9000\nN10 G00 X20.\nG01 Z-10. F0.1\nM98 P2000\nN20 X62.\n"
               "G00 X60. Z2.\nG70 P10 Q20\nM30\n")
    with pytest.raises(InterpretationError) as info:
        steps(program)
    assert (info.value.location.line, info.value.location.col) == (7, 1)
    assert "of the G70 on line 10" in info.value.message


def test_an_m99_inside_the_contour_is_named_rather_than_the_q_beyond_the_program_end():
    """The program that runs the cycle ends at its M99: its Q stands after that end, and the
    M99 between P and Q is the mistake."""
    program = _AFTER.format(cycle=_CYCLES["G71"], inside="M99")
    with pytest.raises(InterpretationError) as info:
        moves(program)
    assert info.value.location.line == 9 and info.value.message.startswith("M99: a return")


def test_a_subprogram_call_outside_the_contour_is_a_warning_as_before():
    program = _AFTER.format(cycle=_CYCLES["G71"], inside="G01 Z-12.").replace("M30", "M98 P2000\nM30")
    assert any(s.in_contour for s in steps(program))


@pytest.mark.parametrize("cycle", sorted(_CYCLES))
def test_a_contour_after_the_end_of_the_tape_is_not_the_programs(cycle):
    """The control stops reading at the closing '%': a P or Q block after it is not found
    (PS0060), and the error says where it stands, instead of the rest of the program being
    skipped as a contour that does not follow its cycle."""
    program = "%\n" + _AFTER.format(cycle=_CYCLES[cycle], inside="G01 Z-12.").replace("N10 G00 X20.", "%\nN10 G00 X20.")
    with pytest.raises(InterpretationError) as info:
        steps(program)
    tape_end = program.splitlines().index("N10 G00 X20.") + 1
    assert info.value.message.startswith(f"{cycle} P10: N10 stands only after the end of the tape (line {tape_end}")
    assert "PS0060" in info.value.message
