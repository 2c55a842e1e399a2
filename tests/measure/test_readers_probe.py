"""Probe files read against what was probed (postproc.measure.readers.probe, measure.probing.
check_on_profile): a duplicated touch, micrometres written as millimetres, inches, x written as
a diameter, a stylus radius given as its diameter or in inches, a datum in another unit and a
file of another part are each one error (exit 3) naming the file, the row and the likely
cause, before anything is screened or compensated, and before a datum is said to have moved."""

from __future__ import annotations

import re

import pytest
from click.testing import CliRunner
from hypothesis import given, settings, strategies as st

from postproc.cli.main import main
from postproc.diagnostics import MeasurementError
from postproc.measure.readers.probe import read_calibration, read_probe
from support import CORPUS, SAMPLES

HEMISHELL = str(SAMPLES / "programs" / "hemishell.nc")
PROBE = SAMPLES / "probe" / "hemishell-pass1.csv"
CALIBRATION = SAMPLES / "probe" / "artifact-calibration.csv"
TEXT = PROBE.read_text()
HEADER = [line for line in TEXT.splitlines() if line.startswith("#") or line.startswith("x_mm")]
ROWS = [line for line in TEXT.splitlines() if line not in HEADER]
FIRST_ROW = len(HEADER) + 1  #: the line of the first data row


def _written(tmp_path_factory, rows, text_header=None) -> str:
    path = tmp_path_factory.mktemp("probe") / "p.csv"
    path.write_text("\n".join((text_header or HEADER) + rows) + "\n")
    return str(path)


def _compensate(plugin: str, probe: str, *more: str):
    return CliRunner().invoke(main, ["compensate", HEMISHELL, "--plugin", plugin, "--probe", probe, *more],
                              catch_exceptions=False)


def _one_error(result, path: str) -> str:
    assert result.exit_code == 3 and result.stdout == "", result.stderr
    errors = [line for line in result.stderr.splitlines() if ": error: " in line]
    assert len(errors) == 1 and errors[0].startswith(f"{path}:"), result.stderr
    assert "dropped as" not in result.stderr  # refused before any screening
    return errors[0]


def _row(x: float, z: float, rest: list[str]) -> str:
    return ",".join([f"{x:.7f}", f"{z:.7f}", *rest])


def _header(header, **values) -> list[str]:
    """``header`` with the keys given set (None: the line left out)."""
    out = []
    for line in header:
        key = line[1:].partition("=")[0].strip() if line.startswith("# ") else None
        if key in values:
            if values[key] is not None:
                out.append(f"# {key} = {values[key]}")
        else:
            out.append(line)
    return out


def _line(header, key: str) -> int:
    return next(number for number, text in enumerate(header, 1) if text.startswith(f"# {key} "))


def _scaled(rows, fx: float, fz: float):
    out = []
    for row in rows:
        x, z, *rest = row.split(",")
        out.append(_row(float(x) * fx, float(z) * fz, rest))
    return out


@settings(max_examples=12)
@given(plugin=st.sampled_from(["omp-feedback", "tool-offset"]),
       misreading=st.sampled_from([(1000.0, 1000.0, "micrometres written as millimetres?"),
                                   (2.0, 1.0, "x written as a diameter?")]))
def test_probe_points_in_another_unit_or_as_diameters_are_refused_naming_the_cause(tmp_path_factory, plugin,
                                                                                    misreading):
    fx, fz, cause = misreading
    path = _written(tmp_path_factory, _scaled(ROWS, fx, fz))
    error = _one_error(_compensate(plugin, path), path)
    assert cause in error
    # coordinates beyond any lathe's travel are refused as they are read, the profile not needed
    assert ("from the program's nominal profile, beyond the 1 mm any correction reaches" in error
            or "mm from the work origin is beyond any lathe's travel (10000 mm)" in error)


@settings(max_examples=12)
@given(plugin=st.sampled_from(["omp-feedback", "tool-offset"]), shift=st.floats(1.2, 500.0),
       axis=st.sampled_from(["x", "z"]))
def test_probe_points_far_off_the_profile_are_refused_as_another_part(tmp_path_factory, plugin, shift, axis):
    rows = [_row(float(x) + (shift if axis == "x" else 0.0), float(z) + (shift if axis == "z" else 0.0), rest)
            for x, z, *rest in (row.split(",") for row in ROWS)]
    path = _written(tmp_path_factory, rows)
    assert "another part, another program or another work offset?" in _one_error(_compensate(plugin, path), path)


