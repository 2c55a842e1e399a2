"""Progress on a terminal, none on a pipe, and ``--quiet`` (postproc.compensate.progress).

The real command line runs in a subprocess whose stderr is a pseudo-terminal (the ``pty``
module) or a pipe; stdout is always a file, so the program written can be compared byte for
byte: the progress line must never reach it.
"""

from __future__ import annotations

import os
import pty
import re
import subprocess
import sys

import pytest

from support import REPO

sys.path.insert(0, str(REPO / "benchmarks"))
from programs import lathe_program  # noqa: E402

CCW = str(REPO / "samples/ballbar/v40r-100-ccw.csv")
CW = str(REPO / "samples/ballbar/v40r-100-cw.csv")
COMPENSATE = ["compensate", "--plugin", "parametric", "--option", "extrapolate=true", "--ballbar", CCW,
              "--ballbar", CW, "--region", "L1-L3000"]
BAR = "\x1b[2K"  #: the progress line erases itself: its mark on the terminal


def _postproc(args, stdout, terminal: bool, cwd=None) -> tuple[int, str]:
    """Run ``postproc ARGS`` with stderr on a pseudo-terminal (or a pipe); its exit code and stderr."""
    command = [sys.executable, "-m", "postproc", *args]
    env = {**os.environ, "COLUMNS": "100"}
    if not terminal:
        result = subprocess.run(command, stdout=stdout, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL,
                                env=env, cwd=cwd, timeout=300)
        return result.returncode, result.stderr.decode()
    controller, child = pty.openpty()
    process = subprocess.Popen(command, stdout=stdout, stderr=child, stdin=subprocess.DEVNULL, env=env, cwd=cwd)
    os.close(child)
    chunks = []
    while True:
        try:
            data = os.read(controller, 65536)
        except OSError:  # the child closed the terminal (EIO on Linux)
            break
        if not data:
            break
        chunks.append(data)
    os.close(controller)
    return process.wait(timeout=300), b"".join(chunks).decode(errors="replace")


def _screen(output: str) -> list[str]:
    """The lines a terminal shows at the end: carriage returns go back to the line's start,
    ESC[2K erases the line, other escapes (the cursor shown, hidden) show nothing."""
    lines, line, column = [], [], 0
    for token in re.findall(r"\x1b\[[0-9;?]*[A-Za-z]|\r\n|\r|\n|[^\x1b\r\n]+", output):
        if token == "\x1b[2K":
            line = []  # always after a carriage return here: the cursor is at the start
        elif token.startswith("\x1b"):
            continue
        elif token == "\r":
            column = 0
        elif token in ("\n", "\r\n"):
            lines.append("".join(line).rstrip())
            line, column = [], 0
        else:
            line[column:column + len(token)] = token
            column += len(token)
    if "".join(line).strip():
        lines.append("".join(line).rstrip())
    return lines


@pytest.fixture(scope="module")
def long_program(tmp_path_factory):
    program = tmp_path_factory.mktemp("progress") / "long.nc"
    program.write_text(lathe_program(20_000))
    return program


def test_a_long_program_shows_progress_on_a_terminal_and_none_on_a_pipe(long_program, tmp_path):
    with open(tmp_path / "tty.nc", "wb") as out:
        code, shown = _postproc(COMPENSATE + [str(long_program)], out, terminal=True)
    assert code == 0, shown
    assert BAR in shown and "long.nc  [" in shown and "%" in shown
    screen = _screen(shown)  # the line is erased at the end: the summary alone is left, nothing glued to it
    assert len(screen) == 1 and re.match(rf"{long_program}: \d+ blocks replaced by \d+; ", screen[0]), screen
    with open(tmp_path / "pipe.nc", "wb") as out:
        code, piped = _postproc(COMPENSATE + [str(long_program)], out, terminal=False)
    assert code == 0, piped
    assert "\x1b" not in piped and "\r" not in piped
    assert piped.splitlines()[-1].startswith(f"{long_program}: ")
    assert (tmp_path / "tty.nc").read_bytes() == (tmp_path / "pipe.nc").read_bytes()


