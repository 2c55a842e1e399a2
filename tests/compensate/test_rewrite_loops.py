"""Loops the interpreter does not follow (GOTO n, GOTO #v, M99 Pn in a main program, WHILE/DO):
the compensated program, run as the control runs it, cuts every pass where the original does.

The block a jump arrives at may be reached with another position and other modal values than
the block written before it leaves: an incremental move there is never turned into an absolute
one computed from the first pass."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import example, given, settings
from hypothesis import strategies as st

from support import SAMPLES
from support.control import executed
from support.interpret import moves
from postproc.diagnostics import Reporter
from postproc.compensate.request import Request
from postproc.compensate.rewrite import Rewriter
from postproc.interpret.program import interpret_source
from postproc.machine.profile import DEFAULT
from postproc.syntax.source import Source

CCW, CW = str(SAMPLES / "ballbar/v40r-100-ccw.csv"), str(SAMPLES / "ballbar/v40r-100-cw.csv")

# Three roughing passes, each 4 mm (diameter) deeper than the last, by incremental moves.
ROUGHING = """%
O7500 (ROUGH 3 PASSES, M99 P LOOP)
G18 G21 G40 G99
T0101
G96 S200 M03
G00 X100. Z2.
#1=0
N100 G00 U-4.
G01 W-52. F0.1
G01 U2.
G00 W52.
G00 U-2.
#1=#1+1
IF[#1GE3]GOTO200
M99 P100
N200 G00 X150. Z50.
M30
%
"""

LOOPS = {  # how the loop is closed: (the line that opens it, the lines that close it)
    "if-goto": ("N100", "#1=#1+1\nIF[#1LT{n}]GOTO100"),
    "goto": ("N100", "#1=#1+1\nIF[#1GE{n}]GOTO200\nGOTO100"),
    "computed goto": ("N100", "#1=#1+1\nIF[#1GE{n}]GOTO200\nGOTO#2"),
    "m99 p": ("N100", "#1=#1+1\nIF[#1GE{n}]GOTO200\nM99 P100"),
    "computed m99 p": ("N100", "#1=#1+1\nIF[#1GE{n}]GOTO200\nM99 P#2"),
    "p m99": ("N100", "#1=#1+1\nIF[#1GE{n}]GOTO200\nP100 M99"),  # the words in the other order
    "while": ("WHILE[#1LT{n}]DO1", "#1=#1+1\nEND1"),
}


def _outwards(pieces):
    """Every feed move 4 um outwards in X: a correction on every line of the profile."""
    return [np.tile([0.004, 0.0], (len(piece.t), 1)) for piece in pieces]


def _compensated(text: str) -> str:
    with Source.from_text(text, "loop.nc") as source:
        rewriter = Rewriter(interpret_source(source), _outwards, DEFAULT, Request(), Reporter(), "loop.nc")
        return "".join(rewriter.run())


def _ends(text: str) -> list[tuple[float, float]]:
    return [(m.x1, m.z1) for m in moves(executed(text))]


def assert_cuts_where(original: str, compensated: str, tolerance: float = 0.02) -> None:
    """Each end point of the original, as run, is met in order by the compensated run, and the
    compensated run goes nowhere the original does not (within ``tolerance`` mm)."""
    want, got = _ends(original), _ends(compensated)
    found = iter(got)
    for x, z in want:
        assert any(math.dist((x, z), end) <= tolerance for end in found), f"no pass reaches {(x, z)}"
    for end in got:
        assert min(math.dist(end, place) for place in want) <= tolerance, f"{end} is cut nowhere in the original"


def _program(loop: str, passes: int, depth: float, length: float, label_alone: bool) -> str:
    opening, closing = (part.format(n=passes) for part in LOOPS[loop])
    body = f"G00 U-{2 * depth:.3f}\nG01 W-{length:.3f} F0.1\nG01 U{depth:.3f}\nG00 W{length:.3f}\nG00 U-{depth:.3f}"
    head = f"{opening}\n{body}" if label_alone or not opening.startswith("N") else f"{opening} {body}"
    return ("%\nO7600\nG18 G21 G40 G99\nT0101\nG96 S200 M03\nG00 X100. Z2.\nG01 Z0. F0.1\nG00 X100. Z2.\n"
            f"#1=0\n#2=100\n{head}\n{closing}\nN200 G00 X150. Z50.\nM30\n%\n")


@settings(max_examples=60, deadline=None)
@given(st.sampled_from(sorted(LOOPS)), st.integers(2, 5), st.floats(0.5, 4.0), st.floats(5.0, 60.0), st.booleans())
@example("p m99", 3, 2.0, 50.0, False)
def test_every_kind_of_loop_is_cut_pass_by_pass_where_the_original_cuts(loop, passes, depth, length, label_alone):
    original = _program(loop, passes, depth, length, label_alone)
    assert_cuts_where(original, _compensated(original))


def test_the_loop_runs_as_many_passes_as_the_control_runs():
    ends = _ends(_program("m99 p", 3, 2.0, 50.0, False))
    # radius: each pass cuts 2 mm deeper, then backs off 1 mm
    assert [x for x, z in ends if z == -48.0] == [48.0, 49.0, 46.0, 47.0, 44.0, 45.0]


def test_a_roughing_loop_closed_by_m99_p_keeps_its_incremental_moves(run, tmp_path):
    program = tmp_path / "rough.nc"
    program.write_text(ROUGHING)
    model = tmp_path / "model.json"
    assert run("fit", "--plugin", "parametric", "--ballbar", CCW, "--ballbar", CW, "--option", "extrapolate=true",
               "-o", str(model)).exit_code == 0
    target = tmp_path / "out.nc"
    result = run("compensate", str(program), "--model", str(model), "-o", str(target))
    assert result.exit_code == 0, result.stderr
    written = target.read_text()
    assert "N100 G00 U-4.\nG01 W-52. F0.1\nG01 U2.\nG00 W52.\nG00 U-2.\n" in written
    assert_cuts_where(ROUGHING, written)
    assert run("check", str(target)).exit_code == 0
