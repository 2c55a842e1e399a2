"""The command line: stdout, stderr and exit codes, each asserted on its own."""

from __future__ import annotations

import pytest

from support import SAMPLES
from support.corpus import corpus

HEMISHELL = b"%\nO1000 (HEMISHELL)\nG18 G21 G99\nT0101\nG00 X0. Z60.\nG01 Z57.15 F0.1\nG03 X114.3 Z0. I0. K-57.15\nG00 X150.\nM30\n%\n"


NOTHING_APPLIED = ("postproc: warning: no compensator was given (--plugin or --model): nothing was applied; the "
                   "program is written back unchanged\n")


def test_compensate_without_compensator_is_the_identity_and_says_so(run, tmp_path):
    """An empty $PLUGIN in a post-processing script must not send an uncompensated part silently."""
    source = tmp_path / "part.nc"
    source.write_bytes(HEMISHELL)
    result = run("compensate", str(source))
    assert (result.exit_code, result.stdout_bytes, result.stderr) == (0, HEMISHELL, NOTHING_APPLIED)
    target = tmp_path / "out.nc"
    result = run("compensate", str(source), "-o", str(target))
    assert (result.exit_code, result.stdout_bytes) == (0, b"")
    assert target.read_bytes() == HEMISHELL
    result = run("compensate", "-", input=HEMISHELL)
    assert result.stdout_bytes == HEMISHELL


def test_out_dir_writes_each_input_under_its_own_name(run, tmp_path):
    programs = corpus("fanuc")[:3]
    result = run("compensate", *map(str, programs), "--out-dir", str(tmp_path))
    assert result.exit_code == 0, result.stderr
    for path in programs:
        assert (tmp_path / path.name).read_bytes() == path.read_bytes()


def test_path_writes_the_csv_contract(run):
    result = run("path", input=HEMISHELL)
    assert result.exit_code == 0
    lines = result.stdout.splitlines()
    assert lines[0] == "line,kind,x_start,z_start,x_end,z_end,x_center,z_center,direction"
    assert lines[1] == "5,rapid,,,0.000000,60.000000,,,"
    assert lines[2] == "6,line,0.000000,60.000000,0.000000,57.150000,,,"
    assert lines[3] == "7,arc,0.000000,57.150000,57.150000,0.000000,0.000000,0.000000,ccw"
    assert lines[4] == "8,rapid,57.150000,0.000000,75.000000,0.000000,,,"
    assert len(lines) == 5


def test_check_talks_on_stderr_only(run):
    result = run("check", input=HEMISHELL)
    assert result.exit_code == 0
    assert result.stdout == ""
    assert result.stderr == "<stdin>: ok: 10 lines, 4 moves, 0 warnings\n"


def test_program_error_has_position_source_line_and_caret(run):
    result = run("compensate", input=b"G00 X1. Z1.\nG01 X2..\n")
    assert result.exit_code == 3
    assert result.stdout_bytes == b""
    assert result.stderr == (
        "<stdin>:2:8: error: a second decimal point in one number (FANUC alarm PS0007)\n"
        "    G01 X2..\n"
        "           ^\n"
    )


def test_missing_input_is_a_whole_file_error(run, tmp_path):
    result = run("check", str(tmp_path / "nope.nc"))
    assert result.exit_code == 3
    assert result.stderr.startswith(f"{tmp_path / 'nope.nc'}: error: cannot read program")


def test_unwritable_output_leaves_nothing_and_says_why(run, tmp_path):
    result = run("compensate", "-o", str(tmp_path / "missing" / "out.nc"), input=HEMISHELL)
    assert result.exit_code == 3
    assert "nothing was written" in result.stderr
    assert result.stdout_bytes == b""


