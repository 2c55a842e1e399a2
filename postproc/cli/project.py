"""The project file: what a shop sets once for the programs of one folder (docs/formats.md §19).

``postproc.toml`` in the working directory or one of its parents names the machine profile,
a default model or compensators, the tolerance and a few other defaults, so that a run need
not repeat ``--machine`` and ``--model``. The search goes up from the working directory and
stops at the first folder holding a ``.git`` (the repository's root: a project file outside
the repository is someone else's) or at the filesystem root.

The command line overrides the file, option by option; naming a compensator or a model on the
command line sets aside the file's ``plugins``, ``model`` and ``options`` together (they go
together). Paths in the file are relative to the file's folder. A bad file is an error (exit
3) at its line and column, never ignored: a run that silently lost its machine profile would
cut with the wrong one.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any

from ..machine import bounds
from ..diagnostics import Location, OptionError

NAME = "postproc.toml"
MAX_BYTES = 64 * 1024  #: a project file is a few lines

#: The keys a project file may set: each is the default of the option of that name (with ``_``
#: for ``-``) in every command that takes one; ``plugins``, ``model`` and ``options`` only in
#: ``compensate`` and ``fit``, where they mean compensation (``path`` and ``report`` draw and
#: report what they are given).
PATHS = ("machine", "model")
CHOICES = {"mode": ("auto", "arc", "line"), "macro_values": ("refuse", "keep", "numbers")}
LISTS = ("plugins", "options")
KEYS = (*PATHS, *LISTS, "tolerance", "max_correction", "jobs", *CHOICES)
COMPENSATION = ("plugins", "model", "options")
COMPENSATING = ("compensate", "fit")


@dataclass
class Project:
    """A project file read and checked: its path and the defaults it sets (paths resolved)."""

    path: str | None  #: None: no project file was found
    searched: str  #: where the search went, for ``profile show``
    values: dict[str, Any] = field(default_factory=dict)

    def defaults(self, command: str, params: set[str]) -> dict[str, Any]:
        """The defaults for one command, given the names of its parameters."""
        found = {}
        for key, value in self.values.items():
            if key in params and (key not in COMPENSATION or command in COMPENSATING):
                found[key] = value
        return found


def find(start: str | None = None) -> tuple[str | None, str]:
    """The project file in ``start`` (the working directory) or a parent, and where the search
    stopped: (path or None, a sentence for ``profile show``)."""
    folder = os.path.abspath(start or os.getcwd())
    while True:
        candidate = os.path.join(folder, NAME)
        if os.path.isfile(candidate):
            return candidate, f"found from {os.path.abspath(start or os.getcwd())}"
        if os.path.exists(os.path.join(folder, ".git")):
            return None, f"none from {os.path.abspath(start or os.getcwd())} up to the repository's root {folder}"
        parent = os.path.dirname(folder)
        if parent == folder:
            return None, f"none from {os.path.abspath(start or os.getcwd())} up to the filesystem root"
        folder = parent


def load(path: str | None = None, start: str | None = None) -> Project:
    """The project file ``path``, or the one :func:`find` finds (an empty project when none)."""
    searched = "given with --project"
    if path is None:
        path, searched = find(start)
        if path is None:
            return Project(None, searched)
    from ..files import inputs

    data, text = inputs.read_toml(path, MAX_BYTES, OptionError, "a project file")
    folder = os.path.dirname(os.path.abspath(path))
    values = {}
    inputs.spellings(data, path, text, OptionError)
    for key, value in data.items():
        name = key.replace("-", "_")
        where = inputs.toml_key(path, text, key)
        if name not in KEYS:
            raise OptionError(f"unknown key {key!r} in the project file{_suggestion(name)} "
                              f"(a project file sets: {', '.join(KEYS)})", where)
        values[name] = _checked(name, value, folder, where)
    if "tolerance" in values:
        bounds.tolerance(values["tolerance"], values.get("max_correction", bounds.MAX_CORRECTION), "tolerance =",
                         inputs.toml_key(path, text, "tolerance"))
    return Project(path, searched, values)


def _suggestion(name: str) -> str:
    """The project key meant, or the machine profile key (which belongs in the profile)."""
    from ..files.inputs import did_you_mean
    from ..machine.profile import NOT_KEYS, MachineProfile

    meant = did_you_mean(name, KEYS)
    if meant:
        return meant
    meant = did_you_mean(name, [f for f in MachineProfile.__dataclass_fields__ if f not in NOT_KEYS])
    return f"{meant[:-1]} (a machine profile key: set it in the profile the project names)" if meant else ""


def _checked(name: str, value: Any, folder: str, where: Location) -> Any:
    if name in PATHS:
        if not isinstance(value, str) or not value:
            raise OptionError(f"{name} must be a path (a string), relative to the project file's folder", where)
        target = os.path.normpath(os.path.join(folder, os.path.expanduser(value)))
        if not os.path.isfile(target):
            raise OptionError(f"{name} = {value!r}: no such file {target} (paths in a project file are relative to "
                              "its own folder)", where)
        return os.path.relpath(target) if not os.path.isabs(value) else target
    if name in LISTS:
        if isinstance(value, str):
            value = [value]
        if not (isinstance(value, list) and all(isinstance(item, str) and item for item in value)):
            raise OptionError(f"{name} must be a list of strings", where)
        return tuple(value)
    if name in CHOICES:
        if value not in CHOICES[name]:
            raise OptionError(f"{name} must be one of {', '.join(CHOICES[name])}", where)
        return value
    if name == "jobs":
        if not isinstance(value, int) or isinstance(value, bool) or value < 1:
            raise OptionError("jobs must be a whole number of at least 1", where)
        return value
    if name == "max_correction":
        return bounds.max_correction(value, "max_correction =", where)
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        raise OptionError(f"{name} must be a number (mm)", where)
    return float(value)
