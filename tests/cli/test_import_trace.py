"""``postproc import-trace``: plain exports of ballbar tests to postproc traces.

The exports are what instruments' software writes: a few lines of text, then angle and
deviation (or raw deviations) with commas, semicolons, tabs or spaces, a decimal comma,
micrometres. Every result is read back by postproc's reader; every bad cell is refused at
its line and column, and nothing is written.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from postproc.measure.readers.ballbar import read_ballbar

ARC = np.arange(-20.0, 200.01, 0.5)  #: a lathe's 220 deg capture


def shape(angles_deg) -> np.ndarray:
    """A trace in um: a peanut, a set-up offset and a step."""
    theta = np.radians(angles_deg)
    return 2.5 * np.cos(2 * theta) + 12.0 * np.cos(theta) - 7.0 * np.sin(theta) + 0.8 * np.sign(np.sin(theta))


def imported(run, tmp_path, text: str, *options: str, name: str = "export.csv"):
    source = tmp_path / name
    source.write_text(text)
    target = tmp_path / "trace.csv"
    result = run("import-trace", str(source), *options, "-o", str(target))
    return result, source, target


def test_a_plain_csv_of_angle_and_deviation_becomes_a_processed_trace(run, tmp_path):
    rows = "".join(f"{a:.1f},{d:.4f}\n" for a, d in zip(ARC, shape(ARC)))
    text = f"Ballbar test export\nMachine: lathe 3, 2026-11-20\nAngle (deg),Deviation (um)\n{rows}"
    result, source, target = imported(run, tmp_path, text, "--radius", "100", "--direction", "ccw", "--unit", "um",
                                      "--feed", "1000")
    assert (result.exit_code, result.stdout, result.stderr) == (0, "", "")
    written = target.read_text()
    assert written.startswith("# postproc ballbar 1\n# radius_mm = 100\n# direction = ccw\n")
    assert "# feed_mm_min = 1000\n" in written and "# x-imported-from = export.csv\n" in written
    trace = read_ballbar(str(target))
    assert trace.arc == pytest.approx((340.0, 220.0)) and len(trace.angles) == ARC.size
    again = np.mod(ARC, 360.0)
    order = np.argsort(again)
    measured = trace.deviations + trace.setup_centre[0] * np.cos(np.radians(trace.angles)) \
        + trace.setup_centre[1] * np.sin(np.radians(trace.angles))
    assert np.abs(measured - np.round(shape(again[order]), 4) / 1000.0).max() < 1e-6  # the centre to second order


@pytest.mark.parametrize("separator, decimal_comma, options", [
    (";", True, ["--decimal-comma"]),
    ("\t", True, ["--decimal-comma"]),
    ("\t", False, []),
    ("   ", False, []),
    ("|", False, ["--delimiter", "|"]),
])
def test_every_dialect_reads_alike(run, tmp_path, separator, decimal_comma, options):
    def number(value: float) -> str:
        text = f"{value:.5f}"
        return text.replace(".", ",") if decimal_comma else text

    rows = "".join(f"{number(a)}{separator}{number(d)}\n" for a, d in zip(ARC, shape(ARC) / 1000.0))
    result, _, target = imported(run, tmp_path, "ANGLE" + separator + "DEV\n" + rows, "--radius", "150",
                                 "--direction", "cw", *options)
    assert result.exit_code == 0, result.stderr
    assert np.allclose(read_ballbar(str(target)).angles, np.sort(np.mod(np.round(ARC, 5), 360.0)))


def test_raw_deviations_with_a_start_angle_and_a_capture_arc_become_a_raw_trace(run, tmp_path):
    readings = np.repeat(shape(ARC) / 1000.0, 6)
    text = "deviation\n" + "".join(f"{value:.7f}\n" for value in readings)
    result, _, target = imported(run, tmp_path, text, "--radius", "100", "--direction", "cw", "--start-angle", "-20",
                                 "--capture-arc", "220")
    assert result.exit_code == 0, result.stderr
    written = target.read_text()
    assert "# start_angle_deg = -20\n# capture_arc_deg = 220\n" in written and "\ndeviation_mm\n" in written
    trace = read_ballbar(str(target))
    assert trace.raw and trace.arc[1] == pytest.approx(219.5, abs=0.01)


def test_columns_by_number_or_by_header_name_and_the_exports_angle_convention(run, tmp_path):
    """An export with an index column, 0 deg at +Z and angles running towards +X (docs/methods.md §2)."""
    exported = np.mod(90.0 - ARC, 360.0)
    rows = "".join(f"{i},{e:.1f},{d:.4f},1\n" for i, (e, d) in enumerate(zip(exported, shape(ARC))))
    text = "No,Angle,Dev_um,Flag\n" + rows
    for columns in ("2,3", "angle,DEV_UM"):
        result, _, target = imported(run, tmp_path, text, "--radius", "100", "--direction", "ccw", "--columns", columns,
                                     "--unit", "um", "--angle-offset", "90", "--reverse-angles")
        assert result.exit_code == 0, result.stderr
        trace = read_ballbar(str(target))
        assert trace.arc == pytest.approx((340.0, 220.0))


@pytest.mark.parametrize("text, options, message", [
    ("angle,dev\n0,0.001\n1,0.0x1\n", [], "{f}:3:3: error: '0.0x1' is not a finite number"),
    ("angle,dev\n0,0.001\n1,0.001,7\n", [], "{f}:3:9: error: 3 cells where the rows above have 2"),
    ("angle,dev\n" + "".join(f"{a},2.5\n" for a in range(0, 200, 2)), [],
     "{f}:2:3: error: deviation 2.5 mm is beyond 1 mm: not a plausible ballbar reading (micrometres read as "
     "millimetres? give --unit um)"),
    ("angle,dev\n" + "".join(f"{a},0.001\n" for a in range(0, 20)), [],
     "{f}: error: 20 samples: a trace needs at least 36, over at least 90 deg of arc"),
    ("angle,dev\n" + "".join(f"{a / 2},0.001\n" for a in range(0, 100)), [],
     "{f}: error: the trace covers 50 deg from 0 to 50 deg: a trace needs at least 90 deg of arc (a lathe's test "
     "in XZ runs about 220 deg)"),
    ("angle,dev\n0,0.001\n360,0.001\n" + "".join(f"{a},0.001\n" for a in range(2, 200, 2)), [],
     "{f}:3:1: error: angle 360 deg again (first on line 2): a second lap or run in one file? give each run of the "
     "test as a file of its own"),
    ("just words\nand more words\n", [], "{f}: error: no rows of numbers in the file (numbers written 1,25 need "
     "--decimal-comma; cells separated otherwise than by tab, semicolon, comma or spaces need --delimiter)"),
    ("\x00\x01binary", [], "{f}: error: this is a binary file, not a measurement table"),
])
def test_bad_exports_are_refused_at_their_position_and_nothing_is_written(run, tmp_path, text, options, message):
    result, source, target = imported(run, tmp_path, text, "--radius", "100", "--direction", "cw", *options)
    assert result.exit_code == 3 and result.stdout == "" and not target.exists()
    assert result.stderr.splitlines()[0] == message.format(f=source)


@pytest.mark.parametrize("options, message", [
    ([], "has one column (raw deviations?): give --start-angle"),
    (["--columns", "3"], "--columns 3: give ANGLE,DEVIATION"),
    (["--start-angle", "0", "--columns", "dev"], "'dev' is neither a column number nor a header name"),
    (["--capture-arc", "220"], "--capture-arc belongs to raw deviations: give --start-angle as well"),
    (["--start-angle", "0", "--delimiter", "comma", "--decimal-comma"], "the delimiter cannot be a comma as well"),
])
def test_options_that_cannot_hold_are_usage_errors(run, tmp_path, options, message):
    result, _, target = imported(run, tmp_path, "deviation\n" + "0.001\n" * 400, "--radius", "100", "--direction",
                                 "ccw", *options)
    assert result.exit_code == 2 and not target.exists()
    assert message in result.stderr


#: exports wider than the columns asked for: (header row, a row's cells from angle and deviation, options)
_WIDE = {
    "an index first": ("No,Angle,Dev", lambda i, a, d: f"{i},{a},{d}", []),
    "a time and a temperature": ("time_s,angle,dev_mm,temp", lambda i, a, d: f"{i * 0.01:.2f},{a},{d},20.1", []),
    "deviation in two units": ("Angle,Dev_mm,Dev_um", lambda i, a, d: f"{a},{d},{float(d) * 1000:.3f}", []),
    "raw readings beside the angle": ("Angle,Dev", lambda i, a, d: f"{a},{d}", ["--start-angle", "0"]),
    "no header row": (None, lambda i, a, d: f"{i};{a};{d}", []),
}


@pytest.mark.parametrize("case", sorted(_WIDE))
def test_a_column_is_never_picked_by_its_place_when_the_rows_have_more(run, tmp_path, case):
    """With more cells per row than the trace needs, which is the angle and which the deviation
    is a guess (an index column read as the angle of a 1 deg export gives a plausible trace
    turned by 1 deg): the user names them with --columns, and nothing is written until then."""
    header, cells, options = _WIDE[case]
    angles = np.arange(0.0, 360.0, 1.0)
    rows = "".join(cells(i + 1, a, f"{d / 1000:.6f}") + "\n" for i, (a, d) in enumerate(zip(angles, shape(angles))))
    result, source, target = imported(run, tmp_path, (header + "\n" if header else "") + rows, "--radius", "100",
                                      "--direction", "ccw", *options)
    assert (result.exit_code, result.stdout) == (2, "") and not target.exists()
    width = len(cells(1, 0.0, "0").split(";" if header is None else ","))
    assert f"{source} has {width} columns" in result.stderr and "--columns" in result.stderr, result.stderr


def test_micrometres_declared_for_millimetres_are_refused(run, tmp_path):
    """--unit um on an export in mm makes a trace of nanometres, which no ballbar reads."""
    rows = "".join(f"{a},{d / 1000:.6f}\n" for a, d in zip(ARC, shape(ARC)))
    result, source, target = imported(run, tmp_path, "angle,dev\n" + rows, "--radius", "100", "--direction", "cw",
                                      "--unit", "um")
    assert result.exit_code == 3 and not target.exists()
    assert result.stderr.startswith(f"{source}: error: with --unit um every deviation is within 0.0")
    assert "millimetres read as micrometres? leave out --unit um" in result.stderr


def test_the_export_itself_is_never_overwritten(run, tmp_path):
    source = tmp_path / "export.csv"
    text = "".join(f"{a},0.001\n" for a in range(0, 360, 2))
    source.write_text(text)
    result = run("import-trace", str(source), "--radius", "100", "--direction", "cw", "-o", str(source))
    assert result.exit_code == 2 and "is the input" in result.stderr and "nothing was written" in result.stderr
    assert source.read_text() == text


def test_imported_220_deg_exports_are_diagnosed(run, tmp_path):
    """The sample machine's 220 deg test, exported plainly (um, semicolons, decimal comma) and imported."""
    from postproc.simulator import ballbar_test, generator, load
    from support import SAMPLES

    simulation, _ = load(str(SAMPLES / "machines" / "v40r-sim.toml"))
    paths = []
    for direction, start in (("ccw", 200.0), ("cw", -20.0)):
        test = ballbar_test(simulation, generator(1, direction), direction, "processed", start=start, capture=220.0,
                            overtravel=2.0)
        rows = "".join(f"{a:.2f};{d * 1000:.4f}\n".replace(".", ",") for a, d in zip(test.angles, test.deviations))
        source = tmp_path / f"{direction}.txt"
        source.write_text("Winkel;Abweichung\n" + rows)
        target = str(tmp_path / f"{direction}.csv")
        result = run("import-trace", str(source), "--radius", "100", "--direction", direction, "--unit", "um",
                     "--decimal-comma", "--feed", "1000", "-o", target)
        assert result.exit_code == 0, result.stderr
        paths.append(target)
    report = run("ballbar", *paths)
    assert report.exit_code == 0, report.stderr
    assert "scaling X                     +79." in report.stdout or "scaling X                     +80." in report.stdout


