"""Saved compensation models: fit once, apply to any number of programs.

A model file is JSON: the compensator's fitted model plus what it was made from (the
inputs with their SHA-256, the machine profile's name and SHA-256, the time of the
measurement, a note on the machine's state) and a SHA-256 over all of it. Reading refuses a file of
another format or version and one whose content no longer matches its hash (edited by
hand, or damaged). A model is data: it names its compensator, which must be installed;
nothing in it is ever imported or executed.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import json
import math
import os
import re
import stat
from typing import Any

from .. import __version__
from ..files import inputs
from ..diagnostics import Location, ModelError, Reporter
from ..machine.profile import MachineProfile, sha256 as profile_sha256
from ..measure.readers.csvfile import measured_time, parse_time

FORMAT = "postproc model"
VERSION = 1
MAX_BYTES = 64 * 1024 * 1024
MAX_DEPTH = 32  #: no compensator's model nests deeper; deeper is not a model
MAX_INTEGER = 2**53  #: integers beyond this are not plausible values (nor exact as floats)
#: every key of a model file, and the type of its value
KEYS = {"format": str, "version": int, "postproc": str, "plugin": str, "plugin_version": str, "machine_profile": str,
        "machine_profile_sha256": str, "measured": str, "created": str, "note": (str, type(None)), "inputs": list, "options": dict, "model": dict,
        "sha256": str}
_SHA256 = re.compile(r"^[0-9a-f]{64}$")


def _canonical(payload: dict[str, Any]) -> bytes:
    return json.dumps(payload, sort_keys=True, separators=(",", ":"), allow_nan=False).encode()


def measurement_times(paths: list[str]) -> list[tuple[str, dt.datetime | None]]:
    """When each measurement was taken: its file's ``measured`` header key (docs/formats.md §3), else the file's modification time at its read; None when the file tells neither
    (a pipe without the key). Called while the files' reads are at hand."""
    times = []
    for path in paths:
        moment = measured_time(path)
        if moment is None:
            snapshot = inputs.recorded(path)
            mtime = snapshot.mtime if snapshot is not None else _mtime(path)
            moment = None if mtime is None else dt.datetime.fromtimestamp(mtime, dt.timezone.utc)
        times.append((path, moment))
    return times


def measured_at(times: list[tuple[str, dt.datetime | None]], reporter: Reporter | None = None) -> str:
    """A model's measurement time: the oldest of its measurements', for a model is as old as its
    oldest measurement. One whose time is unknown counts as now, with a warning; the epoch is
    never a measurement time."""
    now = dt.datetime.now(dt.timezone.utc)
    for path, moment in times:
        if moment is None and reporter is not None:
            reporter.warn("no measurement time: the file has no '# measured = ...' header line and no modification "
                          "time (a pipe?); the model counts it as measured now", Location(path))
    oldest = min((moment or now for _, moment in times), default=now)
    return oldest.astimezone(dt.timezone.utc).replace(microsecond=0).isoformat()


def _mtime(path: str) -> float | None:
    """A regular file's modification time (a stat, not a read)."""
    try:
        info = os.stat(path)
    except OSError:
        return None
    return info.st_mtime if stat.S_ISREG(info.st_mode) else None


