"""Signals and streams, for real, in subprocesses: Ctrl-C exits 130, SIGTERM 143, nothing is
left behind; a reader that goes away ends the run quietly (141); a closed stdout is said."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from support import REPO, SAMPLES

sys.path.insert(0, str(REPO / "benchmarks"))
from programs import lathe_program  # noqa: E402

COMMAND = [sys.executable, "-c", "from postproc.cli.main import main; main()"]
TRACES = ["--plugin", "parametric", "--option", "extrapolate=true",
          "--ballbar", str(SAMPLES / "ballbar" / "v40r-100-ccw.csv"),
          "--ballbar", str(SAMPLES / "ballbar" / "v40r-100-cw.csv")]


def _environment(tmp_path):
    spool = tmp_path / "tmp"
    spool.mkdir()
    return spool, {**os.environ, "TMPDIR": str(spool)}


@pytest.mark.parametrize("sent, code, said", [
    (signal.SIGINT, 130, "postproc: interrupted; no file was left half-written\n"),
    (signal.SIGTERM, 143, "postproc: stopped by SIGTERM; no file was left half-written\n"),
])
def test_a_signal_during_a_stdin_read_leaves_nothing(tmp_path, sent, code, said):
    spool, environment = _environment(tmp_path)
    process = subprocess.Popen(COMMAND + ["compensate", "-o", str(tmp_path / "out.nc")], stdin=subprocess.PIPE,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=environment)
    process.stdin.write(b"G00 X1. Z1.\n" * 200_000)  # 2.4 MB, and the input still open
    process.stdin.flush()
    time.sleep(1.0)
    process.send_signal(sent)
    out, err = process.communicate(timeout=60)
    assert (process.returncode, out, err.decode()) == (code, b"", said)
    assert list(spool.iterdir()) == [] and not (tmp_path / "out.nc").exists()


def test_ctrl_c_stops_a_batch_and_its_workers(tmp_path):
    folder = tmp_path / "in"
    folder.mkdir()
    for index in range(4):
        (folder / f"p{index}.nc").write_text(lathe_program(20_000))
    spool, environment = _environment(tmp_path)
    out = tmp_path / "out"
    process = subprocess.Popen(COMMAND + ["compensate", *map(str, sorted(folder.iterdir())), "--out-dir", str(out),
                                          "--jobs", "2", *TRACES], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               env=environment, start_new_session=True)
    time.sleep(3.0)
    started = time.monotonic()
    os.killpg(process.pid, signal.SIGINT)  # as a terminal's Ctrl-C: to the parent and its workers
    _, err = process.communicate(timeout=60)
    assert process.returncode == 130 and time.monotonic() - started < 10
    assert err.decode().endswith("postproc: interrupted; no file was left half-written\n")
    written = [path.name for path in out.iterdir()] if out.exists() else []
    assert all(not name.startswith(".") for name in written)  # whole programs only
    assert list(spool.iterdir()) == []
    time.sleep(0.5)
    assert subprocess.run(["pgrep", "-f", str(folder)], capture_output=True).stdout == b""  # no worker left


def test_a_reader_that_goes_away_ends_the_run_quietly(tmp_path):
    program = tmp_path / "big.nc"
    program.write_text(lathe_program(20_000))
    script = f"{' '.join(COMMAND[:2])} \"{COMMAND[2]}\" compensate {program} | head -c 10 > /dev/null"
    result = subprocess.run(["bash", "-o", "pipefail", "-c", script], capture_output=True, text=True, timeout=120)
    assert (result.returncode, result.stderr) == (141, "")  # 128 + SIGPIPE, as the shell's own tools end


def test_a_closed_stdout_is_said_and_nothing_is_written(tmp_path):
    program = SAMPLES / "programs" / "hemishell.nc"
    script = f"{' '.join(COMMAND[:2])} \"{COMMAND[2]}\" compensate {program} >&-"
    result = subprocess.run(["bash", "-c", script], capture_output=True, text=True, timeout=60)
    assert result.returncode == 3
    assert result.stderr == "<stdout>: error: cannot write output: standard output is closed; nothing was written\n"