def test_usage_errors_exit_2(run, tmp_path):
    result = run("compensate", "--ballbar", "x.csv", input=HEMISHELL)
    assert result.exit_code == 2
    assert "no compensator" in result.stderr
    assert result.stdout_bytes == b""
    result = run("compensate", "a.nc", "b.nc")
    assert result.exit_code == 2
    result = run("compensate", "--mode", "spline", input=HEMISHELL)
    assert result.exit_code == 2


def test_version_and_help(run):
    assert run("--version").stdout.startswith("postproc, version ")
    assert "compensate" in run("--help").stdout


def test_log_copies_messages_to_a_file(run, tmp_path):
    log = tmp_path / "postproc.log"
    result = run("--log", str(log), "check", input=HEMISHELL)
    assert result.exit_code == 0
    assert log.read_text() == "<stdin>: ok: 10 lines, 4 moves, 0 warnings\n"


# A shop program with axis words of both spellings: X86. and Z0.25, then G01X118 and G00Z220.
MIXED = (b"%\nO0001\nG21 G99 G18\nT0101\nG00 X120. Z5.\nG01 X86. Z0.25 F0.2\nG01X118\nG00Z220\n"
         b"G01 X104 Z-50. F0.2\nM30\n%\n")


def _mixed_model(run, tmp_path):
    from support import SAMPLES

    model = tmp_path / "model.json"
    assert run("fit", "--plugin", "parametric", "--ballbar", str(SAMPLES / "ballbar/v40r-100-ccw.csv"),
               "--ballbar", str(SAMPLES / "ballbar/v40r-100-cw.csv"), "--option", "extrapolate=true",
               "-o", str(model)).exit_code == 0
    return str(model)


def test_check_warns_at_the_first_plain_axis_word_of_a_mixed_program(run):
    result = run("check", input=MIXED)
    assert result.exit_code == 0
    assert result.stdout == ""
    lines = result.stderr.splitlines()
    assert lines[0].startswith("<stdin>:7:4: warning: X118 has no decimal point: "
                               "read in least input increments (IS-B) it is 0.118 mm; on a control with "
                               "calculator-type input (parameter 3401 bit 0, DPI) it is 118 mm")
    assert lines[1:3] == ["    G01X118", "       ^"]
    assert lines[-1] == "<stdin>: ok: 11 lines, 5 moves, 1 warnings"


def test_compensate_refuses_a_mixed_program_until_the_profile_says_how_the_control_reads_it(run, tmp_path):
    model = _mixed_model(run, tmp_path)
    result = run("compensate", "--model", model, input=MIXED)
    assert result.exit_code == 4
    assert result.stdout_bytes == b""
    first = result.stderr.splitlines()[0]
    assert first.startswith("<stdin>:7:4: error: X118 has no decimal point")
    assert first.endswith("state which in the machine profile, calculator_input = true or false")
    for stated, words in (("true", ("X117.994Z0.249", "X103.987 Z-50.006")), ("false", ("X0.114Z0.249", "X0.1 Z-50.006"))):
        machine = tmp_path / f"{stated}.toml"
        machine.write_text(f"calculator_input = {stated}\n")
        result = run("compensate", "--model", model, "--machine", str(machine), input=MIXED)
        assert result.exit_code == 0, result.stderr
        warnings = [line for line in result.stderr.splitlines() if "warning" in line]
        assert len(warnings) == 1 and "the model was made under a machine profile 'fanuc-18i-t' of other content" in \
            warnings[0]  # fitted under the embedded default, applied under this file
        out = result.stdout
        assert all(word in out for word in words), out
        assert run("check", "--machine", str(machine), input=result.stdout_bytes).exit_code == 0


def test_a_program_with_decimal_points_throughout_needs_no_word_on_calculator_input(run, tmp_path):
    model = _mixed_model(run, tmp_path)
    result = run("compensate", "--model", model, input=HEMISHELL)
    assert result.exit_code == 0, result.stderr
    assert "decimal point" not in result.stderr


