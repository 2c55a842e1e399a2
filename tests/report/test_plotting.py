"""postproc.report.plotting and postproc.report.pathplot: the polar plot as shops know it, path plots as
programmers read them."""

from __future__ import annotations

import math
import re
import struct

import numpy as np

from click.testing import CliRunner
from hypothesis import example, given, strategies as st

from support import SAMPLES
from postproc.cli.main import main
from postproc.measure.readers.ballbar import read_ballbar
from postproc.report.pathplot import magnification_for
from postproc.report.plotting import BAND, along_arc, drawn, plot_traces

CCW = SAMPLES / "ballbar" / "v40r-100-ccw.csv"
CW = SAMPLES / "ballbar" / "v40r-100-cw.csv"
PROGRAM = SAMPLES / "programs" / "hemishell.nc"


def _svg_text(path) -> str:
    """The words of an SVG (its text is kept as text)."""
    return " ".join(re.findall(r"<text[^>]*>([^<]*)</text>", path.read_text(encoding="utf-8")))


def _polar(tmp_path, *paths, name="polar.svg", **options) -> str:
    target = tmp_path / name
    plot_traces([read_ballbar(str(p)) for p in paths], str(target), **options)
    return _svg_text(target)


def test_the_polar_plot_states_the_test_its_figures_and_its_scale(tmp_path):
    words = _polar(tmp_path, CCW, CW)
    for shown in ("radius", "100 mm", "feed", "1000 mm/min", "v40r-100-ccw.csv: the whole circle", "measured",
                  "G, circular deviation ccw", "G, circular deviation cw", "G(b), bidirectional",
                  "H, circular hysteresis", "backlash X", "backlash Z", "scaling X", "scaling Z", "ppm", "squareness",
                  "urad", "servo mismatch", "rings every", "deviation magnified", "+X", "+Z"):
        assert shown in words, shown
    assert not re.search(r"\b[a-z]+_[a-z_]+\b", words)  # no raw key
    step = float(re.search(r"rings every ([\d.]+) um", words).group(1))
    outer = float(re.search(r"outermost ring \u00b1([\d.]+) um", words).group(1))
    magnification = int(re.search(r"\u00d7([\d,]+)", words).group(1).replace(",", ""))
    assert magnification == round(BAND * 100.0 * 1000.0 / outer)
    rings = round(outer / step)
    labels = {f"{k * step:+g}" for k in range(-rings, rings + 1) if k}
    assert labels <= set(re.findall(r"[+-][\d.]+", words)) and f"+{outer:g} um" in words  # every ring labelled


def test_the_polar_plot_gives_the_measured_time_stated_in_the_file(tmp_path):
    stamped = tmp_path / "ccw.csv"
    lines = CCW.read_text().splitlines(keepends=True)
    stamped.write_text(lines[0] + "# measured = 2026-03-04T05:06:00+01:00\n" + "".join(lines[1:]))
    words = _polar(tmp_path, stamped)
    assert "2026-03-04 04:06 UTC" in words and "file time" not in words
    assert "(file time)" in _polar(tmp_path, CCW, name="mtime.svg")


def test_a_partial_arc_is_drawn_and_named_as_measured(tmp_path):
    paths = []
    for direction, start in (("ccw", "200"), ("cw", "-20")):
        path = tmp_path / f"{direction}.csv"
        result = CliRunner().invoke(main, ["simulate", "ballbar", "--machine", str(SAMPLES / "machines" / "v40r-sim.toml"),
                                           "--direction", direction, "--start-angle", start, "--capture-arc", "220",
                                           "-o", str(path)])
        assert result.exit_code == 0, result.stderr
        paths.append(path)
    words = _polar(tmp_path, *paths)
    assert "ISO 13041-6" in words and "220 deg from -20 to 200 deg" in words and "dotted: not measured" in words
    svg = (tmp_path / "polar.svg").read_text()
    assert "stroke-dasharray" in svg  # the nominal circle dotted where no trace covers it


def test_the_polar_plot_prints_across_an_a4_page(tmp_path):
    target = tmp_path / "polar.png"
    plot_traces([read_ballbar(str(CCW)), read_ballbar(str(CW))], str(target))
    width, height = struct.unpack(">II", target.read_bytes()[16:24])
    assert width >= 1200 and 0.6 < height / width < 0.85  # 8.27 in at 150 dpi: A4's width


