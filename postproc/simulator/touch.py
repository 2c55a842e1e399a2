"""The touch-trigger probe on the virtual lathe: what the control reports at each trigger.

For each touch the control commands an approach from ``standoff`` outside the nominal
surface along the unit direction n (into the material), and back out the same way. The
actual stylus is where the machine puts it: reported + lost motion + geometric error
(:meth:`.errors.Machine.at_rest`; the encoder sees the servo lag, so it does not count) +
the thermal drift at that moment. The ball first touches the actual surface; the probe
triggers after the stylus has travelled on by the pretravel d(theta) (lobing), and the
control reports the position it believes it is at:

    reported = approach start + (travel to the touch + d) n + noise

so the touched point is ``P = C + (R_stylus - d) n``: the calibration factor is k = -d.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..diagnostics import Collision, Location, MeasurementError
from ..measure.readers.probe import approach_theta
from .config import Simulation
from .errors import Machine
from .surface import Touchable

ITERATIONS = 3  #: the errors depend on where the touch happens; this settles them below 1e-9 mm


@dataclass(frozen=True)
class Touch:
    """One commanded touch: the surface, the nominal point it aims at, the approach, and when."""

    surface: Touchable
    target: np.ndarray  #: the nominal touched point (x, z)
    approach: np.ndarray  #: unit direction into the material
    when: float  #: 0 at the first datum touch, 1 at the last (for the drift)
    name: str  #: for messages: "point 3", "datum before"...


def run(touches: list[Touch], simulation: Simulation, rng: np.random.Generator | None, where: str) -> np.ndarray:
    """The reported stylus centres of a probing session, in order, as (n, 2) rows."""
    probe = simulation.probe
    radius, standoff = probe.stylus_radius_mm, probe.standoff_mm
    targets = np.array([touch.target for touch in touches], dtype=float)
    approach = np.array([touch.approach for touch in touches], dtype=float)
    starts = targets - (radius + standoff) * approach
    pretravel = probe.pretravel(approach_theta(approach))
    drift = np.outer([touch.when for touch in touches], [probe.drift_x_mm, probe.drift_z_mm])
    reported = targets - (radius - pretravel)[:, None] * approach
    machine = Machine(simulation)
    for _ in range(ITERATIONS):
        # each touch: to the approach start, in to the trigger, back out
        sequence = np.stack([starts, reported, starts], axis=1).reshape(-1, 2)
        actual = machine.at_rest(sequence[:, 0], sequence[:, 1])
        error = (actual - sequence)[1::3] + drift
        for i, touch in enumerate(touches):
            travel = _travel(touch, starts[i] + error[i], radius, 2.0 * standoff, where)
            if travel is None:
                raise MeasurementError(
                    f"{touch.name}: the probe met no surface within {standoff:g} mm beyond the nominal",
                    Location(where))
            reported[i] = starts[i] + (travel + pretravel[i]) * approach[i]
    if rng is not None and probe.noise_mm > 0:
        reported = reported + rng.normal(0.0, probe.noise_mm, reported.shape)
    return reported


def _travel(touch: Touch, start: np.ndarray, radius: float, limit: float, where: str) -> float | None:
    try:
        return touch.surface.contact(start, touch.approach, radius, limit)
    except Collision:
        raise MeasurementError(
            f"{touch.name}: the stylus would collide with the surface before its approach (another part of the "
            "profile is in the way, or the surface lies farther out than the standoff); choose the probed stretch "
            "with the line range", Location(where)) from None
