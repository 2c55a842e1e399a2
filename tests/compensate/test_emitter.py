"""The emitter: a canonical block's replacement, written from its fields, is what its words give."""

from __future__ import annotations

import re

from hypothesis import assume, given, settings
from hypothesis import strategies as st

from postproc.interpret import gcodes as G
from postproc.syntax.blocks import Block
from postproc.compensate.emitter import Style, Writer, _word_text
from postproc.syntax.fastpath import detail_of_ordinary, read_ordinary
from postproc.machine.resolution import Grid, rounded
from postproc.compensate.segmenter import Cut
from support.strategies import canonical_lines

CUTS = (
    Cut(10.0, -1.0, 10.25, -2.5),
    Cut(10.0, -1.0, 9.5, -3.0, 12.0, -2.0, True),
    Cut(10.0, 0.0, 10.0, -4.0, rapid=True),
)


def _as_words(block: Block) -> Block:
    """The same line as a block without fields: what every other ordinary block is."""
    return Block(block.line, block.text, block.eol, block.kind, block.label, None, block.codes, None, None,
                 detail_of_ordinary)


@settings(max_examples=400, deadline=None)
@given(canonical_lines(), st.sampled_from([None, G.G00, G.G01, G.G02]), st.booleans(),
       st.sampled_from(["A", "B"]), st.integers(1, 3))
def test_a_canonical_block_is_replaced_as_its_words_say(text, mode, label_last, system, count):
    block = read_ordinary(text, 7, "\r\n")
    assume(block is not None and block.fields is not None)
    words = _as_words(block)
    assert Style.of(block) == Style.of(words), text
    writer = Writer(Grid(3, False, True), system)
    cuts = list(CUTS[:count])
    assert writer.replacement(block, cuts, mode, label_last) == writer.replacement(words, cuts, mode, label_last), text


def _number_as_formatted_twice(value: float, decimals: int, trim: bool, leading_zero: bool) -> str:
    """How a number was spelled before it was spelled by one format: formatted, a zero's minus
    dropped, trimmed, its leading zero dropped by a regular expression."""
    text = f"{value:.{decimals}f}"
    if text.startswith("-") and float(text) == 0.0:
        text = text[1:]
    if trim:
        text = text.rstrip("0")
    if not leading_zero:
        text = re.sub(r"^(-?)0\.(?=\d)", r"\1.", text)
    return text


def _words_rounded_then_spelled(grid: Grid, cut: Cut, style: Style, axes: str) -> list[str]:
    """The geometry words as they were written before: each value rounded onto the grid as a
    float (``Grid.x_word``), then formatted again."""
    values = [(letter, word) for letter, word in (("X", grid.x_word(cut.x1)), ("Z", grid.z_word(cut.z1)))
              if cut.is_arc or letter in axes]
    if cut.is_arc:
        values += [("I", grid.offset_word(cut.xc - cut.x0)), ("K", grid.offset_word(cut.zc - cut.z0))]
    return [style.word(letter, _number_as_formatted_twice(word, grid.decimals, style.trim, style.leading_zero))
            for letter, word in values]


VALUES = st.one_of(st.floats(allow_nan=False, allow_infinity=False, width=64), st.floats(-2000, 2000),
                   st.integers(-10**7, 10**7).map(lambda n: n / 2000.0), st.sampled_from([0.0, -0.0, 5e-4, -5e-4]))


@settings(max_examples=2000, deadline=None)
@given(VALUES, st.integers(0, 8), st.booleans(), st.booleans())
def test_a_number_is_spelled_by_one_format_as_by_two(value, decimals, trim, leading_zero):
    style = Style(trim=trim, leading_zero=leading_zero)
    assert style.number(value, decimals) == _number_as_formatted_twice(value, decimals, trim, leading_zero)
    rounded_first = rounded(value, decimals) + 0.0
    assert _word_text(value, decimals, trim, leading_zero) == style.number(rounded_first, decimals)


@settings(max_examples=1000, deadline=None)
@given(st.lists(VALUES, min_size=6, max_size=6), st.booleans(), st.booleans(), st.booleans(), st.integers(1, 6),
       st.booleans(), st.booleans(), st.booleans(), st.sampled_from(["XZ", "X", "Z"]))
def test_geometry_words_are_the_grid_words_of_the_cut(values, arc, cw, rapid, decimals, inch, diameter, lower, axes):
    x0, z0, x1, z1, xc, zc = values
    cut = Cut(x0, z0, x1, z1, xc, zc, cw) if arc else Cut(x0, z0, x1, z1, rapid=rapid)
    grid = Grid(decimals, inch, diameter)
    for style in (Style(lower=lower), Style(lower=lower, trim=False, leading_zero=False)):
        writer = Writer(grid, "A", True, axes)
        assert writer.geometry_words(cut, style) == _words_rounded_then_spelled(grid, cut, style, axes)
