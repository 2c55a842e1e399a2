"""``postproc report``: one self-contained HTML file, its content, and every image rendered in a real browser."""

from __future__ import annotations

import base64
import hashlib
import html
import io
import json
import os
import re
import signal
import subprocess
import time
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from support import SAMPLES
from postproc import __version__
from postproc.compensate import hookspecs
from postproc.compensate import registry
from postproc.cli.main import main
from postproc.compensator import Compensator
from postproc.measure.figures import figures

CHROMIUM = "/usr/bin/chromium"
PROGRAM = SAMPLES / "programs" / "hemishell.nc"
CCW = SAMPLES / "ballbar" / "v40r-100-ccw.csv"
CW = SAMPLES / "ballbar" / "v40r-100-cw.csv"
PROBE = SAMPLES / "probe" / "hemishell-pass1.csv"
CALIBRATION = SAMPLES / "probe" / "artifact-calibration.csv"
HOSTILE = 'ccw <b>&"\'.csv'  #: a file name that is also markup
INJECTED = "<script>alert(1)</script>"
FOUR = ("mean (um)", "mean |e| (um)", "RMS (um)", "sigma (um)")
FIRST_SCREEN = (1280, 900)  #: a desktop browser's window
NARROW = (500, 900)  #: a phone's, or a narrow window (headless chromium draws no narrower)


