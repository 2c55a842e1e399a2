"""The fast path: ordinary blocks read by one compiled regular expression.

An ordinary block is an optional sequence number, address words whose values are plain
numbers, at most one simple comment and an optional ``;`` (which simple comments and more
``;`` may follow). Such a block is about ninety
per cent of any real program; reading it with a regular expression instead of the LALR
parser is what lets postproc run near the speed of a bare tokenizer. Anything else
(macros, headers, block delete, nested comments, spaces inside numbers, mistakes) goes to
the grammar.

Most blocks a CAM system writes are in *canonical form*: upper-case words G (00-03),
X, Z, I, K, R (with a decimal point) and F, in that order, single spaces at most, then a
simple comment and ``;``. A canonical block keeps its values as written in
:attr:`Block.fields` and builds its ``codes`` only when asked: the interpreter reads the
fields directly, which is what brings a large program near the tokenizer's speed.

``tests/syntax/test_fastpath.py`` proves on the corpus and on generated programs
that both paths give the same block for every line the fast path accepts.
"""

from __future__ import annotations

import re
from operator import itemgetter

from .blocks import BLANK, BLOCK, HEADER, NO_DETAIL, TAPE, Block, Comment, Detail, Word

# Canonical values: lengths with their decimal point (no least-input-increment scaling) and
# at most 8 digits (no significant-digit alarm); a feed of at most 8 digits. ASCII digits only.
_LENGTH = r"([+-]?+(?:\d{1,4}+\.\d{0,4}+|\.\d{1,4}+))"
_CANONICAL_FORM = (
    r"(?:N(\d++) ?)?"
    r"(?:G(0?[0-3]) ?)?"
    rf"(?:X{_LENGTH} ?)?(?:Z{_LENGTH} ?)?(?:I{_LENGTH} ?)?(?:K{_LENGTH} ?)?(?:R{_LENGTH} ?)?"
    r"(?:F(\d{1,4}+(?:\.\d{0,4}+)?+|\.\d{1,4}+) ?)?"
    r"(?:\([^()\r\n]*\) ?)?;?"
)
#: A canonical block's fields from its text (the line without its ending).
canonical_fields = re.compile(_CANONICAL_FORM, re.ASCII).fullmatch
#: The same from the line as read, with its ending (one: LF, CRLF or a lone CR), and not blank:
#: the reader cuts the ending off a canonical line only when its block is made.
canonical_line = re.compile(r"(?=[^\r\n])" + _CANONICAL_FORM + r"\r?\n?", re.ASCII).fullmatch

_ORDINARY = re.compile(
    r"[ \t]*"
    r"(?:(?P<n>[Nn])[ \t]*(?P<label>\d+)[ \t]*)?"
    r"(?P<words>(?:[A-MP-Za-mp-z][ \t]*[+-]?(?:\d+\.?\d*|\.\d+)[ \t]*)*)"
    r"(?:(?P<comment>\([^()\r\n]*\))[ \t]*)?"
    r"(?:(?P<eob>;)[ \t]*(?P<tail>(?:(?:\([^()\r\n]*\)|;)[ \t]*)*))?",
    re.ASCII,  # a control reads only ASCII digits
)
_TAIL_COMMENT = re.compile(r"\([^()\r\n]*\)")
_WORD = re.compile(r"([A-Z])[ \t]*([+-]?(?:\d+\.?\d*|\.\d+))", re.ASCII)
_WORD_SPELLING = re.compile(r"([A-Za-z])[ \t]*([+-]?(?:\d+\.?\d*|\.\d+))", re.ASCII)
_fullmatch = _ORDINARY.fullmatch
_findall = _WORD.findall


_TAPE = re.compile(r"[ \t]*%[ \t]*")
_HEADER = re.compile(r"[ \t]*[Oo][ \t]*\d+[ \t]*(?:(?P<comment>\([^()\r\n]*\))[ \t]*)?"
                     r"(?:(?P<eob>;)[ \t]*(?P<tail>(?:(?:\([^()\r\n]*\)|;)[ \t]*)*))?", re.ASCII)


