"""Measurement readers as data: which reader reads which file.

Readers come from plugins (the ``postproc_measurement_readers`` hook), the built-in ones
included. A file is read by the first reader of its kind that accepts it; a file nobody
accepts is refused with the list of formats that were tried. A ballbar trace is held to the
minimum evidence (36 samples over 90 deg of arc) whichever reader made it.

A reader is a shop's code run on a user's file: when it fails otherwise than by refusing the
file (a MeasurementError), or makes something that is not what the built-in reader of its kind
makes (another type, arrays of other lengths, values that are not finite, angles out of order),
the run stops naming its plugin and the file (PluginError, exit 5): the fault is the reader's,
not the file's nor a compensator's, and nothing it made is used.
"""

from __future__ import annotations

import sys
from contextlib import redirect_stdout
from dataclasses import dataclass, replace
from typing import Any, Callable

import numpy as np

from ...diagnostics import STDIN_NAME, Location, MeasurementError, PluginError, PostprocError, Reporter
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
    plugin: str = ""  #: the plugin that provides it (the host fills it in), for messages


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
        if _called(reader, "accepts", path, reader.accepts, path):
            found = _called(reader, "read", path, reader.read, path, context)
            _check_made(reader, path, found)
            if path == "-":  # named as messages name it, wherever the measurement is shown or recorded
                found = replace(found, path=STDIN_NAME)
            if kind == "ballbar":
                from .ballbar import check_evidence

                check_evidence(found)  # whichever reader made it
            return found
    names = ", ".join(reader.name for reader in candidates) or "none installed"
    snapshot(path)  # a file that cannot be read says why
    raise MeasurementError(f"not a {kind} file any installed reader knows (tried: {names})", Location(path, 1))


def _fault(reader: MeasurementReader, path: str, message: str) -> PluginError:
    return PluginError(reader.plugin or reader.name, f"reader {reader.name!r}: {message}", Location(path))


def _called(reader: MeasurementReader, what: str, path: str, function, *args):
    """``function(*args)``; a failure other than a refusal of the file is the reader's fault."""
    try:
        with redirect_stdout(sys.stderr):  # what a reader prints goes to stderr: stdout carries the output alone
            return function(*args)
    except PostprocError:
        raise
    except Exception as exc:
        raise _fault(reader, path, f"{what} failed: {exc.__class__.__name__}: {exc}") from None


#: kind -> (the type the built-in reader makes, its arrays: name -> columns (0: a vector), its
#: numbers that must be finite and positive, those that must be finite)
_MADE = {
    "ballbar": ("BallbarTrace", {"angles": 0, "deviations": 0}, ("radius",), ("centre", "setup_centre")),
    "probe": ("ProbeFile", {"centres": 2, "approach": 2}, ("stylus_radius",), ()),
    "calibration": ("CalibrationRun", {"centres": 2, "approach": 2}, ("stylus_radius", "artifact_radius"),
                    ("artifact_centre",)),
}


def _check_made(reader: MeasurementReader, path: str, found: Any) -> None:
    """Refuse what a reader made unless it is what the built-in reader of its kind makes."""
    from . import ballbar, probe

    type_name, arrays, positive, finite = _MADE[reader.kind]
    cls = getattr(ballbar if reader.kind == "ballbar" else probe, type_name)
    if not isinstance(found, cls):
        raise _fault(reader, path, f"read returned {type(found).__name__}, not a {type_name}")
    count = None
    for name, columns in arrays.items():
        value = np.asarray(getattr(found, name))
        shape = (value.shape[0],) + ((columns,) if columns else ()) if value.ndim else None
        if value.shape != shape or (count is not None and value.shape[0] != count):
            raise _fault(reader, path, f"read returned {name} of shape {value.shape} "
                                       f"(each of {', '.join(arrays)} needs one entry per sample)")
        count = value.shape[0]
        if not (np.issubdtype(value.dtype, np.number) and np.isfinite(value).all()):
            raise _fault(reader, path, f"read returned {name} with values that are not finite numbers")
    for name in positive + finite:
        value = np.asarray(getattr(found, name), dtype=object).ravel()
        if not all(isinstance(v, (int, float, np.number)) and not isinstance(v, bool) and np.isfinite(v)
                   and (name not in positive or v > 0) for v in value):
            need = "a positive number" if name in positive else "finite numbers"
            raise _fault(reader, path, f"read returned {name} = {getattr(found, name)!r}, not {need}")
    if reader.kind == "ballbar":
        angles = np.asarray(found.angles)
        if found.direction not in ("ccw", "cw"):
            raise _fault(reader, path, f"read returned direction {found.direction!r}, not 'ccw' or 'cw'")
        if len(angles) and (angles.min() < 0.0 or angles.max() >= 360.0 or (np.diff(angles) <= 0.0).any()):
            raise _fault(reader, path, "read returned angles that are not increasing within [0, 360) deg "
                                       "(make the trace with postproc.measure.readers.ballbar.make_trace)")
        if found.rows is not None and len(found.rows) != count:
            raise _fault(reader, path, f"read returned {len(found.rows)} rows for {count} samples")
    elif len(found.lines) != count:
        raise _fault(reader, path, f"read returned {len(found.lines)} lines for {count} touches")
