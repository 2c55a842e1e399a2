"""Test helpers: interpret a program given as text."""

from __future__ import annotations

import dataclasses

from postproc.diagnostics import Reporter
from postproc.interpret.motion import CONTOUR
from postproc.machine.profile import DEFAULT
from postproc.interpret.program import interpret_source
from postproc.syntax.source import Source


def steps(text: str, reporter: Reporter | None = None, **profile):
    """Every step of a program, with its warnings collected in ``reporter``."""
    with Source.from_text(text, "t.nc") as source:
        return list(interpret_source(source, dataclasses.replace(DEFAULT, **profile), reporter or Reporter()))


def moves(text: str, reporter: Reporter | None = None, **profile):
    """The moves ``postproc path`` lists (contour definitions left out)."""
    return [m for s in steps(text, reporter, **profile) for m in s.moves if m.role != CONTOUR]


def geometry(move, digits: int = 6):
    """(kind, line, start, end, centre, direction) rounded, for golden comparisons."""

    def r(value):
        return None if value is None else round(value + 0.0, digits) + 0.0

    return (move.kind, move.line, (r(move.x0), r(move.z0)), (r(move.x1), r(move.z1)),
            None if move.xc is None else (r(move.xc), r(move.zc)), move.direction)
