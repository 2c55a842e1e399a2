"""The calibration sphere on a virtual lathe: the lathe, and what the probe must find on it."""

from __future__ import annotations

import math

from postproc.simulator.config import from_table

R = 25.4
STYLUS = 3.0
PROBE = {"stylus_radius_mm": STYLUS, "pretravel_mm": 0.006, "lobing_mm": 0.0015, "lobes": 3, "noise_mm": 0.0005}


def lathe(x: float, z: float, y: float, **probe) -> object:
    """A lathe without errors of its own, the sample probe, a ball at (x, z) and y off the plane."""
    return from_table({"probe": {**PROBE, **probe}, "artifact": {"radius_mm": R, "center_x_mm": x, "center_z_mm": z,
                                                                 "y_offset_mm": y}})


def expected(simulation) -> tuple[float, float, float]:
    """What the probe must find: centre x, z and apparent radius (module docstring)."""
    a = simulation.artifact
    d0, d90, d180 = simulation.probe.pretravel([0.0, 90.0, 180.0])
    side = (d0 + d180) / 2.0
    return a.center_x_mm + (d180 - d0) / 2.0, a.center_z_mm + side - d90, math.sqrt(R**2 - a.y_offset_mm**2) - side