@settings(max_examples=20)
@given(data=st.data())
def test_a_touch_repeated_to_the_last_digit_is_kept(tmp_path_factory, data):
    """At a printout's 1 um a repeatability check gives the same stylus centre twice: both rows
    are measurements, read as such."""
    copied = data.draw(st.integers(0, len(ROWS) - 1))
    at = data.draw(st.integers(copied + 1, len(ROWS)))
    rows = ROWS[:at] + [ROWS[copied]] + ROWS[at:]
    path = _written(tmp_path_factory, rows)
    assert read_probe(str(path)).centres.shape[0] == len(ROWS) + 1


@pytest.mark.parametrize("plugin", ["omp-feedback", "tool-offset"])
def test_the_sample_probe_file_is_accepted(plugin):
    assert _compensate(plugin, str(PROBE)).exit_code == 0


@pytest.mark.parametrize("fx, fz, cause", [(1000.0, 1000.0, "micrometres written as millimetres?"),
                                           (2.0, 1.0, "x written as a diameter?")])
def test_a_calibration_in_another_unit_or_as_diameters_names_the_cause(tmp_path, fx, fz, cause):
    text = CALIBRATION.read_text().splitlines()
    header = [line for line in text if line.startswith("#") or line.startswith("x_mm")]
    rows = _scaled([line for line in text if line not in header], fx, fz)
    path = tmp_path / "c.csv"
    path.write_text("\n".join(header + rows) + "\n")
    error = _one_error(_compensate("omp-feedback", str(PROBE), "--calibration", str(path)), str(path))
    assert cause in error
    assert "off the artifact's surface" in error or "beyond any lathe's travel" in error


CALIBRATION_HEADER = [line for line in CALIBRATION.read_text().splitlines() if line.startswith("#")
                      or line.startswith("x_mm")]
CALIBRATION_ROWS = [line for line in CALIBRATION.read_text().splitlines() if line not in CALIBRATION_HEADER]


@pytest.mark.parametrize("key, value, cause", [
    ("stylus_radius_mm", "6", "stylus_radius_mm is the ball's diameter? (halved, it fits)"),
    ("stylus_radius_mm", "0.1181", "stylus_radius_mm in inches? (times 25.4, it fits)"),
    ("stylus_radius_mm", "1.5", "stylus_radius_mm is half the ball's radius? (doubled, it fits)"),
    ("artifact_radius_mm", "50.8", "artifact_radius_mm = 50.8: a diameter where a radius is meant? (halved, 25.4 mm)"),
    ("artifact_radius_mm", "1", "artifact_radius_mm = 1: inches written as millimetres? (1 in is 25.4 mm)"),
    ("artifact_radius_mm", "25400", "artifact_radius_mm = 25400: micrometres written as millimetres? (25400 um is 25.4 mm)"),
])
def test_a_calibration_with_a_radius_in_another_unit_or_as_a_diameter_names_it(tmp_path_factory, key, value, cause):
    """A stylus radius given as the ball's diameter read as touches 3 mm inside the artifact,
    blamed on the artifact (or, within half the stylus, on the pretravel); now the radius is named."""
    path = tmp_path_factory.mktemp("calibration") / "c.csv"
    path.write_text("\n".join(_header(CALIBRATION_HEADER, **{key: value}) + CALIBRATION_ROWS) + "\n")
    probe = _written(tmp_path_factory, ROWS, _header(HEADER, stylus_radius_mm=value)) if key.startswith("stylus") \
        else str(PROBE)
    error = _one_error(_compensate("omp-feedback", probe, "--calibration", str(path)), str(path))
    assert re.match(rf"{re.escape(str(path))}(:\d+)?: error: ", error) and cause in error, error
    with pytest.raises(MeasurementError) as raised:
        from postproc.measure.pretravel import fit_calibration
        fit_calibration(read_calibration(str(path)))
    assert cause in str(raised.value)


def _inspect(probe: str, *more: str):
    return CliRunner().invoke(main, ["inspect", HEMISHELL, "--probe", probe, "--band", "0.005", "--from-line", "10",
                                     "--to-line", "10", *more], catch_exceptions=False)


#: (x, z and stylus radius factors, the cause named): the sample file as each misreading writes it
MISREAD = [
    ((1.0, 1.0, 2.0), "stylus_radius_mm is the ball's diameter? (halved, it fits)"),
    ((1.0, 1.0, 1 / 25.4), "stylus_radius_mm in inches? (times 25.4, it fits)"),
    ((25.4, 25.4, 1.0), "millimetres read as inches? (the coordinates divided by 25.4 fit: a printout headed G 20 "
                        "whose numbers are millimetres?)"),
    ((1 / 25.4, 1 / 25.4, 1 / 25.4), "inches written as millimetres? (every length times 25.4 fits)"),
    ((2.0, 1.0, 1.0), "x written as a diameter?"),
    ((0.5, 1.0, 1.0), "x halved twice? (doubled, it fits: a printout's D 2 where X was printed as a radius, D 1?)"),
]


