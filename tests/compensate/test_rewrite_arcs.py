"""The rewriter on arcs written both ways: an R arc and the same arc with I and K compensate
alike, whatever the sense, sweep, units and X programming; and a block that cannot be held
says which limit stops it."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, event, given, settings
from hypothesis import strategies as st

from support import SAMPLES
from postproc.api import Pipeline
from postproc.diagnostics import Reporter
from postproc.geometry import Arc, Line, Profile, segment_of
from postproc.compensate.models import dumps
from postproc.interpret.motion import ARC, LINE, RUN
from postproc.machine.profile import DEFAULT
from postproc.interpret.program import interpret_source
from postproc.compensate.rewrite import _turns
from postproc.machine.resolution import Grid
from postproc.compensate.segmenter import RADIUS_CHECK, TOLERANCE, Limits, PlanError, Segmenter, Target, plan, sample_params
from postproc.syntax.source import Source

CCW, CW = str(SAMPLES / "ballbar/v40r-100-ccw.csv"), str(SAMPLES / "ballbar/v40r-100-cw.csv")
INCH = 25.4


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    """The parametric model of the sample traces, extrapolated to any arc (the issue's case)."""
    path = tmp_path_factory.mktemp("model") / "model.json"
    fitted = Pipeline(plugins=["parametric"], ballbar=[CCW, CW], options=["extrapolate=true"], reporter=Reporter())
    path.write_text(dumps(fitted.core.saved_model()))
    return str(path)


def _compensated(text: str, model: str, **profile) -> str:
    machine = dataclasses.replace(DEFAULT, **profile)
    return Pipeline(model=model, machine=machine, reporter=Reporter()).compensate_text(text, "t.nc")


def _feed_path(text: str, **profile) -> Profile:
    """The program's feed moves (lines and arcs), as one profile in radius mm."""
    machine = dataclasses.replace(DEFAULT, **profile)
    with Source.from_text(text, "t.nc") as source:
        moves = [m for step in interpret_source(source, machine, Reporter()) for m in step.moves
                 if m.kind in (LINE, ARC) and m.role == RUN and m.known and (m.kind == ARC or m.x0 != m.x1 or m.z0 != m.z1)]
    return Profile(tuple(segment_of(m) for m in moves))


def _reversals(path: Profile, grid: Grid) -> list[int]:
    """How many reversals of an axis each arc of a path makes, as the rewriter counts them."""
    return [len(_turns(s, (grid.x_step, grid.z_step))) for s in path.segments if isinstance(s, Arc)]


def _apart(a: Profile, b: Profile) -> float:
    """The larger of the two one-sided distances between two paths, sampled densely."""

    def samples(profile: Profile) -> np.ndarray:
        return np.concatenate([s.point_at(np.linspace(0.0, 1.0, 200)) for s in profile.segments])

    return max(float(b.closest(samples(a)).distance.max()), float(a.closest(samples(b)).distance.max()))


def test_the_r_arc_of_the_issue_compensates_like_its_i_k_form(model):
    """G3 X51.014 Z-35.025 R3.0 starts 43 nm past the apex of its circle (its centre, worked out
    from R, is that far off the start's axis): a reversal of Z by 0.3 pm, which split the arc
    into a 43 nm piece that no block on the 1 um grid can hold, and refused the program."""
    head = "%\nO1000\nG18 G21 G99\nT0101\nG0 X49.3 Z3.231\nG1 Z-34.9 F0.1\n"
    tail = "G1 X60.\nG0 X100. Z50.\nM30\n%\n"
    r_form = _compensated(head + "G3 X51.014 Z-35.025 R3.0\n" + tail, model)
    ik_form = _compensated(head + "G3 X51.014 Z-35.025 I0. K-3.0\n" + tail, model)
    assert _apart(_feed_path(r_form), _feed_path(ik_form)) < 0.002 + 0.0001


@pytest.mark.parametrize("mode", ["auto", "arc", "line"])
@pytest.mark.parametrize("tolerance", [None, 0.005, 0.01])
@pytest.mark.parametrize("plugin, options", [("parametric", ["extrapolate=true"]),
                                             ("effective-angle", ["extrapolate=true"]),
                                             ("ballbar-inverse", ["radius-mapping=relative"])])
def test_the_r_arc_of_the_issue_compensates_with_every_ballbar_model_tolerance_and_mode(plugin, options, tolerance,
                                                                                          mode):
    program = ("%\nO1000\nG18 G21 G99\nT0101\nG0 X49.3 Z3.231\nG1 Z-34.9 F0.1\nG3 X51.014 Z-35.025 R3.0\n"
               "G1 X60.\nG0 X100. Z50.\nM30\n%\n")
    pipeline = Pipeline(plugins=[plugin], ballbar=[CCW, CW], options=options, tolerance=tolerance, mode=mode,
                        reporter=Reporter())
    assert "G3 X51.014 Z-35.025 R3.0" not in pipeline.compensate_text(program, "t.nc")


@st.composite
def arcs(draw):
    """An arc as a CAM system or a programmer writes it, in both forms: (r program, i/k program,
    profile keys). The start is often on an apex or a quadrant (fillets, spheres), where a
    reversal of an axis meets an end of the arc."""
    inch = draw(st.booleans())
    diameter = draw(st.booleans())
    decimals = 4 if inch else 3
    unit = INCH if inch else 1.0
    radius = draw(st.floats(0.5, 80.0)) / unit
    quadrant = draw(st.integers(0, 3)) * 90.0
    start = quadrant + draw(st.sampled_from([0.0, 0.0, draw(st.floats(-0.01, 0.01)), draw(st.floats(0.0, 360.0))]))
    kind = draw(st.sampled_from(["short", "near-half", "long"]))
    sweep = {"short": st.floats(2.0, 170.0), "near-half": st.floats(172.0, 178.0), "long": st.floats(190.0, 350.0)}[kind]
    sweep = math.radians(draw(sweep))
    cw = draw(st.booleans())
    theta0 = math.radians(start)
    theta1 = theta0 + (sweep if cw else -sweep)
    xc, zc = draw(st.floats(0.0, 60.0)) / unit, draw(st.floats(-80.0, 0.0)) / unit
    x_scale = 2.0 if diameter else 1.0

    def word(value: float) -> str:
        text = f"{value:.{decimals}f}"
        return "0." if float(text) == 0.0 else text

    def point(theta: float) -> tuple[str, str]:
        return word((xc + radius * math.cos(theta)) * x_scale), word(zc + radius * math.sin(theta))

    (x0, z0), (x1, z1) = point(theta0), point(theta1)
    start_x, start_z = float(x0) / x_scale, float(z0)
    end_x, end_z = float(x1) / x_scale, float(z1)
    chord = math.hypot(end_x - start_x, end_z - start_z)
    assume(chord > 20 * 10.0**-decimals)  # a rounded end point well off the start: not a full circle
    r_word = float(word(radius))
    assume(chord < 2.0 * r_word * 0.9999)  # clear of the semicircle, where R's sign alone picks the centre
    i_word, k_word = word(xc - start_x), word(zc - start_z)
    centre = (start_x + float(i_word), start_z + float(k_word))
    radii = [math.hypot(x - centre[0], z - centre[1]) for x, z in ((start_x, start_z), (end_x, end_z))]
    assume(abs(radii[0] - radii[1]) * unit < 0.005)  # the control's radius check passes
    code = "G02" if cw else "G03"
    r_value = word(r_word if sweep < math.pi else -r_word)
    units = "G20" if inch else "G21"
    feed = "0.004" if inch else "0.1"
    lead = word(float(z0) + 2.0 / unit)
    head = f"%\nO2000\nG18 {units} G99\nT0101\nG00 X{x0} Z{lead}\nG01 Z{z0} F{feed}\n"
    tail = f"G01 X{word(float(x1) + 4.0 / unit * x_scale)}\nG00 Z{word(float(z1) + 10.0 / unit)}\nM30\n%\n"
    r_form = head + f"{code} X{x1} Z{z1} R{r_value}\n" + tail
    ik_form = head + f"{code} X{x1} Z{z1} I{i_word} K{k_word}\n" + tail
    return r_form, ik_form, {"diameter_x": diameter}


@settings(max_examples=1500, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                                  HealthCheck.filter_too_much, HealthCheck.too_slow])
@given(arcs())
def test_r_and_i_k_arcs_both_compensate_and_agree(model, case):
    """Both forms compensate (no refusal), and the two compensated paths lie as close together
    as the two nominal paths do, give or take each one's tolerance.

    The forms' arcs differ by the rounding of I and K: where one turns an axis back by just
    the half grid step that counts as a reversal and the other by just less, a direction-
    dependent correction (backlash) differs between them by design; those cases must
    compensate, and are not compared."""
    r_form, ik_form, profile = case
    inch = "G20" in r_form
    tolerance = DEFAULT.default_tolerance(inch)
    r_out = _compensated(r_form, model, **profile)
    ik_out = _compensated(ik_form, model, **profile)
    r_nominal, ik_nominal = _feed_path(r_form, **profile), _feed_path(ik_form, **profile)
    grid = Grid(4 if inch else 3, inch, profile["diameter_x"])
    if _reversals(r_nominal, grid) != _reversals(ik_nominal, grid):
        event("the forms reverse an axis differently")
        return
    nominal = _apart(r_nominal, ik_nominal)
    compensated = _apart(_feed_path(r_out, **profile), _feed_path(ik_out, **profile))
    assert compensated <= nominal + 2.0 * tolerance + 1e-4, (compensated, nominal)


