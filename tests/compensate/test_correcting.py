"""Correcting: a batch's moves split into pieces and corrected in one call, held to the route
that takes each move alone (its own arc, turns, pieces and travel, each target sampled by itself)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from postproc.compensate.compensator import Piece
from postproc.compensate.correcting import _merge_continuous, _part, _turns, _unseen_turns, pieces, sample_arcs, sample_lines, travel_after
from postproc.compensate.edits import Entry
from postproc.compensate.request import Request
from postproc.compensate.rewrite import Rewriter
from postproc.compensate.segmenter import Target, sample_params
from postproc.diagnostics import Reporter
from postproc.geometry import Arc, Line
from postproc.interpret.motion import LINE, Move
from postproc.interpret.program import interpret_source
from postproc.machine.profile import DEFAULT
from postproc.syntax.source import Source

radii = st.floats(0.01, 500.0)
angles = st.floats(-7.0, 7.0)


@given(st.floats(-100, 100), st.floats(-100, 100), radii, angles, st.floats(-6.3, 6.3),
       st.one_of(st.none(), radii), st.floats(0.0, 1.0), st.floats(0.0, 1.0))
def test_an_arcs_part_worked_out_with_floats_is_arc_part_to_the_last_bit(xc, zc, r, theta0, sweep, r1, a, b):
    arc = Arc(xc, zc, r, theta0, sweep, r1)
    assert _part(arc, a, b) == arc.part(a, b)
    assert arc.r + a * (arc.end_radius - arc.r) == float(arc.radius_at(a))  # the radii _turns works out


def _program(moves) -> str:
    """A diameter program of lines and I/K arcs, written to the micrometre: its arcs' end radii
    drift from their start radii as a CAM post's do."""
    x, z = 40.0, 0.0
    lines = ["G18 G21 G40 G99", "T0101", f"G00 X{2 * x:.3f} Z{z:.3f}", "G01 F0.1"]
    for kind, dx, dz, turn in moves:
        if kind == "line":
            x, z = max(x + dx, 1.0), z + dz
            lines.append(f"G01 X{2 * x:.3f} Z{z:.3f}")
            continue
        xc, zc = x + dx, z + dz
        r = math.hypot(x - xc, z - zc)
        theta = math.atan2(z - zc, x - xc) + turn
        ex, ez = xc + r * math.cos(theta), zc + r * math.sin(theta)
        if ex < 1.0 or math.hypot(ex - x, ez - z) < 0.01:
            continue
        lines.append(f"{'G02' if turn > 0 else 'G03'} X{2 * ex:.3f} Z{ez:.3f} I{xc - x:.4f} K{zc - z:.4f}")
        x, z = ex, ez
    return "\n".join(["%", "O1000", *lines, "M30", "%"]) + "\n"


def _bulge(parts):
    """A correction that depends on the point and the piece's directions (as a backlash's does)."""
    return [None if piece.move.line % 7 == 0 else
            np.column_stack([1e-3 * np.sin(piece.points[:, 1]) + 2e-4 * piece.x_direction,
                             1e-3 * np.cos(piece.points[:, 0]) - 2e-4 * piece.z_direction]) for piece in parts]


def _everywhere(parts):
    """A correction of every piece, none of them still: as a model of the machine corrects."""
    return [np.column_stack([1e-3 * np.sin(piece.points[:, 1]) + 2e-4 * piece.x_direction,
                             1e-3 * np.cos(piece.points[:, 0]) - 2e-4 * piece.z_direction]) for piece in parts]


def _still(parts):
    """Corrections of nothing but zeros (a move asked and left where it is) and of None."""
    return [None if piece.move.line % 2 else np.zeros((len(piece.t), 2)) for piece in parts]


move = st.tuples(st.sampled_from(["line", "arc"]), st.floats(-20, 20), st.floats(-20, 20),
                 st.floats(-3.0, 3.0).filter(lambda turn: abs(turn) > 0.01))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(move, min_size=1, max_size=25), st.sampled_from([_bulge, _everywhere, _still]))
