"""postproc.report.verdict: the report's first screen says before, after, the band, pass or fail."""

from __future__ import annotations

import html
import re

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings, strategies as st

from support import SAMPLES
from postproc.cli.main import main
from postproc.report.verdict import FAIL, NONE, PASS, Band, Evidence, judge

PROGRAM = SAMPLES / "programs" / "hemishell.nc"
TRACES = ("--ballbar", str(SAMPLES / "ballbar" / "v40r-100-ccw.csv"), "--ballbar", str(SAMPLES / "ballbar" / "v40r-100-cw.csv"))
PROBE = SAMPLES / "probe" / "hemishell-pass1.csv"


def _report(tmp_path, name: str, *args: str) -> str:
    target = tmp_path / name
    result = CliRunner().invoke(main, ["report", *args, "-o", str(target)])
    assert result.exit_code == 0, result.stderr
    return target.read_text(encoding="utf-8")


def _verdict(text: str) -> tuple[str, str]:
    """(state, the verdict box's words) of a report."""
    found = re.search(r'<div class="verdict (\w+)"[^>]*>(.*?)</div>', text, re.S)
    assert found, "no verdict"
    return found.group(1), html.unescape(re.sub(r"<[^>]+>", " ", found.group(2)))


def _cells(text: str, key: str) -> list[list[str]]:
    table = re.search(rf'<table id="{key}".*?</table>', text, re.S).group(0)
    return [[html.unescape(c) for c in re.findall(r"<td>(.*?)</td>", row)] for row in re.findall(r"<tr>(.*?)</tr>", table)[1:]]


@pytest.fixture(scope="module")
def ballbar_report(tmp_path_factory):
    return _report(tmp_path_factory.mktemp("verdict"), "b.html", str(PROGRAM), "--plugin", "parametric", *TRACES)


def test_the_verdict_is_the_first_thing_after_the_title(ballbar_report):
    main_part = ballbar_report.split("<main>", 1)[1]
    assert main_part.index('class="verdict') < main_part.index("<nav") < main_part.index('id="summary"')
    first_image = re.search(r'<img [^>]*alt="([^"]*)"', main_part).group(1)
    assert first_image == "deviation before and after compensation against the band"


def test_the_verdict_says_before_after_band_and_result_and_agrees_with_the_figures(ballbar_report):
    state, words = _verdict(ballbar_report)
    before = float(re.search(r"before ([\d.]+) um", words).group(1))
    after = float(re.search(r"after ([\d.]+) um", words).group(1))
    band = float(re.search(r"band \u00b1([\d.]+) um", words).group(1))
    assert band == 1.0  # the machine profile's default tolerance, said so beside it
    assert "the tolerance in force" in html.unescape(ballbar_report) and "--band MM" in html.unescape(ballbar_report)
    assert state == (PASS if after <= band else FAIL) and words.lstrip().startswith(state.upper())
    assert "with parametric" in words and "Before (ballbar test)" in words
    rows = {row[0]: row for row in _cells(ballbar_report, "verdict-figures")}
    assert float(rows["before: ballbar test"][2]) == pytest.approx(before, abs=0.006)
    assert float(rows["after: ballbar test"][2]) == pytest.approx(after, abs=0.006)
    four = {row[0]: row for row in _cells(ballbar_report, "four-figures")}
    for which in ("before", "after"):  # the verdict's mean |e| is the four figures' own
        assert rows[f"{which}: ballbar test"][3] == four[f"predicted: {which} (ballbar model)"][2]


def test_a_band_tighter_than_the_result_fails_and_says_by_how_much(tmp_path):
    text = _report(tmp_path, "tight.html", str(PROGRAM), "--plugin", "parametric", *TRACES, "--band", "0.0002")
    state, words = _verdict(text)
    assert state == FAIL and words.lstrip().startswith("FAIL: ") and "outside \u00b10.20 um" in words
    assert "The band: \u00b10.20 um about the nominal, along its normal: as given with --band." in html.unescape(text)
    assert "--band 0.0002" in html.unescape(text)  # the command line in the provenance


def test_a_probed_part_is_judged_on_its_points(tmp_path):
    text = _report(tmp_path, "probe.html", str(PROGRAM), "--plugin", "omp-feedback", "--probe", str(PROBE),
                   "--band", "0.01")
    state, words = _verdict(text)
    assert state == PASS and "probe file hemishell-pass1.csv" in words and "measured on the part" in words
    rows = _cells(text, "verdict-figures")
    assert [row[0] for row in rows] == ["before: probe file hemishell-pass1.csv", "after: probe file hemishell-pass1.csv"]
    assert float(rows[1][2]) < float(rows[0][2]) <= 10.0


def test_a_refused_compensation_gives_no_verdict(tmp_path):
    model = tmp_path / "inverse.json"
    result = CliRunner().invoke(main, ["fit", "--plugin", "ballbar-inverse", *TRACES, "-o", str(model)])
    assert result.exit_code == 0, result.stderr
    text = _report(tmp_path, "refused.html", str(PROGRAM), "--model", str(model))  # a 57 mm arc, a 100 mm trace
    state, words = _verdict(text)
    assert state == NONE and "NO VERDICT: the program could not be compensated" in words
    assert "radius-mapping" in words  # the remedy


def test_a_band_that_is_not_a_positive_length_is_refused_as_bad_input(tmp_path):
    for bad in ("0", "-0.01", "nan"):
        result = CliRunner().invoke(main, ["report", str(PROGRAM), *TRACES, "--band", bad, "-o", str(tmp_path / "r.html")])
        assert result.exit_code == 3 and result.stdout == "" and f"--band {bad}" in result.stderr  # as --tolerance
        assert not (tmp_path / "r.html").exists()


deviations = st.lists(st.floats(-0.05, 0.05, allow_nan=False), min_size=1, max_size=30)


@settings(max_examples=200, deadline=None)
@given(before=deviations, after=deviations, band=st.floats(1e-4, 0.05))
def test_judge_passes_exactly_when_every_deviation_after_is_within_the_band(before, after, band):
    n = min(len(before), len(after))
    evidence = Evidence("s", "b", "a", np.arange(n, dtype=float), np.array(before[:n]), np.array(after[:n]), False)
    state, headline = judge([evidence], Band(band, "--band"))
    assert state == (PASS if max(abs(v) for v in after[:n]) <= band + 1e-9 else FAIL)
    assert headline.startswith(state.upper())
    without = Evidence("s", "b", "a", evidence.where, evidence.before, None, True)
    state, headline = judge([without], Band(band, "--band"))  # no compensator: the measurement itself is judged
    assert state == (PASS if max(abs(v) for v in before[:n]) <= band + 1e-9 else FAIL) and "as measured" in headline
    assert judge([], Band(band, "--band"))[0] == NONE
