"""Ballbar traces as model data: what a saved compensation model keeps of a trace."""

from __future__ import annotations

import numpy as np

from .measurements.ballbar import BallbarTrace


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
    return BallbarTrace(
        path=data["file"],
        radius=float(data["radius_mm"]),
        direction=direction or data["direction"],
        centre=tuple(float(v) for v in data["centre_mm"]),
        angles=np.array(data["angles_deg"], dtype=float),
        deviations=np.array(data["deviations_mm"], dtype=float),
        setup_centre=tuple(float(v) for v in data["setup_centre_mm"]),
    )
