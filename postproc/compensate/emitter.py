"""Writing blocks in the program's own style.

A replaced block becomes one or more blocks that look as if the programmer had written
them: the same letter case, the same spacing between words, the same decimal style
(``X114.3`` or ``X114.300``, ``X.5`` or ``X0.5``), ``;`` at the end if the block had one
(the first block keeps what followed it: ``; (COOLANT OFF);``), and its own line ending. Numbers always carry a decimal point, so that no value is ever
read in least input increments. The replaced block's label, feed, spindle, M words, other
G codes and comments stay with its first replacement block (a label that ends a cycle
contour goes on the last: the cycle looks for it there).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import lru_cache

from ..interpret import gcodes as G
from ..syntax.blocks import Block
from ..machine.resolution import Grid, rounded
from .segmenter import Cut

_GEOMETRY = frozenset("XZUWIKR") | {",C", ",R", ",A"}
_TRAILING_ZERO = re.compile(r"\.\d*0$")
_LEADING_DOT = re.compile(r"^[+-]?\.\d")


@dataclass(frozen=True)
class Style:
    lower: bool = False
    separator: str = " "
    two_digit_g: bool = True
    trim: bool = True  #: 114.3 rather than 114.300
    leading_zero: bool = True  #: 0.5 rather than .5
    eob: bool = False

    @classmethod
    def of(cls, block: Block) -> "Style":
        """The style a block is written in."""
        if block.fields is not None:
            return cls._of_canonical(block)
        text = block.text
        lower = None
        joined = True  # no gap between any two words
        two_digit = trim = leading_zero = True
        end = None
        for word in block.words:
            spelled = word.text
            first = spelled[0]
            if first.isalpha():
                lower = first.islower() if lower is None else lower and first.islower()
            if end is not None and text[end:word.col]:
                joined = False
            end = word.col + len(spelled)
            value = word.value
            if type(value) is not str:
                continue
            letter = word.letter
            if letter == "G":
                two_digit = two_digit and len(value) >= 2
            elif letter in "XZUWIKRF" and "." in value:
                trim = trim and not _TRAILING_ZERO.search(value)
                leading_zero = leading_zero and not _LEADING_DOT.match(value)
        separator = "" if joined and len(block.words) >= 2 else " "
        return cls(bool(lower), separator, two_digit, trim, leading_zero, block.has_eob)

    @classmethod
    def _of_canonical(cls, block: Block) -> "Style":
        """The style of a canonical block, read from its fields: what :meth:`of` finds in its
        words (upper case; words apart by one space or none; a decimal point in every length,
        at the end of the value's digits)."""
        fields = block.fields
        text = block.text
        trim = leading_zero = True
        for value in fields[2:]:
            if value is not None and "." in value:
                trim = trim and value[-1] != "0"
                leading_zero = leading_zero and value.lstrip("+-")[0] != "."
        joined = " " not in _canonical_words(text, fields) and sum(value is not None for value in fields[1:]) >= 2
        return _style(joined, fields[1] is None or len(fields[1]) >= 2, trim, leading_zero, text.endswith(";"))

    def number(self, value: float, decimals: int) -> str:
        text = f"{value:.{decimals}f}"
        if text.startswith("-") and float(text) == 0.0:
            text = text[1:]
        if self.trim:
            text = text.rstrip("0")
        if not self.leading_zero:
            text = re.sub(r"^(-?)0\.(?=\d)", r"\1.", text)
        return text

    def word(self, letter: str, text: str) -> str:
        return (letter.lower() if self.lower else letter) + text

    def g(self, key: int) -> str:
        whole, tenth = divmod(key, 10)
        digits = f"{whole:02d}" if self.two_digit_g else f"{whole}"
        return self.word("G", digits if tenth == 0 else f"{digits}.{tenth}")


@dataclass
class Writer:
    """Turns planned cuts into block text for one program."""

    grid: Grid
    system: str  #: the control's G-code system (the machine profile's gcode_system)
    absolute: bool = True  #: G90 in systems B and C (X and Z absolute)
    #: the axes a line is written with: a type I G71 approach keeps moving X only (its Z stays
    #: where it was), or the cycle would read it as type II
    axes: str = "XZ"

    @staticmethod
    def motion_of(cut: Cut) -> int:
        """The motion mode (G00, G01, G02, G03 as interpreter modes) that runs a cut."""
        if cut.rapid:
            return G.G00
        if not cut.is_arc:
            return G.G01
        return G.G02 if cut.cw else G.G03

    def code(self, mode: int, style: Style) -> str:
        return style.g(G.motion_code(self.system, mode))

    def geometry_words(self, cut: Cut, style: Style) -> list[str]:
        grid = self.grid
        x_word, z_word = grid.x_word(cut.x1), grid.z_word(cut.z1)
        if not self.absolute:
            x_word = rounded(x_word - grid.x_word(cut.x0), grid.decimals)
            z_word = rounded(z_word - grid.z_word(cut.z0), grid.decimals)
        words = [style.word(letter, style.number(word, grid.decimals))
                 for letter, word in (("X", x_word), ("Z", z_word)) if cut.is_arc or letter in self.axes]
        if cut.is_arc:
            i_word = grid.offset_word(cut.xc - cut.x0)
            k_word = grid.offset_word(cut.zc - cut.z0)
            words += [style.word("I", style.number(i_word, grid.decimals)), style.word("K", style.number(k_word, grid.decimals))]
        return words

    def replacement(self, block: Block, cuts: list[Cut], mode_before, label_last: bool = False) -> tuple[list[str], int]:
        """The text lines (with line endings) that replace ``block``, and the motion mode after them."""
        style = Style.of(block)
        eob = ";" if style.eob else ""
        eob_col = block.detail.eob_col if block.fields is None else None
        tail = eob if eob_col is None else block.text[eob_col:]  # "; (COOLANT OFF);" as it was written
        lines = []
        mode = mode_before
        for index, cut in enumerate(cuts):
            wanted = self.motion_of(cut)
            if index == 0:
                parts = self._first_words(block, style, wanted, mode, cut, label_last)
            else:
                parts = [self.code(wanted, style)] if wanted != mode else []
                parts += self.geometry_words(cut, style)
            if label_last and index == len(cuts) - 1 and block.label is not None:
                parts.insert(0, _label(block))
            mode = wanted
            last = index == len(cuts) - 1
            end = tail if index == 0 else eob
            lines.append(style.separator.join(parts) + end + (block.eol if last else (block.eol or "\n")))
        return lines, mode

    def _first_words(self, block: Block, style: Style, wanted: int, mode, cut: Cut, label_last: bool) -> list[str]:
        """The replaced block's words with its geometry (and motion G code) swapped for the cut's."""
        if block.fields is not None:
            return self._first_canonical_words(block, style, wanted, mode, cut, label_last)
        parts: list[str] = []
        if block.label is not None and not label_last:
            parts.append(_label(block))
        placed = False
        motion_written = False
        for word in block.words:
            if word.letter in _GEOMETRY:
                if not placed:
                    if wanted != mode and not motion_written:
                        parts.append(self.code(wanted, style))
                        motion_written = True
                    parts += self.geometry_words(cut, style)
                    placed = True
                continue
            if word.letter == "G" and word.is_number and G.SYSTEMS[self.system].get(G.code_key(float(word.value)), ("",))[0] == G.MOTION:
                if not motion_written:
                    parts.append(self.code(wanted, style))
                    motion_written = True
                continue
            parts.append(word.text)
        if not placed:
            if wanted != mode and not motion_written:
                parts.append(self.code(wanted, style))
            parts += self.geometry_words(cut, style)
        eob_col = block.detail.eob_col
        parts += [comment.text for comment in block.comments if eob_col is None or comment.col < eob_col]
        return parts

    def _first_canonical_words(self, block: Block, style: Style, wanted: int, mode, cut: Cut,
                               label_last: bool) -> list[str]:
        """:meth:`_first_words` of a canonical block, from its fields: N, a motion G code,
        the geometry words, F, then the comment."""
        label, g, *geometry, feed = block.fields
        parts = [] if label is None or label_last else ["N" + label]
        code = [self.code(wanted, style)] if g is None and wanted != mode else []
        if g is not None:
            parts.append(self.code(wanted, style))
        if any(value is not None for value in geometry):
            parts += code + self.geometry_words(cut, style)
            if feed is not None:
                parts.append("F" + feed)
        else:  # nothing to swap: the geometry goes after the other words, as in _first_words
            if feed is not None:
                parts.append("F" + feed)
            parts += code + self.geometry_words(cut, style)
        text = block.text
        at = text.find("(")
        if at != -1:
            parts.append(text[at : text.index(")", at) + 1])
        return parts


@lru_cache(maxsize=64)
def _style(joined: bool, two_digit_g: bool, trim: bool, leading_zero: bool, eob: bool) -> Style:
    """One style object per combination: most programs are written in one or two."""
    return Style(False, "" if joined else " ", two_digit_g, trim, leading_zero, eob)


def _canonical_words(text: str, fields: tuple) -> str:
    """The words of a canonical line: the text between its label and its comment or ``;``."""
    start = 0 if fields[0] is None else 1 + len(fields[0])
    end = len(text)
    for mark in ("(", ";"):
        at = text.find(mark, start)
        if at != -1:
            end = min(end, at)
    return text[start:end].strip()


def _label(block: Block) -> str:
    text = block.text
    col = block.detail.label_col
    match = re.match(r"[Nn][ \t]*\d+", text[col:])
    return match.group(0)


def with_motion_code(block: Block, code: str) -> str:
    """An unchanged block with the motion G code it relied on written in front of its words.

    A replacement may leave the control in another motion mode than the original block left
    it; the next block that relied on the old mode gets the code written out.
    """
    words = block.words
    col = words[0].col if words else len(block.text)
    return block.text[:col] + code + (Style.of(block).separator or "") + block.text[col:] + block.eol
