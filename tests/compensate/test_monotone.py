"""The one-way rule of G71/G72 contours (postproc.compensate.monotone) and the rewriter holding
compensated contours to it: generated contours come out running one way as the control checks
them (support.cycles, written apart from the rewriter), or are refused with one clear message."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from support import SAMPLES
from support.cycles import contour_case, cycle_types, turn_backs
from support.interpret import steps
from postproc.compensate import monotone
from postproc.compensate.contours import WrittenContours
from postproc.compensate.request import Request
from postproc.compensate.rewrite import Rewriter
from postproc.compensate.segmenter import Cut
from postproc.diagnostics import PostprocError, Reporter, SafetyError
from postproc.interpret import gcodes as G
from postproc.interpret.motion import CONTOUR, REPLAY
from postproc.interpret.program import interpret_source, tally_source
from postproc.machine.profile import DEFAULT
from postproc.syntax.source import Source

HEMISHELL_G71 = (SAMPLES / "programs" / "hemishell_g71.nc").read_text()


def rewrite(text: str, correct, diameter_x: bool = True, **options) -> tuple[str, Rewriter, Reporter]:
    reporter = Reporter()
    with Source.from_text(text, "t.nc") as source:
        profile = dataclasses.replace(DEFAULT, diameter_x=diameter_x)
        rewriter = Rewriter(interpret_source(source, profile), lambda pieces: [correct(p) for p in pieces],
                            profile, Request(**options), reporter, "t.nc")
        return "".join(rewriter.run()), rewriter, reporter


@pytest.mark.parametrize("cycle, letters, axes, carries, name", [
    (G.ROUGH_TURN, {"G", "X"}, (0, 1), "X", "G71 type I"),
    (G.ROUGH_TURN, {"G", "U"}, (0, 1), "X", "G71 type I"),
    (G.ROUGH_TURN, {"G", "X", "Z"}, (1,), "XZ", "G71 type II"),
    (G.ROUGH_TURN, {"G", "U", "W"}, (1,), "XZ", "G71 type II"),
    (G.ROUGH_FACE, {"G", "Z"}, (0, 1), "Z", "G72 type I"),
    (G.ROUGH_FACE, {"G", "X", "Z"}, (0,), "XZ", "G72 type II"),
])
def test_the_rule_follows_the_cycle_and_its_approach(cycle, letters, axes, carries, name):
    assert monotone.rule(cycle, letters) == (axes, carries, name)


def test_an_arc_runs_back_where_it_passes_an_apex():
    quarter = Cut(0.0, 10.0, 10.0, 0.0, 0.0, 0.0, False)  # from the pole to the equator: one way in both
    assert monotone.direction([quarter], 0) == 1 and monotone.direction([quarter], 1) == -1
    half = Cut(0.0, 10.0, 0.0, -10.0, 0.0, 0.0, False)  # on past the equator: X turns back
    assert monotone.direction([half], 0) is None and monotone.direction([half], 1) == -1
    assert monotone.first_turn(0.0, [half], 0, 1) == (0, 10.0, 0.0)


def test_held_values_are_met_halfway_and_keep_to_the_fixed_ones():
    values = np.array([1.0, 0.5, 2.0, 1.5, 3.0])
    free = np.zeros(5, dtype=bool)
    assert monotone.held(values, 1, free).tolist() == [0.75, 0.75, 1.75, 1.75, 3.0]  # 0.25 off at most
    assert monotone.held(-values, -1, free).tolist() == [-0.75, -0.75, -1.75, -1.75, -3.0]
    assert monotone.held(np.array([0.0, 1.0, 2.0]), 1, np.zeros(3, dtype=bool)).tolist() == [0.0, 1.0, 2.0]
    bounded = np.array([1.2, 1.0, 0.5, 2.0, 1.5, 3.0, 2.5])  # the first (where the approach ends) and last fixed
    fixed = np.array([True, False, False, False, False, False, True])
    assert monotone.held(bounded, 1, fixed).tolist() == [1.2, 1.2, 1.2, 1.75, 1.75, 2.5, 2.5]


def test_the_hemishell_cycle_is_written_with_its_approach_moved_in_x_only():
    """Lifted by 5 um, the G01 to the pole N10 leads to would start above the Z the approach ends
    at (Z turning back); moved in -X by 3 um, so would X. The approach now ends at the new X
    (X only: the cycle stays type I), the lift is held along the line's own path, and the G70
    finishing pass replays the contour as written."""

    def shift(piece):
        return np.tile([-0.0015, 0.005], (len(piece.t), 1))

    out, rewriter, reporter = rewrite(HEMISHELL_G71, shift, tolerance=0.001)
    lines = out.splitlines()
    assert "N10 G00 X-0.003" in lines  # the approach: X only
    assert turn_backs(out) == [] and rewriter.held == [] and not reporter.warnings
    assert cycle_types(out) == ["G71 type I"]
    assert replayed(out)


def replayed(text: str, **profile) -> bool:
    """Whether the G70 after the cycle runs the contour as written (from the same start point)."""
    program = steps(text, **profile)
    contour = [(m.kind, m.x1, m.z1) for s in program for m in s.moves if m.role == CONTOUR]
    replay = [(m.kind, m.x1, m.z1) for s in program for m in s.moves if m.role == REPLAY]
    return bool(contour) and replay[: len(contour)] == contour


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**32 - 1))
def test_a_compensated_cycle_contour_runs_one_way_or_is_refused(seed):
    """Generated G71/G72 contours (type I and II, diameter and radius, either way in each axis,
    lines and arcs, some along an axis or ending tangent to one) under a smooth correction of up
    to 9 um: the program written runs one way as the control checks it, or the run is refused
    with one message naming the block; never a program that turns back."""
    case = contour_case(seed)
    turns = turn_backs(case["text"], diameter_x=case["diameter_x"])
    if turns:  # rounded to the output's decimals, an arc tangent to an axis may pass it: the control alarms as it is
        with pytest.raises(SafetyError) as refused:
            rewrite(case["text"], case["correct"], case["diameter_x"], tolerance=0.001)
        line, axis = turns[0].removeprefix("line ").split(": ")
        assert refused.value.location.line == int(line)
        assert f"as written it turns back in {axis} here" in refused.value.message
        return
    try:
        out, _, _ = rewrite(case["text"], case["correct"], case["diameter_x"], tolerance=0.001)
    except PostprocError as exc:
        assert exc.location is not None and exc.location.line is not None
        assert exc.message and "\n" not in exc.message
        return
    assert turn_backs(out, diameter_x=case["diameter_x"]) == [], (case["cycle"], out)
    assert cycle_types(out, diameter_x=case["diameter_x"]) == [case["cycle"]]
    assert replayed(out, diameter_x=case["diameter_x"])  # the approach still moves the axes it moved: the type stays


# -- a contour that breaks the rule as written: check warns, compensate refuses ---------------------------

@st.composite
def any_contour(draw) -> tuple[str, bool]:
    """A G71 or G72 cycle of type I or II whose contour's lines and arcs run any way in X and Z:
    many break the one-way rule as written. Its program and whether X is a diameter."""
    cycle, kind, diameter = draw(st.sampled_from([71, 72])), draw(st.sampled_from(["I", "II"])), draw(st.booleans())
    scale = 2.0 if diameter else 1.0
    x, z = (100.0 if (cycle, kind) == (72, "I") else 30.0), (50.0 if (cycle, kind) == (71, "I") else 0.0)
    blocks = []
    for _ in range(draw(st.integers(1, 5))):
        dx = draw(st.sampled_from([-1, 0, 1])) * draw(st.integers(1, 8000)) / 1000.0
        dz = draw(st.sampled_from([-1, 0, 1])) * draw(st.integers(1, 8000)) / 1000.0
        if dx == dz == 0.0:
            continue
        x, z = x + dx, z + dz
        radius = ""
        code = "G01"
        if draw(st.booleans()):  # an arc over the chord, from a half circle to a flat one
            code = draw(st.sampled_from(["G02", "G03"]))
            radius = f" R{(dx * dx + dz * dz) ** 0.5 / 2.0 * draw(st.floats(1.01, 3.0)):.3f}"
        blocks.append(f"{code} X{x * scale:.3f} Z{z:.3f}{radius}")
    blocks = blocks or ["G01 Z-5."]
    letter = "X" if cycle == 71 else "Z"
    approach = f"N10 G00 {letter}{30.0 * scale if cycle == 71 else 0.0:.3f}" + (
        "" if kind == "I" else f" {'Z0.' if cycle == 71 else f'X{30.0 * scale:.3f}'}")
    blocks[0] += " F0.1"
    blocks[-1] = "N20 " + blocks[-1]
    lines = ["G18 G21 G99", f"G00 X{100.0 * scale:.3f} Z50.", f"G{cycle} {'U' if cycle == 71 else 'W'}1. R0.5",
             f"G{cycle} P10 Q20 U0.2 W0.1 F0.2", approach, *blocks, "G70 P10 Q20", "G00 X200. Z200.", "M30"]
    return "\n".join(lines) + "\n", diameter


def _checked(text: str, diameter: bool) -> tuple[list, int]:
    """The warnings ``check`` gives a program (its contour steps watched as check watches them),
    and how many steps the watch was given."""
    profile = dataclasses.replace(DEFAULT, diameter_x=diameter)
    reporter = Reporter()
    watch = WrittenContours("t.nc", profile, reporter)
    given: list = []
    with Source.from_text(text, "t.nc") as source:
        tally_source(source, profile, reporter, lambda step: (given.append(step), watch(step)))
    assert all(step.in_contour for step in given)
    return [w for w in reporter.warnings if "as written it turns back" in w.message], len(given)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(any_contour())
def test_a_contour_that_turns_back_as_written_is_warned_of_by_check_and_refused_by_compensate(case):
    """Whatever the contour, ``check`` warns exactly when the control would alarm on it as the
    rule is read apart from the rewriter (support.cycles), naming the block, the axis and the
    alarm; ``compensate`` refuses the same program there, even under no correction at all."""
    text, diameter = case
    turns = turn_backs(text, diameter_x=diameter)
    warnings, watched = _checked(text, diameter)
    assert watched == len([s for s in steps(text, diameter_x=diameter) if s.in_contour])
    if not turns:
        assert warnings == []
        rewrite(text, lambda piece: np.zeros_like(piece.points), diameter, tolerance=0.001)
        return
    line, axis = turns[0].removeprefix("line ").split(": ")
    assert [(w.location.line, f"turns back in {axis} here" in w.message) for w in warnings] == [(int(line), True)]
    assert f"alarm {monotone.ALARMS['XZ'.index(axis)]}; compensate refuses the program" in warnings[0].message
    with pytest.raises(SafetyError) as refused:
        rewrite(text, lambda piece: np.zeros_like(piece.points), diameter, tolerance=0.001)
    assert refused.value.location.line == int(line)
    assert refused.value.message.startswith(warnings[0].message.removesuffix("; compensate refuses the program"))


def test_the_contour_watch_is_given_the_contour_blocks_only():
    """Outside a cycle's P..Q contour the check costs nothing: the watch sees no other step."""
    text = HEMISHELL_G71
    _, watched = _checked(text, True)
    assert watched == 4  # N10 to N20
