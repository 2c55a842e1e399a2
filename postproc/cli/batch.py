"""Many programs at once: a process pool, one summary line per file, no partial files.

Each worker fits the compensators once (from the same request) and then takes programs
from the queue. A program that fails is reported with its error and the others are still
written; the run exits with the most severe failure's code. On a terminal, a progress line
on stderr counts the programs done (:mod:`postproc.compensate.progress`). Running a fleet of programs
across machines needs nothing of postproc's own: split the file list over a job array or a
task queue and run one ``postproc compensate ... --out-dir`` per share (docs/user-guide.md).
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import sys
from dataclasses import dataclass

from ..compensate import progress
from ..api import Pipeline
from ..diagnostics import EXIT_INTERNAL, EXIT_OK, PostprocError, say

_pipeline: Pipeline | None = None


@dataclass(frozen=True)
class Outcome:
    name: str
    code: int  #: exit code for this file
    line: str  #: the summary line
    messages: tuple[str, ...]  #: warnings and errors, as printed


def _one(job: tuple[str, str]) -> Outcome:
    name, destination = job
    pipeline = _pipeline
    before = len(pipeline.reporter.warnings)
    # a program's warnings are told with its summary line (_tell), not as they happen as well
    stream, pipeline.reporter.stream = pipeline.reporter.stream, None
    try:
        summary = pipeline.compensate_file(name, destination)
    except PostprocError as exc:
        warnings = tuple(str(w) for w in pipeline.reporter.warnings[before:])
        return Outcome(name, exc.exit_code, f"{name}: failed (exit {exc.exit_code})", warnings + (str(exc),))
    except Exception as exc:  # a bug in one file must not stop the others
        return Outcome(name, EXIT_INTERNAL, f"{name}: failed (internal error)", (f"postproc: internal error: {exc!r}",))
    finally:
        pipeline.reporter.stream = stream
    warnings = tuple(str(w) for w in pipeline.reporter.warnings[before:])
    line = (f"{name}: ok -> {destination}: {summary.replaced} blocks replaced by {summary.emitted}, largest correction "
            f"{summary.largest_correction * 1000:.2f} um, largest deviation {summary.largest_deviation * 1000:.3f} um")
    return Outcome(name, EXIT_OK, line, warnings)


def run(jobs: list[tuple[str, str]], pipeline: Pipeline, workers: int = 1) -> int:
    """Compensate each (input, destination); returns the exit code for the whole run.

    The pipeline is built (and its measurements checked) once, before any program is read;
    forked workers inherit it. Interrupted (Ctrl-C, SIGTERM), the workers are stopped at once,
    each leaving nothing behind (its spool has no name), and the interruption goes on up.
    """
    global _pipeline
    _pipeline = pipeline
    outcomes: list[Outcome] = []
    pool = None
    with progress.bar(len(jobs), "programs", minimum=2, count=True) as shown:  # before the fork: no worker draws its own
        if workers <= 1:
            results = map(_one, jobs)
        else:
            pool = multiprocessing.get_context("fork").Pool(workers, initializer=_worker)
            results = pool.imap(_one, jobs)
        try:
            for outcome in results:
                _tell(outcome)
                shown.advance(1, os.path.basename(outcome.name))
                outcomes.append(outcome)
        except BaseException:
            if pool is not None:
                pool.terminate()
                pool.join()
            raise
    if pool is not None:
        pool.close()
        pool.join()
    failed = [o for o in outcomes if o.code != EXIT_OK]
    if failed and len(jobs) > 1:
        print(f"postproc: {len(failed)} of {len(jobs)} programs failed", file=sys.stderr)
    return max((o.code for o in failed), default=EXIT_OK)


def _tell(outcome: Outcome) -> None:
    """A program's warnings, its error and its summary line; with ``--quiet``, its error alone
    (and the rest in the ``--log``)."""
    failed = outcome.code != EXIT_OK
    for message in outcome.messages[:-1] if failed else outcome.messages:
        say(message, sys.stderr)
    if failed:
        print(outcome.messages[-1], file=sys.stderr)
    say(outcome.line, sys.stderr)


def _worker() -> None:
    """A worker leaves Ctrl-C to the parent (which stops every worker) and dies at once on SIGTERM."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.signal(signal.SIGHUP, signal.SIG_DFL)
