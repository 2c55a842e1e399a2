"""Probing: the pretravel model and its cross-validation, touched points, the datum check,
deviations from a profile of lines and arcs, and the screening for the nub and outliers.

Calibration and probe files are written here from a known truth: touches on a sphere (or a
part) whose reported stylus centre carries a direction-dependent pretravel k(theta).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from postproc.diagnostics import EXIT_REFUSED, MeasurementError, Reporter, SafetyError
from postproc.geometry import Arc, Line, Profile
from postproc.measure.readers.probe import read_calibration, read_probe
from postproc.measure.pretravel import CalibrationModel, fit_calibration
from postproc.measure.probing import check_datum, probe_profile, profile_deviations, touched_points
from postproc.measure.screening import screen

STYLUS = 3.0
ARTIFACT_R = 25.4
ARTIFACT_C = (80.0, 30.0)
R = 57.15  #: the hemishell
NO_CALIBRATION = "no probe calibration given: the pretravel is taken as k = 0 (give --calibration)"


def outward(theta_deg) -> np.ndarray:
    t = np.radians(np.asarray(theta_deg, dtype=float))
    return np.column_stack([np.cos(t), np.sin(t)])


def cos3(theta):
    """-0.003 - 0.002 cos(3 phi), phi the source's angle (0 on -X, 180 on +X)."""
    return -0.003 - 0.002 * np.cos(np.radians(3.0 * (180.0 - np.asarray(theta))))


def source_shape(theta):
    """The source's shape: quadratic over the +X half (theta < 90), linear over the -X half, a kink at the pole."""
    theta = np.asarray(theta, dtype=float)
    u = (90.0 - theta) / 90.0
    return np.where(theta <= 90.0, -0.002 + 0.006 * u**2 + 0.002 * u, -0.002 - 0.006 * (theta - 90.0) / 90.0)


def linear(theta):
    return -0.002 + 0.001 * (np.asarray(theta) - 90.0) / 90.0


def write_rows(path, magic, header: dict, centres, approach) -> list[int]:
    """Write a probe-style file; returns the line number of each data row."""
    lines = [magic] + [f"# {key} = {value}" for key, value in header.items()] + ["x_mm,z_mm,approach_x,approach_z"]
    first = len(lines) + 1
    lines += [f"{c[0]:.7f},{c[1]:.7f},{a[0]:.9f},{a[1]:.9f}" for c, a in zip(centres, approach)]
    path.write_text("\n".join(lines) + "\n")
    return list(range(first, first + len(centres)))


def write_calibration(path, k_true, noise=0.0003, seed=0, theta=None):
    rng = np.random.default_rng(seed)
    theta = np.arange(0.0, 180.0 + 1e-9, 2.5) if theta is None else np.asarray(theta, dtype=float)
    n = outward(theta)
    k = k_true(theta) + rng.normal(0.0, noise, len(theta))
    centres = np.array(ARTIFACT_C) + (ARTIFACT_R + STYLUS + k)[:, None] * n
    header = {"stylus_radius_mm": STYLUS, "artifact_radius_mm": ARTIFACT_R,
              "artifact_center_x_mm": ARTIFACT_C[0], "artifact_center_z_mm": ARTIFACT_C[1]}
    write_rows(path, "# postproc probe-calibration 1", header, centres, -n)
    return str(path)


def write_probe(path, surface, normals, k_true=None, datum=None, repeatability=0.003):
    """Touches on ``surface`` points approached against ``normals``; the control reports the
    stylus centre short by the pretravel ``k_true``."""
    k = np.zeros(len(surface)) if k_true is None else k_true(np.degrees(np.arctan2(normals[:, 1], normals[:, 0])))
    centres = surface - (STYLUS + k)[:, None] * (-normals)
    header = {"stylus_radius_mm": STYLUS}
    if datum is not None:
        header.update({"datum_before_z_mm": datum[0], "datum_after_z_mm": datum[1], "repeatability_mm": repeatability})
    return write_rows(path, "# postproc probe 1", header, centres, -normals)


def hemishell(deviation, count=36):
    """36 points from the pole to the equator, ``deviation`` (mm, positive = material left)."""
    theta = np.linspace(90.0, 0.0, count)
    n = outward(theta)
    return (R + np.asarray(deviation))[:, None] * n, n, theta


