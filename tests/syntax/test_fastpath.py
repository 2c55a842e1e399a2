"""The fast path against the grammar: for every line the fast path takes, the same block.

This is the proof the fast path owes: on every line of the corpus and on generated
lines, a block read by the regular expression equals the block the grammar reads,
down to word spellings, columns, comments and the end-of-block mark.
"""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from support.corpus import corpus
from postproc.diagnostics import ProgramSyntaxError
from postproc.syntax.fastpath import read_ordinary
from postproc.syntax.source import Source
from postproc.syntax.grammar import parse_block
from support.strategies import comments, lines, words


def _view(block):
    """Everything a block says, for comparison."""
    detail = block.detail
    return (
        block.kind,
        block.label,
        block.delete,
        block.codes,
        block.statement,
        detail.words,
        detail.comments,
        detail.label_col,
        detail.eob_col,
    )


def _agree(text: str) -> bool:
    """Whether the fast path took the line; asserts it read it as the grammar does."""
    fast = read_ordinary(text, 1, "\n")
    if fast is None:
        return False
    slow = parse_block(text, 1, "\n", "t.nc")
    assert _view(fast) == _view(slow), text
    return True


def test_corpus_lines_agree_and_most_take_the_fast_path():
    taken = total = 0
    for folder in ("fanuc", "fanuc-mill", "linuxcnc", "malformed"):
        for path in corpus(folder):
            for raw in Source(str(path)).lines():
                total += 1
                taken += _agree(raw.rstrip("\r\n"))
    assert taken / total > 0.8, f"only {taken} of {total} lines took the fast path"


@settings(max_examples=600, deadline=None)
@given(lines())
def test_generated_lines_agree(text):
    _agree(text)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.one_of(words(), comments(), st.sampled_from([" ", "\t", ";", "N10", "(", ")", ".", "#1", ","])), max_size=8))
def test_arbitrary_fragments_agree_or_are_refused_by_both(parts):
    """Fragments glued without care: when the fast path takes one, the grammar reads it the same."""
    text = "".join(parts)
    fast = read_ordinary(text, 1, "\n")
    try:
        slow = parse_block(text, 1, "\n", "t.nc")
    except ProgramSyntaxError:
        assert fast is None, text
        return
    if fast is not None:
        assert _view(fast) == _view(slow), text


@pytest.mark.parametrize("text", ["%", " % ", "%\t", "O1234", "o0001 (PART)", "O1234;", "O1234 (X) ;", "O 12",
                                  "O12(A(B))", "%(C)", "<NAME>", "O1234 ; (C)",
                                  "O1234; (C) ;;", "%;"])
def test_tape_marks_and_headers_agree(text):
    _agree(text)


@pytest.mark.parametrize("text, canonical", [
    ("N40 G01 X100.317 Z-0.425", True),
    ("G03 X99.886 Z-4.079 I-5.074 K0.", True),
    ("G01 X98.466 Z-8.417 F0.150 (FINISH)", True),
    ("G02 X10. Z-5. R5.;", True),
    ("X.5 Z-.25", True),
    ("N10", True),
    ("(COMMENT ONLY)", True),
    ("G01 X100 Z-1.", False),  # no decimal point: least input increments
    ("G01 X1.23456 Z-1.", False),  # more digits than the canonical form takes
    ("G01 X10. Z-1.; (C);", False),  # more after the ';'
    ("N200 G01 Z.1 M09; (Retract, Collant Off);", False),
    ("G01 Z-1. X10.", False),  # words out of order
    ("g01 x10. z-1.", False),  # lower case
    ("G01  X10.", False),  # two spaces
    ("G01 X10. M08", False),  # an M code
    ("G00 X\u0661\u0662.", False),  # digits that are not ASCII
])
def test_canonical_form(text, canonical):
    """Canonical lines keep their fields; every line still reads as the grammar reads it."""
    block = read_ordinary(text, 1, "\n")
    assert (block is not None and block.fields is not None) == canonical
    if block is not None:
        _agree(text)
    if canonical:
        assert dict(block.codes) == {letter: value for letter, value in zip("GXZIKRF", block.fields[1:]) if value}


@pytest.mark.parametrize("text", ["N200 G01 Z.1 M09; (Retract, Collant Off);", "G01 X1.;;", "X1. (A); (B) ; ",
                                  "M30;\t;", "O1200; (TOKARKA);"])
def test_printed_ends_of_block_take_the_fast_path(text):
    """A ';' with comments and more ';' after it is common in files from other controls:
    the fast path reads it, as the grammar does."""
    assert _agree(text)
