"""Run one command and print its wall time, peak resident set size and exit code.

A child's peak RSS on Linux includes the memory of the process it was forked from, so the
benchmark measures through this small launcher rather than from its own, larger process.

    python benchmarks/launch.py COMMAND...   ->   "<seconds> <peak MB> <exit code>" on stderr
"""

import os
import subprocess
import sys
import time

start = time.perf_counter()
child = subprocess.Popen(sys.argv[1:])
_, status, usage = os.wait4(child.pid, 0)
seconds = time.perf_counter() - start
print(f"{seconds:.6f} {usage.ru_maxrss / 1024.0:.3f} {os.waitstatus_to_exitcode(status)}", file=sys.stderr)