HEMISHELL = Profile((Line(0.0, 60.0, 0.0, R), Arc.through((0.0, R), (R, 0.0), (0.0, 0.0), cw=False)))


# -- the pretravel model --------------------------------------------------------------------------


def test_calibration_recovers_a_lobed_pretravel_and_cv_picks_its_harmonic(tmp_path):
    model = fit_calibration(read_calibration(write_calibration(tmp_path / "cal.csv", cos3)))
    theta = np.linspace(0.0, 180.0, 721)
    assert model.name == "harmonic-3"
    assert np.max(np.abs(model.k_of(theta) - cos3(theta))) < 0.0003
    scores = {c.name: c.cv_rms for c in model.candidates}
    assert model.chosen.cv_rms == min(scores.values())
    # the polynomials the source would reach for cannot follow three lobes
    assert all(scores[f"poly-{n}"] > 2.0 * model.chosen.cv_rms for n in range(4))
    assert scores["split-2/1-jump"] > 2.0 * model.chosen.cv_rms


def test_calibration_recovers_the_sources_piecewise_shape_from_six_runs(tmp_path):
    runs = [read_calibration(write_calibration(tmp_path / f"cal{i}.csv", source_shape, seed=i)) for i in range(6)]
    model = fit_calibration(runs)
    theta = np.linspace(0.0, 180.0, 721)
    assert model.name.startswith("split-")
    assert np.max(np.abs(model.k_of(theta) - source_shape(theta))) < 0.0002
    best_other = min(c.cv_rms for c in model.candidates if not c.name.startswith("split-"))
    assert model.chosen.cv_rms < best_other
    assert len(model.calibrated) == 6 * 73 and model.source.count(".csv, ") == 5


def test_cv_keeps_a_linear_pretravel_simple(tmp_path):
    model = fit_calibration(read_calibration(write_calibration(tmp_path / "cal.csv", linear, seed=2)))
    theta = np.linspace(0.0, 180.0, 181)
    assert model.name == "poly-1"
    assert np.max(np.abs(model.k_of(theta) - linear(theta))) < 0.0001
    scores = {c.name: c.cv_rms for c in model.candidates}
    assert scores["poly-0"] > 1.5 * scores["poly-1"]


def test_the_chosen_model_predicts_a_fresh_run_better_than_fixed_alternatives(tmp_path):
    """Cross-validation shown on simulated runs: fit on one run, judge on another."""
    train = read_calibration(write_calibration(tmp_path / "a.csv", cos3, seed=10))
    test = read_calibration(write_calibration(tmp_path / "b.csv", cos3, seed=11))

    def held_out_rms(model):
        return float(np.sqrt(np.mean((model.k_of(test.theta) - test.factors()) ** 2)))

    best = fit_calibration(train)
    others = {name: held_out_rms(fit_calibration(train, model=name)) for name in ("poly-1", "poly-3", "split-2/1-jump")}
    assert all(held_out_rms(best) < value for value in others.values()), (held_out_rms(best), others)
    assert held_out_rms(best) < 0.0004  # the noise is 0.3 um


def test_the_sources_model_can_be_asked_for_and_is_scored_with_the_rest(tmp_path):
    run = read_calibration(write_calibration(tmp_path / "cal.csv", cos3))
    model = fit_calibration(run, model="split-2/1-jump")
    assert model.name == model.chosen.name == "split-2/1-jump"
    assert model.candidates[0].name == "harmonic-3" and model.chosen.cv_rms > model.candidates[0].cv_rms
    assert model.report()[1].startswith("pretravel model split-2/1-jump (5 parameters)")
    with pytest.raises(MeasurementError, match=r"'poly-9' \(not a candidate\) cannot be fitted"):
        fit_calibration(run, model="poly-9")


def test_the_model_survives_a_round_trip_through_json(tmp_path):
    model = fit_calibration(read_calibration(write_calibration(tmp_path / "cal.csv", source_shape)))
    again = CalibrationModel.from_dict(model.as_dict())
    theta = np.linspace(0.0, 180.0, 19)
    assert np.allclose(again.k_of(theta), model.k_of(theta), atol=1e-15)
    assert again.candidates == model.candidates and again.span == model.span


