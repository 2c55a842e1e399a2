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
    """A paragraph; ``kind`` styles it: ``p``, ``note``, ``warning`` or ``pre`` (kept verbatim)."""

    text: str
    kind: str = "p"


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


Part = Union[Text, Table, Image]


@dataclass(frozen=True)
class Section:
    """A titled part of the report; ``key`` is its anchor (fixed by the code, never user text)."""

    key: str
    title: str
    parts: list[Part] = field(default_factory=list)
    subsections: list["Section"] = field(default_factory=list)


@dataclass(frozen=True)
class Document:
    title: str
    subtitle: str
    sections: list[Section]
