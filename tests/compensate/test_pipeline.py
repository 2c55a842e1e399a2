"""One compensation run (postproc.compensate.pipeline): the provenance header and what it records, double
compensation seen wherever its mark stands, nothing done said, a model's measurement time."""

from __future__ import annotations

import datetime as dt
import hashlib
import json
import os
import subprocess
import sys

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from support import INCH_HEMISHELL, SAMPLES

HEMISHELL = SAMPLES / "programs" / "hemishell.nc"
CCW, CW = (str(SAMPLES / "ballbar" / f"v40r-100-{d}.csv") for d in ("ccw", "cw"))
TRACES = ["--plugin", "parametric", "--ballbar", CCW, "--ballbar", CW]


def _header(program: str) -> list[str]:
    return [line for line in program.splitlines() if line.startswith("(") and line.upper() == line][:20]


def test_the_header_records_every_setting_that_changes_the_output(run):
    result = run("compensate", str(HEMISHELL), *TRACES, "--option", "extrapolate=true", "--region", "L7-L7",
                 "--region", "T01", "--tolerance", "0.002", "--mode", "arc", "--max-correction", "0.05")
    assert result.exit_code == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[2:14] == [
        "(POSTPROC 0.1.0 COMPENSATED)",
        "(PLUGIN PARAMETRIC 0.1.0)",
        "(OPTION PARAMETRIC.EXTRAPOLATE=TRUE)",
        "(INPUT V40R-100-CCW.CSV SHA256 BC5A9CF85373)",
        "(INPUT V40R-100-CW.CSV SHA256 DB4383B0A73C)",
        "(REGION L7-L7)",
        "(REGION T01)",
        "(TOLERANCE 0.002 MM MODE ARC)",
        "(MACHINE FANUC-18I-T MAX CORRECTION 0.05 MM)",
        "(LARGEST CORRECTION 0.0047 MM)",
        "(BLOCKS REPLACED 4 BY 6)",
        "(57.15 MM RADIUS, POLE TO EQUATOR, ALUMINIUM)",
    ]


def test_a_models_options_are_recorded_as_the_fits(run, tmp_path):
    model = tmp_path / "m.json"
    assert run("fit", *TRACES, "--option", "extrapolate=true", "-o", str(model)).exit_code == 0
    result = run("compensate", str(HEMISHELL), "--model", str(model))
    assert "(OPTION PARAMETRIC.EXTRAPOLATE=TRUE)" in result.stdout.splitlines()


def test_a_provenance_mark_anywhere_is_double_compensation(run, tmp_path):
    text = HEMISHELL.read_text()
    for where, program, line, col in [
        ("below line 50", text.replace("M30", "G00 X150.\n" * 60 + "( postproc 0.0.9 compensated )\nM30"), 74, 1),
        ("after a block", "G00 X150. (POSTPROC 0.1.0 COMPENSATED)\n" + text, 1, 11),
    ]:
        path = tmp_path / "p.nc"
        path.write_text(program)
        result = run("compensate", str(path), *TRACES)
        assert (result.exit_code, result.stdout) == (4, ""), where
        assert result.stderr.splitlines()[0] == (f"{path}:{line}:{col}: error: this program was already compensated "
                                                 "by postproc; give --force to compensate it again"), where
        forced = run("compensate", str(path), *TRACES, "--force")
        assert forced.exit_code == 0 and "(FORCED: COMPENSATED AGAIN OR CHECK OVERRIDDEN)" in forced.stdout


def test_a_region_that_selects_nothing_is_said_and_not_marked(run):
    result = run("compensate", str(HEMISHELL), *TRACES, "--region", "L1-L2")  # the tape mark and program number
    assert result.exit_code == 0
    assert result.stdout == HEMISHELL.read_text()
    assert result.stderr.splitlines()[0] == (
        f"{HEMISHELL}: warning: --region L1-L2 selects no block that could be compensated: the program is "
        "written back unchanged and not marked COMPENSATED")


