"""Error budgets: the arithmetic of docs/methods.md §11, the file's checks, and ``postproc budget``."""

from __future__ import annotations

import json
import math

import pytest
from click.testing import CliRunner
from support import SAMPLES

from postproc.measure.budget import read_budget
from postproc.diagnostics import MeasurementError

SMALL = """\
name = "small"
travel_mm = 50.0

[[source]]
name = "repeatability"
group = "stability"
distribution = "gaussian"
pv_mm = { x = 0.006, z = 0.012 }

[[source]]
name = "positioning"
group = "length based"
distribution = "uniform"
pv_um_per_mm = { x = 0.1 }

[[source]]
name = "runout"
group = "stability"
distribution = "sinusoidal"
pv_mm = { z = 0.004 }
x-checked-by = "me"
"""


@pytest.fixture
def budget(tmp_path):
    def write(text: str, name: str = "b.toml") -> str:
        path = tmp_path / name
        path.write_text(text)
        return str(path)

    return write


@pytest.fixture
def cli():
    """``postproc budget ...`` through the real command line."""
    from postproc.cli.main import main

    def invoke(*args: str):
        return CliRunner().invoke(main, ["budget", *args], catch_exceptions=False)

    return invoke


def test_the_arithmetic_is_exact_on_a_small_budget(budget):
    b = read_budget(budget(SMALL))
    assert b.axes == ("x", "z") and b.groups == ("stability", "length based") and b.gaussian_sigmas == 6.0
    repeatability, positioning, runout = b.sources
    assert repeatability.rms == {"x": 0.001, "z": 0.002}  # PV = 6 sigma
    assert positioning.pv == {"x": pytest.approx(0.005, rel=1e-15)}  # 0.1 um/mm * 50 mm
    assert positioning.rms["x"] == pytest.approx(0.005 / (2 * math.sqrt(3)), rel=1e-15)
    assert runout.rms["z"] == pytest.approx(0.004 / (2 * math.sqrt(2)), rel=1e-15)
    total = b.total()
    assert total.pv == {"x": pytest.approx(0.011, rel=1e-15), "z": pytest.approx(0.016, rel=1e-15)}
    rms_x = math.sqrt(0.001**2 + (0.005 / (2 * math.sqrt(3))) ** 2)
    rms_z = math.sqrt(0.002**2 + (0.004 / (2 * math.sqrt(2))) ** 2)
    assert total.rms == {"x": pytest.approx(rms_x, rel=1e-15), "z": pytest.approx(rms_z, rel=1e-15)}
    assert total.estimate["x"] == pytest.approx((0.011 + rms_x) / 2, rel=1e-15)
    stability = b.total("stability")
    assert stability.pv == {"x": 0.006, "z": 0.016} and stability.rms["x"] == 0.001


def test_the_gaussian_convention_and_the_travel_can_be_overridden(budget):
    text = SMALL.replace('travel_mm = 50.0', 'travel_mm = 50.0\ngaussian_pv_sigmas = 4')
    text = text.replace('pv_um_per_mm = { x = 0.1 }', 'pv_um_per_mm = { x = 0.1 }\ntravel_mm = { x = 20.0 }')
    b = read_budget(budget(text))
    assert b.sources[0].rms == {"x": 0.0015, "z": 0.003}
    assert b.sources[1].pv["x"] == pytest.approx(0.002, rel=1e-15) and b.sources[1].travel == {"x": 20.0}


