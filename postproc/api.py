"""The Python API: compensation from a script, a CAM system or a shop's own tools.

>>> import postproc
>>> text = open("samples/programs/hemishell.nc").read()
>>> compensated = postproc.compensate_text(
...     text, plugins=["parametric"],
...     ballbar=["samples/ballbar/v40r-100-ccw.csv", "samples/ballbar/v40r-100-cw.csv"])

For many programs, build the pipeline once (the measurements are read and fitted once):

>>> pipeline = postproc.Pipeline(plugins=["parametric"], ballbar=[...])
>>> for path in programs:
...     pipeline.compensate_file(path, "out/" + path.name)

Errors are :class:`postproc.diagnostics.PostprocError` subclasses with the same messages and
exit codes as the command line; warnings are collected in ``pipeline.warnings``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

from .machine import bounds
from .machine import profile as profiles
from .diagnostics import Diagnostic, OptionError, Reporter
from .files.output import KEEP, Spool, refuse_overwrite
from .compensate.request import Request
from .syntax.source import Source


@dataclass(frozen=True)
class Summary:
    """What one compensation did."""

    name: str
    replaced: int  #: blocks replaced
    emitted: int  #: blocks written for them
    largest_correction: float  #: mm
    largest_deviation: float  #: mm, from the intended path, as read back


class Pipeline:
    """Compensators fitted once, applied to any number of programs.

    With no plugin and no model it checks programs and gives them back unchanged.
    """

    def __init__(
        self,
        plugins: Sequence[str] = (),
        ballbar: Sequence[str] = (),
        probe: Sequence[str] = (),
        calibration: str | None = None,
        model: str | None = None,
        options: Sequence[str] = (),
        tolerance: float | None = None,
        mode: str = "auto",
        machine: str | profiles.MachineProfile | None = None,
        max_correction: float | None = None,
        force: bool = False,
        regions: Sequence[str] = (),
        reporter: Reporter | None = None,
        keep_unplannable: bool = False,
        macro_values: str = "refuse",
    ):
        from .compensate.region import Region

        Region(list(regions))  # refuse a bad region before anything is read
        if macro_values not in ("refuse", "keep", "numbers"):
            raise OptionError(f"--macro-values {macro_values}: expected refuse, keep or numbers")

        if isinstance(machine, str):
            machine = profiles.load(machine)
        self.profile = machine or profiles.DEFAULT
        bounds.in_force(tolerance, max_correction, self.profile)
        self.reporter = reporter or Reporter()
        self.request = Request(plugins=list(plugins), ballbar=list(ballbar), probe=list(probe), calibration=calibration,
                               model=model, options=list(options), tolerance=tolerance, mode=mode,
                               max_correction=max_correction, force=force, regions=list(regions),
                               keep_unplannable=keep_unplannable, macro_values=macro_values)
        self.core = None
        if plugins or model:
            from .compensate.pipeline import Pipeline as Core

            self.core = Core(self.request, self.profile, self.reporter)

    @property
    def warnings(self) -> list[Diagnostic]:
        return self.reporter.warnings

    def compensate_source(self, source: Source, spool: Spool) -> Summary:
        """Compensate one program into a spool (committed by the caller)."""
        if self.core is None:
            from .interpret.program import tally_source

            tally_source(source, self.profile, self.reporter)
            with source.open_binary() as raw:
                while chunk := raw.read(1 << 20):
                    spool.write(chunk)
            return Summary(source.name, 0, 0, 0.0, 0.0)
        rewriter = self.core.run(source, spool)
        return Summary(source.name, rewriter.replaced, rewriter.emitted, rewriter.largest, rewriter.worst)

    def compensate_file(self, path: str, output: str) -> Summary:
        """Compensate the program at ``path`` into ``output`` (``-`` for stdout), atomically. An
        output that is the program or one of the measurement files is refused (UsageError)."""
        request = self.request
        read = [("program", path), ("--calibration", request.calibration), ("--model", request.model)]
        read += [("--ballbar", name) for name in request.ballbar] + [("--probe", name) for name in request.probe]
        refuse_overwrite(read, [("output", output)])
        with Source(path) as source, Spool(output) as spool:
            summary = self.compensate_source(source, spool)
            spool.commit()
        return summary

    def compensate_text(self, text: str, name: str = "<text>") -> str:
        """Compensate a program held in a string; returns the compensated program."""
        with Source.from_text(text, name) as source:
            return self.compensated(source).decode("utf-8", "surrogateescape")

    def compensated(self, source: Source) -> bytes:
        """The compensated program, as bytes (spooled in an anonymous file while it is made)."""
        with Spool(KEEP) as spool:
            self.compensate_source(source, spool)
            return spool.value()


def compensate_text(text: str, name: str = "<text>", **options) -> str:
    """Compensate a program held in a string with the options of :class:`Pipeline`."""
    return Pipeline(**options).compensate_text(text, name)
