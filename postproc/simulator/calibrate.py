"""Calibrating the probe on the sphere artifact (docs/methods.md §9.2; the dissertation's chapter 4).

Touches every ``step_deg`` over the top 180 deg of the ball, from its equator on -X over the
pole to its equator on +X (outward-normal theta 180 down to 0), each approaching the centre.
The probe sees the ball's section in the cutting plane, a circle of radius
``sqrt(R^2 - y_offset^2)``; the file states the radius and centre as given, so an off-plane
ball shows up in k as it did on the real machine. The machine's errors at the artifact are
in the readings too, as they are in a real calibration. The calibration is taken at the
thermal state a probing session starts from: no drift.

:func:`artifact_round` takes one round of finding the ball (:mod:`postproc.measure.artifact`): the
pole touch and the two side touches at an estimated centre, on the same ball.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..diagnostics import Location, OptionError
from .config import Artifact, Simulation
from .surface import Circle
from .touch import Touch, run


@dataclass(frozen=True)
class CalibrationRun:
    stylus_radius: float
    artifact: Artifact
    centres: np.ndarray  #: (n, 2) reported stylus centres
    approach: np.ndarray  #: (n, 2) unit directions into the ball


def _section(simulation: Simulation, artifact: Artifact) -> Circle:
    if abs(artifact.y_offset_mm) >= artifact.radius_mm:
        raise OptionError("the artifact's y offset must be smaller than its radius", Location(simulation.origin))
    return Circle((artifact.center_x_mm, artifact.center_z_mm), math.sqrt(artifact.radius_mm**2 - artifact.y_offset_mm**2))


def artifact_round(simulation: Simulation, rng: np.random.Generator | None, estimate: tuple[float, float],
                   artifact: Artifact | None = None, standoff: float | None = None) -> np.ndarray:
    """One round at ``estimate`` (x, z): the reported stylus centres of the pole, +X and -X touches.

    :param standoff: mm, where each approach starts outside the estimated ball (default the
        probe's ``standoff_mm``): a first estimate by eye needs a few millimetres."""
    artifact = artifact or simulation.artifact
    if standoff is not None:
        simulation = dataclasses.replace(simulation, probe=dataclasses.replace(simulation.probe, standoff_mm=standoff))
    ball = _section(simulation, artifact)
    cx, cz = estimate
    radius = artifact.radius_mm
    touches = [Touch(ball, np.array([cx, cz + radius]), np.array([0.0, -1.0]), 0.0, "the pole touch"),
               Touch(ball, np.array([cx + radius, cz]), np.array([-1.0, 0.0]), 0.0, "the +X side touch"),
               Touch(ball, np.array([cx - radius, cz]), np.array([1.0, 0.0]), 0.0, "the -X side touch")]
    return run(touches, simulation, rng, simulation.origin)


def calibrate(simulation: Simulation, rng: np.random.Generator | None, artifact: Artifact | None = None) -> CalibrationRun:
    artifact = artifact or simulation.artifact
    ball = _section(simulation, artifact)
    count = int(round(180.0 / artifact.step_deg))
    if not math.isclose(count * artifact.step_deg, 180.0, abs_tol=1e-9):
        raise OptionError(f"a step of {artifact.step_deg:g} deg does not divide 180 deg", Location(simulation.origin))
    theta = np.radians(180.0 - artifact.step_deg * np.arange(count + 1))
    outward = np.column_stack([np.cos(theta), np.sin(theta)])
    centre = (artifact.center_x_mm, artifact.center_z_mm)
    targets = np.array(centre) + artifact.radius_mm * outward
    touches = [Touch(ball, targets[i], -outward[i], 0.0, f"artifact touch {i + 1}") for i in range(count + 1)]
    reported = run(touches, simulation, rng, simulation.origin)
    return CalibrationRun(simulation.probe.stylus_radius_mm, artifact, reported, -outward)