def test_without_a_diagnosis_the_plot_says_so(tmp_path):
    words = _polar(tmp_path, CCW, diagnosis=None)
    assert "Diagnosis" in words and "not fitted" in words and "backlash" not in words


def test_the_path_plot_dashes_rapids_and_states_the_magnification(tmp_path):
    picture = tmp_path / "path.svg"
    result = CliRunner().invoke(main, ["path", str(PROGRAM), "--plot", str(picture), "--plugin", "parametric",
                                       "--ballbar", str(CCW), "--ballbar", str(CW)])
    assert result.exit_code == 0, result.stderr
    svg = picture.read_text(encoding="utf-8")
    words = _svg_text(picture)
    assert "rapid (G00)" in words and "nominal feed" in words
    found = re.search(r"correction magnified \u00d7([\d,]+) \(largest ([\d.]+) um\)", words)
    magnification = int(found.group(1).replace(",", ""))
    assert magnification in {m * 10 ** k for m in (1, 2, 5) for k in range(7)}
    dashed = re.findall(r'<path d="[^"]*"[^>]*style="[^"]*stroke-dasharray[^"]*"', svg)
    assert dashed  # the rapids (the nominal feeds and the correction are drawn solid)
    plain = CliRunner().invoke(main, ["path", str(PROGRAM), "--plot", str(tmp_path / "nominal.svg")])
    assert plain.exit_code == 0 and "correction magnified" not in _svg_text(tmp_path / "nominal.svg")


@example(largest=1.0000000000000002e-06, size=1.0, share=0.01)  # log10 of 9999.999... rounds to 4
@example(largest=1e-05, size=1.0, share=0.01)  # 0.01 / 1e-05 is 999.9999999999999
@given(largest=st.floats(1e-6, 10.0), size=st.floats(1.0, 2000.0), share=st.floats(0.01, 0.2))
@example(largest=1e-05, size=1.0, share=0.01)  # wanted is 999.9999999999999, whose log10 rounds to 3.0
def test_the_magnification_is_a_round_number_that_keeps_the_correction_in_its_share(largest, size, share):
    magnification = magnification_for(largest, size, share)
    assert magnification >= 1.0
    power = 10.0 ** math.floor(math.log10(magnification))
    assert any(math.isclose(magnification, m * power) for m in (1, 2, 5))
    if magnification > 1.0:
        assert largest * magnification <= share * size * (1 + 1e-9)  # never drawn beyond its share
        bigger = {1: 2, 2: 5, 5: 10}[round(magnification / power)] * power
        assert largest * bigger > share * size  # and the next round number would be
    assert magnification_for(0.0, size, share) == 1.0


@given(count=st.integers(1, 5000), most=st.integers(8, 400), seed=st.integers(0, 2**16))
def test_a_long_line_is_drawn_from_its_ends_and_every_run_s_extremes(count, most, seed):
    """Thinning for drawing keeps the first and last point, the lowest and the highest (a spike
    stays visible), at most about ``most`` points, in their order; a short line is left whole."""
    rng = np.random.default_rng(seed)
    angles = np.sort(rng.uniform(0.0, 360.0, count))
    deviations = np.cumsum(rng.normal(size=count))
    deviations[rng.integers(count)] += 50.0
    kept_angles, kept = drawn(angles, deviations, most)
    if count <= most:
        assert kept_angles is angles and kept is deviations
        return
    assert len(kept) <= most + 8
    assert kept_angles[0] == angles[0] and kept_angles[-1] == angles[-1]
    assert kept.max() == deviations.max() and kept.min() == deviations.min()
    assert np.all(np.diff(kept_angles) >= 0.0)


def test_a_trace_of_a_million_samples_is_drawn_thinned_and_its_gaps_kept(tmp_path):
    from postproc.measure.readers.ballbar import make_trace

    angles = np.concatenate([np.linspace(-20.0, 90.0, 500_000, endpoint=False), np.linspace(110.0, 200.0, 500_000)])
    deviations = 0.001 * np.sin(np.radians(angles) * 9.0)
    trace = make_trace("long.csv", 100.0, "cw", angles, deviations, centered=True)
    theta, shown = along_arc(trace)
    assert len(theta) < 21_000 and np.isnan(shown).sum() == 1
    assert np.nanmax(shown) == deviations.max() and np.nanmin(shown) == deviations.min()
    whole = read_ballbar(str(SAMPLES / "ballbar" / "v40r-100-ccw.csv"))
    assert len(along_arc(whole)[0]) == len(whole.angles) + 1  # a trace of the usual size: every sample drawn