@pytest.mark.parametrize("factors, cause", MISREAD, ids=[cause.split("?")[0] for _, cause in MISREAD])
@pytest.mark.parametrize("command", ["omp-feedback", "tool-offset", "inspect"])
def test_a_probe_file_misread_by_a_unit_or_a_diameter_names_it_in_every_command(tmp_path_factory, factors, cause,
                                                                                  command):
    """Before: the stylus as its diameter or in inches gave a part "out of tolerance" by the
    stylus radius (inspect, exit 1) or "another part" (compensate); a printout headed G 20 with
    millimetres, a datum that "moved" (exit 4, forceable). Now each names its misreading at the
    furthest touch's row, exit 3, with or without --force."""
    fx, fz, fr = factors
    header = _header(HEADER, stylus_radius_mm=f"{3 * fr:.10g}")
    path = _written(tmp_path_factory, _scaled(ROWS, fx, fz), header)
    for force in ((), ("--force",)):
        result = _inspect(path, *force) if command == "inspect" else _compensate(command, path, *force)
        error = _one_error(result, path)
        assert re.match(rf"{re.escape(path)}:\d+: error: this touch lies [-+]\d+\.\d+ mm from the program's "
                        r"nominal profile, beyond the 1 mm any correction reaches: ", error), error
        assert cause in error


def test_an_inspection_of_a_part_far_off_without_a_misreading_is_reported_as_it_is(tmp_path_factory):
    """inspect reports a part 5 mm oversize as measured (exit 1): only a misreading that explains
    the touches is refused there; a compensation refuses such touches whatever the cause."""
    rows = [_row(float(x) - 5.0 * float(ax), float(z) - 5.0 * float(az), [ax, az])
            for x, z, ax, az in (row.split(",") for row in ROWS)]
    path = _written(tmp_path_factory, rows)
    assert _inspect(path).exit_code == 1


@pytest.mark.parametrize("value, cause", [
    ("3000", "micrometres written as millimetres? (3000 um is 3 mm)"),
    ("76.2", "millimetres read as inches? (76.2 mm is 3 in: a printout headed G 20 whose numbers are millimetres)"),
])
@pytest.mark.parametrize("kind", ["probe", "calibration"])
def test_a_stylus_radius_no_probe_has_is_refused_at_its_line(tmp_path_factory, value, cause, kind):
    header = _header(HEADER if kind == "probe" else CALIBRATION_HEADER, stylus_radius_mm=value)
    path = tmp_path_factory.mktemp("stylus") / "s.csv"
    path.write_text("\n".join(header + (ROWS if kind == "probe" else CALIBRATION_ROWS)) + "\n")
    with pytest.raises(MeasurementError) as raised:
        (read_probe if kind == "probe" else read_calibration)(str(path))
    assert str(raised.value) == (f"{path}:{_line(header, 'stylus_radius_mm')}: error: stylus_radius_mm = {value}: a "
                                 f"stylus radius of {value} mm is larger than any probe's (balls of 0.3 to 25 mm): "
                                 f"{cause}")


# ---------------------------------------------------------------------------- the datum


@pytest.mark.parametrize("before, after, line_of, cause", [
    # one reading in another unit: named at its own line
    ("2.5", "2500.4", "after", "micrometres written as millimetres? (2500.4 um is 2.5004 mm)"),
    ("2500.4", "2.5", "before", "micrometres written as millimetres? (2500.4 um is 2.5004 mm)"),
    ("12.9936", "0.51156", "after", "inches written as millimetres? (0.51156 in is 12.9936 mm)"),
    # both in um: their drift so read is within the repeatability, and they lie by the touches
    ("5006.0", "5007.5", "before", "both readings micrometres written as millimetres?"),
    # two datums, or a digit wrong
    ("12.9936", "15.5", "before", "not one datum touched twice (another face or diameter, or a digit wrong)"),
])
@pytest.mark.parametrize("command", ["omp-feedback", "inspect"])
def test_a_datum_pair_beyond_any_correction_is_a_misreading_force_or_not(tmp_path_factory, before, after, line_of,
                                                                          cause, command):
    """A datum in um read as the machine moving by metres (exit 4), and --force took it. Now
    the pair is refused as read (exit 3), naming the misreading, and --force does not change that."""
    header = _header(HEADER, datum_before_z_mm=before, datum_after_z_mm=after)
    path = _written(tmp_path_factory, ROWS, header)
    line = _line(header, f"datum_{line_of}_z_mm")
    for force in ((), ("--force",)):
        result = _inspect(path, *force) if command == "inspect" else _compensate(command, path, *force)
        error = _one_error(result, path)
        assert error.startswith(f"{path}:{line}: error: datum_before_z_mm = {float(before):g} and datum_after_z_mm = "
                                f"{float(after):g} differ by {abs(float(after) - float(before)):.4f} mm, more than "
                                f"any correction (1 mm), which no forced run can use: "), error
        assert cause in error and error.endswith("; correct the file, or probe again")


