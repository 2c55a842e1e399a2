"""A shop's day: profiles, regions, review before writing, batches, plots and the Python API."""

from __future__ import annotations

import os

import pytest

import postproc
from support import SAMPLES
from support.corpus import corpus
from postproc.diagnostics import OptionError, SafetyError

HEMISHELL = str(SAMPLES / "programs" / "hemishell.nc")
TRACE = ["--plugin", "ballbar-inverse", "--ballbar", str(SAMPLES / "ballbar" / "v40r-100-ccw.csv"),
         "--ballbar", str(SAMPLES / "ballbar" / "v40r-100-cw.csv"), "--option", "radius-mapping=relative"]
TWO_ARCS = "G18 G21 G99 F0.1\nT0101\nG00 X20. Z5.\nN100 G01 Z0.\nG02 X40. Z-10. R10.\nN200 G01 Z-20.\nT0202\nG00 X40. Z-20.\nG03 X60. Z-30. R10.\nG01 Z-40.\n"


def _constant_trace(tmp_path, radius=10.0):
    trace = tmp_path / "t.csv"
    rows = "".join(f"{a},0.004\n" for a in range(0, 360, 2))
    trace.write_text(f"# postproc ballbar 1\n# radius_mm = {radius}\n# direction = ccw\n# centered = true\nangle_deg,deviation_mm\n{rows}")
    return ["--plugin", "ballbar-inverse", "--ballbar", str(trace)]


@pytest.mark.parametrize("region, changed", [("N100-N200", {"G02 X40. Z-10. R10."}), ("L9-L9", {"G03 X60. Z-30. R10."}),
                                             ("9-9", {"G03 X60. Z-30. R10."}), ("T02", {"G03 X60. Z-30. R10."}),
                                             ("T0101", {"G02 X40. Z-10. R10."})])
def test_regions_leave_everything_else_byte_for_byte(run, tmp_path, region, changed):
    program = tmp_path / "p.nc"
    program.write_text(TWO_ARCS)
    result = run("compensate", str(program), *_constant_trace(tmp_path), "--region", region)
    assert result.exit_code == 0, result.stderr
    gone = {line for line in TWO_ARCS.splitlines() if line not in result.stdout.splitlines()}
    assert changed <= gone
    assert not (gone - changed - {"N100 G01 Z0.", "G00 X40. Z-20.", "N200 G01 Z-20.", "G01 Z-40."})


def test_a_bad_region_is_an_option_error(run):
    result = run("compensate", HEMISHELL, *TRACE, "--region", "N10..N20")
    assert result.exit_code == 3 and "expected N100-N200" in result.stderr


def test_diff_and_check(run, tmp_path):
    diff = run("compensate", HEMISHELL, *TRACE, "--diff")
    assert diff.exit_code == 0
    assert diff.stdout.startswith(f"--- {HEMISHELL}\n+++ {HEMISHELL} (compensated)\n")
    assert "-G03 X114.3 Z0. I0. K-57.15\n" in diff.stdout
    check = run("compensate", HEMISHELL, *TRACE, "--check")
    assert (check.exit_code, check.stdout) == (1, "") and "would be changed" in check.stderr
    same = run("compensate", HEMISHELL, "--check")
    assert (same.exit_code, same.stdout) == (0, "")
    assert same.stderr == "postproc: warning: no compensator was given (--plugin or --model): nothing was applied\n"