def test_the_report_states_the_choice_and_every_cv_score(tmp_path):
    model = fit_calibration(read_calibration(write_calibration(tmp_path / "cal.csv", cos3)))
    lines = model.report()
    assert "73 touches, theta 0.0..180.0 deg" in lines[0]
    assert lines[1].startswith("pretravel model harmonic-3 (7 parameters): leave-one-out RMS")
    assert all(c.name in lines[2] for c in model.candidates)


def test_a_calibration_across_zero_degrees_is_one_piece(tmp_path):
    theta = np.arange(-60.0, 60.0 + 1e-9, 2.5) % 360.0

    def truth(theta):
        return linear((np.asarray(theta) + 180.0) % 360.0 - 180.0)

    model = fit_calibration(read_calibration(write_calibration(tmp_path / "cal.csv", truth, theta=theta)))
    assert model.span == pytest.approx((-60.0, 60.0))
    assert model.k_of(350.0) == pytest.approx(float(linear(-10.0)), abs=0.0002)
    inside, outside = outward([296.0, 10.0]), outward([70.0])
    write_probe(tmp_path / "in.csv", 40.0 * inside, inside)
    touched_points(read_probe(str(tmp_path / "in.csv")), model)
    write_probe(tmp_path / "out.csv", 40.0 * outside, outside)
    with pytest.raises(MeasurementError, match=r"theta 70\.0 deg, 10\.0 deg outside .* \(-60\.0\.\.60\.0 deg"):
        touched_points(read_probe(str(tmp_path / "out.csv")), model)


# -- touched points and their directions ------------------------------------------------------------


def test_touched_points_with_the_calibration_lie_on_the_part(tmp_path):
    model = fit_calibration(read_calibration(write_calibration(tmp_path / "cal.csv", source_shape, noise=0.0001)))
    surface, normals, _ = hemishell(np.zeros(36))
    write_probe(tmp_path / "p.csv", surface, normals, k_true=source_shape)
    probe = read_probe(str(tmp_path / "p.csv"))
    points, k = touched_points(probe, model)
    assert np.max(np.abs(np.hypot(points[:, 0], points[:, 1]) - R)) < 0.0002
    assert np.allclose(k, source_shape(np.linspace(90.0, 0.0, 36)), atol=0.0002)


def test_without_a_calibration_k_is_zero_and_the_user_is_warned(tmp_path):
    surface, normals, _ = hemishell(np.zeros(36))
    write_probe(tmp_path / "p.csv", surface, normals, k_true=cos3)
    probe = read_probe(str(tmp_path / "p.csv"))
    reporter = Reporter()
    points, k = touched_points(probe, None, reporter)
    assert not k.any()
    radius = np.hypot(points[:, 0], points[:, 1])
    assert np.allclose(radius - R, cos3(np.linspace(90.0, 0.0, 36)), atol=1e-6)  # k < 0: reads short
    assert [str(w) for w in reporter.warnings] == [f"{tmp_path / 'p.csv'}: warning: {NO_CALIBRATION}"]


def test_a_direction_more_than_5_degrees_outside_the_calibration_is_refused_at_its_row(tmp_path):
    model = fit_calibration(read_calibration(
        write_calibration(tmp_path / "cal.csv", linear, theta=np.arange(0.0, 90.0 + 1e-9, 2.5))))
    theta = np.array([45.0, 94.9, 30.0, 100.0, 120.0])
    lines = write_probe(tmp_path / "p.csv", (R * outward(theta)), outward(theta))
    probe = read_probe(str(tmp_path / "p.csv"))
    with pytest.raises(MeasurementError) as caught:
        touched_points(probe, model)
    message = str(caught.value)
    assert message.startswith(f"{tmp_path / 'p.csv'}:{lines[3]}: error: this touch approaches at theta 100.0 deg, "
                              "10.0 deg outside the directions calibrated in")
    assert "(0.0..90.0 deg; at most 5 deg beyond is allowed) (and 1 more rows)" in message
    assert caught.value.exit_code == 3
    # within 5 deg is accepted
    write_probe(tmp_path / "q.csv", R * outward(theta[:3]), outward(theta[:3]))
    touched_points(read_probe(str(tmp_path / "q.csv")), model)


