"""One-block plans of many targets at once: each one the segmenter's own plan, float for float,
or none (the segmenter then plans the target alone); and a program compensated with them is
byte for byte the program compensated without them."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from support import SAMPLES
from postproc.api import Pipeline
from postproc.compensate import planning
from postproc.compensate.models import dumps
from postproc.compensate.segmenter import Limits, Target, plan, sample_params
from postproc.compensate.batch_plans import batch_plans
from postproc.diagnostics import Reporter
from postproc.geometry import Arc, Line
from postproc.machine.profile import DEFAULT
from postproc.machine.resolution import Grid

GRIDS = [Grid(3, False, True), Grid(4, False, True), Grid(3, False, False), Grid(4, True, True), Grid(5, True, False)]


def cam_arc(grid: Grid, x0: float, z0: float, radius: float, start: float, sweep: float, drift: float) -> Arc:
    """An arc as a CAM post writes it: its start on the grid, its centre a grid offset away."""
    x0, z0 = grid.snap(x0, z0)
    xc, zc = grid.snap(x0 - radius * math.cos(start), z0 - radius * math.sin(start))
    xc = x0 + grid.snap_offset(xc - x0)
    zc = z0 + grid.snap_offset(zc - z0)
    r = math.hypot(x0 - xc, z0 - zc)
    theta0 = math.atan2(z0 - zc, x0 - xc)
    return Arc(xc, zc, r, theta0, sweep, None if drift == 0.0 else r + drift)


def displaced(arc: Arc, scale: tuple[float, float], offset: tuple[float, float], wave: float, turns: int) -> Target:
    """What a model of the machine asks along an arc: a displacement that grows with the position
    (scaling), an offset (backlash, a probe's offset) and a wave (a servo's mismatch)."""
    t = sample_params(arc)
    points = arc.point_at(t)
    d = points * np.array(scale) + np.array(offset)
    d += wave * np.sin(turns * math.pi * t)[:, None] * (points - np.array(arc.centre)) / arc.r
    return Target(arc, t, d)


@st.composite
def cam_targets(draw):
    grid = draw(st.sampled_from(GRIDS))
    radius = draw(st.floats(0.2, 300.0))
    sweep = math.radians(draw(st.floats(0.5, 355.0))) * draw(st.sampled_from([1, -1]))
    start = draw(st.sampled_from([0.0, math.pi / 2, math.pi, -math.pi / 2])) + draw(
        st.sampled_from([0.0, 0.0, draw(st.floats(-math.pi, math.pi))]))
    drift = draw(st.sampled_from([0.0, 0.0, draw(st.floats(-0.002, 0.002))]))
    arc = cam_arc(grid, draw(st.floats(0.0, 150.0)), draw(st.floats(-300.0, 10.0)), radius, start, sweep, drift)
    scale = (draw(st.floats(-3e-4, 3e-4)), draw(st.floats(-3e-4, 3e-4)))
    offset = (draw(st.floats(-0.015, 0.015)), draw(st.floats(-0.015, 0.015)))
    target = displaced(arc, scale, offset, draw(st.sampled_from([0.0, draw(st.floats(0.0, 0.01))])), draw(st.integers(1, 4)))
    tolerance = draw(st.sampled_from([0.0005, 0.001, 0.002, 0.005, 0.00508]))  # mm, whatever the grid's units
    radius_tolerance = draw(st.sampled_from([DEFAULT.arc_radius_tolerance, 0.002, 1e-4]))
    largest = draw(st.sampled_from([DEFAULT.max_arc_radius, DEFAULT.max_arc_radius, 300.0, 20.0]))
    return target, Limits(tolerance, grid, radius_tolerance, largest)


def same_plan(found, expected) -> bool:
    """The same cuts (to the bit, signs of zero included) and the same measured deviation."""
    return (expected.method == found.method and repr(found.cuts) == repr(expected.cuts)
            and found.deviation == expected.deviation and not found.widened and len(found.cuts) == 1)


def check(targets: list[Target], limits: list[Limits]) -> int:
    """Each target's plan from the batch is the segmenter's in every mode it is found for (a
    straight line's in every mode, an arc's in AUTO and ARC mode); the count found."""
    found = batch_plans(targets, limits)
    lines_only = batch_plans(targets, limits, arcs=False)
    for target, within, plan_found, line_found in zip(targets, limits, found, lines_only):
        if plan_found is None:
            continue
        straight = type(target.nominal) is Line
        assert (line_found is not None) == straight
        for mode in ("auto", "arc", "line") if straight else ("auto", "arc"):
            assert same_plan(plan_found, plan(target, within, mode))
    return sum(plan_found is not None for plan_found in found)


@st.composite
def line_targets(draw):
    """Lines as a CAM post writes them, moved as a model moves them: straight (a displacement
    linear along the move, the common case) or bent by a wave."""
    grid = draw(st.sampled_from(GRIDS))
    x0, z0 = grid.snap(draw(st.floats(0.0, 150.0)), draw(st.floats(-300.0, 10.0)))
    x1, z1 = grid.snap(x0 + draw(st.floats(-20.0, 20.0)), z0 + draw(st.sampled_from([0.0, draw(st.floats(-50.0, 50.0))])))
    line = Line(x0, z0, x1, z1)
    t = sample_params(line)
    points = line.point_at(t)
    d = points * np.array([draw(st.floats(-3e-4, 3e-4)), draw(st.floats(-3e-4, 3e-4))])
    d += np.array([draw(st.floats(-0.015, 0.015)), draw(st.floats(-0.015, 0.015))])
    d[:, 0] += draw(st.sampled_from([0.0, 0.0, draw(st.floats(0.0, 0.005))])) * np.sin(math.pi * t)
    tolerance = draw(st.sampled_from([0.0005, 0.001, 0.002, 0.005, 0.00508]))
    return Target(line, t, d), Limits(tolerance, grid)


@settings(max_examples=150, deadline=None)
@given(st.lists(st.one_of(cam_targets(), line_targets()), min_size=1, max_size=8))
def test_each_plan_found_together_is_the_segmenter_s_own_bit_for_bit(cases):
    check([target for target, _ in cases], [limits for _, limits in cases])


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(GRIDS), st.lists(st.tuples(st.floats(-2000.0, 2000.0), st.floats(-2000.0, 2000.0)), min_size=1,
                                        max_size=20), st.integers(0, 3))
def test_points_snapped_together_are_the_grid_s_snap_bit_for_bit(grid, points, halves):
    """Halves included: a value whose scaled digits end in exactly one half (ties go to even).
    Each target is a straight line well within a tolerance of 1 mm: every one is planned (unless
    both its ends snap to one grid point), so the test cannot pass by finding nothing."""
    step = grid.step * grid.unit
    points = points + [((k + 0.5) * step / (2.0 if grid.diameter else 1.0), (k - 0.5) * step) for k in range(halves)]
    x, z = np.array(points).T
    line = Line(0.0, 0.0, 1.0, 1.0)
    targets = [Target(line, np.array([0.0, 1.0]), np.array([[a, b], [a + 1.0, b + 1.0]]) - line.point_at(np.array([0.0, 1.0])))
               for a, b in points]
    for target, (a, b), found in zip(targets, points, batch_plans(targets, [Limits(1.0, grid)] * len(targets))):
        if found is None:
            assert grid.snap(a, b) == grid.snap(a + 1.0, b + 1.0), f"({a!r}, {b!r}) was not planned"
            continue
        assert repr(found.cuts[0].start) == repr(grid.snap(a, b))


def test_most_moves_of_a_cam_program_are_planned_together_as_the_segmenter_plans_them():
    """Not a test that passes by finding nothing: of arcs a CAM post writes, moved as a model of a
    machine moves them, most are planned together, and each plan is the segmenter's."""
    rng = np.random.default_rng(7)
    targets, limits = [], []
    for _ in range(300):
        grid = GRIDS[int(rng.integers(len(GRIDS)))]
        arc = cam_arc(grid, rng.uniform(0, 80), rng.uniform(-150, 0), rng.uniform(0.5, 60),
                      rng.choice([0.0, math.pi / 2, math.pi, -math.pi / 2]),
                      math.radians(rng.uniform(10, 180)) * rng.choice([1, -1]), 0.0)
        targets.append(displaced(arc, tuple(rng.uniform(-2e-4, 2e-4, 2)), tuple(rng.uniform(-0.01, 0.01, 2)), 0.0, 1))
        limits.append(Limits(0.001, grid))
        line = Line(*arc.point_at(np.array([1.0]))[0], *grid.snap(rng.uniform(0, 80), rng.uniform(-150, 0)))
        t = sample_params(line)
        targets.append(Target(line, t, line.point_at(t) * 1e-4 + 0.005))
        limits.append(Limits(0.001, grid))
    assert check(targets, limits) >= 500


