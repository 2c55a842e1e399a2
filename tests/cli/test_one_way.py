"""postproc compensate on G71/G72 programs end to end: a contour held to run one way is written,
one that cannot be is refused (exit 4) with one error naming its block and nothing on stdout."""

from __future__ import annotations

import json

import pytest

from support import SAMPLES
from support.cycles import turn_backs
from postproc.compensate.models import build, dumps
from postproc.machine.profile import DEFAULT

SHAFT = ("G18 G21 G99\nG00 X60. Z5.\nG71 U1. R0.5\nG71 P10 Q20 U0.2 W0.1 F0.2\nN10 G00 X20.\nG01 Z0. F0.1\n"
         "X30.\nZ-60.\nN20 X60.\nG70 P10 Q20\nM30\n")


@pytest.fixture(scope="module")
def sample_model(tmp_path_factory):
    """The sample machine's parametric model, fitted from its two ballbar traces."""
    from click.testing import CliRunner
    from postproc.cli.main import main

    path = tmp_path_factory.mktemp("model") / "model.json"
    result = CliRunner().invoke(main, ["fit", "--plugin", "parametric", "--ballbar",
                                       str(SAMPLES / "ballbar" / "v40r-100-ccw.csv"), "--ballbar",
                                       str(SAMPLES / "ballbar" / "v40r-100-cw.csv"), "-o", str(path)])
    assert result.exit_code == 0, result.stderr
    return path


def with_squareness(model_path, squareness: float, folder):
    """The model with its squareness (X error per unit Z) set: a shaft's diameter then wants a
    taper of that slope taken out."""
    data = json.loads(model_path.read_text())
    model = data["model"]
    model["parameters"]["squareness"][0] = squareness
    path = folder / f"square{squareness:g}.json"
    path.write_text(dumps(build(data["plugin"], data["plugin_version"], model,
                                [(entry["file"], entry["sha256"]) for entry in data["inputs"]],
                                DEFAULT, data["options"], data["note"], data["measured"])))
    return path


def test_the_sample_g71_program_compensates_with_the_sample_model(run, sample_model):
    """The hemishell's G71/G70 finish on the sample machine: written (exit 0), its contour one
    way in X and Z as the control checks it, its approach moving X only (still type I)."""
    result = run("compensate", str(SAMPLES / "programs" / "hemishell_g71.nc"), "--model", str(sample_model))
    assert result.exit_code == 0, result.stderr
    assert "error" not in result.stderr and "blocks replaced" in result.stderr
    out = result.stdout
    assert turn_backs(out) == []
    approach = next(line for line in out.splitlines() if line.startswith("N10"))
    assert approach.startswith("N10 G00 X") and "Z" not in approach


def test_a_taper_the_cycle_cannot_cut_is_refused(run, sample_model, tmp_path):
    """A squareness error of 0.3 mm/m asks the 60 mm diameter of a G71 type I shaft to shrink by
    18 um towards the chuck: its X would run back, which the control alarms on. Exit 4, one
    error naming the block and the rule, nothing on stdout."""
    program = tmp_path / "shaft.nc"
    program.write_text(SHAFT)
    result = run("compensate", str(program), "--model", str(with_squareness(sample_model, -3e-4, tmp_path)))
    assert result.exit_code == 4
    assert result.stdout == ""
    errors = [line for line in result.stderr.splitlines() if ": error: " in line]
    assert len(errors) == 1 and errors[0].startswith(f"{program}:8:1: error: the G71 type I cycle on line 4")
    assert "one way in X and Z (FANUC alarm PS0064/PS0329)" in errors[0] and "9.00 um off" in errors[0]  # held level halfway
    assert "Z-60." in result.stderr  # the block, as written


