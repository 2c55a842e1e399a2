"""Finding the calibration sphere: its centre and apparent radius from pole and side touches
(docs/methods.md §9.2.1; the dissertation's chapter 4, Figures 4.18-4.24).

A calibration (:mod:`postproc.measure.pretravel`) needs the artifact's centre and the radius of the
circle the probe sees: the ball's section in the cutting plane, ``sqrt(R^2 - y^2)`` when its
centre lies ``y`` off the plane (an indicator finds the high point to a few tenths of a
millimetre; 0.36 mm costs 2.5 um of radius on a 25.4 mm ball). Neither is known to a micrometre
before probing, and a wrong one goes straight into k at every direction.

A round is three touches at the current estimate (cx, cz) of the centre: one straight down at
x = cx (the pole), one from +X and one from -X at z = cz (the equators). The three stylus
centres lie on one circle (the section grown by the stylus radius and the pretravel); its centre
is the round's finding, its radius less the stylus radius the apparent radius. The source took
the pole's z less the radius, then each side's x less the radius, and the midpoint of the two
sides' centres, iterating because each reading depends on where the other was taken; the
circle through the three points is that iteration's fixed point in one step when the pretravel
is the same at the three touches. It is not quite (lobing): the finding then depends on where
the touches land, so the rounds are repeated at each finding until the touches were taken
within ``tolerance`` of the pole and equators of the circle they give. Converged, the finding
is defined by the pretravel at exactly 90, 0 and 180 deg, whatever the first estimate.

What a probe in the cutting plane cannot tell apart: a ball off the plane and a pretravel the
same at both sides (each makes the section look smaller), or the centre's z and the pretravel at
the pole. The found centre and apparent radius are the probe's: k is then zero at the pole and
on average zero at the sides, and the calibration carries the lobing relative to them, the
constant part being the probe's tool offset's (set on a reference, as any tool's).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..diagnostics import Location, MeasurementError
from ..geometry.fitting import circumcircle
from .readers.probe import Touches

TOLERANCE = 0.003  #: mm: the rounds stop when taken this close to their finding (the source machine's repeatability)
MAX_OFF_PLANE = 2.0  #: mm: a ball farther off the cutting plane than this is to be realigned, not probed
LARGER = 0.005  #: mm: a section larger than the ball by more than this is no touch on it
SIDE_HEIGHT = 0.005  #: mm: the two side touches are taken at one commanded z (this allows for the readings' noise)
DIRECTION = 0.01  #: how far (as a unit vector's components) an approach may be off its axis

POLE, PLUS_X, MINUS_X = "pole", "+X side", "-X side"
APPROACHES = {POLE: (0.0, -1.0), PLUS_X: (-1.0, 0.0), MINUS_X: (1.0, 0.0)}  #: into the ball


@dataclass(frozen=True, slots=True)
class Round:
    """One round's three reported stylus centres, and the circle through them."""

    pole: tuple[float, float]
    plus: tuple[float, float]  #: the touch from +X
    minus: tuple[float, float]  #: the touch from -X
    centre: tuple[float, float]  #: the circle through the three
    radius: float  #: the circle's: apparent radius + stylus radius

    @property
    def estimate(self) -> tuple[float, float]:
        """Where the round was taken: the pole touch's x, the side touches' z."""
        return (self.pole[0], (self.plus[1] + self.minus[1]) / 2.0)

    @property
    def moved(self) -> float:
        """How far the finding lies from where the round was taken, mm."""
        return math.hypot(self.centre[0] - self.estimate[0], self.centre[1] - self.estimate[1])


@dataclass(frozen=True, slots=True)
class Finding:
    """The artifact as the probe sees it: what a calibration file states."""

    centre: tuple[float, float]
    apparent_radius: float
    artifact_radius: float
    stylus_radius: float
    rounds: tuple[Round, ...]
    tolerance: float

    @property
    def off_plane(self) -> float:
        """How far off the cutting plane the ball's centre would lie were the sides' pretravel nil, mm."""
        return math.sqrt(max(self.artifact_radius**2 - self.apparent_radius**2, 0.0))

    def describe(self) -> str:
        return (f"artifact centre x {self.centre[0]:.4f} z {self.centre[1]:.4f} mm, apparent radius "
                f"{self.apparent_radius:.4f} mm ({1000.0 * (self.apparent_radius - self.artifact_radius):+.1f} um "
                f"against {self.artifact_radius:g} mm: {self.off_plane:.2f} mm off the cutting plane, or the sides' "
                f"pretravel) after {len(self.rounds)} round{'' if len(self.rounds) == 1 else 's'}")


