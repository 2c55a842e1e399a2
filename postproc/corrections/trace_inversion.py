"""Ballbar traces inverted about the nominal on feed arcs: a public helper for compensator
plugins (``ballbar-inverse`` and ``iterative`` are built on it).

- :class:`TraceInversion`: a :class:`~postproc.compensate.compensator.Compensator` that corrects every
  G02/G03 feed arc by minus the error its trace reads at each angle about the arc's own centre
  (eq. 6.1), with the ``radius-mapping`` and ``max-gap`` options; its subclass fits
  ``self.traces`` (a trace, or anything read like one, by direction ``"ccw"``/``"cw"``) and
  saves and loads them;
- :class:`Summed`: the residuals of several iterations of one direction, summed (eq. 6.2)
  and read like one trace.

It imports the contract and the measurement types only, never the engine, so a shop's
plugin may build on it.
"""

from __future__ import annotations

import math

import numpy as np

from ..compensate.compensator import Compensator, Option, Piece
from ..diagnostics import Location, OptionError
from ..geometry.fitting import fit_centre
from ..geometry import Arc
from ..measure.readers.ballbar import BallbarTrace

__all__ = ["MAPPINGS", "Summed", "TraceInversion"]

MAPPINGS = ("absolute", "relative", "center-offset")  #: how a trace applies to an arc of another radius


class TraceInversion(Compensator):
    """A compensator that inverts ballbar traces about the nominal on every feed arc (lines are
    left alone); ``self.traces`` maps a direction (``"ccw"``, ``"cw"``) to its trace. An arc of
    a direction with no trace takes the other's, with one warning."""

    takes = ("ballbar",)
    needs = ("ballbar",)
    options = (
        Option("radius-mapping", str, None, "how a trace applies to an arc of another radius", MAPPINGS),
        Option("max-gap", float, 5.0, "largest gap in the trace over an arc's span, degrees", positive=True),
    )

    traces: dict[str, BallbarTrace | Summed]
    _warned = False  #: whether this program was told that one trace serves both directions

    def start(self) -> None:
        """A new program is told, once, if one trace serves both directions."""
        self._warned = False

    def _trace(self, cw: bool) -> BallbarTrace:
        direction = "cw" if cw else "ccw"
        trace = self.traces.get(direction)
        if trace is None:
            trace = next(iter(self.traces.values()))
            if not self._warned:
                self._warned = True
                self.context.reporter.warn(
                    f"{self.name}: {'G02' if cw else 'G03'} arcs take the {trace.direction} trace: no {direction} trace given",
                    Location(trace.path))
        return trace

    def correct(self, piece: Piece) -> np.ndarray | None:
        arc = piece.segment
        if not isinstance(arc, Arc):
            return None
        trace = self._trace(arc.cw)
        points = piece.points
        radial = (points - np.array(arc.centre)) / arc.r
        theta = np.degrees(np.arctan2(radial[:, 1], radial[:, 0]))
        start, end = sorted((math.degrees(arc.theta0), math.degrees(arc.theta1)))
        trace.require(start % 360.0, end % 360.0, self.settings["max-gap"], f"{self.name} on the arc of line {piece.move.line}")
        mapping = self.settings["radius-mapping"]
        if mapping is None:
            if abs(arc.r - trace.radius) > 0.05 * trace.radius:
                raise OptionError(
                    f"{self.name}: the arc of line {piece.move.line} has radius {arc.r:.3f} mm, the trace "
                    f"{trace.radius:.3f} mm; give --option radius-mapping=absolute|relative|center-offset")
            mapping = "absolute"
        if mapping == "center-offset":
            shift = self._centre_shift(trace, start, end)
            return np.broadcast_to(-np.array(shift), points.shape).copy()
        error = trace.at(theta, None)  # required above: the samples cover the arc's span
        if mapping == "relative":
            error = error * arc.r / trace.radius
        return -error[:, None] * radial

    @staticmethod
    def _centre_shift(trace: BallbarTrace, start: float, end: float) -> tuple[float, float]:
        """The shift of a circle of the trace's radius fitted to the trace over [start, end]."""
        inside = ((trace.angles - start) % 360.0) <= ((end - start) % 360.0 or 360.0)
        points = trace.points()[inside] - np.array(trace.centre)
        fit = fit_centre(points, trace.radius, start=(0.0, 0.0))
        return fit.xc, fit.zc


class Summed:
    """The summed residual of a direction's iterations, read like one trace."""

    def __init__(self, traces: list[BallbarTrace], threshold: float | None):
        self.traces = traces
        self.threshold = threshold
        first = traces[0]
        self.path, self.radius, self.direction, self.centre = first.path, first.radius, first.direction, first.centre

    def at(self, theta_deg, max_gap: float | None = None) -> np.ndarray:
        """e_sum(theta) = sum of e_i(theta) (eq. 6.2); selective: only where |e_i| > threshold."""
        total = np.zeros(np.shape(theta_deg))
        for trace in self.traces:
            error = trace.at(theta_deg, max_gap)
            if self.threshold is not None:
                error = np.where(np.abs(error) > self.threshold, error, 0.0)
            total = total + error
        return total

    def require(self, start: float, end: float, max_gap: float, use: str) -> None:
        for trace in self.traces:
            trace.require(start, end, max_gap, use)

    def points(self) -> np.ndarray:
        theta = np.radians(self.traces[0].angles)
        r = self.radius + self.at(self.traces[0].angles, None)
        return np.column_stack([self.centre[0] + r * np.cos(theta), self.centre[1] + r * np.sin(theta)])

    @property
    def angles(self) -> np.ndarray:
        return self.traces[0].angles
