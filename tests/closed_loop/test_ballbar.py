"""ballbar-inverse and iterative in closed loop on the virtual lathe.

A ballbar test at the hemishell's own radius (57.15 mm, about the work origin, G03 like the
arc) on the Table 6.7 machine; the arc cut uncompensated, compensated by one inversion of the
trace (eq. 6.1), and by iterations (eq. 6.2) whose later residuals are the virtual CMM's radial
deviations of the previous cut (as the source's iterations measured each compensated path
again). Everything goes through the command line.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from support.closed_loop import HEMISHELL, MACHINE, cli, inspected

SAME_RADIUS = MACHINE.replace("radius_mm = 100.0", "radius_mm = 57.15").replace("points = 34", "points = 91")


def _trace_from_cmm(result: dict, path: Path) -> str:
    """A cut's radial deviations as a ballbar trace (processed form, already centred)."""
    rows = []
    for point in result["points"]:
        theta = math.degrees(math.atan2(point["z_mm"], point["x_mm"]))
        rows.append(f"{theta:.6f},{point['deviation_mm']:.7f}")
    path.write_text("# postproc ballbar 1\n# radius_mm = 57.15\n# direction = ccw\n# centered = true\n"
                    "angle_deg,deviation_mm\n" + "\n".join(rows) + "\n")
    return str(path)


@pytest.fixture(scope="module")
def loop(tmp_path_factory):
    folder = tmp_path_factory.mktemp("ballbar-loop")
    machine = folder / "machine.toml"
    machine.write_text(SAME_RADIUS)
    trace = str(folder / "ccw.csv")
    result = cli("simulate", "ballbar", "--machine", str(machine), "--direction", "ccw", "-o", trace)
    assert result.exit_code == 0, result.stderr
    cuts = {"none": inspected(HEMISHELL, machine, folder)}
    traces = [trace]
    for iteration in (1, 2, 3):
        program = str(folder / f"iteration{iteration}.nc")
        plugin = "ballbar-inverse" if iteration == 1 else "iterative"
        args = [arg for t in traces for arg in ("--ballbar", t)]
        result = cli("compensate", HEMISHELL, "--plugin", plugin, *args, "--option", "max-gap=10", "-o", program)
        assert result.exit_code == 0, result.stderr
        cuts[iteration] = inspected(program, machine, folder)
        traces.append(_trace_from_cmm(cuts[iteration], folder / f"residual{iteration}.csv"))
    return cuts


def test_one_inversion_cuts_the_spread_at_least_three_times(loop):
    assert loop[1]["std_um"] * 3 <= loop["none"]["std_um"]


def test_iterations_are_no_worse_and_reach_the_noise_floor_by_the_third(loop):
    assert loop[3]["std_um"] <= loop[1]["std_um"] * 1.05
    assert loop[3]["mean_abs_um"] <= loop[1]["mean_abs_um"] * 1.05
    assert loop[3]["std_um"] < 1.0  # the pitch term and rounding: what no inversion of a circle removes
