"""No data lost: every block that is not a replaced motion block comes out unchanged and in order,
for every compensator, on the corpus, the samples and generated programs."""

from __future__ import annotations

import random

import pytest

from support import SAMPLES
from support.corpus import corpus
from support.interpret import steps
from support.generate import program

CCW, CW = (str(SAMPLES / "ballbar" / f"v40r-100-{d}.csv") for d in ("ccw", "cw"))
PROBE = ["--probe", str(SAMPLES / "probe" / "hemishell-pass1.csv"),
         "--calibration", str(SAMPLES / "probe" / "artifact-calibration.csv")]
BALLBAR = {
    "ballbar-inverse": ["--ballbar", CCW, "--ballbar", CW, "--option", "radius-mapping=relative", "--option", "max-gap=10"],
    "iterative": ["--ballbar", CCW, "--ballbar", CW, "--option", "radius-mapping=relative", "--option", "max-gap=10"],
    "parametric": ["--ballbar", CCW, "--ballbar", CW, "--option", "extrapolate=true"],
    "effective-angle": ["--ballbar", CCW, "--ballbar", CW, "--option", "extrapolate=true"],
}
PROBES = {"omp-feedback": PROBE, "tool-offset": PROBE + ["--force"]}


def _kept_in_order(original: str, written: str) -> None:
    """The blocks with no motion of their own, and every motion block not replaced, in order."""
    out = written.splitlines()
    position = 0
    for step in steps(original):
        if step.moves:
            continue  # a motion block may be replaced, or rewritten to meet a replaced neighbour
        text = step.block.text
        assert text in out[position:], f"line {step.block.line} {text!r} lost or moved"
        position = out.index(text, position) + 1


def _programs():
    texts = [p.read_bytes().decode("utf-8", "surrogateescape") for p in corpus("fanuc")]
    texts += [p.read_text() for p in sorted((SAMPLES / "programs").glob("*.nc"))]
    texts += [program(random.Random(seed)) for seed in range(20)]
    return texts


@pytest.mark.parametrize("plugin", sorted(BALLBAR))
def test_ballbar_compensators_lose_nothing(run, plugin):
    changed = 0
    for text in _programs():
        result = run("compensate", "--plugin", plugin, *BALLBAR[plugin], "--max-correction", "1", input=text.encode(
            "utf-8", "surrogateescape"))
        if result.exit_code != 0:  # refused, with its reason and nothing written
            assert result.stdout_bytes == b"" and ": error: " in result.stderr
            continue
        written = result.stdout_bytes.decode("utf-8", "surrogateescape")
        changed += written != text
        _kept_in_order(text, written)
    assert changed >= 5  # the compensators did change programs


@pytest.mark.parametrize("plugin", sorted(PROBES))
def test_probe_compensators_lose_nothing(run, plugin):
    for path in sorted((SAMPLES / "programs").glob("*.nc")):
        text = path.read_text()
        result = run("compensate", str(path), "--plugin", plugin, *PROBES[plugin])
        assert result.exit_code == 0, result.stderr
        assert result.stdout != text
        _kept_in_order(text, result.stdout)
