"""Where a report came from: the postproc and plugin versions, every input with its SHA-256,
the machine profile, the options, the command and the time.

The time is the report's creation in UTC; with ``SOURCE_DATE_EPOCH`` set (reproducible
builds' convention) it is that moment instead, so the same inputs give the same file.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import os
import platform
from dataclasses import dataclass
from importlib import metadata

from .. import __version__
from ..files import inputs
from ..diagnostics import PostprocError
from ..machine.profile import MachineProfile, to_toml
from .document import Section, Table, Text


MAX_BYTES = 64 * 1024 * 1024  #: the largest of the inputs' own limits (measurement files, models)


@dataclass(frozen=True, slots=True)
class Input:
    role: str  #: program, ballbar trace, probe points, ...
    path: str  #: as given
    sha256: str
    size: int | None  #: bytes; None when only recorded (a saved model's inputs)
    notes: str = ""  #: the file's own ``x-`` header keys, say


def file_input(role: str, path: str, notes: str = "") -> Input:
    """A file as the run read it (its one read, :mod:`postproc.files.inputs`)."""
    snapshot = inputs.read(path, MAX_BYTES, PostprocError, "an input")
    return Input(role, inputs.named(path), snapshot.sha256, len(snapshot.data), notes)


def data_input(role: str, name: str, data: bytes) -> Input:
    return Input(role, name, hashlib.sha256(data).hexdigest(), len(data))


def moment() -> dt.datetime:
    """Now, or ``SOURCE_DATE_EPOCH`` when set."""
    epoch = os.environ.get("SOURCE_DATE_EPOCH", "").strip()
    if epoch.isdigit():
        return dt.datetime.fromtimestamp(int(epoch), dt.timezone.utc)
    return dt.datetime.now(dt.timezone.utc).replace(microsecond=0)


def _version(distribution: str) -> str:
    try:
        return metadata.version(distribution)
    except metadata.PackageNotFoundError:
        return "not installed"


def section(inputs: list[Input], profile: MachineProfile, machine_file: str | None,
            plugins: list[tuple[str, str, str]], settings: dict[str, dict], tolerance: str, command: str,
            when: dt.datetime) -> Section:
    """The provenance section. ``plugins`` are (name, version, distribution)."""
    facts = Table(("item", "value"), (
        ("postproc", __version__),
        ("created (UTC)", when.isoformat()),
        ("command", command),
        ("Python", platform.python_version()),
        ("numpy, scipy, matplotlib", ", ".join(_version(name) for name in ("numpy", "scipy", "matplotlib"))),
        ("machine profile", f"{profile.name} ({profile.controller})"
                            + (f", from {machine_file}" if machine_file else ", the built-in default")),
        ("tolerance", tolerance),
    ), "this report", numeric=False)
    files = Table(("role", "file", "SHA-256", "bytes", "notes"),
                  tuple((i.role, i.path, i.sha256, "" if i.size is None else str(i.size), i.notes) for i in inputs),
                  "inputs", key="inputs", numeric=False)
    parts = [facts, files]
    if plugins:
        parts.append(Table(("compensator", "version", "distribution"), tuple(plugins), "compensators", numeric=False))
    options = tuple((name, key, repr(value)) for name, values in settings.items() for key, value in values.items())
    if options:
        parts.append(Table(("compensator", "option", "value in force"), options, "options", numeric=False))
    parts.append(Text("The machine profile in force:", "note"))
    parts.append(Text(to_toml(profile), "pre"))
    return Section("provenance", "Provenance", parts)