def round_of(pole, plus, minus, stylus_radius: float, artifact_radius: float,
             where: Location | None = None) -> Round:
    """The circle through one round's touches, checked for being touches on the ball.

    :raises MeasurementError: the sides not at one height, the pole not above them and between
        them, or a circle the ball cannot make (larger than the ball, or so much smaller that the
        ball lies more than MAX_OFF_PLANE off the cutting plane).
    """
    pole, plus, minus = (tuple(float(v) for v in p) for p in (pole, plus, minus))
    if abs(plus[1] - minus[1]) > SIDE_HEIGHT:
        raise MeasurementError(f"the side touches were taken at z {plus[1]:.4f} and {minus[1]:.4f} mm: a round takes "
                               "both at the estimated centre's z (use the program 'postproc artifact-program' writes)",
                               where)
    if not (minus[0] < pole[0] < plus[0] and pole[1] > plus[1]):
        raise MeasurementError(f"the pole touch (x {pole[0]:.4f} z {pole[1]:.4f}) does not lie above and between the "
                               f"side touches (x {minus[0]:.4f} and {plus[0]:.4f} at z {plus[1]:.4f}): not three touches "
                               "on one ball; check the estimate the round was taken at", where)
    x, z, radius = circumcircle([pole, plus, minus])
    centre = (x, z)
    apparent = radius - stylus_radius
    smallest = math.sqrt(artifact_radius**2 - min(MAX_OFF_PLANE, artifact_radius) ** 2)
    if apparent > artifact_radius + LARGER or apparent < smallest:
        raise MeasurementError(
            f"the touches lie on a circle of radius {apparent:.4f} mm (less the stylus radius {stylus_radius:g}), "
            f"not a section of a ball of radius {artifact_radius:g} mm within {MAX_OFF_PLANE:g} mm of the cutting "
            "plane: check the artifact radius and the stylus radius, or realign the ball with an indicator", where)
    return Round(pole, plus, minus, centre, radius)


def round_from_touches(touches: Touches, artifact_radius: float) -> Round:
    """A probe file's three touches as a round, each told by its approach (any order).

    :raises MeasurementError: not exactly one touch straight down and one along each of -X and +X.
    """
    found: dict[str, int] = {}
    for name, direction in APPROACHES.items():
        close = np.flatnonzero(np.all(np.abs(touches.approach - np.array(direction)) <= DIRECTION, axis=1))
        if len(close) != 1:
            raise MeasurementError(
                f"a round of finding the artifact is three touches, one straight down on the pole (approach 0, -1), "
                f"one from +X (-1, 0) and one from -X (1, 0); this file has {len(close)} for the {name} "
                f"and {len(touches.centres)} in all", Location(touches.path))
        found[name] = int(close[0])
    if len(touches.centres) != 3:
        extra = sorted(set(range(len(touches.centres))) - set(found.values()))[0]
        raise MeasurementError("a round of finding the artifact is three touches: this one is not the pole or a side",
                               touches.where(extra))
    pole, plus, minus = (touches.centres[found[name]] for name in (POLE, PLUS_X, MINUS_X))
    return round_of(pole, plus, minus, touches.stylus_radius, artifact_radius, Location(touches.path))


def finding(rounds: list[Round], stylus_radius: float, artifact_radius: float,
            tolerance: float = TOLERANCE) -> Finding | None:
    """The artifact from its rounds, in the order taken; None while the last has not converged
    (its finding lies more than ``tolerance`` from where it was taken)."""
    if not rounds:
        raise ValueError("no rounds")
    last = rounds[-1]
    if last.moved > tolerance:
        return None
    return Finding(last.centre, last.radius - stylus_radius, artifact_radius, stylus_radius, tuple(rounds), tolerance)


def find(touch, estimate: tuple[float, float], stylus_radius: float, artifact_radius: float,
         tolerance: float = TOLERANCE, rounds: int = 6, where: Location | None = None) -> Finding:
    """Iterate rounds until converged: ``touch(estimate)`` takes one round at an estimate and
    returns its (pole, +X side, -X side) stylus centres (the machine, or the virtual lathe).

    :raises MeasurementError: not converged within ``rounds``, or touches no ball can give.
    """
    taken: list[Round] = []
    for _ in range(rounds):
        taken.append(round_of(*touch(estimate), stylus_radius, artifact_radius, where))
        found = finding(taken, stylus_radius, artifact_radius, tolerance)
        if found is not None:
            return found
        estimate = taken[-1].centre
    moves = ", ".join(f"{1000.0 * r.moved:.1f}" for r in taken)
    raise MeasurementError(f"finding the artifact did not converge in {rounds} rounds: the centre moved by {moves} um "
                           f"(tolerance {1000.0 * tolerance:g} um); the ball or the probe is loose, or the probe's "
                           "repeatability is worse than the tolerance", where)