def test_an_x_datum_written_as_a_diameter_is_named(tmp_path_factory):
    header = _header(HEADER, datum_after_x_mm="195.963")
    path = _written(tmp_path_factory, ROWS, header)
    with pytest.raises(MeasurementError, match=r"a diameter where a radius is meant\? \(halved, 97\.9815 mm\)"):
        read_probe(path)


@settings(max_examples=40, deadline=None)
@given(datum=st.floats(-400.0, 400.0, allow_nan=False), drift=st.floats(-0.003, 0.003),
       key=st.sampled_from(["datum_before_z_mm", "datum_after_z_mm", "datum_before_x_mm", "datum_after_x_mm"]),
       factor=st.sampled_from([1000.0, 1 / 25.4]))
def test_a_datum_reading_in_um_or_inches_is_never_taken(tmp_path_factory, datum, drift, key, factor):
    """Whatever the datum, one reading written in um (or in inches, where that moves it by more
    than a correction) is refused as read, at its line, naming the unit: never a drift to force."""
    axis = key[-4]
    values = {f"datum_before_{axis}_mm": datum, f"datum_after_{axis}_mm": datum + drift}
    values[key] *= factor
    if abs(values[key] - datum) <= 1.0:  # inches of a datum near the origin are no evident misreading
        return
    header = _header(HEADER, **{k: f"{v:.7f}" for k, v in values.items()})
    path = _written(tmp_path_factory, ROWS, header)
    with pytest.raises(MeasurementError) as raised:
        read_probe(path)
    message = str(raised.value)
    assert message.startswith(f"{path}:{_line(header, key)}: error: ") or "beyond any lathe's travel" in message
    assert ("micrometres written as millimetres?" if factor == 1000.0 else "inches written as millimetres?") in message


@pytest.mark.parametrize("missing", ["datum_before_z_mm", "datum_after_z_mm"])
def test_a_datum_without_its_partner_is_named_at_the_line_of_the_one_given(tmp_path_factory, missing):
    header = _header(HEADER, **{missing: None})
    path = _written(tmp_path_factory, ROWS, header)
    given = missing.replace("before", "AFTER").replace("after", "before").replace("AFTER", "after")
    with pytest.raises(MeasurementError) as raised:
        read_probe(path)
    assert str(raised.value) == (f"{path}:{_line(header, given)}: error: {given} without {missing}: the stability "
                                 "check needs the same datum touched before and after the profile")


@settings(max_examples=10, deadline=None)
@given(plugin=st.sampled_from(["omp-feedback", "tool-offset"]),
       repeatability=st.floats(0.1001, 1e4, allow_nan=False) | st.sampled_from([3.0, 2.0, 0.5]))
def test_a_repeatability_no_probe_has_is_refused_at_its_line(tmp_path_factory, plugin, repeatability):
    """repeatability_mm = 3 (3 um written in mm) was taken: as the floor of the outlier screening
    it called no touch an outlier, and the nub at the pole drove the correction, with exit 0."""
    header = [line if not line.startswith("# repeatability_mm") else f"# repeatability_mm = {repeatability!r}"
              for line in HEADER]
    path = _written(tmp_path_factory, ROWS, header)
    line = next(number for number, text in enumerate(header, 1) if text.startswith("# repeatability_mm"))
    error = _one_error(_compensate(plugin, path), path)
    assert error.startswith(f"{path}:{line}: error: repeatability_mm = {repeatability!r} is above 0.1: ")
    assert "micrometres written as millimetres?" in error


@pytest.mark.parametrize("repeatability", ["0.0005", "0.003", "0.1"])
def test_a_repeatability_a_probe_may_have_is_read(tmp_path_factory, repeatability):
    header = [line if not line.startswith("# repeatability_mm") else f"# repeatability_mm = {repeatability}"
              for line in HEADER]
    assert read_probe(_written(tmp_path_factory, ROWS, header)).repeatability == float(repeatability)