def test_a_program_without_any_decimal_point_is_refused_until_the_profile_says_how_the_control_reads_it(
        run, tmp_path):
    """Its rewritten blocks get decimal points, which mean the same on both controls, while its
    plain words mean 1000 times more on one of them: a whole program of plain words is as
    ambiguous as a mixed one."""
    model = _mixed_model(run, tmp_path)
    plain = b"G21 G99 G18\nG00 X120000 Z5000\nG01 X86000 Z250 F0.2\nG04 X1000\nG28 U0 W0\nM30\n"
    result = run("compensate", "--model", model, input=plain)
    assert result.exit_code == 4 and result.stdout_bytes == b""
    assert result.stderr.startswith("<stdin>:2:5: error: X120000 has no decimal point: read in least input "
                                    "increments (IS-B) it is 120 mm; on a control with calculator-type input")
    checked = run("check", input=plain)
    assert checked.exit_code == 0 and "<stdin>:2:5: warning: X120000 has no decimal point" in checked.stderr
    machine = tmp_path / "increments.toml"
    machine.write_text("calculator_input = false\n")
    result = run("compensate", "--model", model, "--machine", str(machine), input=plain)
    assert result.exit_code == 0, result.stderr
    assert "decimal point" not in result.stderr and "X86." in result.stdout


def test_calculator_input_is_unset_unless_the_profile_states_it(run, tmp_path):
    shown = run("profile", "show")
    assert shown.exit_code == 0 and "calculator_input" not in shown.stdout
    machine = tmp_path / "m.toml"
    machine.write_text("calculator_input = 1\n")
    result = run("check", "--machine", str(machine), input=HEMISHELL)
    assert result.exit_code == 3
    assert "calculator_input must be true or false" in result.stderr


def test_jobs_are_capped_at_the_programs_and_cpus_and_say_so(run, tmp_path):
    import os

    programs = corpus("fanuc")[:2]
    cpus = len(os.sched_getaffinity(0))
    result = run("compensate", *map(str, programs), "--out-dir", str(tmp_path), "--jobs", "64")
    assert result.exit_code == 0, result.stderr
    runs = "1 process runs" if cpus == 1 else "2 processes run"
    assert result.stderr.splitlines()[0] == (f"postproc: warning: --jobs 64: {runs} (2 programs, {cpus} "
                                             f"CPU{'s' * (cpus != 1)})")
    absurd = run("compensate", *map(str, programs), "--out-dir", str(tmp_path / "x"), "--jobs", "100000")
    assert absurd.exit_code == 3 and not (tmp_path / "x").exists()  # a wrong option value
    assert run("compensate", *map(str, programs), "--out-dir", str(tmp_path), "--jobs", "0").exit_code == 3


EMPTY_WARNING = ("warning: the program has no blocks: nothing in it commands the control (empty, or only tape marks, "
                 "program numbers, comments and blank lines); did the step that wrote it fail?")


@pytest.mark.parametrize("data", [b"", b"\n\n", b"%\n%\n", b"%\r\n(PART 7)\r\n\r\n%\r\n", b"%\nO1234 (NOTHING)\n%\n",
                                  b"(ONLY A COMMENT)"], ids=["0-bytes", "blank", "tape", "comment-crlf", "o-number",
                                                              "no-eol"])
def test_a_program_with_no_blocks_is_given_back_with_a_warning_from_a_file_and_from_stdin(run, tmp_path, data):
    """An empty program in a post-processing chain most often means a failed CAM step: said
    once on stderr by check and compensate, whichever way it comes; the identity stays byte for
    byte (nothing for nothing) and a compensated run writes only its provenance around it."""
    path = tmp_path / "empty.nc"
    path.write_bytes(data)
    for name, stdin in ((str(path), None), ("<stdin>", data)):
        given = () if stdin is not None else (str(path),)
        checked = run("check", *given, input=stdin)
        assert checked.exit_code == 0 and checked.stdout == ""
        assert checked.stderr.splitlines()[0] == f"{name}: {EMPTY_WARNING}"
        identity = run("compensate", *given, input=stdin)
        assert identity.exit_code == 0 and identity.stdout_bytes == data
        assert identity.stderr.count(EMPTY_WARNING) == 1
    model = _mixed_model(run, tmp_path)
    compensated = run("compensate", str(path), "--model", model)
    assert compensated.exit_code == 0 and compensated.stderr.count(EMPTY_WARNING) == 1
    out = compensated.stdout_bytes
    assert b"(POSTPROC " in out and b"(BLOCKS REPLACED 0 BY 0)" in out
    assert out.replace(b"\r\n", b"\n").endswith(data.replace(b"\r\n", b"\n").split(b"(NOTHING)\n")[-1].lstrip(b"%\n"))


