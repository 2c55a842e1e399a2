"""What a report is made of, as plain data: the sections build it, :mod:`.html` renders it.

Every string here is plain text (file names, plugin output, warnings: anything), never
markup; the renderer escapes all of it, so nothing a user or a plugin supplies can inject
HTML. Images are PNG bytes with their pixel size.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Union


@dataclass(frozen=True, slots=True)
class Text:
    """A paragraph; ``kind`` styles it: ``p``, ``note``, ``warning``, ``item`` (of a list) or
    ``pre`` (kept verbatim). ``code`` are (start, end) character ranges of ``text`` set as code
    (a name, an option, a formula): the text itself holds no markup."""

    text: str
    kind: str = "p"
    code: tuple[tuple[int, int], ...] = ()


@dataclass(frozen=True, slots=True)
class Verdict:
    """The report's answer, first on its first screen: ``state`` is ``pass``, ``fail`` or
    ``none`` (nothing to judge); ``headline`` says it in a few words, ``figures`` gives the
    numbers (before -> after), ``sentence`` says what they are."""

    state: str
    headline: str
    figures: str
    sentence: str


@dataclass(frozen=True, slots=True)
class Table:
    """A table of text cells; ``key`` names it for readers and tests (an HTML id when given)."""

    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]
    caption: str = ""
    key: str = ""
    numeric: bool = True  #: right-align every column but the first


@dataclass(frozen=True, slots=True)
class Image:
    """A PNG figure."""

    png: bytes
    width: int  #: pixels
    height: int  #: pixels
    alt: str
    caption: str = ""


Part = Union[Text, Table, Image, Verdict]


@dataclass(frozen=True)
class Section:
    """A titled part of the report; ``key`` is its anchor (fixed by the code, never user text)."""

    key: str
    title: str
    parts: list[Part] = field(default_factory=list)
    subsections: list["Section"] = field(default_factory=list)


@dataclass(frozen=True)
class Document:
    """``lead`` is the first screen (the verdict), shown before the contents."""

    title: str
    subtitle: str
    sections: list[Section]
    lead: Section | None = None
