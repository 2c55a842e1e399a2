"""What every figure of the report is called and the unit it is shown in: one table.

Values reach the report under keys: the diagnosis's ``backlash_x_mm``, a compensator's
``scaling_z_plus`` or ``fit_residual_um.ccw``, a third-party plugin's ``shift_x_mm``. A key is
never shown as it is: :func:`quantity` gives its name as people say it and the unit they read
it in (a backlash in um, a scaling in ppm, a squareness in urad, a lag in ms), with the factor
from the key's own unit. The table holds every key the built-in compensators and the
diagnosis report; an unknown key is named from its words and keeps the unit its suffix
states (``_mm``, ``_um``, ``_rad``, ``_deg``, ``_ms``, ``_s``, ``_ppm``), so a third-party
plugin's figures read right without the report knowing it. In a table of fitted errors
(``errors=True``) an unknown length is shown in um, the scale machine errors are read on.

The names of the ballbar parameters are :data:`postproc.measure.ballbar_fit.LABELS`, the ones
``postproc ballbar`` prints, so the report and the command line name a figure alike.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from ..measure.ballbar_fit import LABELS

UM, URAD = "um", "urad"  #: micrometre and microradian, spelt as every message of postproc spells them
_SHOWN = {"um": UM, "urad": URAD}


@dataclass(frozen=True, slots=True)
class Quantity:
    name: str  #: as people say it: "backlash X"
    unit: str  #: as people read it: "um"; "" for a count, a word or a yes/no
    factor: float = 1.0  #: from the key's own unit to ``unit``

    def value(self, value: float) -> float:
        return value * self.factor

    def heading(self) -> str:
        """``name (unit)``, for a column or a row that has no unit column."""
        return f"{self.name} ({self.unit})" if self.unit else self.name


#: the key's unit suffix -> (unit shown, factor); a length of an error is shown in um
SUFFIXES = {"mm": ("mm", 1.0), "um": (UM, 1.0), "rad": (URAD, 1e6), "urad": (URAD, 1.0), "deg": ("deg", 1.0),
            "ms": ("ms", 1.0), "s": ("s", 1.0), "ppm": ("ppm", 1.0), "mm_min": ("mm/min", 1.0)}
ERROR_SUFFIXES = {**SUFFIXES, "mm": (UM, 1e3)}
#: a unit -> (what it measures, its size in that kind's base unit): to convert a key's stated unit
SCALES = {"mm": ("length", 1e-3), UM: ("length", 1e-6), "rad": ("angle", 1.0), URAD: ("angle", 1e-6),
          "ppm": ("ratio", 1e-6), "ms": ("time", 1e-3), "s": ("time", 1.0)}

#: key without its unit suffix -> (name, factor from the key's unit, unit shown)
TABLE: dict[str, tuple[str, float, str]] = {
    **{key: (name, factor, _SHOWN.get(unit, unit)) for key, (name, factor, unit) in LABELS.items()},
    # the diagnosis (postproc.measure.ballbar_analysis) under the keys of `postproc ballbar --json`
    "servo_lag": ("servo lag, X behind Z", 1.0, "ms"),
    "setup_centre_x": ("set-up centre x", 1e3, UM),
    "setup_centre_z": ("set-up centre z", 1e3, UM),
    "setup_centre": ("set-up centre", 1e3, UM),
    "setup_centres": ("set-up centre of test", 1e3, UM),
    # the ballbar compensators' reports
    "centre": ("test centre x, z", 1.0, "mm"),
    "radius": ("test radius", 1.0, "mm"),
    "box": ("box the test arcs span", 1.0, "mm"),
    "square": ("the test circle's square", 1.0, "mm"),
    "extrapolate": ("extrapolated beyond the box", 1.0, ""),
    "one_scaling": ("one scaling for both sides", 1.0, ""),
    "largest_error": ("largest error in the table", 1e3, UM),
    "reference": ("parametric fit of the same traces", 1.0, ""),
    "fit_residual": ("fit residual", 1.0, UM),
    "file": ("file", 1.0, ""),
    "iterations": ("iteration", 1.0, ""),
    "selective": ("selective threshold", 1e3, UM),
    "ccw": ("ccw (G03)", 1.0, ""),
    "cw": ("cw (G02)", 1.0, ""),
    # the probe compensators' reports
    "probe": ("probe file", 1.0, ""),
    "notes": ("notes", 1.0, ""),
    "stock": ("stock of the probed pass", 1.0, "mm"),
    "minimum_touches_per_feature": ("fewest touches per feature", 1.0, ""),
    "chains": ("chain", 1.0, ""),
    "features": ("feature", 1.0, ""),
    "moves": ("moves", 1.0, ""),
    "tool": ("tool", 1.0, ""),
    "points": ("points", 1.0, ""),
    "points_used": ("points used", 1.0, ""),
    "stretch": ("probed stretch, s", 1.0, "mm"),
    "length": ("length", 1.0, "mm"),
    "s": ("s, along the profile", 1.0, "mm"),
    "corrected": ("corrected stretch, s", 1.0, "mm"),
    "touches": ("touches", 1.0, ""),
    "rows": ("rows", 1.0, ""),
    "row": ("row", 1.0, ""),
    "lines": ("lines", 1.0, ""),
    "kind": ("kind", 1.0, ""),
    "how": ("how", 1.0, ""),
    "status": ("status", 1.0, ""),
    "feature": ("feature", 1.0, ""),
    "dropped": ("dropped touch", 1.0, ""),
    "left_out": ("left out", 1.0, ""),
    "deviation": ("deviation", 1e3, UM),
    "replacement": ("replaced by", 1e3, UM),
    "measured_error": ("error as measured", 1.0, UM),
    "cleaned_error": ("error as cleaned", 1.0, UM),
    "offset": ("tool-setting error", 1e3, UM),
    "offset_sigma": ("tool-setting error, 1 sigma", 1e3, UM),
    "residual": ("residual", 1.0, UM),
    "largest_residual": ("largest residual", 1e3, UM),
    "residual_allowed": ("largest residual allowed", 1e3, UM),
    "apply": ("applied as", 1.0, ""),
    "g10": ("G10 block", 1.0, ""),
    "wear_offset": ("wear offset", 1.0, ""),
    "number": ("number", 1.0, ""),
    "u": ("U (diameter)", 1.0, "mm"),
    "w": ("W", 1.0, "mm"),
    "incremental": ("incremental", 1.0, ""),
}

#: the four figures (docs/methods.md §12): column headings, in um
FOUR = (f"mean ({UM})", f"mean |e| ({UM})", f"RMS ({UM})", f"sigma ({UM})")

_SUFFIX = re.compile(r"^(?P<base>.+?)_(?P<unit>mm_min|mm|um|urad|rad|deg|ms|s|ppm)$")
_INDEX = re.compile(r"\[(\d+)\]")


def quantity(key: str, errors: bool = False) -> Quantity:
    """The name and unit of one key (the last part of a path: ``backlash_x_mm``, ``x``)."""
    key = str(key)
    found = _SUFFIX.match(key)
    base, suffix = (found.group("base"), found.group("unit")) if found else (key, None)
    if key in TABLE:
        name, factor, unit = TABLE[key]
        return Quantity(name, unit, factor)
    if base in TABLE and suffix is not None:  # the key states its unit: the factor is from that unit
        name, _, unit = TABLE[base]
        stated, shown = SCALES.get(suffix), SCALES.get(unit)
        if stated is not None and shown is not None and stated[0] == shown[0]:
            return Quantity(name, unit, float(f"{stated[1] / shown[1]:.12g}"))
        unit, factor = (ERROR_SUFFIXES if errors else SUFFIXES)[suffix]
        return Quantity(name, unit, factor)
    if suffix is not None:
        unit, factor = (ERROR_SUFFIXES if errors else SUFFIXES)[suffix]
        return Quantity(words(base), unit, factor)
    return Quantity(words(key), "")


def words(key: str) -> str:
    """A key as words: ``minimum_touches`` -> ``minimum touches``; ``x+`` stays ``x+``."""
    return key.replace("_", " ").strip() or key


def path_quantity(path: str, errors: bool = False) -> Quantity:
    """A nested key (``chains[1].features[2].measured_error_um``) as one name, its unit from the
    last part that has one: ``chain 1, feature 2, error as measured`` in um. Parts that only say
    which (``x``, ``ccw``) follow the name of what they qualify: ``box the test arcs span, x``."""
    names, unit, factor = [], "", 1.0
    for part in path.split("."):
        key, index = _INDEX.sub("", part), [int(n) for n in _INDEX.findall(part)]
        found = quantity(key, errors)
        names.append(" ".join([found.name, *map(str, index)]))
        if found.unit:
            unit, factor = found.unit, found.factor
    return Quantity(", ".join(names), unit, factor)


def significant(value: float, digits: int = 4) -> str:
    """A number for people: ``digits`` significant digits, no float noise, no exponent for
    the sizes a report shows."""
    if not math.isfinite(value):
        return str(value)
    if value == 0:
        return "0"
    decimals = max(0, digits - 1 - math.floor(math.log10(abs(value))))
    return f"{value:.{min(decimals, 9)}f}"


def with_sigma(value: float, sigma: float | None) -> tuple[str, str]:
    """A value and its 1-sigma uncertainty, the value given to the uncertainty's second digit:
    ``4.007``, ``0.081``."""
    if sigma is None or not math.isfinite(sigma) or sigma <= 0:
        return significant(value), ""
    decimals = max(0, 1 - math.floor(math.log10(sigma)))
    return f"{value:.{decimals}f}", f"{sigma:.{decimals}f}"
