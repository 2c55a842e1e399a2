"""Ballbar traces as model data: what a saved compensation model keeps of a trace."""

from __future__ import annotations

import math

import numpy as np

from ..diagnostics import ModelError
from .readers.ballbar import BallbarTrace

MAX_DEVIATION_MM = 1.0  #: as the trace reader's default: beyond it, not a ballbar reading


def trace_model(trace: BallbarTrace) -> dict:
    return {
        "file": trace.path,
        "radius_mm": trace.radius,
        "direction": trace.direction,
        "centre_mm": list(trace.centre),
        "setup_centre_mm": list(trace.setup_centre),
        "angles_deg": [float(a) for a in trace.angles],
        "deviations_mm": [float(d) for d in trace.deviations],
    }


def trace_from_model(data: dict, direction: str | None = None) -> BallbarTrace:
    """A trace saved in a model, held to what the trace reader holds a file to: a direction of
    ccw or cw, a positive radius, finite centres, at least three samples of plausible
    deviations at increasing angles within one turn. Anything else is a ModelError naming it."""
    if not isinstance(data, dict):
        raise ModelError("a saved trace must be an object")
    direction = direction or data.get("direction")
    if direction not in ("ccw", "cw"):
        raise ModelError(f"a saved trace's direction {direction!r}: expected ccw or cw")
    radius = float(data["radius_mm"])
    if not (math.isfinite(radius) and radius > 0):
        raise ModelError(f"a saved {direction} trace's radius_mm {radius!r}: must be positive")
    centre = _pair(data["centre_mm"], "centre_mm", direction)
    setup = _pair(data["setup_centre_mm"], "setup_centre_mm", direction)
    angles = np.array(data["angles_deg"], dtype=float)
    deviations = np.array(data["deviations_mm"], dtype=float)
    if angles.ndim != 1 or angles.shape != deviations.shape or angles.size < 3:
        raise ModelError(f"a saved {direction} trace needs at least 3 angles and as many deviations")
    if not (np.isfinite(angles).all() and np.isfinite(deviations).all()):
        raise ModelError(f"a saved {direction} trace holds values that are not finite")
    if angles[0] < 0.0 or angles[-1] >= 360.0 or np.any(np.diff(angles) <= 0.0):
        raise ModelError(f"a saved {direction} trace's angles must increase within 0 .. 360 deg")
    if np.abs(deviations).max() > MAX_DEVIATION_MM:
        raise ModelError(f"a saved {direction} trace's deviation of {np.abs(deviations).max():g} mm is beyond "
                         f"{MAX_DEVIATION_MM:g} mm: not a plausible ballbar reading")
    return BallbarTrace(path=str(data["file"]), radius=radius, direction=direction, centre=centre, angles=angles,
                        deviations=deviations, setup_centre=setup)


def _pair(value, name: str, direction: str) -> tuple[float, float]:
    pair = tuple(float(v) for v in value)
    if len(pair) != 2 or not all(math.isfinite(v) for v in pair):
        raise ModelError(f"a saved {direction} trace's {name} must be two finite numbers")
    return pair
