"""The command line: stdout, stderr and exit codes, each asserted on its own."""

from __future__ import annotations

from conftest import corpus

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
    assert absurd.exit_code == 2 and not (tmp_path / "x").exists()
    assert run("compensate", *map(str, programs), "--out-dir", str(tmp_path), "--jobs", "0").exit_code == 2