@pytest.mark.parametrize("data", [b"M30\n", b"%\nT0101\nM30\n%\n", b"#1 = 5\n"])
def test_a_program_that_commands_anything_is_not_empty(run, data):
    result = run("check", input=data)
    assert result.exit_code == 0 and "no blocks" not in result.stderr


# ---------------------------------------------------------------------- what a small job loads

#: A run in a fresh interpreter (nothing imported yet) that prints, after the command, its exit
#: code and every module it imported.
STARTED = """
import json, sys
from postproc.cli.main import main
try:
    main(sys.argv[1:])
except SystemExit as stop:
    code = stop.code
print(json.dumps({"code": code, "modules": sorted(sys.modules)}))
"""

#: What a compensation with a saved model never needs: the fitting and plotting libraries, the
#: grammar (the fast path reads ordinary blocks), the installed metadata's reader (this
#: distribution's entry points are found without it), the TOML reader (no profile file is given),
#: measurement reading, the ballbar fit and analysis (the model's parameters are checked by
#: postproc.measure.parameters), the virtual lathe, the report; and the standard library's path,
#: URL and address modules (pathlib, urllib, ipaddress), which a compensation never needs.
NOT_FOR_A_MODEL_RUN = ("scipy", "matplotlib", "lark", "threadpoolctl", "importlib.metadata", "email", "zipfile",
                       "tomllib", "pathlib", "urllib", "ipaddress", "postproc.syntax.grammar", "postproc.measure.readers.registry", "postproc.measure.figures",
                       "postproc.measure.readers.ballbar", "postproc.measure.ballbar_fit",
                       "postproc.measure.ballbar_analysis", "postproc.simulator", "postproc.report")


def _started(*args: str):
    """STARTED with postproc found as an installed copy finds it: without the site module, so
    without the editable install's finder, which imports pathlib, urllib and ipaddress into every
    start of this checkout (an installed postproc does not); the plugins package a link to
    ``plugins/``, the installed libraries and this distribution's entry points where they are."""
    import json
    import subprocess
    import sys
    import sysconfig
    import tempfile
    from pathlib import Path

    from support import REPO

    with tempfile.TemporaryDirectory() as installed:
        (Path(installed) / "postproc_plugins").symlink_to(REPO / "plugins", target_is_directory=True)
        path = [installed, str(REPO), sysconfig.get_paths()["purelib"]]
        done = subprocess.run([sys.executable, "-S", "-c", f"import sys; sys.path[:0] = {path!r}\n{STARTED}", *args],
                              capture_output=True, text=True, cwd=REPO)
    return json.loads(done.stdout), done.stderr


#: what a saved model of these compensators needs of NOT_FOR_A_MODEL_RUN: the traces it holds are
#: the ballbar reader's (which the fit's module comes with)
HOLDS_TRACES = ("postproc.measure.readers.ballbar", "postproc.measure.ballbar_fit")


