"""The virtual CMM (postproc.simulator.cmm): a point that lands on a corner, or beside a corner
the cut moved, measures its feature like its neighbours do; it is never refused for it."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings, strategies as st

from postproc.simulator import cut, inspect, load, nominal
from postproc.simulator.nominal import run_program
from postproc.diagnostics import Reporter
from support import SAMPLES

MACHINE = str(SAMPLES / "machines" / "v40r-sim.toml")
HEMISHELL = str(SAMPLES / "programs" / "hemishell.nc")


def shoulders(tmp_path, steps: list[tuple[int, int]]) -> str:
    """A turned shaft of shoulders: each (length along -Z, radius step along +X), whole mm, from x 20 z 2."""
    lines = ["%", "O0001", "G18 G21 G40 G99", "T0101", "G00 X40. Z2."]
    x, z = 20, 2
    for index, (length, step) in enumerate(steps):
        z -= length
        lines.append(f"G01 Z{z}.{' F0.1' if index == 0 else ''}")
        x += step
        lines.append(f"G01 X{2 * x}.")
    lines += [f"G00 X{2 * x + 20}.", "M30", "%"]
    path = tmp_path / "shaft.nc"
    path.write_text("\n".join(lines) + "\n")
    return str(path)


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(steps=st.lists(st.tuples(st.integers(2, 12), st.integers(1, 6)), min_size=1, max_size=3),
       per_mm=st.sampled_from([1, 2, 5]))
def test_points_exactly_on_the_corners_measure_as_their_neighbours(tmp_path_factory, steps, per_mm):
    """Stations every 1/per_mm mm from a whole-mm start: every corner of the shaft is a station."""
    program = shoulders(tmp_path_factory.mktemp("shaft"), steps)
    simulation, profile = load(MACHINE)
    name, moves, wear = run_program(program, profile, Reporter())
    shaft = nominal(moves, program=name)
    sides = [n for pair in steps for n in pair]  # along -Z, then along +X, in turn
    count = sum(sides) * per_mm + 1
    result = inspect(cut(moves, shaft, simulation, wear), shaft, simulation, None, count)
    assert np.allclose(np.diff(result.s), 1.0 / per_mm)
    corners = np.cumsum(sides)[:-1]
    on_corner = np.isin(np.round(result.s, 9), corners)
    assert on_corner.sum() == len(corners)
    deviations = result.deviations
    for index in np.flatnonzero(on_corner):
        near = deviations[[index - 1, index + 1]] if index + 1 < count else deviations[[index - 1]]
        assert np.min(np.abs(deviations[index] - near)) < 0.005, (index, deviations[index], near)


def test_five_thousand_points_along_the_hemishell_reach_the_equator(run):
    """One of them lands 1 um from the equator's corner, where the face the cut left is 8 um high."""
    result = run("simulate", "inspect", HEMISHELL, "--machine", MACHINE, "--points", "5000")
    assert (result.exit_code, result.stderr) == (0, "")
    assert result.stdout.startswith(f"{HEMISHELL}: mean ")