def _report(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(main, ["report", *args], catch_exceptions=False)
    return result.exit_code, result.stderr


def _png() -> bytes:
    from matplotlib.figure import Figure

    figure = Figure(figsize=(2.0, 1.5))
    figure.add_subplot().plot([0, 1, 2], [1, 0, 1])
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png")
    return buffer.getvalue()


class _ProbeShift(Compensator):
    """Moves every feed move 5 um towards the spindle axis (a test's probe compensator)."""

    name = "test-report-probe"
    takes = ("probe", "calibration")
    needs = ("probe",)

    def fit(self, measurements):
        self.files = [probe.path for probe in measurements.probe]

    def correct(self, piece):
        return np.tile([-0.005, 0.0], (len(piece.t), 1))

    def report(self):
        return {"parameters": {"shift_x_mm": {"value": -0.005, "sigma": 0.0002}, "count": 3},
                "chains": [{"tool": 1, "residual_um": figures([0.001, -0.002, 0.0005]).as_dict()}],
                "plot": _png(), "notes": ["first note", "second <i>note</i>"], "files": self.files}


class _BrokenReport(_ProbeShift):
    """A probe compensator whose report() fails."""

    name = "test-report-broken"

    def report(self):
        raise RuntimeError("no report <today>")


class _Plugin:
    @hookspecs.hookimpl
    def postproc_compensators(self):
        return [_ProbeShift, _BrokenReport]


@pytest.fixture(scope="module")
def reports(tmp_path_factory) -> dict[str, Path]:
    """The reports the tests read: written once."""
    folder = tmp_path_factory.mktemp("reports")
    hostile = folder / HOSTILE
    text = CCW.read_text().replace("angle_deg,deviation_mm", f"# x-note = {INJECTED}\nangle_deg,deviation_mm", 1)
    hostile.write_text(text)
    made = {}
    code, stderr = _report(str(PROGRAM), "--plugin", "parametric", "--ballbar", str(hostile), "--ballbar", str(CW),
                           "-o", str(folder / "ballbar.html"))
    assert code == 0, stderr
    made["ballbar"] = folder / "ballbar.html"
    code, stderr = _report("--plugin", "parametric", "--ballbar", str(CCW), "--ballbar", str(CW),
                           "-o", str(folder / "model.html"))
    assert code == 0, stderr
    made["model"] = folder / "model.html"
    manager = registry.manager()
    plugin = _Plugin()
    manager.register(plugin, name="report-test-plugin")
    try:
        code, stderr = _report(str(PROGRAM), "--plugin", "test-report-probe", "--plugin", "test-report-broken",
                               "--probe", str(PROBE), "--calibration", str(CALIBRATION),
                               "-o", str(folder / "probe.html"))
    finally:
        manager.unregister(plugin)
    assert code == 0, stderr
    made["probe"] = folder / "probe.html"
    made["hostile"] = hostile
    return made


class _Tags(HTMLParser):
    def __init__(self):
        super().__init__()
        self.tags: list[tuple[str, dict[str, str]]] = []

    def handle_starttag(self, tag, attrs):
        self.tags.append((tag, {name: value or "" for name, value in attrs}))


def _tags(text: str) -> list[tuple[str, dict[str, str]]]:
    parser = _Tags()
    parser.feed(text)
    return parser.tags


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _table(text: str, key: str) -> str:
    found = re.search(rf'<table id="{key}".*?</table>', text, re.S)
    assert found, f"no table {key}"
    return html.unescape(found.group(0))


# ---------------------------------------------------------------- one file, nothing outside


@pytest.mark.parametrize("which", ["ballbar", "model", "probe"])
def test_the_report_is_one_file_with_no_external_reference(reports, which):
    text = reports[which].read_text(encoding="utf-8")
    tags = _tags(text)
    images = [attrs for tag, attrs in tags if tag == "img"]
    assert images
    for attrs in images:
        assert attrs["src"].startswith("data:image/png;base64,")
        png = base64.b64decode(attrs["src"].split(",", 1)[1], validate=True)
        assert png.startswith(b"\x89PNG\r\n\x1a\n")
    for tag, attrs in tags:
        assert tag not in ("script", "link", "iframe", "object", "embed", "base"), tag
        for name in ("src", "href", "srcset", "action", "data", "poster"):
            if name not in attrs:
                continue
            value = attrs[name]
            assert not re.match(r"\s*(https?:)?//", value, re.I), (tag, name, value[:80])
            if name == "href":
                assert value.startswith("#"), value
            if name == "src":
                assert value.startswith("data:"), value[:80]
    assert not re.search(r"https?://", re.sub(r'src="data:[^"]*"', "", text))
    style = re.search(r"<style>(.*?)</style>", text, re.S).group(1)
    assert "url(" not in style and "@import" not in style


def test_it_is_written_atomically_and_a_failed_run_leaves_the_old_file(tmp_path):
    target = tmp_path / "report.html"
    target.write_text("old")
    bad = tmp_path / "bad.csv"
    bad.write_text("# postproc ballbar 1\n# radius_mm = 100\nangle_deg,deviation_mm\n0,0\n")
    code, stderr = _report("--ballbar", str(bad), "-o", str(target))
    assert code == 3 and "direction" in stderr
    assert target.read_text() == "old" and sorted(p.name for p in tmp_path.iterdir()) == ["bad.csv", "report.html"]
    code, _ = _report("--ballbar", str(CCW), "-o", str(tmp_path / "missing" / "report.html"))
    assert code == 3 and not (tmp_path / "missing").exists()


def test_usage_errors(tmp_path):
    assert _report("-o", str(tmp_path / "r.html"))[0] == 2
    code, stderr = _report("--ballbar", str(CCW), "--option", "extrapolate=true", "-o", str(tmp_path / "r.html"))
    assert code == 2 and "--option" in stderr
    assert not (tmp_path / "r.html").exists()


# ---------------------------------------------------------------- content


def test_the_four_figures_and_the_prediction_are_there(reports):
    text = reports["ballbar"].read_text(encoding="utf-8")
    four = _table(text, "four-figures")
    for column in FOUR:
        assert f"<th>{column}</th>" in four
    for row in ("ballbar trace ccw", "ballbar trace cw", "ballbar diagnosis: traces minus model",
                "parametric: fit residual, both", "predicted: before (ballbar model)",
                "predicted: after (ballbar model)", "predicted: correction as emitted"):
        assert f"<td>{row}" in four, row
    numbers = re.findall(r"<td>([+-]?\d+\.\d{3})</td>", four)
    assert len(numbers) >= 4 * 7
    prediction = _table(text, "prediction-figures")
    assert "before (ballbar model)" in prediction and "after (ballbar model)" in prediction
    iso = _table(text, "iso-230-4")
    assert "G, circular deviation (ccw)" in iso and "H, circular hysteresis" in iso
    plain = html.unescape(text)
    assert "parametric: fitted parameters (1 sigma)" in plain and "<td>scaling X (+ side)</td>" in plain
    assert "Compensation: " in plain and "blocks replaced by" in plain
    assert len(re.findall(r"<img ", text)) == 5  # the verdict, polar, against angle, along the profile, the profile


def test_provenance_lists_every_input_with_its_hash(reports):
    text = reports["ballbar"].read_text(encoding="utf-8")
    inputs = _table(text, "inputs")
    for path in (PROGRAM, reports["hostile"], CW):
        assert _sha256(path) in inputs, path
    assert str(PROGRAM) in inputs and str(CW) in inputs
    plain = html.unescape(text)
    assert f"<td>postproc</td><td>{__version__}</td>" in plain
    assert "fanuc-18i-t" in plain and "created (UTC)" in plain and "postproc report " in plain
    assert re.search(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\+00:00", plain)


def test_every_string_from_the_user_is_escaped(reports):
    text = reports["ballbar"].read_text(encoding="utf-8")
    assert "<script" not in text and "<b>" not in text
    assert html.escape(INJECTED) in text
    assert html.escape(HOSTILE, quote=True) in text


def test_without_a_program_the_report_covers_measurements_and_model(reports):
    text = html.unescape(reports["model"].read_text(encoding="utf-8"))
    assert 'id="prediction"' not in text
    assert "none: measurements and model only" in text
    assert 'id="measurements"' in text and 'id="iso"' in text and 'id="model-parametric"' in text


def test_probe_points_against_the_program_and_a_plugin_report_of_any_shape(reports):
    text = reports["probe"].read_text(encoding="utf-8")
    plain = html.unescape(text)
    assert "dropped as the nub at the pole" in plain
    assert "pretravel model" in plain and 'id="calibration"' in plain
    prediction = _table(text, "prediction-figures")
    assert "before (probed, hemishell-pass1.csv)" in prediction and "after (probed, hemishell-pass1.csv)" in prediction
    emitted = re.search(r"<td>correction as emitted</td><td>([+-]\d+\.\d+)</td>", prediction)
    assert emitted and -10.0 < float(emitted.group(1)) < 0.0  # 2 x 5 um towards the axis, along the arc's normal
    four = _table(text, "four-figures")
    assert "test-report-probe: chain 1, residual" in four
    assert "<td>shift x</td><td>-5.00</td><td>0.20</td><td>um</td>" in text  # mm shown in um, named in words
    assert "second <i>note</i>" in plain and "<i>note</i>" not in text
    assert "test-report-broken: report() failed: RuntimeError: no report <today>" in plain
    assert len(re.findall(r"<img ", text)) == 6  # verdict, probe deviations, calibration, the plugin's plot, 2 predictions


# ---------------------------------------------------------------- a real browser


PROBE_SCRIPT = """<script>
window.addEventListener('load', function () {
  var sizes = [];
  for (var i = 0; i < document.images.length; i++) {
    var img = document.images[i], box = img.getBoundingClientRect();
    sizes.push({complete: img.complete, natural: [img.naturalWidth, img.naturalHeight], shown: [box.width, box.height],
                alt: img.alt, bottom: box.bottom + window.scrollY});
  }
  function scrolls(element) {  // inside a box that scrolls sideways on its own (a wide table, a listing)
    for (var e = element.parentElement; e && e !== document.body; e = e.parentElement) {
      var x = getComputedStyle(e).overflowX;
      if (x === 'auto' || x === 'scroll') return true;
    }
    return false;
  }
  var wide = [], all = document.body.getElementsByTagName('*');
  for (var j = 0; j < all.length; j++) {
    var box = all[j].getBoundingClientRect();
    if (box.width > 0 && box.right > window.innerWidth + 0.5 && !scrolls(all[j]))
      wide.push(all[j].tagName + (all[j].id ? '#' + all[j].id : '') + ' ' + Math.round(box.right));
  }
  var verdict = document.querySelector('.verdict'), nav = document.querySelector('nav');
  var layout = {width: window.innerWidth, height: window.innerHeight,
                scroll_width: document.documentElement.scrollWidth, wide: wide.slice(0, 20),
                verdict_bottom: verdict ? verdict.getBoundingClientRect().bottom : null,
                verdict_before_nav: verdict && nav ? !!(verdict.compareDocumentPosition(nav) & 4) : null};
  var out = document.createElement('pre');
  out.id = 'image-sizes';
  out.textContent = JSON.stringify({images: sizes, layout: layout});
  document.body.appendChild(out);
});
</script>
"""


def _rendered(report: Path, folder: Path, window: tuple[int, int] = FIRST_SCREEN) -> dict:
    """Open a copy of the report (with a script that writes each image's size and the page's
    layout into the DOM) in headless Chromium with a window of ``window`` pixels, and read them
    back from the dumped DOM."""
    if not (os.path.isfile(CHROMIUM) and os.access(CHROMIUM, os.X_OK)):
        pytest.fail(f"chromium (Debian package chromium) is required at {CHROMIUM} for this test")
    copy = folder / f"{report.stem}-probed.html"
    copy.write_text(report.read_text(encoding="utf-8").replace("</body>", PROBE_SCRIPT + "</body>"), encoding="utf-8")
    profile = folder / f"{report.stem}-{window[0]}-chromium-profile"
    command = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
               "--disable-background-networking", "--disable-component-update", "--disable-sync",
               "--disable-dev-shm-usage", "--hide-scrollbars", f"--window-size={window[0]},{window[1]}",
               f"--user-data-dir={profile}", "--virtual-time-budget=10000", "--dump-dom", copy.resolve().as_uri()]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    try:
        dom, errors = process.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)  # the browser and the helpers it started, nothing else
        process.communicate()
        pytest.fail(f"chromium did not finish within 120 s: {' '.join(command)}")
    found = re.search(rb'<pre id="image-sizes">(.*?)</pre>', dom, re.S)
    assert found, f"chromium (exit {process.returncode}) dumped no image sizes: {errors.decode(errors='replace')[-2000:]}"
    return json.loads(html.unescape(found.group(1).decode()))


