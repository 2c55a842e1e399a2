"""One program from source to interpreted steps: reader and interpreter wired together."""

from __future__ import annotations

from typing import Iterator

from .diagnostics import InterpretationError, Reporter
from .interpreter import Interpreter
from .motion import Step
from .profile import DEFAULT, MachineProfile
from .reader import read_blocks
from .source import Source


def interpret_source(source: Source, profile: MachineProfile = DEFAULT, reporter: Reporter | None = None, *,
                     rewriting: bool = False) -> Iterator[Step]:
    """The steps of a program, streamed; raises ProgramError on the first mistake. ``rewriting``:
    the steps are to be compensated, so what the profile leaves open and the program needs
    (calculator-type input) is refused rather than warned of."""
    interpreter, blocks = _prepare(source, profile, reporter, rewriting=rewriting)
    try:
        yield from interpreter.run(blocks)
    except InterpretationError:
        _syntax_first(blocks)
        raise


def tally_source(source: Source, profile: MachineProfile = DEFAULT, reporter: Reporter | None = None) -> tuple[int, int]:
    """Interpret a whole program for its diagnostics: (blocks, moves). Raises like
    :func:`interpret_source`, keeps no step."""
    interpreter, blocks = _prepare(source, profile, reporter, light=True)
    try:
        return interpreter.tally(blocks)
    except InterpretationError:
        _syntax_first(blocks)
        raise


def _prepare(source: Source, profile: MachineProfile, reporter: Reporter | None,
             light: bool = False, rewriting: bool = False) -> tuple[Interpreter, Iterator]:
    reporter = reporter if reporter is not None else Reporter()

    def reread(first: int, last: int):
        for block in read_blocks(source.lines(), source.name, label_skip=profile.label_skip):
            if block.line > last:
                return
            if block.line >= first:
                yield block

    interpreter = Interpreter(profile, reporter, source.name, labels=lambda: source.labels, reread=reread,
                              refuse_ambiguous_units=rewriting)
    return interpreter, read_blocks(source.lines(), source.name, reporter, light=light, label_skip=profile.label_skip)


def _syntax_first(blocks: Iterator) -> None:
    """A block the control cannot even read is the more basic mistake: a program is
    refused for its syntax first, wherever that lies (reading the rest raises it)."""
    for _ in blocks:
        pass
