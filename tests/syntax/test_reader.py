"""The reader: tape structure (label skip after the opening ``%``, text after the closing one)
and ``;`` as a printed end of block, read as a control reads them and given back byte for byte."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from support import SAMPLES

from support.interpret import moves, steps
from postproc.syntax.blocks import HEADER, TAPE, TRAILER
from postproc.diagnostics import ProgramSyntaxError, Reporter
from postproc.syntax.fastpath import CanonicalLine
from postproc.syntax.reader import read_blocks
from support.strategies import lines

CCW, CW = str(SAMPLES / "ballbar/v40r-100-ccw.csv"), str(SAMPLES / "ballbar/v40r-100-cw.csv")


# A shop program as it came off another control: the program number on the tape mark's line,
# ';' printed at the end of blocks, before and after comments.
TOKARKA = (
    "%O1200(TOKARKA)\r\n"
    "N10 G21 G99 G40;\r\n"
    "N20 T0101 (OD FINISH);\r\n"
    "N30 G96 S180 M03;\r\n"
    "N40 G00 X49.3 Z3.231 M08;\r\n"
    "N50 G01 Z-34.9 F0.1; (FINISH PASS)\r\n"
    "N60 G03 X51.014 Z-35.025 R3.0;\r\n"
    "N70 G01 X60.;;\r\n"
    "N200 G01 Z.1 M09; (Retract, Collant Off);\r\n"
    "N210 G00 X150. Z100.; \r\n"
    "N220 M30;\r\n"
    "%\r\n"
)


def _read(text: str, reporter: Reporter | None = None, **options):
    return list(read_blocks(text.splitlines(True), "t.nc", reporter, **options))


def test_label_skip_reads_the_tape_mark_line_as_the_control_does():
    reporter = Reporter()
    blocks = _read(TOKARKA, reporter)
    assert blocks[0].kind == TAPE and blocks[0].text == "%O1200(TOKARKA)"
    assert "".join(block.raw for block in blocks) == TOKARKA
    (warning,) = reporter.warnings
    assert "O1200 is not seen by the control" in warning.message and "label skip" in warning.message
    assert (warning.location.line, warning.location.col) == (1, 2)


@pytest.mark.parametrize("line, words", [
    ("%(PART 7)", None),  # a comment only: nothing to say
    ("%;", None),  # the end of block printed
    ("% ; (PART 7);", None),
    ("% <SHAFT-12>", "<SHAFT-12> is not seen"),
    ("%G00 X100.", "it is never run"),
    ("% garbage )( the control never reads", "it is never run"),
])
def test_whatever_follows_the_opening_percent_is_skipped_and_said(line, words):
    reporter = Reporter()
    blocks = _read(f"{line}\nG00 X10. Z1.\nM30\n%\n", reporter)
    assert blocks[0].kind == TAPE
    if words is None:
        assert reporter.warnings == []
    else:
        (warning,) = reporter.warnings
        assert words in warning.message and warning.location.line == 1


def test_text_after_the_closing_percent_is_never_read():
    reporter = Reporter()
    blocks = _read("%\nG00 X10. Z1.\nM30\n% O1234 (NEXT)\n", reporter)
    assert blocks[-1].kind == TAPE
    assert "never read" in reporter.warnings[0].message


def test_a_dos_end_of_file_byte_after_the_closing_percent_is_a_complete_block():
    reporter = Reporter()
    blocks = _read("%\nG00 X10. Z1.\nM30\n%\n\x1a", reporter)
    last = blocks[-1]
    assert (last.kind, last.text, last.raw) == (TRAILER, "\x1a", "\x1a")
    assert (last.words, last.comments, last.codes, last.has_eob) == ((), (), (), False)
    assert "never read" in reporter.warnings[0].message and reporter.warnings[0].location.line == 5


# Lines as the control may meet them: lines the grammar reads, tape marks with or without text
# after them, bytes a DOS or Windows file carries, garbage.
_ANY_LINE = st.one_of(lines(), st.sampled_from(["%", "% O1 (X)", "%G00 X1.", "\x1a", "\ufeff%", "", "  "]),
                      st.text(st.sampled_from("%;()GXZN01.# \x1a"), max_size=12))


@settings(max_examples=200, deadline=None)
@given(st.lists(_ANY_LINE, max_size=8), st.sampled_from(["\n", "\r\n"]), st.booleans())
def test_every_block_the_reader_returns_is_complete(lines_, eol, label_skip):
    """Whatever path made it (fast path, grammar, tape mark, trailer), a block answers for its
    words, comments and end of block, and its words are pieces of its line."""
    text = "".join(line + eol for line in lines_)
    try:
        blocks = _read(text, Reporter(), label_skip=label_skip)
    except ProgramSyntaxError:
        return  # refused with a position: no block to answer for
    assert "".join(block.raw for block in blocks) == text
    for block in blocks:
        assert block.detail.words == block.words and isinstance(block.comments, tuple)
        for word in block.words:
            assert block.text[word.col : word.end] == word.text
        block.has_eob


def test_without_label_skip_the_control_reads_on_after_the_percent():
    blocks = _read(TOKARKA, label_skip=False)
    assert blocks[0].kind == HEADER and blocks[0].text == "%O1200(TOKARKA)"
    assert [c.text for c in blocks[0].comments] == ["(TOKARKA)"]
    assert "".join(block.raw for block in blocks) == TOKARKA
    moved = _read("%G00 X10. Z1.\nG01 Z0. F.2\n", label_skip=False)
    assert moved[0].codes == (("G", "00"), ("X", "10."), ("Z", "1."))
    assert moved[0].words[1].col == 5 and moved[0].words[1].text == "X10."


def test_the_interpreter_follows_both_readings():
    program = "%G00 X10. Z1.\nG01 Z0. F.2\nM30\n%\n"
    assert moves(program)[0].x0 is None  # the rapid is skipped: where the tool starts is unknown
    first = moves(program, label_skip=False)[0]
    assert (first.kind, first.x1, first.z1) == ("rapid", 5.0, 1.0)


def test_semicolons_anywhere_an_end_of_block_can_be_are_read_and_interpreted():
    result = steps(TOKARKA)
    retract = next(step for step in result if step.block.label == 200)
    assert retract.block.codes == (("G", "01"), ("Z", ".1"), ("M", "09"))
    assert [c.text for c in retract.block.comments] == ["(Retract, Collant Off)"]
    assert retract.moves[0].z1 == pytest.approx(0.1)


def test_the_program_comes_back_byte_for_byte_and_checks(run, tmp_path):
    path = tmp_path / "tokarka.nc"
    path.write_bytes(TOKARKA.encode())
    result = run("compensate", str(path))
    assert result.exit_code == 0, result.stderr
    assert result.stdout_bytes == TOKARKA.encode()
    checked = run("check", str(path))
    assert checked.exit_code == 0
    assert "1:2: warning: the control skips what follows '%'" in checked.stderr


def test_compensated_blocks_keep_what_followed_their_end_of_block(run, tmp_path):
    """A rewritten block keeps its '; (comment);' tail as written; the tape mark line stays."""
    path = tmp_path / "tokarka.nc"
    path.write_bytes(TOKARKA.encode())
    model = tmp_path / "model.json"
    assert run("fit", "--plugin", "parametric", "--ballbar", CCW, "--ballbar", CW, "--option", "extrapolate=true",
               "-o", str(model)).exit_code == 0
    result = run("compensate", str(path), "--model", str(model))
    assert result.exit_code == 0, result.stderr
    out = result.stdout_bytes.decode()
    assert out.startswith("%O1200(TOKARKA)\r\n(POSTPROC ")
    retract = next(line for line in out.splitlines() if line.startswith("N200 "))
    assert retract.endswith("M09; (Retract, Collant Off);")
    assert "N50 " in out and "; (FINISH PASS)" in next(line for line in out.splitlines() if line.startswith("N50 "))
    again = tmp_path / "out.nc"
    again.write_bytes(result.stdout_bytes)
    assert run("check", str(again)).exit_code == 0


def test_a_byte_order_mark_before_the_tape_mark_is_kept_and_skipped(run, tmp_path):
    """Windows editors write one at the start of a file; the control reads nothing before '%'."""
    data = b"\xef\xbb\xbf%\r\nO0007 (BOM)\r\nG21 G99\r\nG00 X50. Z2.\r\nG01 Z-10. F0.2\r\nM30\r\n%\r\n"
    blocks = _read(data.decode("utf-8"))
    assert blocks[0].kind == TAPE
    path = tmp_path / "bom.nc"
    path.write_bytes(data)
    assert run("compensate", str(path)).stdout_bytes == data
    model = tmp_path / "model.json"
    assert run("fit", "--plugin", "parametric", "--ballbar", CCW, "--ballbar", CW, "-o", str(model)).exit_code == 0
    result = run("compensate", str(path), "--model", str(model))
    assert result.exit_code == 0, result.stderr
    assert result.stdout_bytes.startswith(b"\xef\xbb\xbf%\r\nO0007 (BOM)\r\n(POSTPROC ")


_NUMBER = st.sampled_from(["1.", "-2.5", ".125", "-0.0001", "1234.5678", "10", "0"])
_CANONICAL_LINE = st.builds(
    lambda parts, comment, eob: " ".join(p for p in parts if p) + comment + eob,
    st.tuples(st.sampled_from(["", "N10", "N99999"]), st.sampled_from(["", "G00", "G1", "G03"]),
              *[st.one_of(st.just(""), _NUMBER.map(lambda v, a=letter: a + v)) for letter in "XZIKRF"]),
    st.sampled_from(["", " (CUT)"]), st.sampled_from(["", ";"]))


@settings(max_examples=100, deadline=None)
@given(st.lists(st.one_of(lines(), _CANONICAL_LINE), min_size=1, max_size=8), st.sampled_from(["\n", "\r\n", "\r"]))
def test_the_light_stream_is_the_block_stream_with_canonical_lines_left_unmade(lines_, eol):
    """``light=True`` gives a CanonicalLine where the full stream gives a canonical block: the
    same line, text, raw line and fields, the same words, and ``block()`` makes the same block."""
    raw = [line + eol for line in lines_]
    full = list(read_blocks(raw, "t.nc"))
    light = list(read_blocks(raw, "t.nc", light=True))
    assert len(full) == len(light)
    for block, item in zip(full, light):
        if type(item) is CanonicalLine:
            assert block.fields is not None
            assert (item.line, item.text, item.raw, item.fields) == (block.line, block.text, block.raw, block.fields)
            assert item.words == block.words
            made = item.block()
            assert (made.kind, made.label, made.codes, made.detail, made.raw) == \
                   (block.kind, block.label, block.codes, block.detail, block.raw)
        else:
            assert block.fields is None and item.text == block.text