def test_the_header_takes_the_programs_own_line_ending(run):
    for ending in ("\r", "\r\n", "\n"):
        program = HEMISHELL.read_text().replace("\n", ending)
        result = run("compensate", *TRACES, input=program.encode())
        assert result.exit_code == 0, result.stderr
        out = result.stdout_bytes.decode()
        header = [line for line in out.split(ending) if line.startswith("(POSTPROC")]
        assert header == ["(POSTPROC 0.1.0 COMPENSATED)"], repr(out[:200])
        assert out.count(ending) == out.count("\n" if ending == "\n" else "\r")  # one ending throughout


# ---------------------------------------------------------------------- a model's measurement time


def _measured(run, tmp_path, traces: list[str]) -> dict:
    model = tmp_path / "m.json"
    result = run("fit", "--plugin", "parametric", *[part for trace in traces for part in ("--ballbar", trace)],
                 "-o", str(model))
    assert result.exit_code == 0, result.stderr
    return json.loads(model.read_text()), result.stderr


def test_the_measured_header_key_is_the_models_measurement_time(run, tmp_path):
    ccw, cw = tmp_path / "ccw.csv", tmp_path / "cw.csv"
    for path, source, when in ((ccw, CCW, "2026-11-20T14:05:00+01:00"), (cw, CW, "2026-11-20T14:35:00+01:00")):
        lines = open(source).read().splitlines(keepends=True)
        path.write_text(lines[0] + f"# measured = {when}\n" + "".join(lines[1:]))
    data, _ = _measured(run, tmp_path, [str(ccw), str(cw)])
    assert data["measured"] == "2026-11-20T13:05:00+00:00"  # the older of the two


def test_without_the_key_the_files_modification_time_counts(run, tmp_path):
    ccw, cw = tmp_path / "ccw.csv", tmp_path / "cw.csv"
    ccw.write_bytes(open(CCW, "rb").read())
    cw.write_bytes(open(CW, "rb").read())
    moment = dt.datetime(2026, 3, 1, 8, 0, tzinfo=dt.timezone.utc).timestamp()
    os.utime(ccw, (moment, moment))
    data, _ = _measured(run, tmp_path, [str(ccw), str(cw)])
    assert data["measured"] == "2026-03-01T08:00:00+00:00"