# ---------------------------------------------------------------- blocks that cannot be held

HEMISHELL = SAMPLES / "programs" / "hemishell.nc"


def _model_args(model):
    return ("--model", model)


def test_a_block_the_output_grid_cannot_place_is_refused_naming_the_limit(run, model):
    result = run("compensate", str(HEMISHELL), *_model_args(model), "--tolerance", "0.0003")
    assert result.exit_code == 4
    assert result.stdout_bytes == b""
    first, source, caret = result.stderr.splitlines()[:3]
    assert first.startswith(f"{HEMISHELL}:9:5: error: block cannot be compensated: the output grid (0.001 mm steps)")
    assert "(output resolution); to go on, give more decimals (output_decimals_mm" in first
    assert "--tolerance 0.00044 (the nearest plan for this block keeps within 0.43 um)" in first
    assert "--keep-unplannable" in first
    assert source == "    G01 Z57.15 F0.08" and caret == "        ^"
    again = run("compensate", str(HEMISHELL), *_model_args(model), "--tolerance", "0.00044")
    assert again.stderr.startswith(f"{HEMISHELL}:10:")  # the suggestion holds this block; the arc wants its own


def test_keep_unplannable_leaves_the_block_as_it_is_and_says_so(run, model, tmp_path):
    target = tmp_path / "out.nc"
    result = run("compensate", str(HEMISHELL), *_model_args(model), "--tolerance", "0.0003", "--keep-unplannable",
                 "-o", str(target))
    assert result.exit_code == 0, result.stderr
    assert result.stdout_bytes == b""
    warning = next(line for line in result.stderr.splitlines() if ": warning: " in line)
    assert warning.startswith(f"{HEMISHELL}:9:5: warning: block left uncompensated (--keep-unplannable): the output grid")
    out = target.read_text().splitlines()
    assert "(UNCOMPENSATED LINE 9: OUTPUT RESOLUTION)" in out
    assert "G01 Z57.15 F0.08" in out  # byte for byte, not moved to meet the compensated arc
    assert run("check", str(target)).exit_code == 0


