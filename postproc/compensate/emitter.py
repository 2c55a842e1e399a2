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
from dataclasses import dataclass, field
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
            if value is not None and "." in value:  # at most one sign, and a digit beside the point
                if value[-1] == "0":
                    trim = False
                if value[0] == "." or value[1] == "." and value[0] in "+-":
                    leading_zero = False
        joined = fields[1:].count(None) <= 5 and " " not in _canonical_words(text, fields)
        return _style(joined, fields[1] is None or len(fields[1]) >= 2, trim, leading_zero, text[-1:] == ";")

    def number(self, value: float, decimals: int) -> str:
        return _spelled("%.*f" % (decimals, value), self.trim, self.leading_zero)

    def word(self, letter: str, text: str) -> str:
        return (letter.lower() if self.lower else letter) + text

    def g(self, key: int) -> str:
        whole, tenth = divmod(key, 10)
        digits = f"{whole:02d}" if self.two_digit_g else f"{whole}"
        return self.word("G", digits if tenth == 0 else f"{digits}.{tenth}")


@dataclass(frozen=True)
class Writer:
    """Turns planned cuts into block text for one program (one per grid, system, mode and axes:
    :func:`writer_for`)."""

    grid: Grid
    system: str  #: the control's G-code system (the machine profile's gcode_system)
    absolute: bool = True  #: G90 in systems B and C (X and Z absolute)
    #: the axes a line is written with: a type I G71 approach keeps moving X only (its Z stays
    #: where it was), or the cycle would read it as type II
    axes: str = "XZ"
    #: decimals written, X's factor (2 for a diameter) and mm per program unit: asked for every value written
    _scale: tuple[int, float, float] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        grid = self.grid
        object.__setattr__(self, "_scale", (grid.decimals, 2.0 if grid.diameter else 1.0, grid.unit))

    @staticmethod
    def motion_of(cut: Cut) -> int:
        """The motion mode (G00, G01, G02, G03 as interpreter modes) that runs a cut."""
        if cut.rapid:
            return G.G00
        if not cut.is_arc:
            return G.G01
        return G.G02 if cut.cw else G.G03

    def code(self, mode: int, style: Style) -> str:
        return _code(self.system, mode, style.lower, style.two_digit_g)

    def geometry_words(self, cut: Cut, style: Style) -> list[str]:
        """X and Z of the cut's end (those of :attr:`axes` for a line), then an arc's I and K.

        In absolute mode each value is rounded and spelled by one format (:func:`_word_text`),
        not rounded to a float and formatted again: the same text (``tests/compensate/test_emitter.py``
        holds the two to each other)."""
        if not self.absolute:
            return self._incremental_words(cut, style)
        decimals, d, unit = self._scale
        trim, leading_zero = style.trim, style.leading_zero
        x_letter, z_letter, i_letter, k_letter = _LOWER if style.lower else _UPPER
        x0, z0, x1, z1, xc, zc, _, _ = cut
        if xc is None:
            axes = self.axes
            if axes == "XZ":
                return [x_letter + _word_text(x1 * d / unit, decimals, trim, leading_zero),
                        z_letter + _word_text(z1 / unit, decimals, trim, leading_zero)]
            words = []
            if "X" in axes:
                words.append(x_letter + _word_text(x1 * d / unit, decimals, trim, leading_zero))
            if "Z" in axes:
                words.append(z_letter + _word_text(z1 / unit, decimals, trim, leading_zero))
            return words
        return [x_letter + _word_text(x1 * d / unit, decimals, trim, leading_zero),
                z_letter + _word_text(z1 / unit, decimals, trim, leading_zero),
                i_letter + _word_text((xc - x0) / unit, decimals, trim, leading_zero),
                k_letter + _word_text((zc - z0) / unit, decimals, trim, leading_zero)]

    def _incremental_words(self, cut: Cut, style: Style) -> list[str]:
        """:meth:`geometry_words` in incremental mode (U and W written as X and Z under G91):
        the difference of the rounded end and the rounded start, itself rounded."""
        grid = self.grid
        x_word = rounded(grid.x_word(cut.x1) - grid.x_word(cut.x0), grid.decimals)
        z_word = rounded(grid.z_word(cut.z1) - grid.z_word(cut.z0), grid.decimals)
        words = [style.word(letter, style.number(word, grid.decimals))
                 for letter, word in (("X", x_word), ("Z", z_word)) if cut.is_arc or letter in self.axes]
        if cut.is_arc:
            i_word = grid.offset_word(cut.xc - cut.x0)
            k_word = grid.offset_word(cut.zc - cut.z0)
            words += [style.word("I", style.number(i_word, grid.decimals)), style.word("K", style.number(k_word, grid.decimals))]
        return words

    def replacement(self, block: Block, cuts: list[Cut], mode_before, label_last: bool = False) -> tuple[list[str], int]:
        """The text lines (with line endings) that replace ``block``, and the motion mode after them."""
        fields = block.fields
        style = Style._of_canonical(block) if fields is not None else Style.of(block)
        eob = ";" if style.eob else ""
        eob_col = block.detail.eob_col if fields is None else None
        tail = eob if eob_col is None else block.text[eob_col:]  # "; (COOLANT OFF);" as it was written
        eol = block.eol
        between = eol or "\n"
        separator = style.separator
        last = len(cuts) - 1
        lines = []
        mode = mode_before
        for index, cut in enumerate(cuts):
            wanted = G.G00 if cut.rapid else (G.G01 if cut.xc is None else (G.G02 if cut.cw else G.G03))  # motion_of
            if index == 0:
                parts = (self._first_canonical_words(block, style, wanted, mode, cut, label_last) if fields is not None
                         else self._first_words(block, style, wanted, mode, cut, label_last))
            else:
                parts = self.geometry_words(cut, style)
                if wanted != mode:
                    parts.insert(0, self.code(wanted, style))
            if index == last:
                if label_last and block.label is not None:
                    parts.insert(0, _label(block))
                lines.append(separator.join(parts) + (tail if index == 0 else eob) + eol)
            else:
                lines.append(separator.join(parts) + (tail if index == 0 else eob) + between)
            mode = wanted
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
        fields = block.fields
        label, g, feed = fields[0], fields[1], fields[7]
        parts = [] if label is None or label_last else ["N" + label]
        code = []
        if g is not None:
            parts.append(self.code(wanted, style))
        elif wanted != mode:
            code.append(self.code(wanted, style))
        if fields[2:7] != _NO_GEOMETRY:
            parts += code
            parts += self.geometry_words(cut, style)
            if feed is not None:
                parts.append("F" + feed)
        else:  # nothing to swap: the geometry goes after the other words, as in _first_words
            if feed is not None:
                parts.append("F" + feed)
            parts += code
            parts += self.geometry_words(cut, style)
        text = block.text
        at = text.find("(")
        if at != -1:
            parts.append(text[at : text.index(")", at) + 1])
        return parts


