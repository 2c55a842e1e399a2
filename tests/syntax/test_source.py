"""The program source's quick scans: GOTO targets, subprogram calls, label places."""

from __future__ import annotations

import pytest

from postproc.diagnostics import Reporter
from postproc.interpret.program import interpret_source
from postproc.syntax.source import Source

PROGRAM = """%
O1000
G00 X10. Z1.
m98 p2000
M 0 98 P 3 2000 (three times O2000)
G65 P9010 A1. B2.
g065p9010
IF [#1 GT 2] GOTO 100
GOTO #5
goto20
N100 G01 X20. F.1
M30
O2000
G01 W-1.
M99
%
"""


def test_calls_and_goto_targets_are_found_whatever_the_case_and_spacing():
    with Source.from_text(PROGRAM, "t.nc") as source:
        labels = source.labels
        assert labels.calls == {2000: 2, 9010: 2}
        assert labels.goto_targets == {100, 20}
        assert labels.computed_goto
        assert labels.lines[100] == [11] and labels.counts[100] == 1


def test_one_p_word_read_by_two_call_codes_is_one_call():
    with Source.from_text("G65 M98 P7000\n", "t.nc") as source:
        assert source.labels.calls == {7000: 1}


def test_a_subprogram_called_from_two_places_is_not_compensated():
    reporter = Reporter()
    with Source.from_text(PROGRAM, "t.nc") as source:
        steps = list(interpret_source(source, reporter=reporter))
    assert any("O2000 is called from 2 places" in str(w) for w in reporter.warnings)
    assert all(step.shared for step in steps if step.block.line == 14)


def test_m99_p_and_m98_q_targets_are_jump_targets_whatever_the_spacing():
    text = ("N100 G01 W-1.\nM99 P100\nm 0 99 p 2 00\nM99P#3\nM990 P300\nG99 P400\nM99 (BACK) P600\n"
            "M98 Q700\nM98 P2000 Q800\nM198 P3000 Q900\nG65 P9000 Q1.\nM980 Q1000\n"
            # the control reads a block's words in any order
            "P1100 M99\nQ1200 M98 P5000\np 13 00 m 0 99\nP1400 M990\nQ1500 M980\nP1600 (M99)\n")
    with Source.from_text(text, "t.nc") as source:
        labels = source.labels
        assert labels.goto_targets == {100, 200, 600, 700, 800, 900, 1100, 1200, 1300}
        assert labels.computed_goto  # M99 P#3: any label may be the target
        assert labels.calls == {2000: 1, 9000: 1, 5000: 1}


def test_each_program_runs_from_its_number_to_its_first_end_after_a_block():
    """The program that runs a block (where a cycle's P and Q are looked for): from its O number
    (``:`` number, ``<NAME>``) to its first M30, M02 or M99 at or after the block, at most to the
    next program; an end in a comment, behind '/', or a longer M code (M300, M990) ends nothing."""
    text = ("%\nG00 X1.\nM30\n"             # 2-3: before any O number
            "O 1000 (M30 IN A COMMENT)\nM300\n/M30\nM990\nN10 X2.\nM 0 2\nN10 X3.\n"  # 4-10
            ":2000\nM99\nN20 X4.\nM99\n"     # 11-14
            "<PART_B>\nN30 X5.\n%\n")        # 15-17
    with Source.from_text(text, "t.nc") as source:
        labels = source.labels
        assert labels.program_of(2) == ("the program from line 1", 1, 3)
        assert labels.program_of(5) == ("O1000", 4, 9)
        assert labels.program_of(10) == ("O1000", 4, 10)  # past the M02: up to the next program
        assert labels.program_of(11) == ("O2000", 11, 12)
        assert labels.program_of(13) == ("O2000", 11, 14)  # an M99 before the block is no end of it
        assert labels.program_of(16) == ("<PART_B>", 15, None)
        assert labels.in_program_of(10, 5) == [8] and labels.in_program_of(10, 10) == [8, 10]
        assert labels.in_program_of(20, 11) == [] and labels.in_program_of(20, 13) == [13]
        assert labels.in_program_of(30, 2) == [] and labels.in_program_of(30, 16) == [16]


@pytest.mark.parametrize("head", ["%\n", "\ufeff%\n", " %\n", "", "(NO OPENING MARK)\n"])
def test_nothing_after_the_end_of_the_tape_is_a_label_a_program_or_an_end(head):
    """The control reads nothing after the closing '%' (the second one, or the first after any
    other text): a sequence number, a program number or an M30 there is not in the program."""
    text = head + "O1000\nN10 G00 X1.\nG01 Z-1. F0.1\n%\nN10 X2.\nN20 X3.\nO2000\nM30\n%\n"
    first = head.count("\n") + 1  # the line of O1000
    with Source.from_text(text.encode("utf-8"), "t.nc") as source:
        labels = source.labels
        assert labels.lines == {10: [first + 1]} and labels.counts == {10: 1}
        assert labels.unread == {10: first + 4, 20: first + 5}
        assert labels.program_of(first + 1) == ("O1000", first, None)