def _rendered_sizes(report: Path, folder: Path) -> list[dict]:
    return _rendered(report, folder)["images"]


@pytest.mark.parametrize("window", [FIRST_SCREEN, NARROW], ids=["1280px", "500px"])
def test_every_image_renders_with_a_size_and_nothing_overflows_in_chromium(reports, tmp_path, window):
    """At a desktop's width and a phone's: every image decoded and laid out, nothing wider than
    the window but inside a box that scrolls on its own (a wide table, a listing), and the
    verdict the first thing on the first screen."""
    for which in ("ballbar", "probe", "model"):
        report = reports[which]
        expected = len(re.findall(r"<img ", report.read_text(encoding="utf-8")))
        started = time.perf_counter()
        found = _rendered(report, tmp_path, window)
        elapsed = time.perf_counter() - started
        sizes, layout = found["images"], found["layout"]
        assert len(sizes) == expected > 0, which
        for index, size in enumerate(sizes):
            assert size["complete"], (which, index)
            assert min(size["natural"]) > 0, (which, index, size)  # decoded: a broken image has natural size 0
            assert 0 < size["shown"][0] <= layout["width"] and size["shown"][1] > 0, (which, index, size)
        assert layout["width"] == window[0], layout
        assert layout["scroll_width"] <= layout["width"], (which, layout)  # no sideways scrolling of the page
        assert not layout["wide"], (which, layout["wide"])
        assert layout["verdict_before_nav"] and 0 < layout["verdict_bottom"] <= window[1], (which, layout)
        assert sizes[0]["alt"] == "deviation before and after compensation against the band"
        if window == FIRST_SCREEN:
            assert sizes[0]["bottom"] <= window[1], (which, sizes[0])  # the verdict's chart on the first screen
        print(f"{which} at {window[0]} px: {expected} images rendered by chromium in {elapsed:.2f} s")


