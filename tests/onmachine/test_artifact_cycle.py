"""Finding the calibration sphere on the machine (postproc.onmachine.artifact_cycle, ``artifact-program``,
``artifact-find``): each round's program run on an emulated control whose skips the virtual
lathe latches on an off-plane ball, its printout imported, the rounds iterated through the
command line until the centre stays, and the calibration written about the found ball.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from postproc.diagnostics import EXIT_BAD_INPUT, EXIT_REFUSED, EXIT_USAGE, EXIT_WOULD_CHANGE
from postproc.measure.readers.probe import read_calibration
from postproc.measure.pretravel import fit_calibration
from postproc.simulator import calibrate, generator
from postproc.simulator.files import calibration_text
from postproc.simulator.surface import Circle
from postproc.simulator.touch import Touch as SimTouch, run as sim_run
from support.artifact import R, STYLUS, expected, lathe
from support.control import run_on_control, skips

NEXT = re.compile(r"--center-x (?P<x>[-\d.]+) --center-z (?P<z>[-\d.]+)")


def latch_on_ball(text: str, simulation, rng) -> list[tuple[float, float]]:
    """Where the virtual lathe's probe triggers on each skip move of a program."""
    a = simulation.artifact
    ball = Circle((a.center_x_mm, a.center_z_mm), math.sqrt(a.radius_mm**2 - a.y_offset_mm**2))
    touches = []
    for start, end, _ in skips(text):
        n = (end - start) / np.linalg.norm(end - start)
        touches.append(SimTouch(ball, start + (STYLUS + simulation.probe.standoff_mm) * n, n, 0.0, "skip"))
    return [tuple(p) for p in sim_run(touches, simulation, rng, "lathe")]


def one_round(run, tmp_path: Path, number: int, estimate, simulation, rng) -> str:
    program = tmp_path / f"round{number}.nc"
    made = run("artifact-program", "--center-x", f"{estimate[0]}", "--center-z", f"{estimate[1]}", "--artifact-radius",
               f"{R}", "--clearance", "2.5", "--tool", "T0909", "-o", str(program))
    assert made.exit_code == 0 and made.stdout == "", made.stderr
    text = program.read_text()
    printout = tmp_path / f"round{number}.txt"
    printout.write_text(run_on_control(text, latch_on_ball(text, simulation, rng)))
    probe = tmp_path / f"round{number}.csv"
    imported = run("probe-import", str(printout), "-o", str(probe))
    assert imported.exit_code == 0, imported.stderr
    return str(probe)


@pytest.fixture(scope="module")
def ball():
    """The ball 0.3 mm off the plane, 1.3 mm from where the eye puts it."""
    return lathe(84.2, 18.6, 0.3, standoff_mm=2.5)  # the approaches start at the clearance


def test_the_rounds_run_through_the_command_line_until_the_centre_stays(run, tmp_path, ball):
    rng = generator(7, "artifact")
    estimate, rounds = (83.5, 19.7), []
    for number in range(1, 6):
        rounds.append(one_round(run, tmp_path, number, estimate, ball, rng))
        found = run("artifact-find", *rounds, "--artifact-radius", f"{R}")
        assert found.stdout == ""
        taken = re.search(rf"{re.escape(rounds[-1])}: round {number} at x ([\d.]+) z ([\d.]+): centre x", found.stderr)
        assert math.hypot(float(taken[1]) - estimate[0], float(taken[2]) - estimate[1]) < 0.002  # the probe's noise
        if found.exit_code == 0:
            break
        assert found.exit_code == EXIT_WOULD_CHANGE, found.stderr
        assert "not converged" in found.stderr and "take the next round at the finding" in found.stderr
        match = NEXT.search(found.stderr)
        estimate = (float(match["x"]), float(match["z"]))
    assert found.exit_code == 0 and 2 <= len(rounds) <= 3, found.stderr
    centre = re.search(r"artifact centre x ([\d.]+) z ([\d.]+) mm, apparent radius ([\d.]+) mm", found.stderr)
    x, z, radius = expected(ball)
    # as through the library (test_artifact), the printout's four places adding 0.1 um
    assert math.hypot(float(centre[1]) - x, float(centre[2]) - z) <= 0.0025
    assert float(centre[3]) == pytest.approx(radius, abs=0.0015)

    sweep = tmp_path / "sweep.csv"
    sweep.write_text(calibration_text(calibrate(ball, generator(7, "sweep")), {"simulated-by": "test"}))
    out = tmp_path / "calibration.csv"
    written = run("artifact-find", *rounds, "--artifact-radius", f"{R}", "--sweep", str(sweep), "-o", str(out))
    assert written.exit_code == 0 and written.stdout == "", written.stderr
    calibration = read_calibration(str(out))
    assert calibration.artifact_centre == pytest.approx((float(centre[1]), float(centre[2])), abs=1e-4)
    assert calibration.artifact_radius == pytest.approx(float(centre[3]), abs=1e-4)
    assert calibration.extras["x-artifact-certified-radius-mm"] == "25.4"
    model = fit_calibration([calibration])
    assert abs(float(model.k_of(np.array([90.0]))[0])) < 0.0008  # k is the probe's about the found ball
    stdout = run("artifact-find", *rounds, "--artifact-radius", f"{R}", "--sweep", str(sweep))
    assert stdout.exit_code == 0 and stdout.stdout == out.read_text()


