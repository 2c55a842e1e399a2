"""Memory does not grow with the program's length: postproc streams.

A 50,000- and a 500,000-block program are compensated by a real plugin (the first lines,
so that the rest streams through the reader, interpreter, rewriter and output spool) and
the peak resident set sizes of the two runs are compared. Not a timed test.
"""

from __future__ import annotations

import subprocess
import sys

from support import REPO

sys.path.insert(0, str(REPO / "benchmarks"))
from programs import lathe_program  # noqa: E402

CCW = str(REPO / "samples/ballbar/v40r-100-ccw.csv")
CW = str(REPO / "samples/ballbar/v40r-100-cw.csv")
LAUNCH = str(REPO / "benchmarks/launch.py")


def _peak_mb(program, out) -> float:
    """Peak RSS of one compensate run, measured by the small launcher (a child forked from
    this large test process would count this process's memory too)."""
    command = [sys.executable, LAUNCH, sys.executable, "-c", "from postproc.cli.main import main; main()",
               "compensate", str(program), "--plugin", "parametric", "--option", "extrapolate=true",
               "--ballbar", CCW, "--ballbar", CW, "--region", "L1-L3000", "-o", str(out)]
    result = subprocess.run(command, capture_output=True, text=True, timeout=600)
    seconds, peak, code = result.stderr.split()[-3:]
    assert code == "0", result.stderr
    return float(peak)


def test_peak_memory_is_flat_in_the_programs_length(tmp_path):
    peaks = {}
    for blocks in (50_000, 500_000):
        program = tmp_path / f"p{blocks}.nc"
        program.write_text(lathe_program(blocks))
        out = tmp_path / f"out{blocks}.nc"
        peaks[blocks] = _peak_mb(program, out)
        original, written = program.read_bytes(), out.read_bytes()
        assert written != original  # compensated at the start ...
        tail = original[len(original) // 2:]
        assert written.endswith(tail)  # ... and streamed through unchanged after the region
        program.unlink()
        out.unlink()
    print(peaks)
    assert peaks[500_000] <= 150.0, peaks
    assert peaks[500_000] - peaks[50_000] <= 10.0, f"peak RSS grew with length: {peaks}"
