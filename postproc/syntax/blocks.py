"""The lossless block model.

One line of a part program is one :class:`Block`. A block keeps its exact text, its
line ending and its 1-based line number, so an unchanged block is written back byte for
byte. What the interpreter needs (``codes``: address letters and values) is computed when
the block is read, or, for a block in canonical form, kept as the values of its fixed
addresses (:attr:`Block.fields`) and turned into ``codes`` only when asked for; word
spellings and columns (:attr:`Block.words`) are computed only when asked for, because a
million-block program should not pay for objects that only an error message or a
rewritten block needs.

Conventions: columns are 0-based offsets inside the model and 1-based in every message.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple, Union

if TYPE_CHECKING:
    from .macro import Expr, Statement

#: A word's value as the interpreter sees it: the number as written (sign included,
#: spaces removed, so ``"-.5"`` or ``"10."``) or a macro expression.
Value = Union[str, "Expr"]

BLANK = "blank"  #: nothing but white space
TAPE = "tape"  #: a ``%`` tape mark
HEADER = "header"  #: a program number ``O1234`` or name ``<NAME>``
BLOCK = "block"  #: an ordinary block: words, comments, a macro statement
TRAILER = "trailer"  #: text after the closing ``%``; the control never reads it

#: The addresses of a canonical block, in the order they must stand (see :mod:`postproc.syntax.fastpath`).
CANONICAL_LETTERS = "NGXZIKRF"


class Word(NamedTuple):
    """An address and its value, with the spelling the program used.

    Immutable; a named tuple rather than a frozen dataclass because every replaced block
    has its words spelled out, and a tuple is built several times faster.
    """

    letter: str  #: upper-case address; ``",C"``/``",R"``/``",A"`` for corner words
    text: str  #: exactly as written, e.g. ``"X 10."`` or ``"x-#1"``
    col: int  #: 0-based column of the address in the line
    value: Value  #: numeric literal (str) or macro expression

    @property
    def end(self) -> int:
        return self.col + len(self.text)

    @property
    def is_number(self) -> bool:
        return isinstance(self.value, str)


@dataclass(frozen=True, slots=True)
class Comment:
    text: str  #: with its parentheses
    col: int


@dataclass(frozen=True, slots=True)
class Detail:
    """Everything about a block's spelling: built on demand."""

    words: tuple[Word, ...]
    comments: tuple[Comment, ...]
    label_col: int | None
    eob_col: int | None  #: column of ``;`` when the block has one


#: The detail of a line with no words and no comments the control reads: a blank line, a bare
#: tape mark, text after the closing ``%`` (kept as written, never parsed).
NO_DETAIL = Detail((), (), None, None)


class Block:
    """One line of the program.

    A block is complete when it is made: it carries its :class:`Detail`, or the function
    that builds it from the text (``detailer``), so that ``words``, ``comments`` and
    ``detail`` answer for every block a reader returns.
    """

    __slots__ = ("line", "text", "eol", "kind", "label", "delete", "_codes", "statement", "_detail", "_detailer",
                 "fields")

    def __init__(
        self,
        line: int,
        text: str,
        eol: str,
        kind: str,
        label: int | None = None,
        delete: int | None = None,
        codes: tuple[tuple[str, Value], ...] = (),
        statement: Statement | None = None,
        detail: Detail | None = None,
        detailer=None,
        fields: "tuple[str | None, ...] | None" = None,
    ):
        self.line = line  #: 1-based line number
        self.text = text  #: the line without its ending
        self.eol = eol  #: ``"\n"``, ``"\r\n"``, ``"\r"`` or ``""`` (last line)
        self.kind = kind
        self.label = label  #: N number, or None
        self.delete = delete  #: block delete level (1 for ``/``), or None
        self._codes = codes  # None for a canonical block until asked for
        self.statement = statement  #: the macro statement, if any
        if detail is None and detailer is None:
            raise TypeError(f"line {line}: a block needs its detail or a detailer")
        self._detail = detail
        self._detailer = detailer
        #: For a block in canonical form (see :mod:`postproc.syntax.fastpath`): the values of its
        #: N G X Z I K R F words as written, None where absent. None for every other block.
        self.fields = fields

    @property
    def codes(self) -> tuple[tuple[str, Value], ...]:
        """(LETTER, value) pairs in order, label excluded."""
        codes = self._codes
        if codes is None:
            codes = self._codes = tuple(
                (letter, value) for letter, value in zip(CANONICAL_LETTERS[1:], self.fields[1:]) if value is not None
            )
        return codes

    @property
    def raw(self) -> str:
        return self.text + self.eol

    @property
    def detail(self) -> Detail:
        if self._detail is None:
            self._detail = self._detailer(self.text)
        return self._detail

    @property
    def words(self) -> tuple[Word, ...]:
        return self.detail.words

    @property
    def comments(self) -> tuple[Comment, ...]:
        return self.detail.comments

    @property
    def has_eob(self) -> bool:
        return self.detail.eob_col is not None

    def word(self, letter: str) -> Word | None:
        """The first word with this address."""
        for word in self.words:
            if word.letter == letter:
                return word
        return None

    def __repr__(self) -> str:
        return f"Block(line={self.line}, text={self.text!r})"