def test_a_pipe_without_the_key_is_measured_now_with_a_warning_never_the_epoch(tmp_path):
    command = (f"{sys.executable} -c 'from postproc.cli.main import main; main()' fit --plugin parametric "
               f"--ballbar <(cat {CCW}) --ballbar <(cat {CW}) -o m.json")
    result = subprocess.run(["bash", "-c", command], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert "warning: no measurement time: the file has no '# measured = ...' header line" in result.stderr
    measured = dt.datetime.fromisoformat(json.loads((tmp_path / "m.json").read_text())["measured"])
    assert abs((dt.datetime.now(dt.timezone.utc) - measured).total_seconds()) < 600


PROFILE_KEYS = {"max_correction": st.sampled_from([0.05, 0.08, 0.1, 0.2]),
                "nose_radius_mm": st.sampled_from([0.2, 0.4, 0.8]),
                "output_decimals_mm": st.sampled_from([2, 3]),
                "controller": st.text(alphabet="abc -", max_size=8)}


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(chosen=st.fixed_dictionaries({}, optional=PROFILE_KEYS), spacing=st.sampled_from(["", "\n# shop lathe 3\n"]))
def test_the_header_identifies_a_profile_file_by_its_bytes_whatever_its_name(run, tmp_path_factory, chosen, spacing):
    """A profile without ``name`` is named as the default is: the header tells them apart by the
    file and the SHA-256 of its bytes; the embedded default has no PROFILE line."""
    folder = tmp_path_factory.mktemp("profile")
    path = folder / "shop-lathe.toml"
    text = spacing + "".join(f"{key} = {json.dumps(value)}\n" for key, value in chosen.items())
    path.write_text(text)
    own = run("compensate", str(HEMISHELL), *TRACES, "--machine", str(path))
    default = run("compensate", str(HEMISHELL), *TRACES)
    assert (own.exit_code, default.exit_code) == (0, 0), own.stderr
    digest = hashlib.sha256(text.encode()).hexdigest()[:12].upper()
    assert f"(PROFILE SHOP-LATHE.TOML SHA256 {digest})" in _header(own.stdout)
    assert not any(line.startswith("(PROFILE ") for line in _header(default.stdout))
    assert _header(own.stdout) != _header(default.stdout)


def test_a_profile_made_in_a_library_call_is_identified_by_its_settings():
    from postproc.compensate.pipeline import _profile_lines
    from postproc.machine.profile import DEFAULT, from_mapping

    assert _profile_lines(DEFAULT) == [] and _profile_lines(from_mapping({})) == []
    one, other = from_mapping({"nose_radius_mm": 0.8}), from_mapping({"nose_radius_mm": 0.2})
    assert _profile_lines(one)[0].startswith("PROFILE SETTINGS SHA256 ")
    assert _profile_lines(one) != _profile_lines(other) and _profile_lines(one) == _profile_lines(
        from_mapping({"nose_radius_mm": 0.8}))



def test_an_inch_grid_whose_default_tolerance_swallows_the_correction_warns_naming_the_key(run, tmp_path):
    """Written to 0.001 in, the default tolerance is 50 um and the rounding alone 12.7 um, more
    than the parametric model's 4.65 um: the program is written, with one warning naming the
    profile key and the remedy. The same program on the default 0.0001 in grid warns without
    asking for decimals the control cannot read."""
    program = tmp_path / "inch.nc"
    program.write_text(INCH_HEMISHELL)
    machine = tmp_path / "inch3.toml"
    machine.write_text("output_decimals_inch = 3\n")
    fit = TRACES
    result = run("compensate", str(program), *fit, "--machine", str(machine))
    assert result.exit_code == 0
    assert result.stdout.startswith("%\nO1003 (HEMISHELL IN INCHES)\n(POSTPROC") and "G03 X4.5 Z0." in result.stdout
    warnings = [line for line in result.stderr.splitlines() if ": warning: " in line]
    assert warnings == [
        f"{program}: warning: the largest correction, 4.65 um, is within the tolerance in force, 50.00 um: the written "
        "path may be no nearer the compensated path than the nominal one is (the default tolerance is twice the output "
        "step of 0.001 inch, output_decimals_inch = 3 in the machine profile, and the blocks' rounding alone, up to "
        "12.70 um, is as large as the correction: set output_decimals_inch = 4, the finest the control's least input "
        "increment (IS-B, 0.0001 inch) allows, and give a --tolerance below the correction, or leave the program "
        "uncompensated)"]
    default = run("compensate", str(program), *fit)
    assert default.exit_code == 0 and "(POSTPROC" in default.stdout
    assert [line for line in default.stderr.splitlines() if ": warning: " in line] == [
        f"{program}: warning: the largest correction, 4.65 um, is within the tolerance in force, 5.08 um: the written "
        "path may be no nearer the compensated path than the nominal one is (the default tolerance is twice the output "
        "step of 0.0001 inch, output_decimals_inch = 4 in the machine profile, the finest the control's least input "
        "increment (IS-B, 0.0001 inch) allows: give a finer --tolerance, or leave the program uncompensated)"]
    finer = run("compensate", str(program), *fit, "--tolerance", "0.002")
    assert finer.exit_code == 0 and "within the tolerance" not in finer.stderr


def test_a_metric_run_whose_correction_exceeds_the_tolerance_says_nothing_of_it(run):
    result = run("compensate", str(HEMISHELL), *TRACES)
    assert result.exit_code == 0 and "(POSTPROC" in result.stdout
    assert "within the tolerance" not in result.stderr


def test_a_measurement_or_model_read_from_stdin_is_recorded_as_stdin(run, tmp_path):
    """A file given as ``-`` is named ``<stdin>`` where the run records or shows it, as its
    messages name it: in a saved model's inputs, in the provenance header (``_STDIN_``, the
    header's letters), and in the ballbar and HTML reports; never as a bare ``-``."""
    ccw = open(CCW, "rb").read()
    model = tmp_path / "model.json"
    fitted = run("fit", "--plugin", "parametric", "--ballbar", "-", "--ballbar", CW, "-o", str(model), input=ccw)
    assert fitted.exit_code == 0, fitted.stderr
    assert [entry["file"] for entry in json.loads(model.read_text())["inputs"]] == ["<stdin>", CW]
    direct = run("compensate", str(HEMISHELL), "--plugin", "parametric", "--ballbar", "-", "--ballbar", CW, input=ccw)
    assert direct.exit_code == 0, direct.stderr
    assert "(INPUT _STDIN_ SHA256 BC5A9CF85373)\n" in direct.stdout and "(INPUT - " not in direct.stdout
    loaded = run("compensate", str(HEMISHELL), "--model", "-", input=model.read_bytes())
    assert loaded.exit_code == 0, loaded.stderr
    header = [line for line in loaded.stdout.splitlines() if line.startswith(("(INPUT", "(MODEL"))]
    digest = json.loads(model.read_text())["sha256"][:12].upper()
    assert header == ["(INPUT _STDIN_ SHA256 BC5A9CF85373)", "(INPUT V40R-100-CW.CSV SHA256 DB4383B0A73C)",
                      f"(INPUT _STDIN_ SHA256 {digest})", "(MODEL _STDIN_)"]
    shown = run("ballbar", "-", CW, input=ccw)
    assert shown.exit_code == 0, shown.stderr
    assert "  ccw <stdin> (720 samples, the whole circle)" in shown.stdout.splitlines()
    report = tmp_path / "report.html"
    reported = run("report", str(HEMISHELL), "--plugin", "parametric", "--ballbar", "-", "--ballbar", CW,
                   "-o", str(report), input=ccw)
    assert reported.exit_code == 0, reported.stderr
    assert "<td>&lt;stdin&gt;</td>" in report.read_text() and "<td>-</td>" not in report.read_text()


def test_a_program_refused_half_way_leaves_nothing_to_the_next_of_a_batch():
    """Each program of a batch (one pipeline, several programs) is told of its own moves: a
    program refused half way never reaches the compensators' finish(), and their start() is
    what clears the warning given once per program (here: a move outside the box the test arcs
    span), so the next program is warned of its own."""
    from postproc.api import Pipeline
    from postproc.diagnostics import PostprocError, Reporter

    reporter = Reporter()
    pipeline = Pipeline(plugins=["parametric"], ballbar=[CCW, CW], reporter=reporter)
    outside = "G18 G21 G99 F0.1\nG00 X300. Z5.\nG01 Z-300.\n"
    with pytest.raises(PostprocError):  # refused at its last block, after the move outside the box
        pipeline.compensate_text(outside + "G02 X20. Z-320. R1.\n", "a.nc")
    pipeline.compensate_text(outside, "b.nc")
    told = [w for w in reporter.warnings if "leaves the box" in w.message]
    assert [w.location.file for w in told] == ["a.nc", "b.nc"]


def test_each_program_of_a_batch_is_told_that_one_trace_serves_both_directions():
    """ballbar-inverse given one trace: every program whose G02 arcs take the CCW trace is told
    so, not only the first of a batch."""
    from postproc.api import Pipeline
    from postproc.diagnostics import Reporter

    reporter = Reporter()
    pipeline = Pipeline(plugins=["ballbar-inverse"], ballbar=[CCW], options=["radius-mapping=relative"],
                        reporter=reporter)
    for name in ("a.nc", "b.nc"):
        pipeline.compensate_text(HEMISHELL.read_text().replace("G03", "G02"), name)
    told = [w for w in reporter.warnings if "take the ccw trace" in w.message]
    assert len(told) == 2 and {w.location.file for w in told} == {CCW}  # once for each program, at the trace


def test_effective_angle_predicts_each_program_of_a_batch_from_its_own_moves():
    """The prediction effective-angle warns with is gathered from one program's moves: a program
    refused half way leaves none of its moves in the next one's."""
    from postproc.api import Pipeline
    from postproc.diagnostics import PostprocError, Reporter

    def predicted(before: list[str]) -> list[str]:
        reporter = Reporter()
        pipeline = Pipeline(plugins=["effective-angle"], ballbar=[CCW, CW], reporter=reporter)
        for text in before:
            with pytest.raises(PostprocError):
                pipeline.compensate_text(text, "a.nc")
        pipeline.compensate_text(HEMISHELL.read_text(), "b.nc")
        return [w.message for w in reporter.warnings if "predicted to leave" in w.message]

    refused = "G18 G21 G99 F0.1\nG00 X0. Z5.\nG01 Z0.\nG03 X50. Z-25. R25.\nG01 Z-60.\nG02 X20. Z-320. R1.\n"
    alone = predicted([])
    assert alone and predicted([refused]) == alone
