"""One program from source to interpreted steps: reader and interpreter wired together."""

from __future__ import annotations

from typing import Callable, Iterator

from ..syntax.blocks import BLOCK
from ..diagnostics import InterpretationError, Location, Reporter
from .interpreter import Interpreter
from .motion import Step
from ..machine.profile import DEFAULT, MachineProfile
from ..syntax.reader import read_blocks
from ..syntax.source import Source


def interpret_source(source: Source, profile: MachineProfile = DEFAULT, reporter: Reporter | None = None, *,
                     rewriting: bool = False) -> Iterator[Step]:
    """The steps of a program, streamed; raises ProgramError on the first mistake. ``rewriting``:
    the steps are to be compensated, so what the profile leaves open and the program needs
    (calculator-type input) is refused rather than warned of."""
    reporter = reporter if reporter is not None else Reporter()
    interpreter, blocks = _prepare(source, profile, reporter, rewriting=rewriting)
    moved = False
    try:
        for step in interpreter.run(blocks):
            if not moved and step.moves:
                moved = True
            yield step
    except InterpretationError:
        _syntax_first(blocks)
        raise
    if not moved:
        _note_empty(source, profile, reporter)


def tally_source(source: Source, profile: MachineProfile = DEFAULT, reporter: Reporter | None = None,
                 contours: Callable[[Step], None] | None = None) -> tuple[int, int]:
    """Interpret a whole program for its diagnostics: (blocks, moves). Raises like
    :func:`interpret_source`, keeps no step; ``contours`` sees the steps of cycle contours."""
    reporter = reporter if reporter is not None else Reporter()
    interpreter, blocks = _prepare(source, profile, reporter, light=True)
    try:
        count, moves = interpreter.tally(blocks, contours)
    except InterpretationError:
        _syntax_first(blocks)
        raise
    if not moves:
        _note_empty(source, profile, reporter)
    return count, moves


def _note_empty(source: Source, profile: MachineProfile, reporter: Reporter) -> None:
    """A program with no block that commands anything (empty, or only tape marks, program
    numbers, comments and blank lines) is read as it is, with a warning: in a post-processing
    chain an empty input most often means that a step before it failed. Looked for only in a
    program without moves, so it costs nothing on the way of any other."""
    for block in read_blocks(source.lines(), source.name, label_skip=profile.label_skip):
        if block.kind == BLOCK and (block.codes or block.statement is not None):
            return
    reporter.warn("the program has no blocks: nothing in it commands the control (empty, or only tape marks, "
                  "program numbers, comments and blank lines); did the step that wrote it fail?", Location(source.name))


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
                              refuse_ambiguous_units=rewriting, rewriting=rewriting)
    return interpreter, read_blocks(source.lines(), source.name, reporter, light=light, label_skip=profile.label_skip)


def _syntax_first(blocks: Iterator) -> None:
    """A block the control cannot even read is the more basic mistake: a program is
    refused for its syntax first, wherever that lies (reading the rest raises it)."""
    for _ in blocks:
        pass
