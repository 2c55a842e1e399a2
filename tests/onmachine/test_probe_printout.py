"""The printout of a probing program read in its own units (postproc.onmachine.probe_printout):
a header whose G 20 / G 21 does not match its numbers, a stylus radius or a position no probe or
lathe has, a --stylus-radius in another unit, and a run cut short are each one error naming the
printout's line and the likely cause; a printout that is right in either unit is read as it is.
The printout's other rules are tested with the probing program (test_probe_cycle.py)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import given, settings, strategies as st

from postproc.cli.main import main
from postproc.diagnostics import EXIT_BAD_INPUT
from postproc.measure.readers.probe import read_probe
from support import SAMPLES

HEMISHELL = str(SAMPLES / "programs" / "hemishell.nc")
R_PART, STYLUS = 57.15, 3.0
ANGLES = [5 + 80 * j / 11 for j in range(12)]


def printout(units: int = 21, divisor: int = 2, radius: float = STYLUS, scale: float | None = None,
             datum: bool = True, end: bool = True) -> str:
    """A printout of 12 touches on the hemishell's dome (perfect part), as a control prints it:
    in ``units``, X divided by ``divisor``; ``scale`` (default: that of ``units``) turns mm into the
    printed numbers, so a header and its numbers can disagree."""
    scale = (1 / 25.4 if units == 20 else 1.0) if scale is None else scale
    lines = [f"POSTPROC PROBE V 1 O 8100 G {units} D {divisor} R {radius:9.4f} N 12"]
    if datum:
        lines.append(f"DATUM BEFORE X {190 * scale:9.4f} Z {13.006 * scale:9.4f} I .00000 K -1.00000")
    for number, angle in enumerate(ANGLES, start=1):
        t = math.radians(angle)
        x, z = (R_PART + STYLUS) * math.cos(t), (R_PART + STYLUS) * math.sin(t)
        lines.append(f"POINT {number:4d} X {x * divisor * scale:9.4f} Z {z * scale:9.4f} I {-math.cos(t):.5f} "
                     f"K {-math.sin(t):.5f}")
    if datum:
        lines.append(f"DATUM AFTER X {190 * scale:9.4f} Z {13.007 * scale:9.4f} I .00000 K -1.00000")
    if end:
        lines.append("END")
    return "\r\n".join(lines) + "\r\n"


def _import(tmp_path: Path, text: str, *options: str):
    path = tmp_path / "printout.txt"
    path.write_text(text)
    out = tmp_path / "probe.csv"
    result = CliRunner().invoke(main, ["probe-import", str(path), "-o", str(out), *options], catch_exceptions=False)
    return str(path), str(out), result


def _refused(result, out: str) -> str:
    assert result.exit_code == EXIT_BAD_INPUT and result.stdout == "" and not Path(out).exists(), result.stderr
    errors = [line for line in result.stderr.splitlines() if ": error: " in line]
    assert len(errors) == 1, result.stderr
    return errors[0]


@settings(max_examples=12, deadline=None)
@given(units=st.sampled_from([20, 21]), divisor=st.sampled_from([1, 2]), stylus=st.floats(0.15, 12.5))
def test_a_printout_right_in_either_unit_is_read_in_mm(tmp_path_factory, units, divisor, stylus):
    tmp_path = tmp_path_factory.mktemp("right")
    scale = 1 / 25.4 if units == 20 else 1.0
    _, out, result = _import(tmp_path, printout(units, divisor, radius=round(stylus * scale, 4)))
    assert result.exit_code == 0, result.stderr
    probe = read_probe(out)
    assert abs(probe.centres[0, 0] - (R_PART + STYLUS) * math.cos(math.radians(5))) < 2e-3
    assert abs(probe.datum_before["z"] - 13.006) < 2e-3


def test_a_printout_headed_g20_whose_numbers_are_millimetres_is_refused_naming_the_units(tmp_path):
    """Before: read as inches (a 3 mm stylus as 76.2 mm, the part 25.4 times its size), and the
    datum's 1 um drift, made 25 um, refused as the machine moving (exit 4)."""
    path, out, result = _import(tmp_path, printout(units=20, scale=1.0))
    assert _refused(result, out) == (
        f"{path}:1: error: stylus radius R 3 (G 20): a stylus radius of 76.2 mm is larger than any probe's (balls of "
        "0.3 to 25 mm): millimetres read as inches? (76.2 mm is 3 in: a printout headed G 20 whose numbers are "
        "millimetres)")


