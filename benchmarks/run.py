"""The benchmark suite: postproc against the regex floor and its peers, in one run.

Every figure is a median of several runs of a whole process, measured side by side on the
same files in this run (the machines are shared and noisy: compare ratios, not seconds).
The parsing commands run in rounds, one of each in turn; a ratio to the floor is the median
of the ratios within each round.
Peak memory is the child's maximum resident set size. Run with ``./scripts/bench``, which
builds the benchmark's own environment (postproc, pygcode, gcodeparser).

The rows: parsing a large program (check, an identity run) against the floor and the peers;
a 1000-block program from process start to exit against starting Python with numpy;
compensating a CAM-style program against the floor on the same file, in one process and as
four programs with ``--jobs``.

    python benchmarks/run.py [--runs N] [--quick]
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(HERE))

from programs import lathe_program  # noqa: E402

PYTHON = sys.executable
POSTPROC = [PYTHON, "-m", "postproc.cli.main"]


def once(command: list[str], stdout=subprocess.DEVNULL) -> tuple[float, float, int]:
    """Wall time (s), peak RSS (MB) and exit code of one run of a command, through the small
    launcher so that this process's own memory is not counted."""
    result = subprocess.run([PYTHON, str(HERE / "launch.py"), *command], stdout=stdout,
                            stderr=subprocess.PIPE, text=True, check=True)
    seconds, peak, code = result.stderr.split()[-3:]
    return float(seconds), float(peak), int(code)


def measure(command: list[str], runs: int, stdout=subprocess.DEVNULL) -> tuple[float, float, int]:
    """Median wall time (s), median peak RSS (MB) and the last exit code of several runs."""
    results = [once(command, stdout) for _ in range(runs)]
    return _medians(results)


def _medians(results: list[tuple[float, float, int]]) -> tuple[float, float, int]:
    return (statistics.median(r[0] for r in results), statistics.median(r[1] for r in results),
            max((r[2] for r in results), key=abs))


def interleaved(commands: dict[str, tuple[list[str], int]], runs: int) -> dict[str, list[tuple[float, float, int]]]:
    """Each command once per round, in turn, for ``runs`` rounds (a command given fewer runs
    takes part in the first rounds only): a shared machine that slows down for a while
    slows every command alike, so the ratio of two commands in one round stays fair."""
    results: dict[str, list[tuple[float, float, int]]] = {name: [] for name in commands}
    for round_ in range(runs):
        for name, (command, count) in commands.items():
            if round_ < count:
                results[name].append(once(command))
    return results


def ratio(floor: list[tuple[float, float, int]], other: list[tuple[float, float, int]]) -> float:
    """Median over the rounds of the floor's time over the other command's time."""
    return statistics.median(f[0] / o[0] for f, o in zip(floor, other))


def row(name: str, seconds: float, peak: float, blocks: int, speed: float | None, code: int = 0, note: str = "") -> str:
    """One table row; ``speed`` is the ratio to the floor (floor time over this time), if any."""
    rate = blocks / seconds if seconds else 0.0
    ratio = f"{speed:5.2f}x" if speed else "      "
    failed = "" if code == 0 else f"  (exit {code})"
    return f"  {name:<34} {seconds:8.3f} s  {rate / 1000:8.1f} k blocks/s  {ratio}  {peak:7.1f} MB{failed}{note}"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5, help="runs per measurement (median)")
    parser.add_argument("--quick", action="store_true", help="smaller programs, fewer runs: a smoke test")
    args = parser.parse_args()
    runs = 2 if args.quick else args.runs
    work = Path(tempfile.mkdtemp(prefix="postproc-bench-"))
    try:
        return _suite(work, runs, args.quick)
    finally:
        shutil.rmtree(work, ignore_errors=True)


