"""The bounds on a tolerance and a maximum correction: one place for the command line, the
Python API and machine profiles.

A tolerance is how far the emitted path may run from the compensated one, so it is never
above the largest correction allowed (the path could then stray further than any correction
moves it) nor above :data:`MAX_TOLERANCE`. A maximum correction above :data:`MAX_CORRECTION`
is beyond any error a compensation corrects. Both are far more often microns typed as
millimetres (``--tolerance 20``, ``--max-correction 5``) than meant, so the refusal asks
"did you mean um?" and gives the value in both units.
"""

from __future__ import annotations

import math
from typing import Any

from ..diagnostics import Location, OptionError

MAX_TOLERANCE = 0.05  #: mm
MAX_CORRECTION = 1.0  #: mm


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def tolerance(value: Any, max_correction: float, name: str = "--tolerance", where: Location | None = None) -> float:
    """A tolerance in mm: positive, at most :data:`MAX_TOLERANCE` and at most the maximum correction."""
    if not _is_number(value) or not math.isfinite(value):
        raise OptionError(f"{name} {value}: the tolerance must be a finite length in mm", where)
    if not value > 0:
        raise OptionError(f"{name} {value}: the tolerance must be positive", where)
    if value > MAX_TOLERANCE:
        meant = (f"did you mean {value:g} um ({name} {value / 1000:g})?" if 1e-4 <= value / 1000 <= MAX_TOLERANCE
                 else f"give at most {MAX_TOLERANCE:g} mm")  # 0.06 um or 1e9 um is no tolerance anybody meant
        raise OptionError(f"{name} {value:g}: a tolerance of {value:g} mm ({_um(value)} um) is above "
                          f"{MAX_TOLERANCE:g} mm, which would let the emitted path stray from the part; {meant}", where)
    if value > max_correction:
        raise OptionError(f"{name} {value:g}: a tolerance above the maximum correction ({max_correction:g} mm) would "
                          f"let the emitted path stray further than any correction moves it; give at most "
                          f"{max_correction:g} mm", where)
    return float(value)


def max_correction(value: Any, name: str = "--max-correction", where: Location | None = None) -> float:
    """A maximum correction in mm: positive and at most :data:`MAX_CORRECTION`."""
    if not _is_number(value) or not math.isfinite(value) or not value > 0:
        raise OptionError(f"{name} {value}: must be positive", where)
    if value > MAX_CORRECTION:
        raise OptionError(f"{name} {value:g}: {value:g} mm ({_um(value)} um) is above {MAX_CORRECTION:g} mm, beyond "
                          f"any error a compensation corrects; did you mean {value:g} um ({name} {value / 1000:g})?",
                          where)
    return float(value)


MAX_BAND = 1.0  #: mm; the widest band a part is judged against here


def bounded(value: Any, name: str, ceiling: float, meaning: str, where: Location | None = None) -> float:
    """A length in mm that is positive and at most ``ceiling``: a part's band (``--band``), a
    convergence tolerance. Above the ceiling it is far more often microns typed as millimetres
    (``--band 5``) than meant, and a verdict judged against it would pass anything."""
    if not _is_number(value) or not math.isfinite(value) or not value > 0:
        raise OptionError(f"{name} {value:g}: must be positive (a length in mm)" if _is_number(value) else
                          f"{name} {value}: must be positive (a length in mm)", where)
    if value > ceiling:
        raise OptionError(f"{name} {value:g}: {value:g} mm ({_um(value)} um) is above {ceiling:g} mm, {meaning}; did "
                          f"you mean {value:g} um ({name} {value / 1000:g})?", where)
    return float(value)


def in_force(tolerance_mm: float | None, max_correction_mm: float | None, profile) -> float:
    """Check a run's tolerance and maximum correction (given, or the machine profile's); the
    maximum correction in force."""
    largest = profile.max_correction if max_correction_mm is None else max_correction(max_correction_mm)
    if tolerance_mm is not None:
        tolerance(tolerance_mm, largest)
    elif profile.tolerance is not None:
        tolerance(profile.tolerance, largest, "tolerance =")
    return largest


def _um(mm: float) -> str:
    return f"{mm * 1000:g}"


MAX_TRAVEL = 10_000.0  #: mm; no lathe's axis reaches further from its work origin


def travel(limits: tuple[float, float] | None) -> tuple[float, float]:
    """The span (mm, work coordinates) an interpreted end point must lie in. A coordinate
    beyond it is a typing mistake, not a part: inches read as millimetres, a missing decimal
    point (``X50000`` for ``X50.000``), a digit too many. Without soft limits in the profile,
    :data:`MAX_TRAVEL` either side of the origin; with them, the limits widened by their own
    span, so a machine longer than :data:`MAX_TRAVEL` states its limits and is not refused
    while a move beyond its whole travel still is. Checked once per interpreted end point,
    before anything samples the move, whose cost grows with its length."""
    if limits is None:
        return -MAX_TRAVEL, MAX_TRAVEL
    span = limits[1] - limits[0]
    return limits[0] - span, limits[1] + span


def beyond_travel(word: str, axis: str, value: float, span: tuple[float, float], limits_key: str,
                  stated: bool) -> str:
    """The message refusing an end point outside :func:`travel`'s span (``stated``: the span
    comes from the profile's soft limits)."""
    where = (f"far beyond the machine profile's {limits_key} (an end point must lie in {span[0]:g} .. {span[1]:g} mm)"
             if stated else f"beyond the travel of any lathe ({span[0]:g} .. {span[1]:g} mm in work coordinates)")
    remedy = (f"correct the coordinate, or {limits_key} if the machine travels further" if stated else
              f"correct the coordinate; a machine that travels further states it with {limits_key} in the machine "
              f"profile")
    return (f"{word} puts {axis} at {value:g} mm, {where}: inches read as millimetres, a missing decimal point or a "
            f"digit too many? {remedy[0].upper()}{remedy[1:]}")