@lru_cache(maxsize=64)
def writer_for(grid: Grid, system: str, absolute: bool = True, axes: str = "XZ") -> Writer:
    """The writer for a grid, G-code system, distance mode and axes, made once: a run writes
    tens of thousands of blocks with one or two."""
    return Writer(grid, system, absolute, axes)


_NO_GEOMETRY = (None,) * 5  #: a canonical block's X Z I K R, none written


_UPPER, _LOWER = tuple("XZIK"), tuple("xzik")


def _spelled(text: str, trim: bool, leading_zero: bool) -> str:
    """A number formatted with its decimals (``"%.3f"``), spelled in a style: no minus on a zero,
    trailing zeros trimmed (``114.3``, ``0.``), the zero before the point dropped (``.5``)."""
    if text[0] == "-" and float(text) == 0.0:
        text = text[1:]
    if trim:
        text = text.rstrip("0")
    if not leading_zero:  # digits follow the point: "0." keeps its zero, the point alone being no number
        if text[:2] == "0." and len(text) > 2:
            text = text[1:]
        elif text[:3] == "-0." and len(text) > 3:
            text = "-" + text[2:]
    return text


def _word_text(value: float, decimals: int, trim: bool, leading_zero: bool) -> str:
    """``Style.number(rounded(value, decimals) + 0.0, decimals)``, what a length word is written as,
    by one format: the rounded text T formats back to itself. Where the doubles are finer than the
    last decimal, the double nearest T is within half of one of them of T; where they are coarser,
    ``value`` itself is the double nearest T (T is within half a decimal of it)."""
    text = "%.*f" % (decimals, value)
    if text[0] == "-" or not leading_zero:
        return _spelled(text, trim, leading_zero)
    return text.rstrip("0") if trim else text  # :func:`_spelled` of a number without a minus, kept inline


@lru_cache(maxsize=256)
def _code(system: str, mode: int, lower: bool, two_digit_g: bool) -> str:
    """The G word that commands a motion mode, in a style (its case and G digits): a replacement
    writes a few over and over."""
    return Style(lower, two_digit_g=two_digit_g).g(G.motion_code(system, mode))


@lru_cache(maxsize=64)
def _style(joined: bool, two_digit_g: bool, trim: bool, leading_zero: bool, eob: bool) -> Style:
    """One style object per combination: most programs are written in one or two."""
    return Style(False, "" if joined else " ", two_digit_g, trim, leading_zero, eob)


def _canonical_words(text: str, fields: tuple) -> str:
    """The words of a canonical line: the text between its label and its comment or ``;``."""
    start = 0 if fields[0] is None else 1 + len(fields[0])
    end = text.find("(", start)
    if end == -1:
        end = len(text)
    at = text.find(";", start, end)
    return text[start:end if at == -1 else at].strip()


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
