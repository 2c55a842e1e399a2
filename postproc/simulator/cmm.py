"""A virtual CMM: the deviation of a surface from the nominal profile of its program.

At ``count`` points evenly spaced along the profile (both ends included), or, given an
``inset``, spread over its features clear of their ends as a probe run spreads them
(:meth:`.nominal.Nominal.spread`: what a CMM program that keeps off corners measures), the deviation is
the signed distance from the nominal point to where the surface crosses the nominal normal,
positive out of the material (material left where the nominal says air), nearest crossing
first, within ``REACH`` mm; plus the CMM's noise. Summarised by the four figures.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..diagnostics import Location, MeasurementError
from ..measure.figures import Figures, figures
from ..measure.nominal import Nominal
from .config import Simulation
from .surface import Turned

REACH = 1.0  #: mm: a surface farther than this from the nominal is not this program's surface


@dataclass(frozen=True)
class Inspection:
    points: np.ndarray  #: (n, 2) nominal points
    normals: np.ndarray  #: (n, 2) outward unit normals
    s: np.ndarray  #: arc length of each point along the profile
    deviations: np.ndarray  #: mm, positive = material left
    figures: Figures

    def as_dict(self) -> dict:
        rows = [{"x_mm": float(x), "z_mm": float(z), "s_mm": float(s), "deviation_mm": float(d)}
                for (x, z), s, d in zip(self.points, self.s, self.deviations)]
        return {**self.figures.as_dict(), "points": rows}


def inspect(surface: Turned, nominal: Nominal, simulation: Simulation, rng: np.random.Generator | None,
            count: int | None = None, inset: float | None = None) -> Inspection:
    count = count or simulation.cmm.points
    if inset is None:
        points, normals, s = nominal.stations(count)
    else:
        s = nominal.spread(count, inset).s
        points, normals = nominal.places(s)
    deviations = np.empty(count)
    for i in range(count):
        crossing = surface.crossing(points[i], normals[i], REACH)
        if crossing is None:
            raise MeasurementError(
                f"point {i + 1} ({points[i, 0]:.4f}, {points[i, 1]:.4f}): the surface does not cross the normal within "
                f"{REACH:g} mm of the nominal", Location(nominal.program))
        deviations[i] = crossing
    if rng is not None and simulation.cmm.noise_mm > 0:
        deviations = deviations + rng.normal(0.0, simulation.cmm.noise_mm, count)
    return Inspection(points, normals, s, deviations, figures(deviations))
