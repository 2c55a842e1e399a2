"""Lines to blocks: the fast path where it serves, the grammar everywhere else.

The reader streams: it holds one line at a time. It knows the tape structure of a
program: a leading ``%``, the blocks, and the closing ``%`` after which the control
reads nothing (that text is kept, as trailer, and never parsed).
"""

from __future__ import annotations

from typing import Iterable, Iterator

from .blocks import BLANK, BLOCK, TAPE, TRAILER, Block
from .diagnostics import Location, Reporter
from .fastpath import canonical_block, canonical_fields, read_ordinary


def read_blocks(lines: Iterable[str], file: str, reporter: Reporter | None = None, *,
                light: bool = False) -> Iterator[Block | tuple]:
    """Blocks of a program given as lines, each with its ending; raises ProgramSyntaxError.

    With ``light``, a canonical line comes as the tuple ``(line, text, eol, fields)`` rather
    than a block (:func:`~postproc.fastpath.canonical_block` makes it one): for a consumer that
    seldom needs the block, such as the interpreter's tally.
    """
    started = ended = False
    for line, raw in enumerate(lines, 1):
        text = raw.rstrip("\r\n")  # one ending per line: LF, CRLF or a lone CR
        eol = raw[len(text):]
        if ended:
            if text.strip() and reporter is not None and ended is True:
                reporter.warn("text after the closing '%' is never read by the control", Location(file, line, 1, text))
                ended = "warned"
            yield Block(line, text, eol, TRAILER)
            continue
        if text:
            match = canonical_fields(text)
            if match is not None:  # read_ordinary's first case, written out: most lines are canonical
                started = True
                yield (line, text, eol, match.groups()) if light else canonical_block(line, text, eol, match.groups())
                continue
        block = read_ordinary(text, line, eol)
        if block is None:
            from .syntax import parse_block  # the grammar, built on the first unusual line

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
