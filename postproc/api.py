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
exit codes as the command line; warnings are collected in ``pipeline.warnings``. Arguments are
checked as the command line's options are: a value of the wrong type (one string where a list
of them is expected, which Python would read letter by letter; a mode the command line has no
choice for; a flag that is not a bool) is an :class:`~postproc.diagnostics.OptionError` naming
the argument, never a guess. A path is a ``str`` or an :class:`os.PathLike`; None only where the
argument is optional (``calibration``, ``model``, ``machine``), never for a file to read or write.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Sequence

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
        machine: str | os.PathLike | Mapping | profiles.MachineProfile | None = None,
        max_correction: float | None = None,
        force: bool = False,
        regions: Sequence[str] = (),
        reporter: Reporter | None = None,
        keep_unplannable: bool = False,
        macro_values: str = "refuse",
    ):
        from .compensate.region import Region

        plugins, options, regions = (_strings(name, value) for name, value in
                                     (("plugins", plugins), ("options", options), ("regions", regions)))
        ballbar, probe = _paths("ballbar", ballbar), _paths("probe", probe)
        calibration, model = (None if value is None else _path(name, value)
                              for name, value in (("calibration", calibration), ("model", model)))
        _choice("mode", mode, ("auto", "arc", "line"))
        _choice("macro_values", macro_values, ("refuse", "keep", "numbers"))
        for name, value in (("force", force), ("keep_unplannable", keep_unplannable)):
            if not isinstance(value, bool):
                raise OptionError(f"{name}={value!r}: expected True or False")
        if reporter is not None and not isinstance(reporter, Reporter):
            raise OptionError(f"reporter={reporter!r}: expected a postproc.diagnostics.Reporter or None")
        Region(regions)  # refuse a bad region before anything is read

        self.profile = _profile(machine)
        bounds.in_force(tolerance, max_correction, self.profile)
        self.reporter = reporter or Reporter()
        self.request = Request(plugins=plugins, ballbar=ballbar, probe=probe, calibration=calibration,
                               model=model, options=options, tolerance=tolerance, mode=mode,
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
        path, output = _path("path", path), _path("output", output)
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
        if not isinstance(text, (str, bytes)):
            raise OptionError(f"text: expected the program as a str (or bytes), not {type(text).__name__}")
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


def _strings(name: str, value: Any) -> list[str]:
    """A list argument of strings; one string alone is refused (Python would read it letter by letter)."""
    if isinstance(value, (str, bytes, os.PathLike)):
        raise OptionError(f"{name}={value!r}: expected a list ({name}=[{value!r}])")
    try:
        items = list(value)
    except TypeError:
        raise OptionError(f"{name}={value!r}: expected a list of strings") from None
    for item in items:
        if not isinstance(item, str):
            raise OptionError(f"{name}: {item!r} is not a string")
    return items


def _paths(name: str, value: Any) -> list[str]:
    """A list argument of paths (str or os.PathLike), as strings."""
    if isinstance(value, (str, bytes, os.PathLike)):
        raise OptionError(f"{name}={value!r}: expected a list of paths ({name}=[{value!r}])")
    try:
        return [_path(name, item) for item in value]
    except TypeError:
        raise OptionError(f"{name}={value!r}: expected a list of paths") from None


def _path(name: str, value: Any) -> str:
    """One path argument (str or os.PathLike), as a string. None is refused as any other
    non-path: an output of None would spool the program and write it nowhere."""
    if isinstance(value, os.PathLike):
        value = os.fspath(value)
    if not isinstance(value, str) or not value:
        raise OptionError(f"{name}: {value!r} is not a path (a str or os.PathLike)")
    return value


def _choice(name: str, value: Any, choices: tuple[str, ...]) -> None:
    if value not in choices:
        raise OptionError(f"{name}={value!r}: expected {', '.join(choices[:-1])} or {choices[-1]}")


def _profile(machine: Any) -> profiles.MachineProfile:
    """The machine profile of a ``machine`` argument: a TOML path, a profile, a mapping of a
    profile file's keys, or None (the default profile)."""
    if machine is None:
        return profiles.DEFAULT
    if isinstance(machine, profiles.MachineProfile):
        return machine
    if isinstance(machine, Mapping):
        return profiles.from_mapping(dict(machine), "<machine>")
    return profiles.load(_path("machine", machine))
