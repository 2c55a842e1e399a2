"""The machine error model: where the tool really is for a commanded position.

docs/methods.md §8, extended. With u = x - x_ref, w = z - z_ref (the machine's reference):

    e_x = a_x u + d_x sin(2 pi w / p) + s w + h_z bow_z(z) + sum of the x terms
    e_z = a_z w + d_z sin(2 pi w / p)       + h_x bow_x(x) + sum of the z terms

a: scaling, d: pitch-periodic term (p the ballscrew pitch; both axes as functions of z, as
docs/methods.md §8 gives), s: squareness (the X error per unit Z), h bow: a slide's straightness, a
parabola over its span, 1 at the middle and 0 at the ends (the Z slide bows X, the X slide
bows Z), and the general terms of ``[[simulation.term]]``, each a polynomial in (u, w)
(:class:`.config.Term`). These are functions of the commanded position.

On top of them, in the order the drive chain applies them:

1. servo lag: each axis's motor is where its command was ``lag_s`` earlier,
   ``x_motor(t) = x_cmd(t - tau_x)``; a mismatch of the two lags distorts the path by an
   amount that grows with the feed and flips with the direction of motion;
2. lost motion (backlash b): the slide follows its motor with play b, so it lags by b/2 in
   the direction of travel and stands still after a reversal until the motor has moved b
   (the play operator). An axis that has not moved yet last moved towards it from the home
   position, or in + when no home is set.

Actual position = lost_motion(servo(command)) + e(command). A probe at rest reads its own
encoder, which sees the servo lag, so for touches only lost motion and e apply: errors common
to cutting and probing cancel, as on the real machine.
"""

from __future__ import annotations

import math

import numpy as np

from .config import Axis, Simulation
from .path import Commanded


def play(command: np.ndarray, backlash: float, last: float = 1.0) -> np.ndarray:
    """The slide positions for a sequence of motor positions through play of ``backlash``.

    ``last`` (+1 or -1) is the direction the axis travelled before the first position. Exact
    at the samples when the motion between neighbouring samples is monotonic.
    """
    command = np.asarray(command, dtype=float)
    half = backlash / 2.0
    if half == 0.0 or command.size == 0:
        return command.copy()
    slide = np.empty_like(command)
    slide[0] = command[0] - last * half
    if command.size == 1:
        return slide
    step = np.sign(np.diff(command))
    # a pause keeps the direction of the motion before it
    latest = np.where(step != 0, np.arange(step.size), -1)
    np.maximum.accumulate(latest, out=latest)
    direction = np.where(latest >= 0, step[np.maximum(latest, 0)], 0.0)
    starts = np.concatenate([[0], np.flatnonzero(np.diff(direction)) + 1])
    ends = np.concatenate([starts[1:], [step.size]])
    state = slide[0]
    for first, stop in zip(starts, ends):
        run = command[first + 1: stop + 1]
        if direction[first] > 0:
            values = np.maximum(state, np.maximum.accumulate(run) - half)
        elif direction[first] < 0:
            values = np.minimum(state, np.minimum.accumulate(run) + half)
        else:
            values = np.full(run.size, state)
        slide[first + 1: stop + 1] = values
        state = values[-1]
    return slide


def bow(axis: Axis, position: np.ndarray) -> np.ndarray:
    """A slide's straightness error over its span: ``h`` at the middle, 0 at both ends."""
    if axis.straightness_mm == 0.0:
        return np.zeros_like(position)
    low, high = axis.straightness_span_mm
    u = (2.0 * position - low - high) / (high - low)
    return axis.straightness_mm * (1.0 - u * u)


class Machine:
    """The virtual lathe's axes: commanded positions in, actual positions out."""

    def __init__(self, simulation: Simulation):
        self.simulation = simulation

    def geometric(self, x, z) -> np.ndarray:
        """(e_x, e_z) rows of the position-dependent errors at commanded positions."""
        sim = self.simulation
        x = np.asarray(x, dtype=float)
        z = np.asarray(z, dtype=float)
        u = x - sim.reference_x_mm
        w = z - sim.reference_z_mm
        pitch = np.sin(2.0 * math.pi * w / sim.pitch_mm)
        ex = sim.x.scaling * u + sim.x.pitch_amplitude_mm * pitch + sim.squareness_rad * w + bow(sim.z, z)
        ez = sim.z.scaling * w + sim.z.pitch_amplitude_mm * pitch + bow(sim.x, x)
        for term in sim.term:
            if term.axis == "x":
                ex = ex + term.at(u, w)
            else:
                ez = ez + term.at(u, w)
        return np.column_stack([ex, ez])

    def _last(self, axis: int, first: float) -> float:
        """The direction an axis travelled before ``first``: from home, else +."""
        home = self.simulation.home[axis]
        if home is None or home == first:
            return 1.0
        return 1.0 if first > home else -1.0

    def lost_motion(self, x, z) -> np.ndarray:
        """Slide positions for a time-ordered sequence of motor positions, as (n, 2) rows."""
        x = np.asarray(x, dtype=float)
        z = np.asarray(z, dtype=float)
        if x.size == 0:
            return np.zeros((0, 2))
        return np.column_stack([
            play(x, self.simulation.x.backlash_mm, self._last(0, float(x[0]))),
            play(z, self.simulation.z.backlash_mm, self._last(1, float(z[0]))),
        ])

    def servo(self, commanded: Commanded) -> np.ndarray:
        """Motor positions: each axis where its command was ``lag_s`` earlier (still before the start)."""
        motors = commanded.points.copy()
        for column, axis in enumerate((self.simulation.x, self.simulation.z)):
            if axis.lag_s:
                motors[:, column] = commanded.timeline.at(commanded.time - axis.lag_s)[:, column]
        return motors

    def tool_path(self, commanded: Commanded) -> np.ndarray:
        """Actual positions at the samples of a commanded path."""
        motors = self.servo(commanded)
        return self.lost_motion(motors[:, 0], motors[:, 1]) + self.geometric(commanded.points[:, 0], commanded.points[:, 1])

    def at_rest(self, x, z) -> np.ndarray:
        """Actual positions of a sequence of positions each reached and held (probe touches)."""
        return self.lost_motion(x, z) + self.geometric(x, z)