def build(plugin: str, plugin_version: str, model: dict[str, Any], inputs: list[tuple[str, str]],
          profile: MachineProfile, options: dict[str, Any], note: str | None, measured: str) -> dict[str, Any]:
    """A model file's content: the profile by its name and its SHA-256 (:func:`~postproc.machine.profile.sha256`),
    for a profile file's name may be the default's."""
    payload = {
        "format": FORMAT,
        "version": VERSION,
        "postproc": __version__,
        "plugin": plugin,
        "plugin_version": plugin_version,
        "machine_profile": profile.name,
        "machine_profile_sha256": profile_sha256(profile),
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


def saved(data: dict[str, Any], where: Location) -> bytes:
    """A model's file, refused (naming ``where``, the measurements) when it would be over the
    MAX_BYTES that reading a model allows: a model keeps the traces it applies (ballbar-inverse,
    iterative), and a trace of millions of samples would make a file no command reads back."""
    data_bytes = dumps(data).encode()
    if len(data_bytes) > MAX_BYTES:
        raise ModelError(f"the model would be {len(data_bytes) / 2**20:.0f} MiB, over the {MAX_BYTES / 2**20:g} MiB "
                         "a model file may be (compensate --model refuses a larger one): it keeps the measurements' "
                         "samples; fit from traces of fewer samples (an export at a coarser angle step), or fit and "
                         "apply in one run: postproc compensate PROGRAM --plugin NAME --ballbar FILE ...", where)
    return data_bytes


def read_back(data: dict[str, Any]) -> dict[str, Any]:
    """A model's content as :func:`read` will read it from its file, held to what read holds a
    file to: what ``postproc fit`` writes is checked before it is written."""
    reread = json.loads(dumps(data), parse_constant=_not_a_number)
    _check(reread, Location("<model>"))
    return reread


def read(path: str) -> dict[str, Any]:
    """A model file, checked as strictly as the command line checks options: JSON of at most
    MAX_BYTES, its format, version and hash, every key of the right type, every number finite
    and plausible, every radius positive, the measurement time with its zone."""
    where = Location(inputs.named(path))
    raw = inputs.read(path, MAX_BYTES, ModelError, "a model").data
    try:
        # utf-8-sig: a byte order mark, as an editor on Windows saves a model looked at, is no content
        data = json.loads(raw.decode("utf-8-sig"), parse_constant=_not_a_number)
    except UnicodeDecodeError:
        raise ModelError("not a postproc model (not UTF-8 text)", where) from None
    except json.JSONDecodeError as exc:
        raise ModelError(f"not a postproc model (not JSON: {exc})", where) from None
    except RecursionError:
        raise ModelError(f"not a postproc model (nested deeper than {MAX_DEPTH} levels)", where) from None
    except ValueError as exc:  # NaN or Infinity; an integer of thousands of digits
        reason = str(exc) if "number a model holds" in str(exc) else "an integer of thousands of digits"
        raise ModelError(f"not a postproc model ({reason})", where) from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise ModelError("not a postproc model (no 'format: postproc model')", where)
    if data.get("version") != VERSION:
        raise ModelError(f"a model of version {data.get('version')!r}; this postproc reads version {VERSION}", where)
    claimed = data.get("sha256")
    payload = {key: value for key, value in data.items() if key != "sha256"}
    try:
        actual = hashlib.sha256(_canonical(payload)).hexdigest()
    except (ValueError, RecursionError):
        actual = None
    if claimed != actual:
        raise ModelError("the model's content does not match its SHA-256: it was changed after it was saved", where)
    _check(data, where)
    return data


def _not_a_number(constant: str):
    raise ValueError(f"{constant} is not a number a model holds")


def _check(data: dict[str, Any], where: Location) -> None:
    for key in ("plugin", "model", "options", "measured", "machine_profile"):
        if key not in data:
            raise ModelError(f"the model has no {key!r}", where)
    for key, value in data.items():
        if key not in KEYS:
            raise ModelError(f"unknown key {key!r} in the model (known: {', '.join(sorted(KEYS))})", where)
        if not isinstance(value, KEYS[key]) or isinstance(value, bool):
            raise ModelError(f"{key!r} must be {_kind(KEYS[key])}, not {_kind(type(value))}", where)
    for index, entry in enumerate(data.get("inputs", [])):
        if not (isinstance(entry, dict) and set(entry) == {"file", "sha256"} and isinstance(entry["file"], str)
                and isinstance(entry["sha256"], str) and _SHA256.match(entry["sha256"])):
            raise ModelError(f"inputs[{index}] must be {{\"file\": name, \"sha256\": 64 hex digits}}", where)
    if "machine_profile_sha256" in data and not _SHA256.match(data["machine_profile_sha256"]):
        raise ModelError("'machine_profile_sha256' must be 64 hex digits (lower case)", where)
    for name, value in data["options"].items():
        if value is not None and not isinstance(value, (str, int, float, bool)):
            raise ModelError(f"options.{name} must be a number, a string or true/false", where)
    _values(data["options"], "options", 1, where)
    _values(data["model"], "model", 1, where, numbers_only=True)
    _time(data["measured"], "measured", where)


def _values(value: Any, name: str, depth: int, where: Location, numbers_only: bool = False) -> None:
    """Every number finite and plausible, every radius positive, nothing nested too deeply.
    ``numbers_only`` (a compensator's fitted model, which holds numbers, file names and
    directions): true/false and a number written as a string are refused, for a reader's
    ``float()`` would take them as 1.0 or as the number (a hand edit that passes the hash)."""
    if depth > MAX_DEPTH:
        raise ModelError(f"not a postproc model (nested deeper than {MAX_DEPTH} levels)", where)
    if isinstance(value, dict):
        for key, item in value.items():
            path = f"{name}.{key}"
            if "radius" in key and isinstance(item, (int, float)) and not isinstance(item, bool) and not item > 0:
                raise ModelError(f"{path} = {item}: a radius must be positive", where)
            _values(item, path, depth + 1, where, numbers_only)
    elif isinstance(value, list):
        for index, item in enumerate(value):
            _values(item, f"{name}[{index}]", depth + 1, where, numbers_only)
    elif isinstance(value, bool):
        if numbers_only:
            raise ModelError(f"{name} = {json.dumps(value)}: a fitted model holds numbers, not true/false; the model "
                             "was edited: fit it again from its measurements", where)
    elif isinstance(value, float) and not math.isfinite(value):
        raise ModelError(f"{name} = {value}: not a finite number", where)
    elif isinstance(value, int) and abs(value) > MAX_INTEGER:
        raise ModelError(f"{name}: an integer of {len(str(abs(value)))} digits is not a plausible value", where)
    elif numbers_only and isinstance(value, str) and _numeric(value):
        raise ModelError(f"{name} = {json.dumps(value)}: a number written as a string (in quotes); a fitted model "
                         "holds JSON numbers: the model was edited: fit it again from its measurements", where)


def _numeric(text: str) -> bool:
    """Whether ``float()`` would read the string as a number (``"0.1"``, ``" 4e-6"``, ``"nan"``)."""
    try:
        float(text)
    except ValueError:
        return False
    return True


def _time(text: str, name: str, where: Location) -> dt.datetime:
    moment = parse_time(text)
    if moment is None:
        raise ModelError(f"the model's {name} time {text!r} is not an ISO 8601 time with a time zone "
                         "(such as 2026-11-20T14:05:00+01:00)", where)
    return moment


def _kind(kind) -> str:
    kinds = kind if isinstance(kind, tuple) else (kind,)
    names = {str: "a string", int: "a whole number", float: "a number", list: "a list", dict: "an object",
             bool: "true or false", type(None): "null"}
    return " or ".join(names.get(k, k.__name__) for k in kinds)


def check_age(data: dict[str, Any], path: str, profile: MachineProfile, reporter: Reporter) -> None:
    """Warn when a model is older than the profile's ``model_max_age_days``, or was made under
    another machine profile: another name, or the same name and other content (its SHA-256). A
    model saved before the SHA-256 was recorded is compared by the name only."""
    where = Location(path)
    measured = _time(data["measured"], "measured", where)
    age = (dt.datetime.now(dt.timezone.utc) - measured).total_seconds() / 86400.0
    if age > profile.model_max_age_days:
        reporter.warn(f"the model was measured {age:.0f} days ago (more than {profile.model_max_age_days:g}); the "
                      "machine may have changed since: measure again", where)
    made, sha = data["machine_profile"], data.get("machine_profile_sha256")
    if made != profile.name:
        reporter.warn(f"the model was made for machine profile {made!r}, not {profile.name!r}", where)
    elif sha is not None and sha != profile_sha256(profile):
        this = f"{profile.source}, SHA-256" if profile.source else "its settings' SHA-256"
        reporter.warn(f"the model was made under a machine profile {made!r} of other content (SHA-256 {sha[:12]}) than "
                      f"this run's ({this} {profile_sha256(profile)[:12]}): make sure it is the same machine, or fit "
                      "the model again with this --machine", where)