def test_a_stylus_radius_in_um_is_refused_at_the_header(tmp_path):
    path, out, result = _import(tmp_path, printout(radius=3000.0))
    assert _refused(result, out).startswith(f"{path}:1: error: stylus radius R 3000 (G 21): a stylus radius of "
                                            "3000 mm is larger than any probe's")
    assert "micrometres written as millimetres? (3000 um is 3 mm)" in result.stderr


@pytest.mark.parametrize("units, scale", [(21, 1000.0), (20, 25.4 * 25.4)])
def test_a_position_beyond_any_lathes_travel_is_refused_at_its_line(tmp_path, units, scale):
    path, out, result = _import(tmp_path, printout(units=units, scale=scale / (25.4 if units == 20 else 1.0),
                                                   radius=STYLUS / (25.4 if units == 20 else 1.0)))
    error = _refused(result, out)
    assert error.startswith(f"{path}:2: error: X ") and "beyond any lathe's travel (10000 mm)" in error


@pytest.mark.parametrize("drop", ["END", "DATUM AFTER"])
def test_a_run_cut_short_is_named_at_its_last_line(tmp_path, drop):
    """Before: 'the printout ends without END' named no line."""
    text = "".join(line for line in printout().splitlines(True) if not line.startswith(drop))
    path, out, result = _import(tmp_path, text)
    error = _refused(result, out)
    if drop == "END":
        assert error == (f"{path}:15: error: the printout ends here without END: the probing program did not finish "
                         "(12 of 12 points printed)")
    else:
        assert error.startswith(f"{path}:2: error: the datum along Z has no DATUM AFTER touch")


@pytest.mark.parametrize("radius, cause", [
    ("0.1181", "inches written as millimetres? (0.1181 in is 2.99974 mm)"),
    ("3000", "micrometres written as millimetres? (3000 um is 3 mm)"),
])
def test_a_stylus_radius_option_in_another_unit_is_refused(tmp_path, radius, cause):
    _, out, result = _import(tmp_path, printout(), "--stylus-radius", radius)
    error = _refused(result, out)
    assert error.startswith(f"postproc: error: --stylus-radius {radius}: the probing program was written for a stylus "
                            "radius of 3 mm; ") and cause in error


def test_a_stylus_radius_option_twice_the_printed_one_is_used_and_said(tmp_path):
    """Another stylus may be fitted: used, with a warning that names the diameter."""
    path, out, result = _import(tmp_path, printout(), "--stylus-radius", "6")
    assert result.exit_code == 0 and read_probe(out).stylus_radius == 6.0
    assert (f"{path}:1: warning: the probing program was written for a stylus radius of 3 mm; 6 mm is used "
            "(--stylus-radius); a diameter where a radius is meant? (halved, 3 mm)") in result.stderr


@pytest.mark.parametrize("header, printed, cause", [
    (1, 2, "a printout's D 1 where X was printed as a diameter, D 2?"),
    (2, 1, "a printout's D 2 where X was printed as a radius, D 1?"),
])
def test_an_x_divisor_that_does_not_match_the_numbers_is_named_by_inspect(tmp_path, header, printed, cause):
    """A D 1 header over diameters doubles every x: inspect named no cause (a part 60 mm off, exit 1)."""
    text = printout(divisor=printed).replace(f" D {printed} ", f" D {header} ", 1)
    _, out, result = _import(tmp_path, text)
    assert result.exit_code == 0
    inspected = CliRunner().invoke(main, ["inspect", HEMISHELL, "--probe", out, "--band", "0.01", "--to-line", "10"],
                                   catch_exceptions=False)
    assert inspected.exit_code == EXIT_BAD_INPUT and inspected.stdout == ""
    assert cause in inspected.stderr