def test_a_probe_with_another_stylus_cannot_use_the_calibration(tmp_path):
    model = fit_calibration(read_calibration(write_calibration(tmp_path / "cal.csv", linear)))
    path = tmp_path / "p.csv"
    path.write_text("# postproc probe 1\n# stylus_radius_mm = 1.0\nx_mm,z_mm,approach_x,approach_z\n0,58.15,0,-1\n")
    with pytest.raises(MeasurementError, match=r"p\.csv: error: stylus_radius_mm is 1 here but 3 in the calibration"):
        touched_points(read_probe(str(path)), model)


# -- the datum stability check ----------------------------------------------------------------------


def test_a_datum_that_moved_refuses_the_inspection_for_safety(tmp_path):
    surface, normals, _ = hemishell(np.zeros(36))
    write_probe(tmp_path / "p.csv", surface, normals, datum=(10.0012, 10.0063))
    probe = read_probe(str(tmp_path / "p.csv"))
    with pytest.raises(SafetyError) as caught:
        check_datum(probe)
    assert caught.value.exit_code == EXIT_REFUSED == 4
    assert str(caught.value) == (
        f"{tmp_path / 'p.csv'}: error: the machine moved during the inspection: datum_before_z_mm = 10.0012 and "
        "datum_after_z_mm = 10.0063 differ by 0.0051 mm, more than repeatability_mm = 0.003; the points are not "
        "valid (re-probe after a cool-down, or --force to use them anyway)")
    with pytest.raises(SafetyError):
        probe_profile(probe, HEMISHELL, reporter=Reporter())


def test_the_override_turns_the_refusal_into_a_warning(tmp_path):
    surface, normals, _ = hemishell(np.zeros(36))
    write_probe(tmp_path / "p.csv", surface, normals, datum=(10.0012, 10.0063))
    probe = read_probe(str(tmp_path / "p.csv"))
    reporter = Reporter()
    notes = check_datum(probe, force=True, reporter=reporter)
    assert len(reporter.warnings) == 1 and "used anyway (--force)" in str(reporter.warnings[0])
    assert "10.0063" in notes[0]
    result = probe_profile(probe, HEMISHELL, reporter=Reporter(), force=True)
    assert np.allclose(result.deviation, 0.0, atol=1e-6)


def test_a_stable_datum_passes_and_is_noted(tmp_path):
    surface, normals, _ = hemishell(np.zeros(36))
    write_probe(tmp_path / "p.csv", surface, normals, datum=(10.0012, 10.0013))
    notes = check_datum(read_probe(str(tmp_path / "p.csv")))
    assert notes == [f"{tmp_path / 'p.csv'}: datum z stable: 10.0012 before, 10.0013 after (+0.0001 mm, "
                     "repeatability 0.003)"]


# -- deviations from a profile of lines and arcs ------------------------------------------------------


SHOULDER = Profile((
    Line(0.0, 40.0, 20.0, 40.0),  # face, material below
    Arc.through((20.0, 40.0), (25.0, 35.0), (20.0, 35.0), cw=False),  # convex corner
    Line(25.0, 35.0, 25.0, 15.0),  # outside diameter
    Arc.through((25.0, 15.0), (30.0, 10.0), (30.0, 15.0), cw=True),  # concave fillet
    Line(30.0, 10.0, 40.0, 10.0),  # shoulder face
))


def test_deviations_along_the_outward_normal_of_lines_and_arcs():
    # (foot, outward normal, segment)
    c45 = math.sqrt(0.5)
    places = [((10.0, 40.0), (0.0, 1.0), 0),
              ((20.0 + 5 * c45, 35.0 + 5 * c45), (c45, c45), 1),
              ((25.0, 25.0), (1.0, 0.0), 2),
              ((30.0 - 5 * c45, 15.0 - 5 * c45), (c45, c45), 3),  # concave: the normal points to the centre
              ((35.0, 10.0), (0.0, 1.0), 4)]
    deviations = np.array([0.012, -0.007, 0.003, -0.004, 0.0005])
    feet = np.array([p[0] for p in places])
    normals = np.array([p[1] for p in places])
    points = feet + deviations[:, None] * normals
    tilt = np.radians(20.0)  # approaches need not be normal to the surface
    approach = -normals @ np.array([[math.cos(tilt), math.sin(tilt)], [-math.sin(tilt), math.cos(tilt)]])
    result = profile_deviations(points, approach, SHOULDER)
    assert np.allclose(result.deviation, deviations, atol=1e-12)
    assert list(result.nearest.index) == [0, 1, 2, 3, 4]
    assert np.allclose(result.outward, normals, atol=1e-12)
    # the direction of travel does not matter: the approach says where the material is
    backwards = Profile(tuple(segment.reversed() for segment in reversed(SHOULDER.segments)))
    assert np.allclose(profile_deviations(points, approach, backwards).deviation, deviations, atol=1e-12)


