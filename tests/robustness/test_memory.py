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


def _peak_mb(program, out, region: str = "L1-L3000") -> float:
    """Peak RSS of one compensate run, measured by the small launcher (a child forked from
    this large test process would count this process's memory too)."""
    command = [sys.executable, LAUNCH, sys.executable, "-c", "from postproc.cli.main import main; main()",
               "compensate", str(program), "--plugin", "parametric", "--option", "extrapolate=true",
               "--ballbar", CCW, "--ballbar", CW, "--region", region, "-o", str(out)]
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


def test_peak_memory_is_flat_in_a_stretch_without_motion(tmp_path):
    """A corrected move followed by a long stretch of blocks that move nothing (a coolant code
    on every line, a block of comments) is joined to the next move through a bounded window, the
    rest of the stretch waiting in a temporary file: 300,000 such blocks take no more memory
    than 3,000."""
    peaks = {}
    for blocks in (3_000, 300_000):
        program = tmp_path / f"s{blocks}.nc"
        program.write_text("%\nO1000\nG18 G21 G40 G99\nT0101\nG97 S1000 M03\nG00 X40. Z2.\nG01 Z-10. F0.1\n"
                           + "M08\n(COOLANT)\n" * (blocks // 2) + "G01 X60. Z-30.\nG00 X100. Z5.\nM30\n%\n")
        out = tmp_path / f"s{blocks}.out.nc"
        peaks[blocks] = _peak_mb(program, out, region="L1-L99999999")
        written = out.read_text()
        assert written.count("M08\n") == blocks // 2 and "X40. Z-10." not in written.split("M08", 1)[1]
        program.unlink()
        out.unlink()
    print(peaks)
    assert peaks[300_000] - peaks[3_000] <= 10.0, f"peak RSS grew with the stretch: {peaks}"
