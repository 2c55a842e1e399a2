"""The self-check: every replacement read back as the control reads it, by the interpreter's fast
path where a line takes it, exactly as the general path reads it; a replacement that reads back
wrong, or as a move from an unknown position, refuses the run naming the block."""

from __future__ import annotations

from dataclasses import replace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import numpy as np

from postproc.compensate.edits import _cut_of
from postproc.compensate.request import Request
from postproc.compensate.rewrite import Rewriter
from postproc.compensate.self_check import _lines_read, _read_back
from postproc.diagnostics import PostprocError, Reporter, SafetyError
from postproc.interpret import gcodes as G
from postproc.interpret.interpreter import Interpreter
from postproc.interpret.motion import Modal
from postproc.interpret.program import interpret_source
from postproc.machine.profile import DEFAULT
from postproc.syntax.fastpath import CanonicalLine
from postproc.syntax.reader import read_blocks
from postproc.syntax.source import Source
from support.strategies import canonical_lines, lathe_blocks


def _checker() -> Interpreter:
    return Interpreter(replace(DEFAULT, name="self-check"), Reporter(), "t.nc")


def _by_steps(checker: Interpreter, lines: list[str]):
    """The replacement read back block by block through :meth:`Interpreter.step`: the general
    route, which every line took before canonical lines took the fast path."""
    cuts = []
    for block in read_blocks(lines, "<replacement>"):
        cuts += map(_cut_of, checker.step(block).moves)
    return cuts


def _outcome(read, checker: Interpreter, lines: list[str]):
    try:
        result = read(checker, lines)
    except PostprocError as exc:
        result = (type(exc), exc.message)
    return result, checker.x, checker.z, checker.modal


@settings(max_examples=600, deadline=None)
@given(st.lists(st.one_of(canonical_lines(), canonical_lines(), lathe_blocks()), min_size=1, max_size=6),
       st.sampled_from([G.G00, G.G01, G.G02, G.G03, None]), st.sampled_from([None, 0.1, 100.0]),
       st.floats(-60, 60), st.floats(-60, 60), st.sampled_from(["\n", "\r\n", ""]))
def test_a_replacement_reads_back_by_the_fast_path_as_by_the_general_one(lines, motion, feed, x, z, eol):
    """The cuts, the error if any, and the position and modal state after it, line for line."""
    lines = [line + eol for line in lines]
    outcomes = []
    for read in (_read_back, _by_steps):
        checker = _checker()
        checker.x, checker.z = x, z
        checker.modal = Modal(motion=motion, feed=feed)
        outcomes.append(_outcome(read, checker, lines))
    assert outcomes[0] == outcomes[1], lines


@settings(max_examples=400, deadline=None)
@given(st.lists(st.one_of(canonical_lines(), canonical_lines(), canonical_lines(), lathe_blocks(), st.just("%")),
                min_size=1, max_size=3), st.sampled_from(["\n", "\r\n", ""]))
def test_a_replacements_lines_are_read_as_the_reader_reads_them(lines, eol):
    """The self-check's own route for a replacement of one line gives what the reader's light stream does."""
    lines = [line + eol for line in lines]
    def read(items):
        return [(type(item), tuple(item) if type(item) is CanonicalLine else (item.line, item.raw, item.kind))
                for item in items]

    assert read(_lines_read(lines)) == read(read_blocks(lines, "<replacement>", light=True))


@pytest.mark.parametrize("word", ["M30", "M02"])
def test_a_replacement_that_reads_back_from_an_unknown_position_is_refused(word):
    """A word that leaves the position unknown (the end of the program; a call or return is
    refused before, when planning: test_rewrite) stays on the first of the blocks that replace
    its block: the next one reads back as a move from nowhere, which is a refusal naming the
    block, not a crash."""
    text = f"%\nO1000\nG18 G21 G40 G99\nT0101\nG00 X0. Z2.\nG01 Z0. F0.2\nG03 X40. Z-20. I0. K-20. {word}\n%\n"
    with Source.from_text(text, "t.nc") as source:
        rewriter = Rewriter(interpret_source(source), lambda pieces: [_outwards(piece, 0.01) for piece in pieces],
                            DEFAULT, Request(mode="line", tolerance=0.001), Reporter(), "t.nc")
        with pytest.raises(SafetyError) as caught:
            "".join(rewriter.run())
    message = str(caught.value)
    assert message.startswith("t.nc:7: error: self-check: block 2 of the ")
    assert "reads back as a move from an unknown position" in message
    assert "give the move a block of its own" in message


