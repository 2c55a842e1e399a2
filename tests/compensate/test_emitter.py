"""The emitter: a canonical block's replacement, written from its fields, is what its words give."""

from __future__ import annotations

from hypothesis import assume, given, settings
from hypothesis import strategies as st

from postproc.interpret import gcodes as G
from postproc.syntax.blocks import Block
from postproc.compensate.emitter import Style, Writer
from postproc.syntax.fastpath import detail_of_ordinary, read_ordinary
from postproc.machine.resolution import Grid
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