def read_ordinary(text: str, line: int, eol: str) -> Block | None:
    """The block for an ordinary line, or None when the line needs the grammar."""
    if text:
        match = canonical_fields(text)
        if match is not None:
            return canonical_block(line, text, eol, match.groups())
    match = _fullmatch(text)
    if match is None:
        return _program_start(text, line, eol)
    label, words, comment, eob = match.group(2, 3, 4, 5)
    if words:
        codes = tuple(_findall(words if words.isupper() else words.upper()))
    elif label is None and comment is None and eob is None:
        return Block(line, text, eol, BLANK, None, None, (), None, NO_DETAIL)
    else:
        codes = ()
    return Block(line, text, eol, BLOCK, None if label is None else int(label), None, codes, None, None, detail_of_ordinary)


class CanonicalLine(tuple):
    """A line in canonical form, not yet made a :class:`Block`: what the reader's light stream
    gives for most lines (``read_blocks(..., light=True)``), for a consumer that seldom needs
    the block (the interpreter's tally). It answers what the interpreter reads of a block in
    canonical form (``line``, ``text``, ``fields``, and ``words`` for an error's column);
    :meth:`block` makes the block when more is needed.

    Made as ``CanonicalLine((line, raw, fields))``, ``raw`` the line with its ending: a
    tuple subclass with named fields rather than a ``NamedTuple``, because the reader makes one
    per line and a named tuple is made through a Python ``__new__`` (or ``tuple.__new__``
    called through its wrapper), which costs about three times what this class, built by
    tuple's own constructor, adds over a bare tuple (0.2 against 0.07 us a line)."""

    __slots__ = ()

    line = property(itemgetter(0), doc="1-based line number")
    raw = property(itemgetter(1), doc="the line with its ending")
    fields = property(itemgetter(2), doc="the values of its N G X Z I K R F words as written, "
                                         "None where absent (Block.fields)")

    def __repr__(self) -> str:
        return f"CanonicalLine(line={self[0]!r}, raw={self[1]!r}, fields={self[2]!r})"

    @property
    def text(self) -> str:
        """The line without its ending, cut off only when asked: most lines never need it."""
        return self[1].rstrip("\r\n")

    def block(self) -> Block:
        text = self.text
        return canonical_block(self[0], text, self[1][len(text):], self[2])

    @property
    def words(self) -> tuple[Word, ...]:
        return detail_of_ordinary(self.text).words


def canonical_block(line: int, text: str, eol: str, fields: tuple) -> Block:
    """The block of a canonical line, from its fields (N G X Z I K R F, None where absent)."""
    label = fields[0]
    return Block(line, text, eol, BLOCK, None if label is None else int(label), None, None, None, None,
                 detail_of_ordinary, fields)


def detail_of_ordinary(text: str) -> Detail:
    match = _ORDINARY.fullmatch(text)
    start, end = match.span("words")
    words = tuple(
        Word(m.group(1).upper(), m.group(0), m.start(), m.group(2)) for m in _WORD_SPELLING.finditer(text, start, end)
    )
    label_col = match.start("n") if match.group("n") is not None else None
    eob_col = match.start("eob") if match.group("eob") else None
    return Detail(words, _comments(match, text), label_col, eob_col)


def _comments(match: re.Match, text: str) -> tuple[Comment, ...]:
    """The comment before the ``;`` and those after it."""
    comments = (Comment(match.group("comment"), match.start("comment")),) if match.group("comment") else ()
    if match.group("tail"):
        start, end = match.span("tail")
        comments += tuple(Comment(found.group(0), found.start()) for found in _TAIL_COMMENT.finditer(text, start, end))
    return comments


def _program_start(text: str, line: int, eol: str) -> Block | None:
    """A ``%`` tape mark, or a program number ``O1234`` with at most a simple comment."""
    if _TAPE.fullmatch(text):
        return Block(line, text, eol, TAPE, None, None, (), None, NO_DETAIL)
    match = _HEADER.fullmatch(text)
    if match is None:
        return None
    eob = match.start("eob") if match.group("eob") else None
    return Block(line, text, eol, HEADER, None, None, (), None, Detail((), _comments(match, text), None, eob))
