"""Probe files read against what was probed (postproc.measure.readers.probe, measure.probing.
check_on_profile): a duplicated touch, micrometres written as millimetres, x written as a
diameter and a file of another part are each one error (exit 3) naming the file, the row and
the likely cause, before anything is screened or compensated."""

from __future__ import annotations

import pytest
from click.testing import CliRunner
from hypothesis import given, settings, strategies as st

from postproc.cli.main import main
from postproc.measure.readers.probe import read_probe
from support import SAMPLES

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
    assert "from the program's nominal profile, beyond the 1 mm any correction reaches" in error and cause in error


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
    assert "off the artifact's surface" in error and cause in error


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
