"""Lengths in the wrong unit: how large each kind of length in a measurement file can be, and
which misreading makes one that cannot be plausible again (docs/formats.md §3).

People type micrometres where millimetres are meant, inches into a file in mm, a diameter
where a radius is asked, and a printout headed G 20 may carry millimetres. Such a value is
most often still a number the next check can use, and that check then blames something else: a
datum that "moved" by 13 m, a part "out of tolerance" by the stylus radius. So each reader holds
its lengths to what the thing measured can be, and names the misreading under which a value
that is not becomes plausible: the likely cause, at its file and line. One place for the
readers of traces, probe files, calibrations and printouts.
"""

from __future__ import annotations

from typing import Callable

from ...machine.bounds import MAX_TRAVEL

#: mm: the stylus balls of touch probes, 0.3 mm to 25 mm across. A radius above is micrometres
#: (3000 for 3 mm), or inches read as mm (a printout headed G 20 whose R is in mm reads 76.2)
STYLUS_RADIUS_MM = (0.15, 12.5)


def _um(value: float) -> str:
    return f"micrometres written as millimetres? ({value:g} um is {value / 1000:g} mm)"


def _inch(value: float) -> str:
    return f"inches written as millimetres? ({value:g} in is {value * 25.4:g} mm)"


def _inch_read(value: float) -> str:
    return (f"millimetres read as inches? ({value:g} mm is {value / 25.4:g} in: a printout headed G 20 whose "
            "numbers are millimetres)")


def _diameter(value: float) -> str:
    return f"a diameter where a radius is meant? (halved, {value / 2:g} mm)"


def _halved(value: float) -> str:
    return f"a radius where a diameter is meant, or halved twice? (doubled, {value * 2:g} mm)"


#: (factor to the value meant, why the value would be that many times too large or small):
#: what is typed into a file in mm; and what a printout headed G 20 may hold besides
WRITTEN = ((1 / 1000, _um), (25.4, _inch))
UNITS = WRITTEN + ((1 / 25.4, _inch_read),)
DIAMETERS = ((0.5, _diameter), (2.0, _halved))
RADII = UNITS + DIAMETERS


def misreading(value: float, plausible: Callable[[float], bool], readings=UNITS) -> str | None:
    """The likely cause of a ``value`` that is not ``plausible``: the first of ``readings``
    (factor, cause) under which ``value * factor`` is, or None."""
    for factor, cause in readings:
        if plausible(value * factor):
            return cause(value)
    return None


def within_travel(value: float) -> bool:
    """Whether a coordinate lies within any lathe's travel of its work origin (docs/formats.md §2)."""
    return abs(value) <= MAX_TRAVEL


def travel_problem(value: float) -> str | None:
    """What is wrong with a coordinate (mm, from the work origin) no lathe reaches, or None."""
    if within_travel(value):
        return None
    cause = misreading(value, within_travel) or "not a coordinate in mm"
    return f"{abs(value):g} mm from the work origin is beyond any lathe's travel ({MAX_TRAVEL:g} mm): {cause}"


def plausible_stylus(radius: float) -> bool:
    return STYLUS_RADIUS_MM[0] <= radius <= STYLUS_RADIUS_MM[1]


def stylus_problem(radius: float) -> str | None:
    """What is wrong with a stylus radius (mm) larger than any probe's, or None. A small one is
    left to the touches to judge (:data:`RADII` at the profile or artifact): 0.5 mm balls exist."""
    if radius <= STYLUS_RADIUS_MM[1]:
        return None
    cause = misreading(radius, plausible_stylus) or "a length in another unit"
    return (f"a stylus radius of {radius:g} mm is larger than any probe's (balls of {2 * STYLUS_RADIUS_MM[0]:g} to "
            f"{2 * STYLUS_RADIUS_MM[1]:g} mm): {cause}")
