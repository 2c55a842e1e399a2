"""Saved compensation models: fit once, apply to any number of programs.

A model file is JSON: the compensator's fitted model plus what it was made from (the
inputs with their SHA-256, the machine profile's name, the time of the measurement, a
note on the machine's state) and a SHA-256 over all of it. Reading refuses a file of
another format or version and one whose content no longer matches its hash (edited by
hand, or damaged). A model is data: it names its compensator, which must be installed;
nothing in it is ever imported or executed.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import json
import os
from typing import Any

from . import __version__
from .diagnostics import Location, ModelError, Reporter

FORMAT = "postproc model"
VERSION = 1
MAX_BYTES = 64 * 1024 * 1024


def _canonical(payload: dict[str, Any]) -> bytes:
    return json.dumps(payload, sort_keys=True, separators=(",", ":"), allow_nan=False).encode()


def measured_at(paths: list[str], stated: list[dt.datetime] | None = None) -> str:
    """When the measurements were made, in UTC: the newest of the times the files state (their
    ``measured`` key) or, when none states one, the newest of the files' modification times."""
    if stated:
        moment = max(stated).astimezone(dt.timezone.utc)
    else:
        times = [os.path.getmtime(path) for path in paths if os.path.exists(path)]
        moment = dt.datetime.fromtimestamp(max(times) if times else 0.0, dt.timezone.utc)
    return moment.replace(microsecond=0).isoformat()


def build(plugin: str, plugin_version: str, model: dict[str, Any], inputs: list[tuple[str, str]], profile: str,
          options: dict[str, Any], note: str | None, measured: str) -> dict[str, Any]:
    payload = {
        "format": FORMAT,
        "version": VERSION,
        "postproc": __version__,
        "plugin": plugin,
        "plugin_version": plugin_version,
        "machine_profile": profile,
        "measured": measured,
        "created": dt.datetime.now(dt.timezone.utc).replace(microsecond=0).isoformat(),
        "note": note,
        "inputs": [{"file": path, "sha256": sha} for path, sha in inputs],
        "options": options,
        "model": model,
    }
    return {**payload, "sha256": hashlib.sha256(_canonical(payload)).hexdigest()}


def dumps(data: dict[str, Any]) -> str:
    try:
        return json.dumps(data, indent=1, allow_nan=False) + "\n"
    except (TypeError, ValueError) as exc:
        raise ModelError(f"the model cannot be saved as JSON: {exc}") from None


def read(path: str) -> dict[str, Any]:
    """A model file, checked: its format, its version and its hash."""
    where = Location(path)
    try:
        if os.path.getsize(path) > MAX_BYTES:
            raise ModelError(f"the file is larger than {MAX_BYTES} bytes: not a model", where)
        with open(path, "rb") as handle:
            data = json.loads(handle.read().decode("utf-8"))
    except OSError as exc:
        raise ModelError(f"cannot read the model: {exc.strerror}", where) from None
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ModelError(f"not a postproc model (not JSON: {exc})", where) from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise ModelError("not a postproc model (no 'format: postproc model')", where)
    if data.get("version") != VERSION:
        raise ModelError(f"a model of version {data.get('version')!r}; this postproc reads version {VERSION}", where)
    claimed = data.get("sha256")
    payload = {key: value for key, value in data.items() if key != "sha256"}
    if claimed != hashlib.sha256(_canonical(payload)).hexdigest():
        raise ModelError("the model's content does not match its SHA-256: it was changed after it was saved", where)
    for key in ("plugin", "model", "options", "measured", "machine_profile"):
        if key not in data:
            raise ModelError(f"the model has no {key!r}", where)
    return data


def check_age(data: dict[str, Any], path: str, profile: str, max_age_days: float, reporter: Reporter) -> None:
    """Warn when a model is older than the set age, or was made for another machine profile."""
    try:
        measured = dt.datetime.fromisoformat(data["measured"])
    except (TypeError, ValueError):
        raise ModelError(f"the model's measurement time {data['measured']!r} is not a time", Location(path)) from None
    age = (dt.datetime.now(dt.timezone.utc) - measured).total_seconds() / 86400.0
    if age > max_age_days:
        reporter.warn(f"the model was measured {age:.0f} days ago (more than {max_age_days:g}); the machine may have "
                      "changed since: measure again", Location(path))
    if data["machine_profile"] != profile:
        reporter.warn(f"the model was made for machine profile {data['machine_profile']!r}, not {profile!r}",
                      Location(path))