@pytest.mark.parametrize("change, message", [
    (('name = "small"', 'name = "small"\ntravell_mm = 3'),
     r"b\.toml:2: error: unknown key 'travell_mm' at the top of the budget \(known: gaussian_pv_sigmas, name, "
     r"source, travel_mm; keys of your own start with x-\)"),
    (('group = "length based"', 'group = "length based"\npv = 1'),
     r"b\.toml:13: error: unknown key 'pv' in \[\[source\]\]"),
    (('pv_mm = { z = 0.004 }', 'pv_mm = { w = 0.004 }'), r"b\.toml:20: error: unknown axis 'w' in pv_mm"),
    (('distribution = "sinusoidal"', 'distribution = "normal"'),
     r"b\.toml:19: error: source 'runout': distribution = 'normal': expected gaussian, uniform, sinusoidal"),
    (('pv_mm = { z = 0.004 }', 'pv_mm = { z = -0.004 }'), r"b\.toml:20: error: pv_mm\.z must be zero or more"),
    (('travel_mm = 50.0\n', ''), r"b\.toml:13: error: source 'positioning' is length based: give travel_mm"),
    (('pv_mm = { z = 0.004 }', 'pv_mm = { z = 0.004 }\npv_um_per_mm = { z = 1 }'),
     r"b\.toml:16: error: source 'runout': give exactly one of pv_mm and pv_um_per_mm"),
    (('name = "runout"', 'name = "runout\n'), r"b\.toml:17:15: error: not valid TOML: Illegal character"),
])
def test_a_wrong_file_names_the_file_line_and_key(budget, change, message):
    with pytest.raises(MeasurementError, match=message) as caught:
        read_budget(budget(SMALL.replace(*change)))
    assert caught.value.exit_code == 3


def test_the_sample_budget_reads_and_adds_up():
    b = read_budget(str(SAMPLES / "budget" / "v40r-budget.toml"))
    assert b.groups == ("length based", "stability") and b.axes == ("x", "y", "z")
    assert len(b.sources) == 11
    total, parts = b.total(), [b.total(g) for g in b.groups]
    for axis in b.axes:
        assert total.pv[axis] == pytest.approx(sum(p.pv[axis] for p in parts))
        assert total.rms[axis] == pytest.approx(math.hypot(*(p.rms[axis] for p in parts)))
    repeatability = next(s for s in b.sources if s.name == "linear positioning repeatability")
    assert repeatability.pv == {"x": 0.006, "z": 0.010}  # Table 3.1: +-0.003, +-0.005 mm


def test_cli_prints_the_table_on_stdout(cli, budget):
    result = cli(budget(SMALL))
    assert (result.exit_code, result.stderr) == (0, "")
    lines = result.stdout.splitlines()
    assert lines[0].startswith("error budget: small (") and "PV = 6 sigma" in lines[1]
    assert lines[-1].split() == ["total", "11.000", "16.000", f"{rms_um('x'):.3f}", f"{rms_um('z'):.3f}",
                                 f"{(11 + rms_um('x')) / 2:.3f}", f"{(16 + rms_um('z')) / 2:.3f}"]
    assert lines[-3].split()[:3] == ["stability", "6.000", "16.000"]
    assert any(line.split()[:4] == ["positioning", "uniform", "5.000", "-"] for line in lines)


def rms_um(axis: str) -> float:
    if axis == "x":
        return 1000 * math.sqrt(0.001**2 + (0.005 / (2 * math.sqrt(3))) ** 2)
    return 1000 * math.sqrt(0.002**2 + (0.004 / (2 * math.sqrt(2))) ** 2)


def test_cli_json_is_one_object_in_millimetres(cli, budget):
    result = cli(budget(SMALL), "--json")
    assert (result.exit_code, result.stderr) == (0, "")
    data = json.loads(result.stdout)
    assert data["total"]["x"] == {"pv_mm": pytest.approx(0.011), "rms_mm": pytest.approx(rms_um("x") / 1000),
                                  "estimate_mm": pytest.approx((0.011 + rms_um("x") / 1000) / 2)}
    assert set(data["groups"]) == {"stability", "length based"}
    assert data["sources"][1]["pv_um_per_mm"] == {"x": 0.1} and data["sources"][1]["travel_mm"] == {"x": 50.0}
    assert data["gaussian_pv_sigmas"] == 6.0 and data["axes"] == ["x", "z"]


def test_cli_refuses_a_bad_file_with_exit_code_3_and_nothing_on_stdout(cli, budget):
    path = budget(SMALL.replace('group = "stability"', 'grup = "stability"', 1))
    result = cli(path)
    assert result.exit_code == 3
    assert result.stdout == ""
    assert result.stderr.startswith(f"{path}:6: error: unknown key 'grup' in [[source]]")
    missing = cli(path + ".nope")
    assert (missing.exit_code, missing.stdout) == (3, "")
    assert missing.stderr == f"{path}.nope: error: cannot read the file: No such file or directory\n"
