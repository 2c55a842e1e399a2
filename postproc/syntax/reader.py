"""Lines to blocks: the fast path where it serves, the grammar everywhere else.

The reader streams: it holds one line at a time. It knows the tape structure of a
program: a leading ``%``, the blocks, and the closing ``%`` after which the control
reads nothing (that text is kept, as trailer, and never parsed).

Label skip: after ``%`` the control ignores everything up to the first end of block, so
``%O1200(TOKARKA)`` is a tape mark whose label the control never reads (FANUC: always;
``label_skip = false`` in the machine profile for a control that reads on after ``%``).
Text after a closing ``%`` on its line is never read either. Such text is kept as it is
and never parsed.
"""

from __future__ import annotations

import re
from typing import Iterable, Iterator

from .blocks import BLANK, BLOCK, NO_DETAIL, TAPE, TRAILER, Block
from ..diagnostics import Location, Reporter
from .fastpath import CanonicalLine, canonical_block, canonical_line, read_ordinary

#: What may stand before a tape mark: spaces, and the byte order mark a Windows editor writes
#: at the start of a file (the control reads nothing before the opening %).
_LEADER = " \t\ufeff"
_UNREAD = re.compile(r"[ \t;]*(?:\([^()\r\n]*\)[ \t;]*)*")  # nothing but spaces, ';' and simple comments
_PROGRAM = re.compile(r"[ \t]*([Oo][ \t]*[0-9]+|<[^<>\r\n]*>)")


def read_blocks(lines: Iterable[str], file: str, reporter: Reporter | None = None, *,
                light: bool = False, label_skip: bool = True) -> Iterator[Block | CanonicalLine]:
    """Blocks of a program given as lines, each with its ending; raises ProgramSyntaxError.

    With ``light``, a canonical line comes as a :class:`~postproc.syntax.fastpath.CanonicalLine`
    rather than a block (its ``block()`` makes it one): for a consumer that seldom needs the
    block, such as the interpreter's tally. ``label_skip``: what follows the
    opening ``%`` on its line is skipped, as the control skips it (the machine profile's key).
    """
    started = ended = False
    for line, raw in enumerate(lines, 1):
        if not ended:
            match = canonical_line(raw)
            if match is not None:  # read_ordinary's first case, written out: most lines are canonical
                started = True
                if light:  # the line's ending is cut off only if the block is made
                    yield CanonicalLine((line, raw, match.groups()))
                else:
                    text = raw.rstrip("\r\n")
                    yield canonical_block(line, text, raw[len(text):], match.groups())
                continue
        text = raw.rstrip("\r\n")  # one ending per line: LF, CRLF or a lone CR
        eol = raw[len(text):]
        if ended:
            if text.strip() and reporter is not None and ended is True:
                reporter.warn("text after the closing '%' is never read by the control", Location(file, line, 1, text))
                ended = "warned"
            yield Block(line, text, eol, TRAILER, detail=NO_DETAIL)
            continue
        block = read_ordinary(text, line, eol)
        if block is None:
            percent = text.find("%")
            if percent != -1 and not text[:percent].strip(_LEADER):  # a tape mark with more on its line
                block = _tape_mark(text, line, eol, file, reporter, percent, started, label_skip)
            else:
                from .grammar import parse_block  # the grammar, built on the first unusual line

                block = parse_block(text, line, eol, file)
                if reporter is not None:
                    _note_spaced_numbers(block, file, reporter)
        kind = block.kind
        if kind is BLOCK:
            started = True
        elif kind == TAPE:
            if started:
                ended = True
            started = True
        elif kind != BLANK:
            started = True
        yield block


def _tape_mark(text: str, line: int, eol: str, file: str, reporter: Reporter | None, percent: int,
               started: bool, label_skip: bool) -> Block:
    """A ``%`` line with more on it: the rest is a label the control skips (after the opening
    ``%``), text it never reads (after the closing one), or, on a control without label skip,
    the program's first block (never rewritten: nothing is known of where the tool stands
    before it)."""
    rest = text[percent + 1 :]
    if not started and not label_skip:
        from .grammar import parse_block

        block = parse_block(" " * (percent + 1) + rest, line, eol, file)  # the same columns
        block.text = text
        return block
    if reporter is not None and not _UNREAD.fullmatch(rest):
        col = percent + 2 + len(rest) - len(rest.lstrip(" \t"))
        where = Location(file, line, col, text)
        if started:
            reporter.warn("text after the closing '%' is never read by the control", where)
        else:
            program = _PROGRAM.match(rest)
            seen = f"{program.group(1).strip()} is not seen by the control" if program else "it is never run"
            reporter.warn(f"the control skips what follows '%' up to the end of the line (label skip): {seen}; "
                          "the program takes the number it is given when it is read in", where)
    return Block(line, text, eol, TAPE, detail=NO_DETAIL)


def _note_spaced_numbers(block: Block, file: str, reporter: Reporter) -> None:
    """FANUC ignores spaces, even inside a number: say so where it changes what one reads."""
    for word in block.words:
        if word.is_number:
            address_end = next(i for i, char in enumerate(word.text) if char.isalpha()) + 1
            spelled = word.text[address_end:].strip()
            if " " in spelled or "\t" in spelled:
                reporter.warn(
                    f"space inside a number: {word.text!r} is read as {word.letter}{word.value}",
                    Location(file, block.line, word.col + 1, block.text),
                )