@pytest.mark.parametrize("plugin, option, needs", [
    ("parametric", "extrapolate=true", ()),
    ("effective-angle", "extrapolate=true", ()),
    ("ballbar-inverse", "radius-mapping=relative", HOLDS_TRACES),
    ("iterative", "radius-mapping=relative", HOLDS_TRACES),
])
def test_a_compensation_with_a_saved_model_imports_only_what_it_uses(run, tmp_path, plugin, option, needs):
    """Each of these costs a small job's start (README, "Speed and fuzzing"); a lazy import made eager
    again would go unnoticed by every other test."""
    from support import SAMPLES

    model = str(tmp_path / "model.json")
    assert run("fit", "--plugin", plugin, "--ballbar", str(SAMPLES / "ballbar/v40r-100-ccw.csv"), "--ballbar",
               str(SAMPLES / "ballbar/v40r-100-cw.csv"), "--option", option, "-o", model).exit_code == 0
    output = tmp_path / "out.nc"
    loaded, stderr = _started("compensate", str(SAMPLES / "programs/hemishell.nc"), "--model", model, "-o", str(output))
    assert loaded["code"] == 0, stderr
    assert output.exists()
    held_out = [lazy for lazy in NOT_FOR_A_MODEL_RUN if lazy not in needs]
    assert [name for name in loaded["modules"] if any(name == lazy or name.startswith(lazy + ".") for lazy in held_out)] == []
    assert [name for name in loaded["modules"] if name.startswith("postproc_plugins.")] == \
        [f"postproc_plugins.{plugin.replace('-', '_')}"]


#: A run as the console script starts it (``main()`` with no arguments reads ``sys.argv``), then
#: whether the objects it built were frozen out of the garbage collector's reach, the collector's
#: thresholds at the end and when numpy was imported, and the BLAS thread counts asked for.
AS_A_PROCESS = """
import gc, os, sys

class Seen:
    def find_spec(self, name, path=None, target=None):
        if name == "numpy":
            seen.append(gc.get_threshold())

seen = []
sys.meta_path.insert(0, Seen())
from postproc.cli.main import main
try:
    main()
except SystemExit as stop:
    print(stop.code, gc.get_freeze_count() > 0, gc.get_threshold(), seen[0], os.environ.get("OPENBLAS_NUM_THREADS"),
          os.environ.get("MKL_NUM_THREADS"))
"""


def test_a_compensation_in_its_own_process_settles_its_collector_and_blas_and_a_callers_does_not(run, tmp_path):
    """In the command line's own process the collector looks for cycles less often from the
    compensation's start (numpy and the engine are imported so) and then leaves the imports and
    the loaded model alone, and numpy's BLAS starts one thread (a small job's start), unless the
    user set its variable; never in a caller's, whose objects must stay collectable and whose
    collector and environment stay as it set them."""
    import gc
    import os
    import subprocess
    import sys

    from postproc.cli.main import BLAS_THREADS, COLLECT_EVERY

    thresholds, environment = gc.get_threshold(), dict(os.environ)
    model = _mixed_model(run, tmp_path)
    program = str(SAMPLES / "programs/hemishell.nc")
    assert run("compensate", program, "--model", model, "-o", str(tmp_path / "here.nc")).exit_code == 0
    assert (gc.get_freeze_count(), gc.get_threshold()) == (0, thresholds)
    assert {name: os.environ.get(name) for name in BLAS_THREADS} == {name: environment.get(name) for name in BLAS_THREADS}
    unset = {name: value for name, value in os.environ.items() if name not in BLAS_THREADS}
    for env, threads in ((unset, "1 1"), (dict(unset, OPENBLAS_NUM_THREADS="3"), "3 1")):
        out = tmp_path / f"own{threads[0]}.nc"
        done = subprocess.run([sys.executable, "-c", AS_A_PROCESS, "compensate", program, "--model", model,
                               "-o", str(out)], capture_output=True, text=True, env=env)
        assert done.stdout == f"0 True {COLLECT_EVERY} {COLLECT_EVERY} {threads}\n", done.stderr
        assert out.read_bytes() == (tmp_path / "here.nc").read_bytes()


