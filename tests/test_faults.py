"""Faults: a run killed mid-write, a full disk, an unwritable directory: nothing half-written."""

from __future__ import annotations

import os
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

from conftest import REPO

sys.path.insert(0, str(REPO / "benchmarks"))
from programs import lathe_program  # noqa: E402

COMMAND = [sys.executable, "-c", "from postproc.cli import main; main()"]


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
        for name in leftovers:  # a kill in the last instant (the rename) can leave the finished copy only
            assert (out / name).read_bytes() == program.read_bytes()


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
