"""Compensator cases kept as data: one TOML file each in ``tests/compensate/cases/``, run through
the command line by ``tests/compensate/test_compensator_cases.py``; docs/architecture.md says how
to add one.

A case is a program, the measurements, the options of ``postproc compensate`` and what must come
of them: the exit code, a fragment of the error for a refusal, the blocks replaced, the largest
correction, figures of the ``--report``, or the program back byte for byte. A file that does not
read as a case fails its test with a message that names the file and what is wrong in it."""

from __future__ import annotations

import json
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from support import REPO

CASES = REPO / "tests" / "compensate" / "cases"

#: the options of ``postproc compensate`` a case may give, and whether each takes a list
OPTIONS = {"plugin": list, "option": list, "tolerance": float, "mode": str, "max-correction": float, "force": bool,
           "keep-unplannable": bool, "macro-values": str, "region": list, "machine": str, "model": str}
MEASUREMENTS = {"ballbar": list, "probe": list, "calibration": str}
SIMULATE = {"ballbar": list, "probe": dict, "calibration": bool}
EXPECT = {"exit": int, "error": str, "warning": list, "replaced": (int, list), "emitted": (int, list),
          "largest_correction_um": list, "largest_deviation_um": list, "unchanged": bool, "contains": list,
          "absent": list, "report": dict}
TOP = {"about": str, "program": dict, "machine": dict, "measurements": dict, "simulate": dict, "options": dict,
       "expect": dict}
#: what ``postproc compensate`` says of a run on stderr (postproc/cli/main.py)
SUMMARY = re.compile(r": (\d+) blocks replaced by (\d+); largest correction ([\d.]+) um; largest deviation from the "
                     r"intended path ([\d.]+) um$", re.M)


class CaseError(Exception):
    """A case file that does not read as a case: the message names the file."""


@dataclass
class Case:
    path: Path
    about: str
    program: dict
    machine: dict | None
    measurements: dict = field(default_factory=dict)
    simulate: dict = field(default_factory=dict)
    options: dict = field(default_factory=dict)
    expect: dict = field(default_factory=dict)

    @property
    def name(self) -> str:
        return self.path.stem


def files() -> list[Path]:
    return sorted(CASES.glob("*.toml"))


def load(path: Path) -> Case:
    """Read and check one case file; any fault is a CaseError naming the file."""
    where = path.relative_to(REPO) if path.is_relative_to(REPO) else path
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise CaseError(f"{where}: not a TOML case file: {exc}") from None
    _keys(where, "", data, TOP)
    for name in ("about", "program", "expect"):
        if name not in data:
            raise CaseError(f"{where}: '{name}' is required ({_FORM})")
    program = data["program"]
    if len([key for key in ("path", "text") if key in program]) != 1 or set(program) - {"path", "text"}:
        raise CaseError(f"{where}: [program] takes one of path = \"samples/...\" or text = \"\"\"...\"\"\"")
    if "path" in program:
        _repository_file(where, "program.path", program["path"])
    _keys(where, "measurements.", data.get("measurements", {}), MEASUREMENTS)
    _keys(where, "simulate.", data.get("simulate", {}), SIMULATE)
    _keys(where, "options.", data.get("options", {}), OPTIONS)
    _keys(where, "expect.", data["expect"], EXPECT)
    if "exit" not in data["expect"]:
        raise CaseError(f"{where}: expect.exit is required (0 success, 2 usage, 3 bad input, 4 refused)")
    for kind, paths in data.get("measurements", {}).items():
        for value in paths if isinstance(paths, list) else [paths]:
            _repository_file(where, f"measurements.{kind}", value)
    for key in ("machine", "model"):
        if key in data.get("options", {}):
            _repository_file(where, f"options.{key}", data["options"][key])
    if "machine" in data and "machine" in data.get("options", {}):
        raise CaseError(f"{where}: a [machine] table and options.machine both given: give one")
    if data.get("simulate") and "machine" not in data and "machine" not in data.get("options", {}):
        raise CaseError(f"{where}: [simulate] needs the machine to simulate: a [machine] table with its [simulation], "
                        "or options.machine")
    for key in ("largest_correction_um", "largest_deviation_um", "replaced", "emitted"):
        _range(where, key, data["expect"].get(key))
    for key, value in data["expect"].get("report", {}).items():
        _range(where, f"report.{key}", value)
    return Case(path, data["about"], program, data.get("machine"), data.get("measurements", {}),
                data.get("simulate", {}), data.get("options", {}), data["expect"])


_FORM = "a case has about, [program], [expect], and may have [machine], [measurements], [simulate], [options]"


def _keys(where, prefix: str, table, known: dict) -> None:
    if not isinstance(table, dict):
        raise CaseError(f"{where}: {prefix.rstrip('.')} must be a table")
    for key, value in table.items():
        if key not in known:
            raise CaseError(f"{where}: unknown key '{prefix}{key}' (known: {', '.join(known)})")
        kind = known[key]
        if kind is float and isinstance(value, int) and not isinstance(value, bool):
            continue
        if not isinstance(value, kind) or (isinstance(value, bool) and kind is not bool):
            names = " or ".join(k.__name__ for k in (kind if isinstance(kind, tuple) else (kind,)))
            raise CaseError(f"{where}: {prefix}{key} = {value!r}: expected {names}")


def _repository_file(where, key: str, value: str) -> None:
    path = (REPO / value).resolve()
    if Path(value).is_absolute() or not path.is_relative_to(REPO) or value.split("/")[0] not in ("samples", "tests"):
        raise CaseError(f"{where}: {key} = {value!r}: give a path under samples/ or tests/, from the repository's top")
    if not path.is_file():
        raise CaseError(f"{where}: {key} = {value!r}: no such file")


def _range(where, key: str, value) -> None:
    if value is None or isinstance(value, int | float) and not isinstance(value, bool):
        return
    if not (isinstance(value, list) and len(value) == 2 and all(isinstance(v, int | float) for v in value)
            and value[0] <= value[1]):
        raise CaseError(f"{where}: expect.{key} = {value!r}: expected a number or [low, high]")


def within(value: float, expected) -> bool:
    """A figure as a case expects it: a number exactly, or a [low, high] range."""
    if isinstance(expected, list):
        return expected[0] <= value <= expected[1]
    return math.isclose(value, expected, rel_tol=1e-9, abs_tol=1e-12)


def toml_text(table: dict, prefix: str = "") -> str:
    """A [machine] table written back as a machine profile (plain values, nested tables)."""
    lines = [f"{key} = {json.dumps(value)}" for key, value in table.items() if not isinstance(value, dict)]
    for key, value in table.items():
        if isinstance(value, dict):
            lines += ["", f"[{prefix}{key}]", toml_text(value, f"{prefix}{key}.")]
    return "\n".join(lines) + "\n"


def report_value(report: dict, dotted: str):
    """``compensators.0.fit_residual_um.both.rms_um`` in a ``--report`` document."""
    value = report
    for part in dotted.split("."):
        value = value[int(part)] if isinstance(value, list) else value[part]
    return value
