"""``postproc path``: the interpreted tool path as CSV (docs/formats.md §10).

One row per motion in radius millimetres of the active work coordinate system, six
decimals; centre and direction only for arcs; an unknown coordinate is an empty cell.
Contour blocks of G71/G72/G73 have no rows where they stand (the control does not run
them there); G70 lists them, with their own line numbers, where it runs them.
"""

from __future__ import annotations

from typing import Iterable, Iterator

from ..interpret.motion import CONTOUR, Move, Step

HEADER = "line,kind,x_start,z_start,x_end,z_end,x_center,z_center,direction"


def _cell(value: float | None) -> str:
    return "" if value is None else f"{round(value, 6) + 0.0:.6f}"


def row(move: Move) -> str:
    return ",".join(
        (
            str(move.line),
            move.kind,
            _cell(move.x0),
            _cell(move.z0),
            _cell(move.x1),
            _cell(move.z1),
            _cell(move.xc),
            _cell(move.zc),
            move.direction or "",
        )
    )


def path_rows(steps: Iterable[Step]) -> Iterator[str]:
    yield HEADER
    for step in steps:
        for move in step.moves:
            if move.role != CONTOUR:
                yield row(move)
