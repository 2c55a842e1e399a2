"""Faults: a run killed mid-write, a full disk, an unwritable directory: nothing half-written."""

from __future__ import annotations

import errno
import os
import resource
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from support import REPO
from postproc.files.output import PARTIAL, Spool, write_atomically

sys.path.insert(0, str(REPO / "benchmarks"))
from programs import lathe_program  # noqa: E402

COMMAND = [sys.executable, "-c", "from postproc.cli.main import main; main()"]


def test_a_run_killed_mid_write_leaves_the_old_output_and_nothing_else(tmp_path):
    program = tmp_path / "big.nc"
    program.write_text(lathe_program(60_000))
    out = tmp_path / "out"
    out.mkdir()
    target = out / "part.nc"
    target.write_text("THE PREVIOUS OUTPUT\n")
    for delay in (0.3, 0.8, 1.5):
        process = subprocess.Popen(COMMAND + ["compensate", str(program), "-o", str(target)],
                                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(delay)
        process.send_signal(signal.SIGKILL)
        process.wait()
        content = target.read_bytes()
        assert content in (b"THE PREVIOUS OUTPUT\n", program.read_bytes())  # all or nothing
        leftovers = [p.name for p in out.iterdir() if p.name != "part.nc"]
        assert leftovers == [] or all(".postproc-" in name for name in leftovers)
        for name in leftovers:  # a kill in the last instant (the rename) can leave the finished copy, one
            if not name.endswith(PARTIAL):  # during a copy (where /proc cannot name the spool) a partial one
                assert (out / name).read_bytes() == program.read_bytes()
    finished = subprocess.run(COMMAND + ["compensate", str(program), "-o", str(target)], capture_output=True)
    assert finished.returncode == 0 and target.read_bytes() == program.read_bytes()
    assert not [p.name for p in out.iterdir() if p.name.endswith(PARTIAL)]  # cleared by the run that finished


def _cross_device(*args, **kwargs):
    """os.link where /proc/self/fd cannot be linked from (EXDEV): the spool's commit copies."""
    raise OSError(errno.EXDEV, "Invalid cross-device link")


def _killed_while_copying(target: Path, data: bytes) -> int:
    """In a child process: a spool whose naming through /proc fails (as across devices), killed
    by SIGKILL halfway through the copy its commit makes. The child's exit status."""
    pid = os.fork()
    if pid == 0:  # the child: never returns
        try:
            def half_then_killed(source, destination, *args):
                destination.write(source.read(len(data) // 2))
                destination.flush()
                os.kill(os.getpid(), signal.SIGKILL)

            os.link = _cross_device
            shutil.copyfileobj = half_then_killed
            with Spool(str(target)) as spool:
                spool.write(data)
                spool.commit()
        finally:
            os._exit(1)
    return os.waitpid(pid, 0)[1]


def test_a_kill_during_the_commit_copy_leaves_the_output_and_a_partial_the_next_run_removes(tmp_path, monkeypatch):
    target = tmp_path / "part.nc"
    target.write_bytes(b"THE PREVIOUS OUTPUT\n")
    data = b"G01 X10. Z-5.\n" * 50_000
    with Spool(str(target)) as probe:
        anonymous = probe.path is None
        probe.discard()
    if not anonymous:
        pytest.skip("no anonymous spool file here (O_TMPFILE): the commit never copies")
    status = _killed_while_copying(target, data)
    assert os.WIFSIGNALED(status) and os.WTERMSIG(status) == signal.SIGKILL
    assert target.read_bytes() == b"THE PREVIOUS OUTPUT\n"  # untouched
    (partial,) = [p for p in tmp_path.iterdir() if p != target]
    assert partial.name.startswith(".part.nc.postproc-") and partial.name.endswith(PARTIAL)
    assert 0 < partial.stat().st_size < len(data)  # it was killed mid-copy
    running = tmp_path / f".part.nc.postproc-{os.getppid()}-abcd{PARTIAL}"  # a live run's copy under way
    running.write_bytes(b"G01")
    monkeypatch.setattr(os, "link", _cross_device)
    write_atomically(str(target), b"THE NEXT OUTPUT\n")  # the same fallback, as on the same machine
    assert sorted(p.name for p in tmp_path.iterdir()) == [running.name, "part.nc"]
    assert target.read_bytes() == b"THE NEXT OUTPUT\n"


def _limited():
    resource.setrlimit(resource.RLIMIT_FSIZE, (20_000, 20_000))
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)


def test_a_full_disk_is_reported_and_leaves_nothing(tmp_path):
    """The program (17 kB) fits under the limit; its compensation in lines (41 kB) does not."""
    program = tmp_path / "big.nc"
    program.write_text(lathe_program(600))
    target = tmp_path / "out.nc"
    compensator = ["--plugin", "parametric", "--option", "extrapolate=true", "--mode", "line",
                   "--ballbar", str(REPO / "samples/ballbar/v40r-100-ccw.csv"),
                   "--ballbar", str(REPO / "samples/ballbar/v40r-100-cw.csv")]
    result = subprocess.run(COMMAND + ["compensate", str(program), *compensator, "-o", str(target)],
                            capture_output=True, text=True, preexec_fn=_limited)
    assert result.returncode == 3
    assert result.stderr.startswith(f"{target}: error: cannot write output: no space left for it")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["big.nc"]


def test_a_full_temporary_folder_is_reported_as_such(tmp_path):
    """The one copy of the program kept while it is compensated does not fit: said, and nothing written."""
    program = tmp_path / "big.nc"
    program.write_text(lathe_program(3000))
    target = tmp_path / "out.nc"
    result = subprocess.run(COMMAND + ["compensate", str(program), "-o", str(target)], capture_output=True, text=True,
                            preexec_fn=_limited)
    assert result.returncode == 3
    assert result.stderr.startswith(f"{program}: error: cannot keep a copy of the program in ")
    assert "no space left for it" in result.stderr and "nothing was written" in result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["big.nc"]


def test_an_unwritable_directory_is_reported(tmp_path):
    if os.geteuid() == 0:  # root writes anywhere: take the directory away instead
        target = tmp_path / "gone" / "out.nc"
    else:
        locked = tmp_path / "locked"
        locked.mkdir(mode=0o500)
        target = locked / "out.nc"
    program = Path(REPO / "samples" / "programs" / "hemishell.nc")
    result = subprocess.run(COMMAND + ["compensate", str(program), "-o", str(target)], capture_output=True, text=True)
    assert result.returncode == 3 and "nothing was written" in result.stderr and result.stdout == ""
    assert not target.exists()
