"""ballbar-inverse: the ballbar trace inverted about the nominal, on every feed arc."""

from __future__ import annotations

from postproc.compensator import Measurements
from postproc.diagnostics import Location, MeasurementError
from postproc.hookspecs import hookimpl
from postproc.measure.readers.ballbar import pair
from postproc.corrections.trace_inversion import TraceInversion
from postproc.measure.traces import trace_from_model, trace_model


class BallbarInverse(TraceInversion):
    """Invert a ballbar trace about the nominal on every feed arc (docs/methods.md §4, §6).

    What it corrects: the radial error the ballbar saw, at each angle, on arcs cut with
    the same motion: every G02/G03 feed arc takes ``-e(theta)`` along its radius, theta
    measured about the arc's own centre (eq. 6.1). Lines are left alone.

    What it needs (the minimum evidence): ``--ballbar`` with one trace, or a CCW and a CW trace
    of one test (G03 arcs then take the CCW trace, G02 arcs the CW one; with one trace, arcs of
    the other direction take it with a warning), each of at least 36 samples over at least
    90 deg of arc. A partial arc (a lathe's 220 deg test, ISO 13041-6) serves the arcs it
    covers: the trace must cover each arc's span without a gap wider than ``max-gap`` degrees,
    and an arc that leaves the captured arc is refused naming its line (a trace is never
    extrapolated round the circle). A CCW and a CW trace are centred with one set-up centre
    fitted jointly with the machine model (a separate circle fit is biased on a partial arc);
    if their backlash reads negative on both axes (swapped labels) the run is refused unless
    ``--force``.

    Options:

    - ``radius-mapping=absolute|relative|center-offset`` (docs/methods.md §6): ``absolute`` applies
      the error of the same angle (eq. 6.3), ``relative`` scales it by the arc's radius over
      the trace's (eq. 6.4), ``center-offset`` keeps only a translation: the trace over the
      arc's span is fitted as a circle of the nominal radius, and the arc's centre moves by
      minus its shift. Required when an arc's radius differs from the trace's by over 5 %.
    - ``max-gap=DEG`` (default 5).

    Example: a trace that reads +5 um all round the 57.15 mm hemishell arc::

        G03 X114.3 Z0. I0. K-57.15   becomes   G03 X114.29 Z0. I0. K-57.145
    """

    name = "ballbar-inverse"

    def fit(self, measurements: Measurements) -> None:
        from postproc.measure.ballbar_analysis import jointly_centred, screen_spikes  # not for a saved model's run

        traces = measurements.ballbar
        if len(traces) > 2:
            raise MeasurementError(f"{self.name} takes one trace or a CCW and a CW trace; {len(traces)} given",
                                   Location(traces[2].path))
        if len(traces) == 2:
            ccw, cw = pair(traces)
            result = None
            if not (ccw.centered or cw.centered):
                (ccw, cw), result = jointly_centred([ccw, cw])
                self._check_labels(result)
            screen_spikes([ccw, cw], self.context.reporter, self.context.force, self.name, result)
            self.traces = {"ccw": ccw, "cw": cw}
        else:
            screen_spikes(traces, self.context.reporter, self.context.force, self.name)
            self.traces = {traces[0].direction: traces[0]}

    def _check_labels(self, result) -> None:
        """Swapped ccw/cw labels would put each trace on the other direction's arcs: refused unless forced."""
        from postproc.measure.ballbar_analysis import backlash_signs  # not for a saved model's run

        if "backlash_x" not in result.names or "backlash_z" not in result.names:
            return
        problem, caution = backlash_signs(result.estimate("backlash_x"), result.estimate("backlash_z"))
        where = Location(result.samples.traces[0].path)
        if problem and not self.context.force:
            raise MeasurementError(f"{self.name}: {problem}; --force uses the traces as they are", where)
        for text in (problem, caution):
            if text:
                self.context.reporter.warn(f"{self.name}: {text}", where)

    def model(self) -> dict:
        return {"traces": {direction: trace_model(trace) for direction, trace in self.traces.items()}}

    def load(self, model: dict) -> None:
        self.traces = {direction: trace_from_model(data, direction) for direction, data in model["traces"].items()}

    def report(self) -> dict:
        return {direction: {"file": trace.path, "radius_mm": trace.radius, "setup_centre_mm": list(trace.setup_centre)}
                for direction, trace in self.traces.items()}


@hookimpl
def postproc_compensators():
    return [BallbarInverse]