EXPORTS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


@EXPORTS
@given(st.sampled_from([",", ";", "\t", " "]), st.booleans(), st.sampled_from(["mm", "um"]),
       st.floats(90.0, 360.0), st.integers(36, 300), st.integers(0, 2**32 - 1))
def test_an_export_round_trips_whatever_its_dialect(run, tmp_path_factory, separator, decimal_comma, unit, span,
                                                    count, seed):
    if decimal_comma and separator == ",":
        separator = ";"
    rng = np.random.default_rng(seed)
    step = 360.0 / count if span > 359.0 else span / (count - 1)  # a whole circle does not repeat its first angle
    angles = rng.uniform(-180.0, 180.0) + step * np.arange(count)
    deviations = rng.normal(0.0, 0.005, count)
    scale = 1000.0 if unit == "um" else 1.0

    def number(value: float) -> str:
        text = repr(float(value))
        return text.replace(".", ",") if decimal_comma else text

    text = "".join(f"{number(a)}{separator}{number(d * scale)}\n" for a, d in zip(angles, deviations))
    folder = tmp_path_factory.mktemp("export")
    options = ["--radius", "80", "--direction", "cw", "--unit", unit, "--centered"]
    result, _, target = imported(run, folder, text, *options, *(["--decimal-comma"] if decimal_comma else []))
    assert result.exit_code == 0, result.stderr
    trace = read_ballbar(str(target))
    order = np.argsort(np.mod(angles, 360.0), kind="stable")
    assert np.allclose(trace.angles, np.mod(angles, 360.0)[order], atol=1e-8)
    assert np.allclose(trace.deviations, deviations[order], atol=1e-12 + 1e-9 * math.isclose(scale, 1000.0))


def test_raw_deviations_of_a_partial_arc_without_capture_arc_are_refused_naming_it(run, tmp_path):
    """Before: spread over 360 deg, the readings of a 220 deg test were refused later as a fit
    the traces do not determine, with no word of --capture-arc."""
    readings = np.repeat(shape(ARC) / 1000.0, 6)
    text = "deviation\n" + "".join(f"{value:.7f}\n" for value in readings)
    result, source, target = imported(run, tmp_path, text, "--radius", "100", "--direction", "cw", "--start-angle",
                                      "-20")
    assert result.exit_code == 3 and result.stdout == "" and not target.exists()
    first = result.stderr.splitlines()[0]
    assert first.startswith(f"{source}:{readings.size + 1}:1: error: the last reading and the first differ by ")
    assert first.endswith("so these readings do not go round it (a partial arc: a lathe's test in XZ runs about "
                          "220 deg); give the arc they span with --capture-arc")