def test_targets_planned_another_way_are_left_to_the_segmenter():
    """A whole circle, a bent line, a target of two samples and a target that turns back across
    its frame."""
    grid = GRIDS[0]
    circle = Arc(0.0, 0.0, 10.0, 0.3, 2.0 * math.pi)
    line = Line(10.0, 0.0, 12.0, -5.0)
    two = Arc(0.0, 0.0, 5.0, 0.0, 1.0)
    back = Arc(0.0, 0.0, 5.0, 0.0, 1.0)
    t = sample_params(back)
    along = 0.3 * np.sin(3.0 * math.pi * t)[:, None] * np.column_stack([-np.sin(t), np.cos(t)])
    targets = [Target(circle, sample_params(circle), np.zeros((len(sample_params(circle)), 2))),
               Target(line, sample_params(line), 0.01 * np.sin(math.pi * sample_params(line))[:, None] * np.ones((1, 2))),
               Target(two, np.array([0.0, 1.0]), np.zeros((2, 2))), Target(back, t, along)]
    assert batch_plans(targets, [Limits(0.001, grid)] * len(targets)) == [None] * len(targets)
    assert batch_plans([], []) == []


def test_an_arc_beyond_the_profile_s_largest_radius_is_left_to_the_segmenter():
    """An R400 arc on a machine whose largest arc radius is 300 mm: the segmenter writes it as
    lines (or smaller arcs), never as one arc the control would refuse; the batch finds nothing.
    Within the largest radius the batch finds the segmenter's arc."""
    grid = GRIDS[0]
    arc = cam_arc(grid, 40.0, -10.0, 400.0, 0.0, -0.1, 0.0)
    target = displaced(arc, (1e-4, -1e-4), (0.004, 0.002), 0.0, 1)
    for largest, method in ((300.0, None), (500.0, "arc")):
        limits = Limits(0.001, grid, DEFAULT.arc_radius_tolerance, largest)
        found = batch_plans([target], [limits])[0]
        expected = plan(target, limits)
        assert (found and found.method) == method
        assert method is None and not (len(expected.cuts) == 1 and expected.cuts[0].is_arc) or same_plan(found, expected)


