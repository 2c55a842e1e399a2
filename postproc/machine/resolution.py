"""The control's number grid: what a value becomes once it is written into a block.

X is written as a diameter in diameter mode, every length in the program's units, to a
fixed number of decimals. A point in radius millimetres therefore lands on a grid whose X
step is half the written step; I (always a radius on a FANUC lathe) and K land on the
written step itself. The segmenter plans on this grid so that consecutive blocks join
exactly and arcs pass the control's radius check.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

INCH = 25.4


def rounded(value: float, decimals: int) -> float:
    """``round(value, decimals)``, the same correctly rounded result (half to even on the exact
    binary value), through one format and one parse: round() on a float builds and parses an
    exponent string as well, and a compensation run rounds every coordinate it writes."""
    return float("%.*f" % (decimals, value))


@lru_cache(maxsize=256)
def _snapped(x: float, z: float, decimals: int, inch: bool, diameter: bool) -> tuple[float, float]:
    """:meth:`Grid.snap`, remembered: a run snaps each end point several times over (planning
    it, joining it to the next move, connecting it)."""
    unit = INCH if inch else 1.0
    d = 2.0 if diameter else 1.0
    return (rounded(x * d / unit, decimals) + 0.0) * unit / d, (rounded(z / unit, decimals) + 0.0) * unit


@dataclass(frozen=True, slots=True)
class Grid:
    decimals: int  #: decimals written
    inch: bool  #: program in inches
    diameter: bool  #: X written as a diameter

    @property
    def unit(self) -> float:
        """Millimetres per program unit."""
        return INCH if self.inch else 1.0

    @property
    def step(self) -> float:
        """One written digit, in program units."""
        return 10.0**-self.decimals

    @property
    def x_step(self) -> float:
        """Grid step of x in radius millimetres."""
        return self.step * self.unit / (2.0 if self.diameter else 1.0)

    @property
    def z_step(self) -> float:
        return self.step * self.unit

    def _round(self, value: float) -> float:
        return rounded(value, self.decimals) + 0.0

    def x_word(self, x: float) -> float:
        """The X value written for radius x (mm)."""
        return self._round(x * (2.0 if self.diameter else 1.0) / self.unit)

    def z_word(self, z: float) -> float:
        return self._round(z / self.unit)

    def offset_word(self, length: float) -> float:
        """I or K (radius values) written for a length in mm."""
        return self._round(length / self.unit)

    def x_of(self, word: float) -> float:
        """Radius mm of a written X value."""
        return word * self.unit / (2.0 if self.diameter else 1.0)

    def z_of(self, word: float) -> float:
        return word * self.unit

    def offset_of(self, word: float) -> float:
        return word * self.unit

    def snap(self, x: float, z: float) -> tuple[float, float]:
        """A point moved onto the grid, in radius mm (``x_of(x_word(x))``, ``z_of(z_word(z))``,
        written out: the segmenter snaps candidate vertices by the thousand)."""
        return _snapped(float(x), float(z), self.decimals, self.inch, self.diameter)

    def snap_offset(self, length: float) -> float:
        return self.offset_of(self.offset_word(length))

    @property
    def rounding_error(self) -> float:
        """The largest distance rounding moves a point."""
        return math.hypot(self.x_step / 2.0, self.z_step / 2.0)