def test_a_batch_gives_every_move_the_pieces_and_targets_it_gets_alone(moves, corrector):
    with Source.from_text(_program(moves), "t.nc") as source:
        steps = list(interpret_source(source))
    rewriter = Rewriter(iter(()), corrector, DEFAULT, Request(tolerance=0.001), Reporter(), "t.nc")
    batch = [Entry(step) for step in steps]
    rewriter._correct(batch)
    last = (0, 0)
    grid = DEFAULT.grid(False)
    steps_mm = (grid.x_step, grid.z_step)
    for entry in batch:
        for index, one in enumerate(entry.step.moves):
            edit = entry.edits[index] if entry.edits else None
            if one.kind in ("line", "arc") and (one.kind == "arc" or (one.x0, one.z0) != (one.x1, one.z1)):
                parts = pieces(one, last, steps_mm)  # the move alone: its own arc and turns
                shifts = corrector(parts)
                if all(shift is None or not shift.any() for shift in shifts):
                    assert edit is None
                else:
                    alone = [Target.along(piece.segment, piece.t, np.zeros((len(piece.t), 2)) if shift is None
                                          else shift, piece.points) for piece, shift in zip(parts, shifts)]
                    alone = _merge_continuous(alone, 0.0001) if len(alone) > 1 else alone
                    assert edit is not None and len(edit.targets) == len(alone)
                    for mine, theirs in zip(edit.targets, alone):
                        assert mine.nominal == theirs.nominal
                        assert np.array_equal(mine.t, theirs.t) and np.array_equal(mine.d, theirs.d)
                        assert np.array_equal(mine.points, theirs.points)
                        assert mine.bend == theirs.bend
            last = travel_after(one, last, steps_mm)
    assert rewriter._last_travel == last


coordinate = st.floats(-500.0, 500.0)
segments = st.one_of(st.builds(Line, coordinate, coordinate, coordinate, coordinate),
                     st.builds(Arc, coordinate, coordinate, radii, angles, st.floats(-6.3, 6.3),
                               st.one_of(st.none(), radii)))


@given(st.lists(segments, min_size=1, max_size=30))
def test_pieces_sampled_together_are_sampled_as_each_alone(chosen):
    """Lines of every direction, arcs either way of any sweep, spirals: the points of a batch,
    worked out in one array pass, are each piece's ``point_at`` to the last bit."""
    move = Move(LINE, 1, 0.0, 0.0, 1.0, 1.0)
    parts = [Piece(move, segment, sample_params(segment), 1, -1) for segment in chosen]
    sample_lines(parts)
    sample_arcs(parts)
    for piece in parts:
        assert np.array_equal(piece.points, piece.segment.point_at(piece.t))
        assert not piece.points.flags.writeable


quarter = st.integers(-4, 4).map(lambda k: k * math.pi / 2)
starts = st.one_of(angles, quarter, st.tuples(quarter, st.floats(-1e-6, 1e-6)).map(sum))
drifts = st.one_of(st.just(0.0), st.floats(-1e-3, 1e-3), st.floats(-1.0, 1.0))
turning_arcs = st.builds(lambda xc, zc, r, theta0, sweep, drift: Arc(xc, zc, r, theta0, sweep,
                                                                     None if drift == 0.0 else r + drift),
                         st.floats(-100, 100), st.floats(-100, 100), st.floats(0.01, 200.0), starts,
                         st.one_of(st.floats(-6.3, 6.3), st.floats(-0.05, 0.05)), drifts)
grids = st.sampled_from([(0.0005, 0.001), (0.00127, 0.00254), (0.005, 0.01)])


@settings(max_examples=300)
@given(st.lists(turning_arcs, min_size=1, max_size=20), grids)
def test_an_arc_said_to_have_no_turn_the_grid_sees_has_none(arcs, steps):
    """Arcs starting on an axis or beside one, either way, spirals drifting by a rounding or by
    a millimetre: the arcs whose turns are left unworked are arcs :func:`_turns` gives none."""
    unseen = _unseen_turns(arcs, np.array([steps] * len(arcs)))
    for arc, none in zip(arcs, unseen.tolist()):
        if none:
            assert _turns(arc, steps) == []


def test_a_cam_posts_arcs_starting_on_an_axis_have_their_turns_left_unworked():
    """An I/K arc from a point on the axis through its centre, its end rounded to the
    micrometre: a reversal picometres past its start that no grid sees."""
    text = _program([("arc", -20.0, 0.0, 0.2), ("line", 0.0, -1.0, 0.0), ("arc", 15.0, 0.0, -0.3)])
    with Source.from_text(text, "t.nc") as source:
        arcs = [Arc.through((m.x0, m.z0), (m.x1, m.z1), (m.xc, m.zc), bool(m.cw))
                for step in interpret_source(source) for m in step.moves if m.kind == "arc"]
    assert len(arcs) == 2 and all(arc.r1 is not None and arc.reversal_params() for arc in arcs)
    assert _unseen_turns(arcs, np.array([(0.0005, 0.001)] * 2)).all()
