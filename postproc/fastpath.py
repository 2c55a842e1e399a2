"""The fast path: ordinary blocks read by one compiled regular expression.

An ordinary block is an optional sequence number, address words whose values are plain
numbers, at most one simple comment and an optional ``;``. Such a block is about ninety
per cent of any real program; reading it with a regular expression instead of the LALR
parser is what lets postproc run near the speed of a bare tokenizer. Anything else
(macros, headers, block delete, nested comments, spaces inside numbers, mistakes) goes to
the grammar. ``tests/test_fastpath.py`` proves on the corpus and on generated programs
that both paths give the same block for every line the fast path accepts.
"""

from __future__ import annotations

import re

from .blocks import BLANK, BLOCK, HEADER, TAPE, Block, Comment, Detail, Word

_ORDINARY = re.compile(
    r"[ \t]*"
    r"(?:(?P<n>[Nn])[ \t]*(?P<label>\d+)[ \t]*)?"
    r"(?P<words>(?:[A-MP-Za-mp-z][ \t]*[+-]?(?:\d+\.?\d*|\.\d+)[ \t]*)*)"
    r"(?:(?P<comment>\([^()\r\n]*\))[ \t]*)?"
    r"(?:(?P<eob>;)[ \t]*)?",
    re.ASCII,  # a control reads only ASCII digits
)
_WORD = re.compile(r"([A-Z])[ \t]*([+-]?(?:\d+\.?\d*|\.\d+))", re.ASCII)
_WORD_SPELLING = re.compile(r"[A-Za-z][ \t]*[+-]?(?:\d+\.?\d*|\.\d+)", re.ASCII)
_fullmatch = _ORDINARY.fullmatch
_EMPTY = Detail((), (), None, None)
_findall = _WORD.findall


_TAPE = re.compile(r"[ \t]*%[ \t]*")
_HEADER = re.compile(r"[ \t]*[Oo][ \t]*\d+[ \t]*(?:(?P<comment>\([^()\r\n]*\))[ \t]*)?(?:(?P<eob>;)[ \t]*)?", re.ASCII)


def read_ordinary(text: str, line: int, eol: str) -> Block | None:
    """The block for an ordinary line, or None when the line needs the grammar."""
    match = _fullmatch(text)
    if match is None:
        return _program_start(text, line, eol)
    label, words, comment, eob = match.group(2, 3, 4, 5)
    if words:
        codes = tuple(_findall(words if words.isupper() else words.upper()))
    elif label is None and comment is None and eob is None:
        return Block(line, text, eol, BLANK, None, None, (), None, _EMPTY)
    else:
        codes = ()
    return Block(line, text, eol, BLOCK, None if label is None else int(label), None, codes, None, None, _detail)


def _detail(text: str) -> Detail:
    match = _ORDINARY.fullmatch(text)
    start, end = match.span("words")
    words = tuple(
        Word(m.group(0)[0].upper(), m.group(0), m.start(), _WORD.fullmatch(m.group(0).upper()).group(2))
        for m in _WORD_SPELLING.finditer(text, start, end)
    )
    comments = (Comment(match.group("comment"), match.start("comment")),) if match.group("comment") else ()
    label_col = match.start("n") if match.group("n") is not None else None
    eob_col = match.start("eob") if match.group("eob") else None
    return Detail(words, comments, label_col, eob_col)


def _program_start(text: str, line: int, eol: str) -> Block | None:
    """A ``%`` tape mark, or a program number ``O1234`` with at most a simple comment."""
    if _TAPE.fullmatch(text):
        return Block(line, text, eol, TAPE, None, None, (), None, _EMPTY)
    match = _HEADER.fullmatch(text)
    if match is None:
        return None
    comment = match.group("comment")
    comments = (Comment(comment, match.start("comment")),) if comment else ()
    eob = match.start("eob") if match.group("eob") else None
    return Block(line, text, eol, HEADER, None, None, (), None, Detail((), comments, None, eob))