def test_the_program_touches_pole_and_sides_from_clear_of_the_ball(run):
    made = run("artifact-program", "--center-x", "80", "--center-z", "30", "--artifact-radius", "25.4",
               "--clearance", "3", "--tool", "T0909")
    assert made.exit_code == 0
    assert made.stderr == ("artifact: probing program O8100: the pole, +X and -X of a 25.4 mm ball at x 80 z 30; read "
                           "its printout with 'postproc probe-import', then 'postproc artifact-find'\n")
    moves = [(start, end) for start, end, _ in skips(made.stdout)]
    assert [tuple(np.round(s, 4)) for s, _ in moves] == [(80.0, 61.4), (111.4, 30.0), (48.6, 30.0)]
    assert [tuple(np.round(e, 4)) for _, e in moves] == [(80.0, 55.4), (105.4, 30.0), (54.6, 30.0)]
    assert "(ARTIFACT R25.4 MM AT X 80.0000 Z 30.0000, POLE +X -X, STYLUS R3 MM, CLEARANCE 3 MM)" in made.stdout
    check = run("check", "-", input=made.stdout)
    assert check.exit_code == 0, check.stderr


def test_a_ball_too_near_the_axis_is_refused_and_bad_options_named(run):
    near = run("artifact-program", "--center-x", "20", "--center-z", "30", "--artifact-radius", "25.4")
    assert near.exit_code == EXIT_REFUSED and near.stdout == ""
    assert "ARTIFACT: error: the -X side touch would start at x -9.400 mm, past the spindle axis" in near.stderr
    negative = run("artifact-program", "--center-x", "80", "--center-z", "30", "--artifact-radius", "-1")
    assert negative.exit_code == EXIT_BAD_INPUT and "--artifact-radius -1: must be positive" in negative.stderr
    missing = run("artifact-program", "--center-x", "80", "--center-z", "30")
    assert missing.exit_code == EXIT_USAGE and "--artifact-radius" in missing.stderr
    tolerance = run("artifact-find", "x.csv", "--artifact-radius", "25.4", "--tolerance", "0")
    assert tolerance.exit_code == EXIT_BAD_INPUT and "--tolerance 0: must be positive" in tolerance.stderr
    nothing = run("artifact-find", "x.csv", "--artifact-radius", "25.4", "-o", "calibration.csv")
    assert nothing.exit_code == EXIT_USAGE and "give --sweep FILE" in nothing.stderr


def test_touches_that_are_not_a_round_are_refused_naming_the_file(run, tmp_path):
    path = tmp_path / "round.csv"
    path.write_text("# postproc probe 1\n# stylus_radius_mm = 3\nx_mm,z_mm,approach_x,approach_z\n"
                    "80,58.4,0,-1\n108.4,30,-1,0\n108.4,30.5,-1,0\n")
    refused = run("artifact-find", str(path), "--artifact-radius", "25.4")
    assert refused.exit_code == EXIT_BAD_INPUT and refused.stdout == ""
    assert refused.stderr.startswith(f"{path}: error: a round of finding the artifact is three touches")
    assert "this file has 2 for the +X side and 3 in all" in refused.stderr
    path.write_text("# postproc probe 1\n# stylus_radius_mm = 3\nx_mm,z_mm,approach_x,approach_z\n"
                    "80,58.4,0,-1\n108.4,30,-1,0\n51.6,30,1,0\n")
    wrong = run("artifact-find", str(path), "--artifact-radius", "20")
    assert wrong.exit_code == EXIT_BAD_INPUT and wrong.stdout == ""
    assert "not a section of a ball of radius 20 mm" in wrong.stderr
