"""The tolerance cannot gouge (postproc.machine.bounds, and the rewriter's last check against the
nominal path): the bounds themselves, their "did you mean um?", and the check that holds
whatever the options let through."""

from __future__ import annotations

import math
import re

import pytest
from hypothesis import given
from hypothesis import strategies as st

from support import SAMPLES
from postproc.machine import bounds
from postproc.diagnostics import OptionError

HEMISHELL = str(SAMPLES / "programs" / "hemishell.nc")
TRACES = ["--plugin", "parametric", "--ballbar", str(SAMPLES / "ballbar" / "v40r-100-ccw.csv"),
          "--ballbar", str(SAMPLES / "ballbar" / "v40r-100-cw.csv")]


@given(st.floats(allow_nan=True, allow_infinity=True), st.floats(0.0001, 1.0))
def test_a_tolerance_is_accepted_exactly_when_it_is_a_sane_length(value, largest):
    sane = math.isfinite(value) and 0 < value <= min(bounds.MAX_TOLERANCE, largest)
    try:
        assert bounds.tolerance(value, largest) == value
        accepted = True
    except OptionError as exc:
        accepted = False
        assert exc.message.startswith("--tolerance ")
        if math.isfinite(value) and value > bounds.MAX_TOLERANCE:
            assert f"({value * 1000:g} um)" in exc.message  # both units
            # microns typed as millimetres, unless the micron reading is no tolerance either (0.06 um)
            meant = ("did you mean" if 1e-4 <= value / 1000 <= bounds.MAX_TOLERANCE else
                     f"give at most {bounds.MAX_TOLERANCE:g} mm")
            assert meant in exc.message
    assert accepted == sane


@given(st.floats(allow_nan=True, allow_infinity=True))
def test_a_maximum_correction_is_accepted_exactly_when_it_is_at_most_1_mm(value):
    sane = math.isfinite(value) and 0 < value <= bounds.MAX_CORRECTION
    try:
        bounds.max_correction(value)
        accepted = True
    except OptionError as exc:
        accepted = False
        if sane is False and math.isfinite(value) and value > 1:
            assert f"did you mean {value:g} um (--max-correction {value / 1000:g})?" in exc.message
    assert accepted == sane


@pytest.mark.parametrize("tolerance, said", [("20", "did you mean 20 um (--tolerance 0.02)?"),
                                              ("1e9", "(1e+12 um) is above 0.05 mm, which would let the emitted "
                                                      "path stray from the part; give at most 0.05 mm"),
                                              ("0.06", "(60 um) is above 0.05 mm, which would let the emitted path "
                                                       "stray from the part; give at most 0.05 mm")])
def test_microns_typed_as_millimetres_ask_did_you_mean_um(run, tolerance, said):
    """A micron reading below 0.1 um (0.06) or above the bound (1e9) is no tolerance anybody meant:
    the bound instead."""
    result = run("compensate", HEMISHELL, *TRACES, "--tolerance", tolerance)
    assert (result.exit_code, result.stdout) == (3, "")
    assert said in result.stderr, result.stderr


def test_the_chord_of_the_hemishell_is_refused_whatever_the_options(run, monkeypatch):
    """With the bounds out of the way (as a script could, through the API), the arc turned into
    its chord (16.7 mm off the part) is still refused for safety, and nothing is written."""
    monkeypatch.setattr(bounds, "tolerance", lambda value, *args, **kwargs: value)
    for tolerance in ("20", "1e9"):
        result = run("compensate", HEMISHELL, *TRACES, "--tolerance", tolerance)
        assert (result.exit_code, result.stdout) == (4, "")
        assert re.fullmatch(
            re.escape(f"{HEMISHELL}:10: error: the replacement would run ") + r"167\d\d\.\d um from the programmed "
            r"path, more than the largest correction \(\d\.\d\d um\) plus the tolerance \(50\.00 um\) allow: refused\n",
            result.stderr), result.stderr


def test_the_last_check_passes_the_compensations_it_should(run):
    """Every sample compensation at the default and the largest tolerance passes the check."""
    for tolerance in ([], ["--tolerance", "0.05"]):
        result = run("compensate", HEMISHELL, *TRACES, *tolerance)
        assert result.exit_code == 0, result.stderr


def test_the_last_check_sees_every_replaced_block(run, monkeypatch):
    """It runs on each written replacement, and cheaply: one measure per written cut."""
    from postproc.compensate import self_check

    measured = []
    real = self_check.within
    monkeypatch.setattr(self_check, "within", lambda cut, segment, allowed: measured.append(cut) or real(cut, segment,
                                                                                                    allowed))
    result = run("compensate", HEMISHELL, *TRACES)
    assert result.exit_code == 0
    written = int(re.search(r"\(BLOCKS REPLACED \d+ BY (\d+)\)", result.stdout).group(1))
    assert written > 0 and len(set(measured)) == written  # every cut written, each measured once


@pytest.mark.parametrize("args", [
    ("inspect", "{program}", "--probe", "{probe}", "--band", "5"),
    ("report", "{program}", "--plugin", "parametric", "--ballbar", "{ccw}", "--ballbar", "{cw}", "--band", "1000"),
    ("artifact-find", "{probe}", "--artifact-radius", "25.4", "--tolerance", "30")])
def test_a_band_or_a_convergence_in_microns_typed_as_millimetres_asks_did_you_mean(run, tmp_path, args):
    """--band 5 meant 5 um: judged as 5 mm, a part 17.5 um off passed; a 30 mm convergence
    tolerance took a round 22 mm off the ball as settled."""
    names = {"program": HEMISHELL, "probe": str(SAMPLES / "probe" / "hemishell-pass1.csv"),
             "ccw": str(SAMPLES / "ballbar" / "v40r-100-ccw.csv"), "cw": str(SAMPLES / "ballbar" / "v40r-100-cw.csv")}
    out = tmp_path / "out"
    result = run(*(arg.format(**names) for arg in args), "-o", str(out)) if args[0] != "inspect" else \
        run(*(arg.format(**names) for arg in args))
    assert result.exit_code == 3 and result.stdout == "" and not out.exists(), result.stderr
    value = args[-1]
    assert f"did you mean {value} um" in result.stderr, result.stderr
