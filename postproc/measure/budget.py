"""Error budgets (docs/methods.md §11; the dissertation's sections 2.2.2 and 5.4, Tables 5.1 and 5.2).

Each error source has a peak-to-valley amplitude per axis and a distribution. A length-based
source is given in micrometres per millimetre and multiplied by the travel. Per axis,
``PV_tot = sum PV_i`` (every source at its worst at once: too pessimistic),
``RMS_tot = sqrt(sum RMS_i^2)`` with ``RMS_i = PV_i / k`` (too optimistic), and the estimate is
their average ``(PV_tot + RMS_tot) / 2`` (Estler, Thompson).

``k`` by distribution (Table 5.1): uniform ``2 sqrt 3``, sinusoidal ``2 sqrt 2``, Gaussian the
number of sigmas the PV spans, **6 unless the file says otherwise** (``gaussian_pv_sigmas``;
PV = 6 sigma means a repeatability of +-3 sigma, so RMS = sigma = PV / 6).

The file is TOML::

    name = "Okuma & Howa V40R, hemishell outside"
    travel_mm = 57.15                 # or a table per axis: { x = 57.15, z = 57.15 }
    gaussian_pv_sigmas = 6            # optional, default 6

    [[source]]
    name = "linear positioning accuracy"
    group = "length based"            # optional: subtotals per group
    distribution = "uniform"          # gaussian, uniform or sinusoidal
    pv_um_per_mm = { x = 0.1, z = 0.05 }   # length based (times the travel) ...

    [[source]]
    name = "linear positioning repeatability"
    group = "stability"
    distribution = "gaussian"
    pv_mm = { x = 0.006, z = 0.010 }  # ... or a plain PV in mm

A source may set its own ``travel_mm``. Axes are ``x``, ``y``, ``z``. Unknown keys are refused,
except keys starting with ``x-`` (kept out of the arithmetic), as in every postproc format.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from ..files import inputs
from ..diagnostics import Location, MeasurementError

MAX_BYTES = 1024 * 1024  #: an error budget is a page of text

AXES = ("x", "y", "z")
DISTRIBUTIONS = ("gaussian", "uniform", "sinusoidal")
DEFAULT_GAUSSIAN_SIGMAS = 6.0
TOP_KEYS = {"name", "travel_mm", "gaussian_pv_sigmas", "source"}
SOURCE_KEYS = {"name", "group", "distribution", "pv_mm", "pv_um_per_mm", "travel_mm", "note"}
UNGROUPED = "ungrouped"


def divisor(distribution: str, gaussian_sigmas: float = DEFAULT_GAUSSIAN_SIGMAS) -> float:
    """``k`` of Table 5.1: ``RMS = PV / k``."""
    factors = {"gaussian": gaussian_sigmas, "uniform": 2.0 * math.sqrt(3.0), "sinusoidal": 2.0 * math.sqrt(2.0)}
    return factors[distribution]


@dataclass(frozen=True, slots=True)
class Source:
    name: str
    group: str
    distribution: str
    pv: dict[str, float]  #: axis -> peak-to-valley, mm (length-based ones already times the travel)
    rms: dict[str, float]  #: axis -> mm
    per_mm: dict[str, float] | None = None  #: axis -> um per mm, for a length-based source
    travel: dict[str, float] | None = None  #: axis -> mm, for a length-based source


@dataclass(frozen=True, slots=True)
class Total:
    """One combination: per axis, mm."""

    pv: dict[str, float]  #: arithmetic sum of the PVs
    rms: dict[str, float]  #: root sum of squares of the RMS values
    estimate: dict[str, float]  #: (pv + rms) / 2

    def as_dict(self) -> dict[str, dict[str, float]]:
        return {axis: {"pv_mm": self.pv[axis], "rms_mm": self.rms[axis], "estimate_mm": self.estimate[axis]}
                for axis in self.pv}


def combine(sources, axes) -> Total:
    """PV sum, RSS of RMS and their average, per axis, over ``sources``."""
    pv = {axis: sum(s.pv.get(axis, 0.0) for s in sources) for axis in axes}
    rms = {axis: math.sqrt(sum(s.rms.get(axis, 0.0) ** 2 for s in sources)) for axis in axes}
    return Total(pv, rms, {axis: (pv[axis] + rms[axis]) / 2.0 for axis in axes})


@dataclass(frozen=True)
class Budget:
    path: str
    name: str
    gaussian_sigmas: float
    sources: tuple[Source, ...]

    @property
    def axes(self) -> tuple[str, ...]:
        return tuple(axis for axis in AXES if any(axis in s.pv for s in self.sources))

    @property
    def groups(self) -> tuple[str, ...]:
        """The groups, in the order they first appear."""
        return tuple(dict.fromkeys(s.group for s in self.sources))

    def total(self, group: str | None = None) -> Total:
        return combine([s for s in self.sources if group is None or s.group == group], self.axes)

    def as_dict(self) -> dict:
        return {
            "file": self.path,
            "name": self.name,
            "gaussian_pv_sigmas": self.gaussian_sigmas,
            "axes": list(self.axes),
            "sources": [{"name": s.name, "group": s.group, "distribution": s.distribution,
                         "pv_mm": s.pv, "rms_mm": s.rms,
                         **({"pv_um_per_mm": s.per_mm, "travel_mm": s.travel} if s.per_mm is not None else {})}
                        for s in self.sources],
            "groups": {group: self.total(group).as_dict() for group in self.groups},
            "total": self.total().as_dict(),
        }


class _File:
    """The text of a budget file, to point errors at a line."""

    def __init__(self, path: str, text: str):
        self.path = path
        self.lines = text.splitlines()

    def error(self, message: str, key: str | None = None, source: int | None = None) -> MeasurementError:
        return MeasurementError(message, Location(self.path, self._line(key, source)))

    def _line(self, key: str | None, source: int | None) -> int | None:
        """The line of ``key`` (in the ``source``-th [[source]] table, 0-based), if it can be found."""
        start, seen = 0, -1
        if source is not None:
            for number, text in enumerate(self.lines):
                if re.match(r"\s*\[\[\s*source\s*\]\]", text):
                    seen += 1
                    if seen == source:
                        start = number
                        break
            if key is None:
                return start + 1 if seen == source else None
        if key is None:
            return None
        pattern = re.compile(rf"\s*\"?{re.escape(key)}\"?\s*=")
        for number in range(start, len(self.lines)):
            if number > start and source is not None and re.match(r"\s*\[", self.lines[number]):
                break
            if pattern.match(self.lines[number]):
                return number + 1
        return None


def _number(file: _File, value, key: str, source: int | None = None, positive: bool = False) -> float:
    """A finite number, not negative (``positive``: above zero); ``key`` may be ``table.axis``."""
    line_key = key.split(".")[0]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise file.error(f"{key} = {value!r} is not a number", line_key, source)
    if value < 0 or (positive and value == 0):
        raise file.error(f"{key} must be {'positive' if positive else 'zero or more'}, not {value!r}", line_key, source)
    return float(value)


def _per_axis(file: _File, value, key: str, source: int | None = None, positive: bool = False) -> dict[str, float]:
    """A table ``{ x = .., z = .. }`` of non-negative numbers."""
    if not isinstance(value, dict):
        raise file.error(f"{key} must be a table of axes, such as {{ x = 0.001, z = 0.002 }}", key, source)
    for axis in value:
        if axis not in AXES:
            raise file.error(f"unknown axis {axis!r} in {key} (axes: x, y, z)", key, source)
    return {axis: _number(file, value[axis], f"{key}.{axis}", source, positive) for axis in AXES if axis in value}


def _unknown(file: _File, table: dict, known: set[str], where: str, source: int | None = None) -> None:
    for key in table:
        if key not in known and not key.startswith("x-"):
            raise file.error(f"unknown key {key!r} {where} (known: {', '.join(sorted(known))}; "
                             "keys of your own start with x-)", key, source)


def _travel(file: _File, value, source: int | None = None) -> dict[str, float]:
    if isinstance(value, dict):
        return _per_axis(file, value, "travel_mm", source, positive=True)
    length = _number(file, value, "travel_mm", source, positive=True)
    return {axis: length for axis in AXES}


def _source(file: _File, number: int, table, travel: dict[str, float] | None, sigmas: float) -> Source:
    if not isinstance(table, dict):
        raise file.error("source must be an array of tables ([[source]])", "source")
    _unknown(file, table, SOURCE_KEYS, "in [[source]]", number)
    name = table.get("name")
    if not isinstance(name, str) or not name.strip():
        raise file.error("every [[source]] needs a name", "name" if "name" in table else None, number)
    distribution = table.get("distribution")
    if distribution not in DISTRIBUTIONS:
        raise file.error(f"source {name!r}: distribution = {distribution!r}: expected {', '.join(DISTRIBUTIONS)}",
                         "distribution" if "distribution" in table else None, number)
    group = table.get("group", UNGROUPED)
    if not isinstance(group, str):
        raise file.error(f"source {name!r}: group must be a string", "group", number)
    given = [key for key in ("pv_mm", "pv_um_per_mm") if key in table]
    if len(given) != 1:
        raise file.error(f"source {name!r}: give exactly one of pv_mm and pv_um_per_mm", None, number)
    per_mm = None
    if given == ["pv_mm"]:
        if "travel_mm" in table:
            raise file.error(f"source {name!r}: travel_mm only goes with pv_um_per_mm", "travel_mm", number)
        pv = _per_axis(file, table["pv_mm"], "pv_mm", number)
    else:
        per_mm = _per_axis(file, table["pv_um_per_mm"], "pv_um_per_mm", number)
        if "travel_mm" in table:
            travel = _travel(file, table["travel_mm"], number)
        if travel is None or any(axis not in travel for axis in per_mm):
            raise file.error(f"source {name!r} is length based: give travel_mm (here or at the top of the file) "
                             "for each of its axes", "pv_um_per_mm", number)
        travel = {axis: travel[axis] for axis in per_mm}
        pv = {axis: per_mm[axis] * travel[axis] / 1000.0 for axis in per_mm}
    k = divisor(distribution, sigmas)
    rms = {axis: value / k for axis, value in pv.items()}
    return Source(name.strip(), group, distribution, pv, rms, per_mm, travel if per_mm is not None else None)


def read_budget(path: str) -> Budget:
    """Read and check an error budget file (TOML)."""
    document, text = inputs.read_toml(path, MAX_BYTES, MeasurementError, "an error budget")
    file = _File(path, text)
    _unknown(file, document, TOP_KEYS, "at the top of the budget")
    name = document.get("name", path)
    if not isinstance(name, str):
        raise file.error("name must be a string", "name")
    sigmas = _number(file, document.get("gaussian_pv_sigmas", DEFAULT_GAUSSIAN_SIGMAS), "gaussian_pv_sigmas",
                     positive=True)
    travel = _travel(file, document["travel_mm"]) if "travel_mm" in document else None
    tables = document.get("source", [])
    if not isinstance(tables, list):
        raise file.error("source must be an array of tables ([[source]])", "source")
    if not tables:
        raise MeasurementError("the budget has no [[source]]", Location(path))
    sources = tuple(_source(file, number, table, travel, sigmas) for number, table in enumerate(tables))
    return Budget(path, name, sigmas, sources)