def test_blocks_shorter_than_the_minimum_block_time_name_that_limit(run, model, tmp_path):
    machine = tmp_path / "slow.toml"
    machine.write_text("min_block_time_s = 1.0\n")
    result = run("compensate", str(HEMISHELL), *_model_args(model), "--mode", "line", "--machine", str(machine))
    assert result.exit_code == 4
    assert result.stdout_bytes == b""
    errors = [line for line in result.stderr.splitlines() if ": error: " in line]  # the model was fitted under the default
    first, = errors
    assert first.startswith(f"{HEMISHELL}:10:5: error: block cannot be compensated: blocks shorter than")
    assert "(minimum block time); to go on, give a smaller min_block_time_s in the machine profile" in first


def _arc_target(displacement: float = 0.002):
    arc = Arc(20.0, -10.0, 12.345, 0.3, 0.8)
    t = sample_params(arc)
    d = np.column_stack([np.full(len(t), displacement), np.linspace(0.0, displacement, len(t))])
    return Target(arc, t, d)


def test_the_arc_radius_check_is_named_when_relaxing_it_would_let_a_plan_through(monkeypatch):
    monkeypatch.setattr(Segmenter, "lines", lambda self: None)  # as if no chords could follow
    limits = Limits(0.001, Grid(3, False, True), arc_radius_tolerance=1e-12)
    with pytest.raises(PlanError) as info:
        plan(_arc_target(), limits)
    assert info.value.limit == RADIUS_CHECK
    assert "arc radius check (1e-12 mm)" in str(info.value)
    assert plan(_arc_target(), Limits(0.001, Grid(3, False, True))).cuts  # the control's usual check lets it through


