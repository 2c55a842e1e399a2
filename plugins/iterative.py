"""iterative: the residuals of several compensation iterations, summed and inverted."""

from __future__ import annotations

from postproc.compensator import Measurements, Option
from postproc.hookspecs import hookimpl
from postproc.measure.readers.ballbar import BallbarTrace
from postproc.corrections.trace_inversion import Summed, TraceInversion
from postproc.measure.traces import trace_from_model, trace_model


class Iterative(TraceInversion):
    """Invert the sum of the residuals of iterations 1..N (docs/methods.md §5, eq. 6.2).

    What it corrects: what ``ballbar-inverse`` corrects, iteratively. Iteration 1 is the
    original trace; each later trace is measured on the path the previous iteration
    produced. Trajectory N is the nominal inverted by the sum of all residuals measured so
    far, so a residual that a single inversion leaves is taken out at the next cut.

    What it needs: ``--ballbar`` traces in iteration order (first the original trace, then
    the residual of each compensated run), of one direction or of both (each direction is
    summed on its own, in the order given), each of at least 36 samples over at least 90 deg
    of arc; every iteration's trace must cover each arc's span (a partial arc serves the arcs
    it covers; an arc outside it is refused naming its line). If the bar was not re-mounted between
    iterations, mark the later traces ``centered = true`` so the set-up centre of the first
    is not removed again (a later trace's least-squares centre also holds the centre shift
    the compensated path made on purpose).

    Options: ``selective=MM`` adds a residual to the sum only where its magnitude exceeds
    MM, so in-tolerance residuals do not pile up over iterations and push good points out;
    ``radius-mapping`` and ``max-gap`` as for ``ballbar-inverse``.

    Example: traces reading +5 um, then -1 um, then +0.5 um on the hemishell arc sum to
    +4.5 um::

        G03 X114.3 Z0. I0. K-57.15   becomes   G03 X114.291 Z0. I0. K-57.1455
    """

    name = "iterative"
    options = TraceInversion.options + (
        Option("selective", float, None, "add a residual only where it exceeds this many mm", positive=True,
               largest_mm=0.1),
    )

    def fit(self, measurements: Measurements) -> None:
        from postproc.measure.ballbar_analysis import one_test, screen_spikes  # not for a saved model's run

        by_direction: dict[str, list[BallbarTrace]] = {}
        for trace in measurements.ballbar:
            by_direction.setdefault(trace.direction, []).append(trace)
        one_test(list(measurements.ballbar), self.name)
        for trace in measurements.ballbar:
            screen_spikes([trace], self.context.reporter, self.context.force, self.name)
        self._sequences = by_direction
        threshold = self.settings["selective"]
        self.traces = {direction: Summed(traces, threshold) for direction, traces in by_direction.items()}

    def model(self) -> dict:
        return {"selective": self.settings["selective"],
                "iterations": {d: [trace_model(t) for t in traces] for d, traces in self._sequences.items()}}

    def load(self, model: dict) -> None:
        self._sequences = {d: [trace_from_model(t, d) for t in traces] for d, traces in model["iterations"].items()}
        self.settings["selective"] = model.get("selective")
        self.traces = {d: Summed(traces, self.settings["selective"]) for d, traces in self._sequences.items()}

    def report(self) -> dict:
        return {d: {"iterations": [t.path for t in traces]} for d, traces in self._sequences.items()}


@hookimpl
def postproc_compensators():
    return [Iterative]