@pytest.mark.parametrize("command", ["omp-feedback", "tool-offset", "inspect"])
def test_a_file_in_another_unit_is_named_before_its_datum_seems_to_move(tmp_path_factory, command):
    """A printout headed G 20 whose numbers are millimetres, imported, has every length 25.4
    times too large, its datum's 1 um drift too: the datum check refused it as the machine
    moving (exit 4, and --force would take it). The unit is named first (exit 3)."""
    values = {line[2:].partition(" = ")[0]: float(line.partition(" = ")[2]) for line in HEADER
              if line.startswith("# datum_")}
    header = _header(HEADER, **{key: f"{value * 25.4:.7f}" for key, value in values.items()})
    path = _written(tmp_path_factory, _scaled(ROWS, 25.4, 25.4), header)
    result = _inspect(path) if command == "inspect" else _compensate(command, path)
    assert "millimetres read as inches?" in _one_error(result, path)
    if command != "inspect":  # without a program to compare with, the datum's refusal stands
        fitted = CliRunner().invoke(main, ["fit", "--plugin", command, "--probe", path], catch_exceptions=False)
        assert fitted.exit_code == 4 and fitted.stdout == ""
        assert f"{path}: error: the machine moved during the inspection" in fitted.stderr


@pytest.mark.parametrize("plugin", ["omp-feedback", "tool-offset"])
def test_a_file_of_another_part_is_not_a_unit_because_shrunk_it_heaps_on_the_profile(plugin):
    """The hemishell's touches divided by 25.4 heap within 2.4 mm of the origin, where a small
    part's profile runs: they lay within 1 mm of it, and the file was called a printout in mm
    headed G 20. Read otherwise, touches must keep a part's form to be called misread."""
    program = str(CORPUS / "fanuc" / "corbinpro_o4001.nc")
    result = CliRunner().invoke(main, ["compensate", program, "--plugin", plugin, "--probe", str(PROBE)],
                                catch_exceptions=False)
    assert _one_error(result, str(PROBE)).endswith(
        "beyond the 1 mm any correction reaches: a file of another part, another program or another work offset?")


@pytest.mark.parametrize("command", ["omp-feedback", "inspect"])
@pytest.mark.parametrize("before, after, um", [("5006.0", "5006.5", True), ("-1287.0064", "-1287.0024", True),
                                               ("-887.0064", "-887.0024", False)])
def test_a_datum_far_from_the_touches_that_drifts_names_um_beside_the_move(tmp_path_factory, command, before, after, um):
    """Both readings in um, 0.5 um apart, read as a drift of 0.5 mm of a datum 5 m from every
    touch; a long part's datum 1287 mm away that drifted 4 um reads alike: neither can be told
    from the file. The move is refused (exit 4) naming the micrometres beside it, and --force may
    take it, as any move it covers; a datum within a metre of the touches is a move alone."""
    header = _header(HEADER, datum_before_z_mm=before, datum_after_z_mm=after)
    path = _written(tmp_path_factory, ROWS, header)
    result = _inspect(path) if command == "inspect" else _compensate(command, path)
    assert result.exit_code == 4 and result.stderr.count("error:") == 1, result.stderr
    message = result.stderr
    assert f"{path}: error: the machine moved during the inspection" in message and "--force" in message
    assert ("mm from every touch, both readings micrometres written as millimetres?" in message) == um
    forced = _inspect(path, "--force") if command == "inspect" else _compensate(command, path, "--force")
    assert forced.exit_code in (0, 1), forced.stderr


@settings(max_examples=40, deadline=None)
@given(datum=st.floats(-900.0, 900.0), drift=st.floats(0.0031, 1.0), sign=st.sampled_from([-1.0, 1.0]),
       axis=st.sampled_from("xz"))
def test_a_datum_that_really_moved_is_read_for_the_stability_check(tmp_path_factory, datum, drift, sign, axis):
    """A datum by the profile (within a metre of its touches) that moved by up to a correction is
    read as it is: the stability check refuses it (exit 4), and --force may use it."""
    header = _header(HEADER, **{f"datum_before_{axis}_mm": f"{datum:.7f}",
                                f"datum_after_{axis}_mm": f"{datum + sign * drift:.7f}"})
    probe = read_probe(_written(tmp_path_factory, ROWS, header))
    assert probe.datum_after[axis] - probe.datum_before[axis] == pytest.approx(sign * drift, abs=1e-6)