def test_a_bore_too_small_is_material_left():
    bore = Profile((Line(10.0, 0.0, 10.0, -30.0),))  # an inside diameter: material at x > 10
    points = np.array([[9.995, -10.0], [10.004, -20.0]])
    result = profile_deviations(points, [[1.0, 0.0], [1.0, 0.0]], bore)
    assert np.allclose(result.deviation, [0.005, -0.004])
    assert np.allclose(result.outward, [[-1.0, 0.0], [-1.0, 0.0]])


def test_the_plunge_along_the_axis_is_not_mistaken_for_the_pole():
    surface, normals, _ = hemishell(np.full(36, 0.01))
    result = profile_deviations(surface, -normals, HEMISHELL)
    assert np.allclose(result.deviation, 0.01, atol=1e-12)
    assert set(result.nearest.index) == {1}


def test_a_touch_no_segment_faces_is_refused_at_its_row(tmp_path):
    theta = np.array([45.0, 30.0])
    lines = write_probe(tmp_path / "p.csv", R * outward(theta), outward(theta))
    probe = read_probe(str(tmp_path / "p.csv"))
    wall = Profile((Line(60.0, -10.0, 60.0, 80.0),))  # normals along X; the first touch comes in at 45 deg: fine
    sideways = np.array([[0.0, -1.0], [0.0, -1.0]])
    with pytest.raises(MeasurementError, match=rf"p\.csv:{lines[0]}: error: no segment of the nominal profile faces"):
        profile_deviations(probe.touched(), sideways, wall, probe)


# -- the nub and outliers ---------------------------------------------------------------------------------


def shell_probe(tmp_path, extra, noise=0.0008, seed=4):
    rng = np.random.default_rng(seed)
    theta = np.linspace(90.0, 0.0, 36)
    truth = 0.004 * np.sin(np.radians(2.0 * theta)) - 0.003 + rng.normal(0.0, noise, 36)
    measured = truth + extra
    surface, normals, _ = hemishell(measured)
    lines = write_probe(tmp_path / "p.csv", surface, normals, datum=(10.0, 10.001))
    return read_probe(str(tmp_path / "p.csv")), truth, lines


def test_the_nub_and_an_outlier_are_dropped_reported_and_replaced(tmp_path):
    extra = np.zeros(36)
    extra[0], extra[1], extra[20] = 0.018, 0.007, -0.012
    probe, truth, lines = shell_probe(tmp_path, extra)
    reporter = Reporter()
    result = probe_profile(probe, HEMISHELL, reporter=reporter)
    dropped = result.screening.dropped
    assert [(d.row, d.kind) for d in dropped] == [(lines[0], "nub"), (lines[1], "nub"), (lines[20], "outlier")]
    assert list(np.nonzero(~result.kept)[0]) == [0, 1, 20]
    assert [d.how for d in dropped] == ["extrapolated", "extrapolated", "interpolated"]
    assert dropped[0].source_rows == tuple(lines[2:6])
    assert np.max(np.abs(result.cleaned - truth)) < 0.003
    assert np.array_equal(result.cleaned[result.kept], result.deviation[result.kept])
    path = str(tmp_path / "p.csv")
    nub = f"{path}:{lines[0]}: dropped as the nub at the pole: deviation +0.01"
    assert any(note.startswith(nub) for note in result.notes)
    assert any(note.startswith(f"{path}:{lines[20]}: dropped as an outlier") for note in result.notes)
    warnings = [str(w) for w in reporter.warnings]
    assert warnings[0] == f"{path}: warning: {NO_CALIBRATION}"
    assert [w.split(": warning:")[0] for w in warnings[1:]] == [f"{path}:{lines[i]}" for i in (0, 1, 20)]