def test_points_beyond_the_integers_a_float_holds_are_snapped_as_the_grid_snaps_them():
    """Some 1e13 mm at 3 decimals: the scaled value is past 2**53, where rint is not the decimal
    rounding; the grid's own format decides there (no lathe reaches it; the library may)."""
    grid = GRIDS[0]
    line = Line(0.0, 0.0, 1.0, 1.0)
    rng = np.random.default_rng(3)
    points = [(float(a), float(b)) for a, b in rng.uniform(1e13, 6e13, (200, 2))]
    targets = [Target(line, np.array([0.0, 1.0]), np.array([[a, b], [a + 1e6, b + 1e6]]) - line.point_at(np.array([0.0, 1.0])))
               for a, b in points]
    for (a, b), found in zip(points, batch_plans(targets, [Limits(1.0, grid)] * len(targets))):
        if found is None:
            assert grid.snap(a, b) == grid.snap(a + 1.0, b + 1.0), f"({a!r}, {b!r}) was not planned"
            continue
        assert repr(found.cuts[0].start) == repr(grid.snap(a, b))


def test_an_arc_a_line_follows_is_the_segmenter_s_line():
    """An arc so flat that its chord keeps within the tolerance: the segmenter measures a line
    first and keeps it; one a little less flat is an arc."""
    grid = GRIDS[0]
    methods = []
    for sweep in (-0.0001, -0.004):  # a sagitta of 0.01 um, and of 2 um: under the rounding budget, a line is tried
        flat = Arc(0.0, -1000.0, 1000.0, math.pi / 2, sweep)
        target = Target(flat, sample_params(flat), np.zeros((len(sample_params(flat)), 2)))
        found = batch_plans([target], [Limits(0.001, grid)])[0]
        assert same_plan(found, plan(target, Limits(0.001, grid)))
        methods.append(found.method)
    assert methods == ["line", "arc"]


