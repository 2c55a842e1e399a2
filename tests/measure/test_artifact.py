"""Finding the calibration sphere (postproc.measure.artifact, docs/methods.md §9.2.1): the circle through
a round's pole and side touches, the rounds iterated on the virtual lathe until the centre stays,
and what is refused.

The closed loop uses a lathe with no errors of its own but the sample machine's probe (6 um of
pretravel with 1.5 um of three-lobe lobing, 0.5 um of noise): what the finding should be is
then known exactly. The probe in the cutting plane sees the section of radius sqrt(R^2 - y^2),
smaller by the sides' pretravel d_side = (d(0) + d(180)) / 2; its centre x moves by
(d(180) - d(0)) / 2 and its z by d_side - d(90) (the circle through the three points).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from postproc.measure.artifact import MAX_OFF_PLANE, find, finding, round_from_touches, round_of
from postproc.diagnostics import MeasurementError
from postproc.measure.readers.probe import Touches
from postproc.measure.pretravel import fit_calibration
from postproc.measure.readers.probe import CalibrationRun
from postproc.simulator import artifact_round, calibrate, generator
from support.artifact import R, STYLUS, expected, lathe

@given(st.floats(-1.5, 1.5), st.floats(-1.5, 1.5), st.floats(0.0, 1.0), st.integers(0, 10_000))
@settings(max_examples=25, deadline=None)
def test_the_rounds_find_a_ball_off_the_plane_from_an_estimate_by_eye(dx, dz, y, seed):
    """Closed loop: the centre within 2.5 um and the apparent radius within 1.5 um (about 5 sigma of the
    probe's 0.5 um of noise through the circle), in at most 4 rounds."""
    simulation = lathe(83.7, 21.3, y)
    rng = generator(seed, "artifact")
    found = find(lambda estimate: artifact_round(simulation, rng, estimate, standoff=2.5), (83.7 + dx, 21.3 + dz),
                 STYLUS, R)
    x, z, radius = expected(simulation)
    assert math.hypot(found.centre[0] - x, found.centre[1] - z) <= 0.0025
    assert found.apparent_radius == pytest.approx(radius, abs=0.0015)
    assert len(found.rounds) <= 4
    assert found.rounds[-1].moved <= found.tolerance


def test_the_sources_misalignment_shows_as_its_apparent_radius():
    """0.36 mm off the plane costs 2.54 um of radius on the source's ball (its chapter 4); noise-free here."""
    aligned, missed = (lathe(80.0, 30.0, y, noise_mm=0.0, pretravel_mm=0.0, lobing_mm=0.0) for y in (0.0, 0.36))
    radii = [find(lambda e, s=s: artifact_round(s, None, e, standoff=2.0), (79.0, 31.0), STYLUS, R).apparent_radius
             for s in (aligned, missed)]
    assert radii[0] == pytest.approx(R, abs=1e-6)
    assert 1000.0 * (radii[0] - radii[1]) == pytest.approx(2.55, abs=0.01)


def test_the_found_artifact_makes_k_zero_at_the_pole_and_on_average_at_the_sides():
    """The finding feeds the calibration: with it the sweep's k carries the lobing about the pole's and
    sides' pretravel; with the ball taken where it was estimated, k is off by micrometres."""
    simulation = lathe(80.0, 30.0, 0.36)
    rng = generator(4, "artifact")
    found = find(lambda e: artifact_round(simulation, rng, e, standoff=2.0), (80.8, 29.5), STYLUS, R)
    sweep = calibrate(simulation, generator(4, "sweep"))
    run = CalibrationRun("sweep.csv", STYLUS, sweep.centres, sweep.approach, tuple(range(1, len(sweep.centres) + 1)),
                         artifact_radius=found.apparent_radius, artifact_centre=found.centre)
    model = fit_calibration([run])
    pole, sides = model.k_of(np.array([90.0])), model.k_of(np.array([0.0, 180.0]))
    assert abs(float(pole[0])) < 0.0006 and abs(float(np.mean(sides))) < 0.0006
    theta = np.degrees(np.arctan2(-sweep.approach[:, 1], -sweep.approach[:, 0])) % 360.0
    truth = -(simulation.probe.pretravel(theta) - simulation.probe.pretravel(0.0) / 2 - simulation.probe.pretravel(180.0) / 2)
    shift = np.array(found.centre) - np.array(expected(simulation)[:2])
    assert np.sqrt(np.mean((run.factors() - truth) ** 2)) < 0.001 + float(np.hypot(*shift))
    guessed = dataclasses.replace(run, artifact_radius=R, artifact_centre=(80.8, 29.5))
    assert np.sqrt(np.mean((guessed.factors() - truth) ** 2)) > 0.2  # the estimate by eye: k off by tenths of a mm


def test_a_round_is_refused_when_its_touches_cannot_be_on_one_ball():
    pole, plus, minus = (80.0, 58.4), (108.4, 30.0), (51.6, 30.0)
    assert round_of(pole, plus, minus, STYLUS, R).radius == pytest.approx(R + STYLUS)
    with pytest.raises(MeasurementError, match="side touches were taken at z 30.0000 and 30.0200"):
        round_of(pole, plus, (51.6, 30.02), STYLUS, R)
    with pytest.raises(MeasurementError, match="does not lie above and between"):
        round_of((110.0, 58.4), plus, minus, STYLUS, R)
    with pytest.raises(MeasurementError, match="radius 25.4000 mm .* not a section of a ball of radius 20 mm"):
        round_of(pole, plus, minus, STYLUS, 20.0)  # the wrong ball: its section cannot be larger
    small = math.sqrt(R**2 - (MAX_OFF_PLANE + 0.5) ** 2) + STYLUS
    with pytest.raises(MeasurementError, match="realign the ball"):
        round_of((80.0, 30.0 + small), (80.0 + small, 30.0), (80.0 - small, 30.0), STYLUS, R)


def test_a_round_that_moved_is_not_a_finding_and_rounds_that_never_settle_are_refused():
    simulation = lathe(80.0, 30.0, 0.0, noise_mm=0.001)  # 1 um of scatter
    rng = generator(1, "artifact")
    first = round_of(*artifact_round(simulation, rng, (81.0, 30.5), standoff=2.0), STYLUS, R)
    assert finding([first], STYLUS, R) is None
    with pytest.raises(MeasurementError, match=r"did not converge in 3 rounds: the centre moved by [\d.]+, [\d.]+, "
                                               r"[\d.]+ um \(tolerance 0.2 um\)"):
        find(lambda e: artifact_round(simulation, rng, e, standoff=2.0), (81.0, 30.5), STYLUS, R, 0.0002, rounds=3)


def test_a_probe_file_is_a_round_only_with_one_pole_and_two_side_touches():
    centres = np.array([[108.4, 30.0], [80.0, 58.4], [51.6, 30.0]])
    approach = np.array([[-1.0, 0.0], [0.0, -1.0], [1.0, 0.0]])
    touches = Touches("round.csv", STYLUS, centres, approach, (2, 3, 4))
    assert round_from_touches(touches, R).pole == (80.0, 58.4)
    twice = Touches("round.csv", STYLUS, centres, np.array([[-1.0, 0.0], [-1.0, 0.0], [1.0, 0.0]]), (2, 3, 4))
    with pytest.raises(MeasurementError, match="this file has 0 for the pole and 3 in all"):
        round_from_touches(twice, R)
    extra = Touches("round.csv", STYLUS, np.vstack([centres, [[90.0, 50.0]]]),
                    np.vstack([approach, [[-0.6, -0.8]]]), (2, 3, 4, 5))
    with pytest.raises(MeasurementError, match="three touches: this one is not the pole or a side") as error:
        round_from_touches(extra, R)
    assert error.value.location.line == 5