def test_nearest_fill_repeats_the_neighbours_value(tmp_path):
    extra = np.zeros(36)
    extra[0] = 0.015
    probe, _, lines = shell_probe(tmp_path, extra)
    result = probe_profile(probe, HEMISHELL, fill="nearest")
    (nub,) = result.screening.dropped
    assert (nub.kind, nub.how, nub.source_rows) == ("nub", "nearest", (lines[1],))
    assert result.cleaned[0] == result.deviation[1]


def test_clean_data_lose_nothing(tmp_path):
    probe, truth, _ = shell_probe(tmp_path, np.zeros(36))
    result = probe_profile(probe, HEMISHELL)
    assert result.kept.all() and not result.screening.dropped
    assert np.array_equal(result.cleaned, result.deviation)
    assert "0 nub and 0 outlier points dropped" in result.notes[-1]


def test_a_low_point_at_the_pole_is_an_outlier_not_the_nub(tmp_path):
    extra = np.zeros(36)
    extra[0] = -0.015
    probe, _, lines = shell_probe(tmp_path, extra)
    (low,) = probe_profile(probe, HEMISHELL).screening.dropped
    assert (low.row, low.kind) == (lines[0], "outlier")


def test_too_many_outliers_are_an_error_not_a_cleaning_job():
    rng = np.random.default_rng(0)
    s = np.linspace(0.0, 90.0, 36)
    y = rng.normal(0, 0.0005, 36)
    y[[5, 15, 25]] += 0.02
    assert len(screen(y, s).dropped) == 3
    with pytest.raises(MeasurementError, match=r"^p\.csv: error: 3 of 36 points lie more than .* smooth profile"):
        screen(y, s, path="p.csv", max_fraction=0.05)


def test_two_points_are_not_screened_and_three_show_one_bad_point():
    result = screen([0.0, 0.02], [0.0, 1.0])
    assert result.kept.all() and "too few to screen" in result.notes[0]
    three = screen([0.0, 0.02, 0.0005], [0.0, 1.0, 2.0])
    assert list(three.kept) == [True, False, True]
    assert three.deviation[1] == pytest.approx(0.00025)  # interpolated from the other two


# -- per feature, never across a corner ---------------------------------------------------------------------------

STEP = Profile((
    Line(0.0, 40.0, 25.0, 40.0),  # an end face, material below
    Line(25.0, 40.0, 25.0, 0.0),  # a diameter: a square corner between them
))


def stepped(tmp_path, face_error: float, diameter_error: float, extra: dict[int, float] | None = None,
            noise: float = 0.0003, seed: int = 3):
    """Touches on the end face and the diameter, each with its own error (a tool set long in X,
    push-off along each normal): the error steps at the corner."""
    rng = np.random.default_rng(seed)
    face = np.column_stack([np.linspace(1.0, 24.0, 12), np.full(12, 40.0)])
    diameter = np.column_stack([np.full(14, 25.0), np.linspace(39.0, 1.0, 14)])
    normals = np.concatenate([np.tile([0.0, 1.0], (12, 1)), np.tile([1.0, 0.0], (14, 1))])
    error = np.concatenate([np.full(12, face_error), np.full(14, diameter_error)]) + rng.normal(0.0, noise, 26)
    for index, value in (extra or {}).items():
        error[index] += value
    surface = np.concatenate([face, diameter]) + error[:, None] * normals
    lines = write_probe(tmp_path / "p.csv", surface, normals)
    return read_probe(str(tmp_path / "p.csv")), error, lines


def test_a_step_at_a_corner_is_not_an_outlier_and_a_nub_on_its_feature_is(tmp_path):
    probe, error, lines = stepped(tmp_path, 0.002, 0.013, extra={0: 0.02})
    result = probe_profile(probe, STEP, lines=(5, 6))
    assert [(d.row, d.kind) for d in result.screening.dropped] == [(lines[0], "nub")]  # 1 mm from the axis
    assert list(result.feature) == [0] * 12 + [1] * 14
    assert np.allclose(result.cleaned[1:], error[1:], atol=1e-6)  # the file's 7 decimals
    assert result.cleaned[0] == pytest.approx(0.002, abs=0.001)  # from the face's own touches
    assert any(note.startswith("the face on line 5: 12 points") for note in result.notes)
    # screened as one run of points, the corner's 11 um step throws out good touches on both sides
    across = screen(result.deviation, result.deviations.nearest.s, floor=0.002)
    assert {d.index for d in across.dropped} - {0}