def test_batch_writes_each_program_and_goes_on_past_a_failure(run, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    bad = tmp_path / "bad.nc"
    bad.write_text("G01 X1..\n")
    programs = [str(p) for p in corpus("fanuc")[:3]] + [str(bad), HEMISHELL]
    for jobs in ("1", "2"):
        result = run("compensate", *programs, "--out-dir", str(out), "--jobs", jobs)
        assert result.exit_code == 3
        lines = result.stderr.splitlines()
        assert sum(1 for line in lines if ": ok -> " in line) == 4
        assert any(line.startswith(f"{bad}:1:") for line in lines)
        assert lines[-1] == "postproc: 1 of 5 programs failed"
        for program in programs:
            assert (out / os.path.basename(program)).exists() == (program != str(bad))
        assert sorted(os.listdir(out)) == sorted(os.path.basename(p) for p in programs if p != str(bad))


def test_profile_show_round_trips(run, tmp_path):
    shown = run("profile", "show")
    assert shown.exit_code == 0 and 'gcode_system = "A"' in shown.stdout
    saved = tmp_path / "m.toml"
    saved.write_text(shown.stdout.replace("max_correction = 0.1", "max_correction = 0.002"))
    again = run("profile", "show", "--machine", str(saved))
    assert "max_correction = 0.002" in again.stdout
    refused = run("compensate", HEMISHELL, *TRACE, "--machine", str(saved))
    assert refused.exit_code == 4 and "exceeds the maximum correction 0.002 mm" in refused.stderr
    saved.write_text("gcode_system = 'D'\n")
    assert run("profile", "show", "--machine", str(saved)).exit_code == 3
    saved.write_text("tolerence = 0.002\n")
    assert "unknown key 'tolerence'" in run("profile", "show", "--machine", str(saved)).stderr


def test_soft_limits_refuse_a_compensated_move_beyond_them(run, tmp_path):
    machine = tmp_path / "m.toml"
    machine.write_text("x_limits = [-1.0, 57.146]\n")
    result = run("compensate", HEMISHELL, *_constant_trace(tmp_path, 57.15), "--machine", str(machine))
    assert result.exit_code == 0  # the arc shrinks inside the limit
    machine.write_text("x_limits = [-1.0, 57.0]\n")
    refused = run("compensate", HEMISHELL, *_constant_trace(tmp_path, 57.15), "--machine", str(machine))
    assert refused.exit_code == 4 and "beyond the soft limit" in refused.stderr and ":10:" in refused.stderr


def test_path_plot(run, tmp_path):
    picture = tmp_path / "p.png"
    result = run("path", HEMISHELL, "--plot", str(picture), *TRACE)
    assert result.exit_code == 0 and result.stdout.startswith("line,kind,")
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert run("path", HEMISHELL, *TRACE).exit_code == 2


def test_python_api(tmp_path):
    text = open(HEMISHELL).read()
    assert postproc.compensate_text(text) == text
    ballbar = [str(SAMPLES / "ballbar" / f"v40r-100-{d}.csv") for d in ("ccw", "cw")]
    pipeline = postproc.Pipeline(plugins=["ballbar-inverse"], ballbar=ballbar, options=["radius-mapping=relative"])
    out = pipeline.compensate_text(text, "hemishell.nc")
    assert "(POSTPROC 0.1.0 COMPENSATED)" in out and out != text
    summary = pipeline.compensate_file(HEMISHELL, str(tmp_path / "h.nc"))
    assert summary.replaced == 2 and 0 < summary.largest_correction < 0.01
    with pytest.raises(OptionError):
        postproc.Pipeline(plugins=["nope"])
    with pytest.raises(SafetyError):
        postproc.compensate_text(out, plugins=["ballbar-inverse"], ballbar=ballbar, options=["radius-mapping=relative"])


def test_report_json_says_what_was_fitted(run, tmp_path):
    import json

    report = tmp_path / "r.json"
    result = run("compensate", HEMISHELL, "--plugin", "tool-offset", "--probe", str(SAMPLES / "probe" / "hemishell-pass1.csv"),
                 "--calibration", str(SAMPLES / "probe" / "artifact-calibration.csv"), "--report", str(report), "--force")
    assert result.exit_code == 0, result.stderr
    (entry,) = json.loads(report.read_text())["compensators"]
    assert entry["plugin"] == "tool-offset" and "offset_mm" in json.dumps(entry)


def test_a_batch_tells_each_programs_warnings_once_with_its_summary(run, tmp_path):
    """Each warning of a batch's program came out twice (as it happened, and again with the
    program's summary line), and a compensator that warns once per program was silent for the
    programs after the first: each program's warnings now come once, just before its line."""
    traces = tmp_path / "traces"
    traces.mkdir()
    for direction in ("ccw", "cw"):  # the half of each trace below the axis: the part lies outside its box
        lines = (SAMPLES / "ballbar" / f"v40r-100-{direction}.csv").read_text().splitlines()
        kept = [line for line in lines if line.startswith(("#", "angle")) or 180.0 <= float(line.split(",")[0]) <= 310.0]
        (traces / f"{direction}.csv").write_text("\n".join(kept) + "\n")
    programs = []
    for name in ("a.nc", "b.nc", "c.nc"):
        programs.append(tmp_path / name)
        programs[-1].write_text((SAMPLES / "programs" / "hemishell.nc").read_text())
    for jobs in ("1", "2"):
        result = run("compensate", *map(str, programs), "--plugin", "parametric", "--ballbar",
                     str(traces / "ccw.csv"), "--ballbar", str(traces / "cw.csv"), "--out-dir",
                     str(tmp_path / f"out{jobs}"), "--jobs", jobs)
        assert result.exit_code == 0, result.stderr
        lines = result.stderr.splitlines()
        for program in programs:
            said = [line for line in lines if line.startswith(f"{program}: warning: parametric: the move on line 9")]
            assert len(said) == 1, result.stderr
            assert lines[lines.index(said[0]) + 1].startswith(f"{program}: ok -> ")