def _outwards(piece, deviation: float):
    """An arc's correction: outwards by ``deviation`` mm; a line's: none."""
    centre = getattr(piece.segment, "centre", None)
    return None if centre is None else (piece.points - np.array(centre)) / piece.segment.r * deviation


def test_a_replacement_from_an_unknown_position_exits_4_with_no_output(run, tmp_path):
    program = tmp_path / "p.nc"
    program.write_text("%\nO1000\nG18 G21 G40 G99\nT0101\nG00 X0. Z2.\nG01 Z0. F0.2\n"
                       "G03 X40. Z-20. I0. K-20. M30\n%\n")
    trace = tmp_path / "ccw.csv"
    rows = "".join(f"{a},0.005\n" for a in range(0, 360, 2))
    trace.write_text(f"# postproc ballbar 1\n# radius_mm = 20\n# direction = ccw\n# centered = true\n"
                     f"angle_deg,deviation_mm\n{rows}")
    output = tmp_path / "out.nc"
    result = run("compensate", str(program), "--plugin", "ballbar-inverse", "--ballbar", str(trace), "--tolerance", "0.001", "--mode", "line",
                 "-o", str(output))
    assert result.exit_code == 4, result.stderr
    assert result.stdout == ""
    assert f"{program}:7: error: self-check: block 2 of the " in result.stderr
    assert "unknown position" in result.stderr
    assert not output.exists()


def _shifted_lines(text: str, **options) -> str:
    """``text`` rewritten with every line moved by (3, -2) um (rapids left alone)."""
    shift = lambda piece: None if piece.move.kind != "line" else np.tile((0.003, -0.002), (len(piece.points), 1))
    with Source.from_text(text, "t.nc") as source:
        rewriter = Rewriter(interpret_source(source), lambda pieces: [shift(piece) for piece in pieces], DEFAULT,
                            Request(tolerance=0.001, **options), Reporter(), "t.nc", labels=source.labels)
        return "".join(rewriter.run())


def test_a_replacement_that_does_not_start_where_the_tool_stands_is_refused(monkeypatch):
    """The read-back starts where the blocks written before leave the tool, so a join the planner
    failed to make is found as surely as a wrong block: here the move after G50 with its connecting
    G01 taken away (as it was missing before), a planner fault refused with no program."""
    text = "G18 G21 G99 F0.1\nG50 X20. Z5.\nG01 X20. Z-20.\nG00 X100.\n"
    assert _shifted_lines(text).splitlines()[2] == "G01 X20.006 Z4.998"
    monkeypatch.setattr(Rewriter, "_from_nominal_start", lambda self, entry: None)
    with pytest.raises(SafetyError) as caught:
        _shifted_lines(text)
    message = str(caught.value)
    assert message.startswith("t.nc:3: error: self-check: the replacement starts at x 10.0030 z 4.9980 (a radius, and z)")
    assert "leave the tool at x 10.0000 z 5.0000" in message and "fault of the planner" in message


@pytest.mark.parametrize("move", ["G00 X40. Z-5.", "G01 X40. Z-5.", "G00 X40. Z-10.\nG00 X40. Z-5."])
def test_a_block_moved_to_meet_the_next_starts_where_the_last_one_left_the_tool(move):
    """A line whose end is moved to meet the corrected start of the next, and whose own end words
    are all absolute, is written with its new end only: it runs from wherever the corrected block
    before it left the tool, and that is where its read-back and its checks start."""
    text = f"G18 G21 G99 F0.1\nG00 X40. Z5.\nG01 Z-10.\n{move}\nG01 X30. Z-20.\nG00 X100.\n"
    out = _shifted_lines(text)
    assert "X40.006 Z-10.002" in out.splitlines()  # the corrected end the next block starts from


@pytest.mark.parametrize("start", ["G50 X20.0005 Z5.0004", "G00 X20.0005 Z5.0004"])
def test_a_start_off_the_output_grid_is_where_the_tool_stands(start):
    """A program may hold more decimals than its output is written with: the plan starts at the
    grid point nearest the tool, and the self-check takes that for where the tool stands."""
    text = f"G18 G21 G99 F0.1\n{start}\nG01 X20.0005 Z-20.0003\nG00 X100.\n"
    assert _shifted_lines(text).splitlines()[2] == "G01 X20.006 Z4.998"