def test_a_short_program_draws_no_progress_line(tmp_path):
    with open(tmp_path / "out.nc", "wb") as out:
        code, shown = _postproc(COMPENSATE + [str(REPO / "samples/programs/hemishell.nc")], out, terminal=True)
    assert code == 0, shown
    assert "hemishell.nc  [" not in shown and "blocks replaced by" in shown  # the fit's line only


def test_a_batch_counts_its_programs_on_a_terminal(tmp_path):
    programs = []
    for index in range(3):
        program = tmp_path / f"p{index}.nc"
        program.write_text(lathe_program(300))
        programs.append(str(program))
    code, shown = _postproc(COMPENSATE + programs + ["--out-dir", str(tmp_path / "out")], subprocess.DEVNULL,
                            terminal=True)
    assert code == 0, shown
    assert "programs" in shown and "1/3" in shown and BAR in shown
    screen = _screen(shown)  # each summary line erased the progress line before it, and stays
    assert len(screen) == 3 and all(": ok -> " in line and "[" not in line for line in screen), screen
    code, piped = _postproc(COMPENSATE + programs + ["--out-dir", str(tmp_path / "out2")], subprocess.DEVNULL,
                            terminal=False)
    assert code == 0 and "\x1b" not in piped and piped.count(": ok -> ") == 3


def test_a_fit_shows_the_compensator_being_fitted_on_a_terminal(tmp_path):
    code, shown = _postproc(["fit", "--plugin", "parametric", "--ballbar", CCW, "--ballbar", CW,
                             "-o", str(tmp_path / "model.json")], subprocess.DEVNULL, terminal=True)
    assert code == 0, shown
    assert "fitting" in shown and "parametric" in shown and BAR in shown


@pytest.mark.parametrize("where", ["before", "after"])
def test_quiet_shows_errors_only(long_program, tmp_path, where):
    args = COMPENSATE + [str(long_program)]
    args = ["--quiet", *args] if where == "before" else [*args, "-q"]
    with open(tmp_path / "out.nc", "wb") as out:
        code, shown = _postproc(args, out, terminal=True)
    assert code == 0 and shown == ""
    assert (tmp_path / "out.nc").stat().st_size > long_program.stat().st_size // 2
    code, shown = _postproc(["--quiet", "check", str(tmp_path / "missing.nc")], subprocess.DEVNULL, terminal=False)
    assert code == 3 and "missing.nc" in shown and "error" in shown


def test_quiet_keeps_a_failed_programs_error_in_a_batch(tmp_path, run):
    good = tmp_path / "good.nc"
    good.write_text(lathe_program(100))
    bad = tmp_path / "bad.nc"
    bad.write_text("%\nO1000\nG21 G18 G99\nG00 X20. Z0.\nG01 X10. Z0. F0.1\nG02 X40. Z-10. I5. K0.\nM30\n%\n")
    result = run("--quiet", *COMPENSATE, str(good), str(bad), "--out-dir", str(tmp_path / "out"))
    assert result.exit_code == 3
    assert result.stderr.startswith(f"{bad}:6:16: error: arc end point is off the circle")
    assert "ok ->" not in result.stderr and "warning" not in result.stderr
    assert (tmp_path / "out" / "good.nc").exists()


def test_quiet_silences_warnings_and_summary_lines(run):
    hemishell = str(REPO / "samples/programs/hemishell.nc")
    loud = run("compensate", hemishell)
    assert loud.exit_code == 0 and "warning: no compensator was given" in loud.stderr
    quiet = run("compensate", hemishell, "--quiet")
    assert quiet.exit_code == 0 and quiet.stderr == "" and quiet.stdout == loud.stdout
    checked = run("-q", "compensate", hemishell, *COMPENSATE[1:], "--check")
    assert checked.exit_code == 1 and checked.stderr == ""  # the exit code says it; no "would be changed"
    assert run("check", hemishell).stderr.startswith(f"{hemishell}: ok: ")
    assert run("check", hemishell, "-q").stderr == ""
    assert run("compensate", hemishell).stderr == loud.stderr  # quiet ends with its run