def test_chromium_reports_a_broken_image_and_an_overflow_as_such(tmp_path):
    """The browser checks can fail: an image that does not decode has no natural size, a block
    wider than the window is found."""
    page = tmp_path / "broken.html"
    good = base64.b64encode(_png()).decode()
    page.write_text(f'<!DOCTYPE html><html><body><img src="data:image/png;base64,{good}" alt="good">'
                    f'<img src="data:image/png;base64,AAAA" alt="broken"><div style="width:2000px">wide</div>'
                    f'<div style="overflow-x:auto"><table><tr><td style="width:2000px">scrolls</td></tr></table></div>'
                    f'</body></html>')
    found = _rendered(page, tmp_path, NARROW)
    sizes, layout = found["images"], found["layout"]
    assert min(sizes[0]["natural"]) > 0 and sizes[1]["natural"] == [0, 0]
    assert layout["scroll_width"] > layout["width"] and [w.split()[0] for w in layout["wide"]] == ["DIV"]


def test_a_partial_arc_is_reported_and_drawn_as_measured(tmp_path):
    """A lathe's 220 deg test: the report names ISO 13041-6 and the arc, the plots do not close it."""
    from postproc.measure.readers.ballbar import read_ballbar
    from postproc.report.plotting import along_arc

    paths = []
    for direction, start in (("ccw", "200"), ("cw", "-20")):
        path = str(tmp_path / f"{direction}.csv")
        result = CliRunner().invoke(main, ["simulate", "ballbar", "--machine", str(SAMPLES / "machines" / "v40r-sim.toml"),
                                           "--direction", direction, "--start-angle", start, "--capture-arc", "220",
                                           "--overtravel", "2", "-o", path])
        assert result.exit_code == 0, result.stderr
        paths.append(path)
    target = tmp_path / "partial.html"
    code, stderr = _report("--ballbar", paths[0], "--ballbar", paths[1], "-o", str(target))
    assert code == 0 and "warning" not in stderr and "error" not in stderr
    text = target.read_text(encoding="utf-8")
    assert "ISO 13041-6" in text and "220 deg from -20 to 200 deg" in text
    assert "parametric diagnosis of the machine" in text
    angles, deviations = along_arc(read_ballbar(paths[1]))
    assert np.all(np.diff(angles[np.isfinite(angles)]) > 0)  # from the arc's start round to its end
    assert angles[0] == pytest.approx(-20.0) and angles[-1] == pytest.approx(199.5)  # across 0, not across the gap