def _suite(work: Path, runs: int, quick: bool) -> int:
    big_blocks = 20_000 if quick else 200_000
    big = work / "big.nc"
    big.write_text(lathe_program(big_blocks))
    small = work / "small.nc"
    small.write_text(lathe_program(1000, seed=2))
    out = work / "out.nc"
    _compiled()

    print(f"postproc benchmark: {big_blocks} and 1000-block lathe programs, median of {runs} runs, "
          f"python {sys.version.split()[0]}, {os.cpu_count()} cpus\n")
    print(f"Parsing and interpreting a {big_blocks}-block program (ratio: speed relative to the regex floor)")
    peers = max(1, runs // 2)  # slow, and only for comparison
    rounds = interleaved({
        "regex tokenizer floor": ([PYTHON, str(HERE / "floor.py"), str(big)], runs),
        "postproc check": (POSTPROC + ["check", str(big)], runs),
        "postproc compensate (identity)": (POSTPROC + ["compensate", str(big), "-o", str(out)], runs),
        "pygcode": ([PYTHON, str(HERE / "peers.py"), "pygcode", str(big)], peers),
        "gcodeparser": ([PYTHON, str(HERE / "peers.py"), "gcodeparser", str(big)], peers),
    }, runs)
    floor_rounds = rounds["regex tokenizer floor"]
    results = {}
    for name, measured in rounds.items():
        seconds, peak, code = _medians(measured)
        results[name] = (seconds, peak, code, ratio(floor_rounds, measured))
        print(row(name, seconds, peak, big_blocks, results[name][3], code))

    print("\nA 1000-block program end to end, process start to exit (ratio: time over starting Python with numpy)")
    model = _model(work)
    started = interleaved({
        "python -c 'import numpy'": ([PYTHON, "-c", "import numpy"], runs),
        "postproc check": (POSTPROC + ["check", str(small)], runs),
        "postproc compensate (identity)": (POSTPROC + ["compensate", str(small), "-o", str(out)], runs),
        "postproc compensate --model": (POSTPROC + ["compensate", str(small), "--model", str(model), "-o", str(out)], runs),
    }, runs)
    start_rounds = started["python -c 'import numpy'"]
    for name, measured in started.items():
        seconds, peak, code = _medians(measured)
        slower = 1.0 / ratio(start_rounds, measured)
        print(row(name, seconds, peak, 1000, None, code, f"  {slower:5.2f}x the time of python with numpy"))
    small_job = 1.0 / ratio(start_rounds, started["postproc compensate --model"])

    moves_blocks = 5000 if quick else 50_000
    print(f"\nCompensating a {moves_blocks}-block CAM-style program (parametric model, 1 um tolerance, segmenter and "
          "self-check included; ratio: speed relative to the regex floor on the same blocks)")
    feed = work / "feed.nc"
    feed.write_text(lathe_program(moves_blocks, seed=3))
    moves = _feed_moves(feed)
    parts = _parts(work, moves_blocks, 4)
    part_moves = sum(_feed_moves(part) for part in parts)
    cpus = os.cpu_count() or 1
    compensate = POSTPROC + ["compensate", "--model", str(model), "--tolerance", "0.001"]
    repeats = max(2, runs // 2)
    commands = {
        "regex tokenizer floor": ([PYTHON, str(HERE / "floor.py"), str(feed)], repeats),
        "postproc compensate --model": (compensate + [str(feed), "-o", str(out)], repeats),
        "4 programs, --jobs 1": (compensate + [*map(str, parts), "--out-dir", str(work / "jobs1")], repeats),
    }
    if cpus > 1:
        commands[f"4 programs, --jobs {min(cpus, 4)}"] = (
            compensate + [*map(str, parts), "--out-dir", str(work / "jobsn"), "--jobs", str(min(cpus, 4))], repeats)
    (work / "jobs1").mkdir()
    (work / "jobsn").mkdir()
    measured_rounds = interleaved(commands, repeats)
    floor_rounds = measured_rounds["regex tokenizer floor"]
    compensation = {}
    for name, measured in measured_rounds.items():
        seconds, peak, code = _medians(measured)
        count = moves if not name.startswith("4 programs") else part_moves
        compensation[name] = (ratio(floor_rounds, measured), peak)
        note = "" if name.startswith("regex") else f"  {count / seconds:8,.0f} feed moves/s"
        if name.startswith("4 programs") and name != "4 programs, --jobs 1":  # the same rounds as --jobs 1
            note += f", {ratio(measured_rounds['4 programs, --jobs 1'], measured):.2f}x the speed of --jobs 1"
        print(row(name, seconds, peak, moves_blocks, compensation[name][0], code, note))

    print("\nImport time (python -X importtime, cumulative)")
    _imports()
    _imports(["compensate", str(small), "--model", str(model), "-o", str(out)])

    check = results["postproc check"][3]
    identity = results["postproc compensate (identity)"][3]
    speed = compensation["postproc compensate --model"][0]
    print("\nTargets")
    print(f"  compensation at {speed:.2f}x the floor (target 0.1x): {'met' if speed >= 0.1 else 'NOT MET'}")
    print(f"  a 1000-block compensate --model in {small_job:.2f}x the time of python with numpy (target 2x): "
          f"{'met' if small_job <= 2.0 else 'NOT MET'}")
    print(f"  check at {check:.2f}x the floor, identity compensate at {identity:.2f}x (target 0.5x): "
          f"{'met' if min(check, identity) >= 0.5 else 'NOT MET'}")
    peak = max([results["postproc check"][1], results["postproc compensate (identity)"][1]]
               + [peak for _, peak in compensation.values()])
    print(f"  peak memory {peak:.1f} MB of any process (target 150 MB): {'met' if peak <= 150 else 'NOT MET'}")
    return 0


def _feed_moves(path: Path) -> int:
    """The feed moves of a benchmark program (its G01 and G03 blocks)."""
    return sum(1 for line in path.read_text().splitlines() if line.startswith(("N", "G01", "G03")))


def _parts(work: Path, blocks: int, count: int) -> list[Path]:
    """``count`` programs of ``blocks / count`` blocks each, for ``--jobs``."""
    parts = []
    for index in range(count):
        part = work / f"part{index}.nc"
        part.write_text(lathe_program(blocks // count, seed=10 + index))
        parts.append(part)
    return parts


def _compiled() -> None:
    """Compile the package's modules to bytecode, as installing it does: every figure is then
    that of an installed postproc, whatever PYTHONDONTWRITEBYTECODE says (an editable install
    would otherwise compile every module again in every run)."""
    import importlib.util

    for name in ("postproc", "postproc_plugins"):
        spec = importlib.util.find_spec(name)
        for folder in spec.submodule_search_locations or ():
            subprocess.run([PYTHON, "-m", "compileall", "-q", folder], check=True)


def _model(work: Path) -> Path:
    """A parametric model fitted from the bundled sample traces."""
    model = work / "model.json"
    subprocess.run(POSTPROC + ["fit", "--plugin", "parametric", "--option", "extrapolate=true",
                               "--ballbar", str(REPO / "samples/ballbar/v40r-100-ccw.csv"),
                               "--ballbar", str(REPO / "samples/ballbar/v40r-100-cw.csv"), "-o", str(model)],
                   check=True, stderr=subprocess.DEVNULL)
    return model


def _imports(command: list[str] | None = None) -> None:
    """The heaviest imports of the command line at its start, or of a whole run of ``command``:
    what a small job pays for besides its work."""
    launch = ["-m", "postproc.cli.main", *command] if command else ["-c", "import postproc.cli.main"]
    result = subprocess.run([PYTHON, "-X", "importtime", *launch], capture_output=True, text=True)
    rows = []
    for line in result.stderr.splitlines():
        parts = line.split("|")
        if len(parts) == 3 and parts[1].strip().isdigit():
            rows.append((int(parts[1]), parts[2].rstrip()))
    names = {name.strip() for _, name in rows}
    if command:
        outermost = [(micros, name) for micros, name in rows if not name.startswith("  ")]  # each with its own
        args = " ".join("..." if "/" in arg else arg for arg in command)
        print(f"  postproc {args}: {sum(micros for micros, _ in outermost) / 1e6:.3f} s of imports in all (Python's "
              "own start's among them); the heaviest, each with what it imports:")
        heaviest = sorted(outermost, reverse=True)[:6]
        unused = [name for name in ("scipy", "matplotlib", "lark", "importlib.metadata") if name in names]
        verdict = f"  scipy, matplotlib, lark or importlib.metadata imported by the run: {', '.join(unused) or 'none'}"
    else:
        total = max(rows)[0] if rows else 0
        print(f"  postproc.cli.main: {total / 1e6:.3f} s in all; the heaviest modules:")
        heaviest = sorted(rows, reverse=True)[1:6]
        heavy = [name for name in ("numpy", "scipy", "matplotlib", "lark") if name in names]
        verdict = f"  numpy, scipy, matplotlib or lark loaded at start: {', '.join(heavy) or 'none'}"
    for micros, name in heaviest:
        print(f"    {micros / 1e6:.3f} s {name.strip()}")
    print(verdict)


if __name__ == "__main__":
    sys.exit(main())