def test_few_touches_on_a_feature_are_judged_among_themselves():
    s = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    trend = 0.010 - 0.001 * s  # a real slope along the feature: nothing to drop
    assert screen(trend, s).kept.all() and screen(trend[:3], s[:3]).kept.all()
    four = screen(trend[:4] + [0.0, 0.0, 0.03, 0.0], s[:4])  # the three on a line stand for the four
    assert list(four.kept) == [True, True, False, True] and four.deviation[2] == pytest.approx(trend[2], abs=1e-9)
    three = screen([0.041, 0.010, 0.007], s[:3])  # the nub at one end of three: judged against the other two
    assert list(three.kept) == [False, True, True] and three.deviation[0] == pytest.approx(0.013, abs=1e-9)
    grouped = screen(np.concatenate([trend[:3], trend[:2]]), np.concatenate([s[:3], s[:2]]), groups=[0, 0, 0, 1, 1],
                     names=["the face on line 4", "the diameter on line 5"])
    assert "the diameter on line 5: 2 points: too few to screen for outliers (at least 3); none dropped" \
        in grouped.notes


@settings(max_examples=200, deadline=None)
@example(n=4, bad=3, length=5.0, level=0.0, slope=0.0, bow=0.001, spike=0.008, seed=2)
@given(n=st.integers(4, 5), bad=st.integers(0, 4), length=st.floats(5.0, 120.0), level=st.floats(-0.03, 0.03),
       slope=st.floats(-2e-4, 2e-4), bow=st.floats(-0.001, 0.001), spike=st.floats(0.008, 0.05),
       seed=st.integers(0, 2**16))
def test_one_bad_touch_among_four_or_five_is_dropped_wherever_it_lies(n, bad, length, level, slope, bow, spike, seed):
    """A few touches spread along a feature (as `probe-program` places them, give or take a
    quarter of their spacing), whose error bows by up to 1 um: a touch 8 um or more off is the
    one dropped, at an end (the nub at the pole) as well as between, and no good one is.
    (Touches bunched together cannot tell one high touch from a steep trend, nor can four
    touches tell an end touch 8 um high from a bow of 2 um: three of them then lie as well on a
    line through it.)"""
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, length, n) + rng.uniform(-0.25, 0.25, n) * length / (n - 1)
    u = s / length
    y = level + slope * s + bow * 4.0 * u * (1.0 - u) + rng.normal(0.0, 0.0002, n)
    bad = bad % n
    y[bad] += spike
    result = screen(y, s, floor=0.002)
    assert [d.index for d in result.dropped] == [bad]


def test_a_feature_with_too_many_bad_points_names_itself():
    s = np.arange(20.0)
    y = np.random.default_rng(1).normal(0.0, 0.0003, 20)
    y[[2, 5, 8, 11, 14, 17]] += 0.02
    with pytest.raises(MeasurementError, match=r"^p\.csv: error: the face on line 4: 6 of 20 points lie more than"):
        screen(y, s, groups=np.zeros(20, dtype=int), names=["the face on line 4"], path="p.csv")


@pytest.mark.parametrize("change_mm, found", [(0.05, "smaller than it is, more than the 50 um"),
                                               (-0.05, "larger than it is at the median touch")])
def test_a_calibration_with_a_wrong_artifact_radius_is_refused(tmp_path, change_mm, found):
    """A touch-trigger probe reads the artifact smaller than it is, by its pretravel (a few um to
    a few tens): the sample calibration with its artifact_radius_mm off by 0.05 mm reads it
    larger, or smaller by far more, and would set a pretravel that moves every probed point."""
    from support import SAMPLES

    text = (SAMPLES / "probe" / "artifact-calibration.csv").read_text()
    line = next(l for l in text.splitlines() if l.startswith("# artifact_radius_mm"))
    radius = float(line.split("=")[1])
    edited = tmp_path / "cal.csv"
    edited.write_text(text.replace(line, f"# artifact_radius_mm = {radius + change_mm:.4f}"))
    fit_calibration(read_calibration(str(SAMPLES / "probe" / "artifact-calibration.csv")))  # the sample itself fits
    with pytest.raises(MeasurementError, match="artifact_radius_mm or stylus_radius_mm") as refused:
        fit_calibration(read_calibration(str(edited)))
    assert found in str(refused.value) and str(refused.value).startswith(str(edited))