def test_a_report_from_a_saved_model_plots_the_traces_the_model_carries(tmp_path):
    """ballbar-inverse keeps its traces: a --model report draws them (polar plot, against angle)
    with the model's measurement time; a model that keeps none says why and how to show them."""
    inverse, parametric = tmp_path / "inverse.json", tmp_path / "parametric.json"
    for plugin, model in (("ballbar-inverse", inverse), ("parametric", parametric)):
        result = CliRunner().invoke(main, ["fit", "--plugin", plugin, "--ballbar", str(CCW), "--ballbar", str(CW),
                                           "-o", str(model)])
        assert result.exit_code == 0, result.stderr
    code, stderr = _report("--model", str(inverse), "-o", str(tmp_path / "inverse.html"))
    assert code == 0, stderr
    text = html.unescape((tmp_path / "inverse.html").read_text(encoding="utf-8"))
    assert "polar plot of the ballbar traces" in text and "ballbar deviation against angle" in text
    assert f"The traces are those the saved model {inverse} carries" in text
    assert 'id="iso-230-4"' in text and "v40r-100-ccw.csv" in text
    code, stderr = _report("--model", str(parametric), "-o", str(tmp_path / "parametric.html"))
    assert code == 0, stderr
    text = html.unescape((tmp_path / "parametric.html").read_text(encoding="utf-8"))
    assert "polar plot" not in text and "keeps what it fitted, not the traces" in text and "--ballbar" in text
    code, stderr = _report("--model", str(parametric), "--ballbar", str(CCW), "--ballbar", str(CW),
                           "-o", str(tmp_path / "given.html"))
    assert code == 0, stderr
    text = html.unescape((tmp_path / "given.html").read_text(encoding="utf-8"))
    assert "polar plot of the ballbar traces" in text
    assert "they are the ones the model" in text and "was fitted from (by the SHA-256 it records)" in text