FILLETS = """%
O0100 (SHAFT: FILLETS AND TAPERS, AS A CAM POST WRITES THEM)
G18 G21 G40 G99
T0101
G50 S3000
G96 S180 M03
G00 X62. Z2. M08
{body}G00 X100. Z50.
M30
%
"""


def fillet_program(count: int) -> str:
    """A shaft turned in steps, each corner a fillet written with I and K."""
    lines, x, z = [], 20.0, 0.0
    lines.append(f"G01 X{x:.3f} Z{z:.3f} F0.2")
    for k in range(count):
        r = 0.5 + (k % 5)
        lines.append(f"G01 Z{z - 4.0 - k % 3:.3f}")
        z -= 4.0 + k % 3
        lines.append(f"G02 X{x + 2 * r:.3f} Z{z - r:.3f} I{r:.3f} K0.")
        x, z = x + 2 * r, z - r
        lines.append(f"G01 X{x + 1.0:.3f} Z{z - 0.5:.3f}")
        x, z = x + 1.0, z - 0.5
        lines.append(f"G03 X{x + 2 * r:.3f} Z{z - r:.3f} I0. K{-r:.3f}")
        x, z = x + 2 * r, z - r
        if x > 120.0:
            lines.append(f"G00 X{x + 2.0:.3f}\nG00 Z0.\nG00 X20.\nG01 Z0.")
            x, z = 20.0, 0.0
    return FILLETS.format(body="".join(line + "\n" for line in lines))


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    traces = [str(SAMPLES / "ballbar/v40r-100-ccw.csv"), str(SAMPLES / "ballbar/v40r-100-cw.csv")]
    path = tmp_path_factory.mktemp("model") / "model.json"
    fitted = Pipeline(plugins=["parametric"], ballbar=traces, options=["extrapolate=true"], reporter=Reporter())
    path.write_text(dumps(fitted.core.saved_model()))
    return str(path)


@pytest.mark.parametrize("tolerance, mode", [(0.001, "auto"), (0.002, "auto"), (0.001, "line")])
def test_a_program_compensated_with_moves_planned_together_is_the_same_byte_for_byte(model, monkeypatch, tolerance,
                                                                                       mode):
    program = fillet_program(300)
    together = {"arc": 0, "line": 0}

    def counted(targets, limits, arcs=True):
        found = batch_plans(targets, limits, arcs)
        for plan_found in found:
            if plan_found is not None:
                together[plan_found.method] += 1
        return found

    monkeypatch.setattr(planning, "batch_plans", counted)
    text = Pipeline(model=model, tolerance=tolerance, mode=mode, reporter=Reporter()).compensate_text(program, "t.nc")
    assert together["line"] >= 600 and (together["arc"] >= 300 if mode == "auto" else together["arc"] == 0)
    monkeypatch.setattr(planning.Planning, "_presolve", lambda self, batch: None)
    assert text == Pipeline(model=model, tolerance=tolerance, mode=mode, reporter=Reporter()).compensate_text(program,
                                                                                                             "t.nc")


def test_a_step_refused_for_its_correction_is_not_planned_with_its_batch(model, monkeypatch):
    """A correction beyond the maximum refuses the run when its step is reached, and may be of any
    size (a model of the wrong machine, a unit slip): planning it first could take any time and
    memory. The batch plans none of the refused steps' moves."""
    from postproc.diagnostics import SafetyError

    planned = []

    def recorded(targets, limits, arcs=True):
        planned.extend(targets)
        return batch_plans(targets, limits, arcs)

    monkeypatch.setattr(planning, "batch_plans", recorded)
    with pytest.raises(SafetyError, match="maximum correction"):
        Pipeline(model=model, tolerance=0.001, max_correction=0.005, reporter=Reporter()).compensate_text(
            fillet_program(20), "t.nc")
    assert planned and all(np.hypot(*target.d.T).max() <= 0.005 for target in planned)
