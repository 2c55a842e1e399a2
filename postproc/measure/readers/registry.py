"""Measurement readers as data: which reader reads which file.

Readers come from plugins (the ``postproc_measurement_readers`` hook), the built-in ones
included. A file is read by the first reader of its kind that accepts it; a file nobody
accepts is refused with the list of formats that were tried. A ballbar trace is held to the
minimum evidence (36 samples over 90 deg of arc) whichever reader made it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

from ...diagnostics import Location, MeasurementError, Reporter
from .csvfile import snapshot

KINDS = ("ballbar", "probe", "calibration")


@dataclass(frozen=True)
class ReadContext:
    """What a reader may need besides the file: settings and where warnings go."""

    reporter: Reporter
    averaging: int = 6  #: ballbar raw form: readings averaged per sample
    max_deviation: float = 1.0  #: mm: a ballbar deviation beyond this is not plausible


@dataclass(frozen=True)
class MeasurementReader:
    kind: str  #: ballbar, probe or calibration
    name: str  #: the format's name, for messages
    accepts: Callable[[str], bool]  #: whether this reader reads the file at this path
    read: Callable[[str, ReadContext], Any]  #: the file's content, as the built-in readers make it


def first_line(path: str, size: int = 256) -> str:
    """The start of a file's first line, for readers that recognise a format by it (from the
    file's one read: a pipe would be empty for the reader that comes next)."""
    try:
        head = snapshot(path).data[:size]
    except MeasurementError:
        return ""
    return head.split(b"\n", 1)[0].decode("utf-8", "replace").lstrip("\ufeff").strip()


def read(path: str, kind: str, readers: list[MeasurementReader], context: ReadContext):
    """Read a measurement file of a kind with the first reader that accepts it."""
    candidates = [reader for reader in readers if reader.kind == kind]
    for reader in candidates:
        if reader.accepts(path):
            found = reader.read(path, context)
            if kind == "ballbar":
                from .ballbar import BallbarTrace, check_evidence

                if isinstance(found, BallbarTrace):
                    check_evidence(found)  # whichever reader made it
            return found
    names = ", ".join(reader.name for reader in candidates) or "none installed"
    snapshot(path)  # a file that cannot be read says why
    raise MeasurementError(f"not a {kind} file any installed reader knows (tried: {names})", Location(path, 1))