def test_the_same_taper_the_other_way_is_written(run, sample_model, tmp_path):
    """The opposite squareness widens the diameter towards the chuck: X keeps running one way,
    and the program is written."""
    program = tmp_path / "shaft.nc"
    program.write_text(SHAFT)
    result = run("compensate", str(program), "--model", str(with_squareness(sample_model, 3e-4, tmp_path)))
    assert result.exit_code == 0, result.stderr
    assert turn_backs(result.stdout) == []
    assert "N10 G00 X19.991\n" in result.stdout  # the approach ends where the corrected contour starts, in X


SHARED = ("G18 G21 G99\nG00 X100. Z5.\n{first} P10 Q20 U0.2 W0.1 F0.2\nN10 G00 X20.\nG01 Z-10. F0.1\nX40. Z-30.\n"
          "Z-45.\nN20 X100.\nG00 X100. Z5.\n{second} P10 Q20 U0.2 W0.1 F0.2\nG70 P10 Q20\nM30\n")


@pytest.mark.parametrize("first, second, refused", [
    ("G71", "G72", True), ("G72", "G71", True), ("G73", "G71", True), ("G73", "G72", True),
    ("G71", "G71", False), ("G72", "G72", False), ("G71", "G73", False),
])
def test_a_contour_run_by_two_kinds_of_cycle_is_held_to_both_or_refused(run, sample_model, tmp_path, first, second,
                                                                        refused):
    """A compensated contour is held to the one-way rule of the cycle that runs it first; a later
    G71 or G72 of another kind would judge it by another rule (G71 type II holds Z, G72 type II
    X; a G73 holds none), so compensating it is refused (exit 4, at the later cycle's P word,
    nothing on stdout). The same kind again, or a G73 after, needs nothing more. ``check``
    leaves the program as it stands to the control."""
    program = tmp_path / "shared.nc"
    program.write_text(SHARED.format(first=first, second=second))
    assert run("check", str(program)).exit_code == 0
    result = run("compensate", str(program), "--model", str(sample_model))
    if refused:
        assert result.exit_code == 4 and result.stdout == ""
        assert f"{program}:10:5: error: {second}: its contour N10..N20 was run first by the {first} on line 3" \
            in result.stderr
    else:
        assert result.exit_code == 0, result.stderr
        assert turn_backs(result.stdout) == []


TURNING_BACK = """%
O1004 (G71 TURNING BACK)
G18 G21 G40 G99
T0101
G00 X130. Z65.
G71 U2. R0.5
G71 P10 Q20 U0.5 W0.1 F0.25
N10 G00 X20.
G01 Z50. F0.08
X60. Z30.
X50. Z20.
N20 G01 X130. Z0.
G70 P10 Q20
G00 X200. Z150.
M30
%
"""
TURNS = ("the G71 type I cycle on line 7 needs its contour to run one way in X and Z; as written it turns back in X "
         "here, by 5.000 mm: the control stops the cycle on it with alarm PS0329")


def test_a_contour_that_turns_back_as_written_is_warned_of_by_check(run, tmp_path):
    program = tmp_path / "o1004.nc"
    program.write_text(TURNING_BACK)
    result = run("check", str(program))
    assert result.exit_code == 0
    assert result.stdout == ""
    assert result.stderr == (f"{program}:11:1: warning: {TURNS}; compensate refuses the program\n"
                             "    X50. Z20.\n    ^\n"
                             f"{program}: ok: 16 lines, 14 moves, 1 warnings\n")


def test_a_contour_that_turns_back_as_written_is_refused_by_compensate(run, sample_model, tmp_path):
    program = tmp_path / "o1004.nc"
    program.write_text(TURNING_BACK)
    target = tmp_path / "out.nc"
    result = run("compensate", str(program), "--model", str(sample_model), "-o", str(target))
    assert result.exit_code == 4
    assert result.stdout == ""
    assert result.stderr == (f"{program}:11:1: error: {TURNS}: the program cannot run as it is, refused; make the "
                             "contour (its P..Q blocks) run one way in X\n    X50. Z20.\n    ^\n")
    assert not target.exists()
