"""One program from source to interpreted steps: reader and interpreter wired together."""

from __future__ import annotations

from typing import Iterator

from .diagnostics import InterpretationError, Reporter
from .interpreter import Interpreter
from .motion import Step
from .profile import DEFAULT, MachineProfile
from .reader import read_blocks
from .source import Source


def interpret_source(source: Source, profile: MachineProfile = DEFAULT, reporter: Reporter | None = None) -> Iterator[Step]:
    """The steps of a program, streamed; raises ProgramError on the first mistake."""
    reporter = reporter if reporter is not None else Reporter()

    def reread(first: int, last: int):
        for block in read_blocks(source.lines(), source.name):
            if block.line > last:
                return
            if block.line >= first:
                yield block

    interpreter = Interpreter(profile, reporter, source.name, labels=lambda: source.labels, reread=reread)
    blocks = read_blocks(source.lines(), source.name, reporter)
    try:
        yield from interpreter.run(blocks)
    except InterpretationError:
        # A block the control cannot even read is the more basic mistake: a program is
        # refused for its syntax first, wherever that lies.
        for _ in blocks:
            pass
        raise