def test_check_and_an_identity_run_import_no_numpy(tmp_path):
    from support import SAMPLES

    program = str(SAMPLES / "programs/hemishell.nc")
    for args in (("check", program), ("compensate", program, "-o", str(tmp_path / "out.nc"))):
        loaded, stderr = _started(*args)
        assert loaded["code"] == 0, stderr
        assert [name for name in loaded["modules"] if name.split(".")[0] in ("numpy", "pluggy", "lark")] == [], args


def _runs(tmp_path):
    """Commands that say warnings and summary lines, and one that fails after a warning."""
    from support import SAMPLES

    source = tmp_path / "part.nc"
    source.write_bytes(HEMISHELL)
    out = tmp_path / "out"
    out.mkdir()
    traces = ["--plugin", "parametric", "--ballbar", str(SAMPLES / "ballbar/v40r-100-ccw.csv"),
              "--ballbar", str(SAMPLES / "ballbar/v40r-100-cw.csv")]
    return {
        "check": (["check", str(source)], 0),
        "compensate, a warning": (["compensate", str(source)], 0),
        "compensate, a summary": (["compensate", str(source), *traces], 0),
        "a batch": (["compensate", str(source), *map(str, corpus("fanuc")[:2]), "--out-dir", str(out), *traces], None),
        "artifact-program": (["artifact-program", "--center-x", "80", "--center-z", "30", "--artifact-radius", "25.4"], 0),
        "a failure": (["compensate", str(source), "--tolerance", "0"], 3),
    }


@pytest.mark.parametrize("name", ["check", "compensate, a warning", "compensate, a summary", "a batch",
                                  "artifact-program", "a failure"])
def test_quiet_keeps_the_terminal_to_errors_and_the_log_gets_what_it_would_get(run, tmp_path, name):
    args, code = _runs(tmp_path)[name]
    loud_log, quiet_log = tmp_path / "loud.log", tmp_path / "quiet.log"
    loud = run("--log", str(loud_log), *args)
    if name == "a batch":
        for path in (tmp_path / "out").iterdir():
            path.unlink()
    quiet = run("-q", "--log", str(quiet_log), *args)
    assert code is None or (loud.exit_code, quiet.exit_code) == (code, code)
    assert quiet.exit_code == loud.exit_code
    assert quiet.stdout == loud.stdout
    assert loud.stderr != "" and loud_log.read_text() == loud.stderr
    assert quiet_log.read_text() == loud.stderr  # the log: all of it, quiet or not
    errors = [line for line in loud.stderr.splitlines(keepends=True) if ": error: " in line]
    assert quiet.stderr == "".join(errors)  # the terminal: the errors alone


@pytest.mark.parametrize("command", ["check", "path", "compensate"])
@pytest.mark.parametrize("word", ["X99999999.", "X2000000.", "Z-20000.", "U50000."])
def test_a_coordinate_beyond_any_lathes_travel_is_one_error_at_its_word(run, tmp_path, command, word):
    program = tmp_path / "huge.nc"
    program.write_text(f"%\nO1000\nG18 G21 G99\nT0101\nG00 X60. Z5.\nG01 Z0. F0.1\nG01 {word} F0.1\nM30\n%\n")
    target = tmp_path / "out.nc"
    measured = (["--plugin", "parametric", "--ballbar", str(SAMPLES / "ballbar" / "v40r-100-ccw.csv"), "--ballbar",
                 str(SAMPLES / "ballbar" / "v40r-100-cw.csv"), "-o", str(target)] if command == "compensate" else [])
    result = run(command, str(program), *measured)
    assert result.exit_code == 3 and result.stdout == ""
    first, source, caret = result.stderr.splitlines()[:3]
    assert first.startswith(f"{program}:7:5: error: {word} puts ")
    assert "beyond the travel of any lathe" in first and "missing decimal point" in first and "_limits" in first
    assert source.strip() == f"G01 {word} F0.1" and caret.strip() == "^"
    assert result.stderr.count("error:") == 1 and not target.exists()