def test_a_target_no_blocks_can_follow_names_the_tolerance_without_a_remedy_in_it():
    """A correction that turns the path back on itself: no tolerance up to 0.1 mm helps."""
    line = Line(20.0, 0.0, 20.0, -0.01)
    t = sample_params(line)
    d = np.column_stack([np.zeros(len(t)), 0.03 * t**2])  # z turns to run forwards where the move runs back
    with pytest.raises(PlanError) as info:
        plan(Target(line, t, d), Limits(0.001, Grid(3, False, True)))
    assert (info.value.limit, info.value.needed) == (TOLERANCE, None)


_grid_values = st.integers(-200_000, 200_000).map(lambda n: n / 2000.0)  # radius mm on a 0.001 mm diameter grid


@given(st.lists(st.tuples(_grid_values, _grid_values, _grid_values, _grid_values,
                          st.integers(-40_000, 40_000), st.integers(-40_000, 40_000), st.booleans()),
                min_size=1, max_size=8),
       st.sampled_from([(0.0005, 0.001), (0.00005, 0.0001), (0.0127, 0.0254)]),
       st.sampled_from([(0, 0), (1, -1), (-1, 1)]))
@settings(max_examples=200, deadline=None)
def test_an_arc_batchs_reversals_found_at_once_split_and_steer_its_moves_as_one_by_one(arcs, steps, last):
    """I/K arcs (their ends and centres on the grid, their radius drifting as a control's does):
    the pieces and the travel after each move, from reversals found for the whole batch in one
    array pass, are those worked out move by move."""
    from postproc.compensate.rewrite import pieces, travel_after
    from postproc.geometry import reversal_params_of
    from postproc.interpret.motion import Move

    moves = [Move(ARC, n + 1, x0, z0, x1, z1, x0 + i / 1000.0, z0 + k / 1000.0, cw, feed=0.1)
             for n, (x0, z0, x1, z1, i, k, cw) in enumerate(arcs) if (i, k) != (0, 0)]
    assume(moves)
    found = reversal_params_of([segment_of(move) for move in moves])
    one_by_one, batched = last, last
    for move, reversals in zip(moves, found):
        turns = _turns(segment_of(move), steps, reversals)
        assert turns == _turns(segment_of(move), steps)
        alone = pieces(move, one_by_one, steps)
        together = pieces(move, batched, steps, turns)
        assert [(p.segment, p.t.tolist(), p.x_direction, p.z_direction) for p in alone] == \
               [(p.segment, p.t.tolist(), p.x_direction, p.z_direction) for p in together]
        one_by_one, batched = travel_after(move, one_by_one, steps), travel_after(move, batched, steps, turns)
        assert one_by_one == batched


@pytest.mark.parametrize("limit", ["max_arc_radius", "arc_radius_tolerance"])
def test_an_arc_beyond_what_the_profile_lets_the_control_run_is_never_written(model, monkeypatch, limit):
    """Whatever planned it: with the planner's limits loosened behind the profile's back, an R400
    arc comes out as one arc, which a machine whose profile allows 300 mm (or a radius check of
    a nanometre) cannot run; the writer refuses it, naming the key, and nothing is written."""
    from postproc.compensate import planning
    from postproc.compensate.segmenter import Limits
    from postproc.diagnostics import SafetyError

    program = "G18 G21 G99 F0.2\nG00 X40. Z2.\nG01 Z0.\nG03 X42.808 Z-17.967 R400.\nG00 X60.\n"
    profile = {"max_arc_radius": 300.0} if limit == "max_arc_radius" else {"arc_radius_tolerance": 1e-6}
    loose = lambda self, step, held=0.0: Limits(self._tolerance(step) - held, self._grid(step), math.inf, math.inf)
    monkeypatch.setattr(planning.Planning, "_limits_for", loose)
    with pytest.raises(SafetyError, match=limit):
        _compensated(program, model, **profile)
