"""Everything a report draws on, gathered once: what was asked, read, fitted, compensated and predicted.

:func:`gather` runs the steps in order:

1. the compensators, fitted (or the saved model loaded) exactly as ``compensate`` does, so
   their errors and warnings are the same; measurements given with a saved model are the
   report's alone (the model is not fitted again);
2. the measurements, read again for the report (quietly when the compensators have read them
   and warned already), the probe calibration fitted; with a saved model and no ballbar
   trace, the traces the model carries (``ballbar-inverse`` and ``iterative`` keep theirs),
   or why there are none;
3. the ballbar traces' ISO 230-4 figures and parametric diagnosis (one trace, or the ccw and
   cw traces of one test: of several, the first of each direction);
4. the program: its profile, the probe points against it, the compensated program exactly
   as ``compensate`` writes it (a compensation refused for safety or by a compensator is kept
   as the reason, not raised), and the prediction on the virtual lathe (:mod:`.prediction`).

A program or measurement that cannot be read raises, with the command line's message and
exit code.
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..measure.ballbar_analysis import CircularTest, Diagnosis, centred, circular_test, diagnose, plausibility
from ..diagnostics import EXIT_BAD_INPUT, EXIT_REFUSED, MeasurementError, PostprocError, Reporter, SafetyError
from ..measure.figures import Figures, figures
from ..measure.readers.ballbar import BallbarTrace, pair
from ..measure.readers.probe import CalibrationRun, ProbeFile
from ..measure.readers.registry import ReadContext, read as read_measurement
from ..files.output import KEEP, Spool
from ..compensate.request import Request
from ..measure.probing import ProbedProfile, probe_profile
from ..machine.profile import MachineProfile
from ..syntax.source import Source
from . import prediction, provenance

if TYPE_CHECKING:
    from ..api import Pipeline, Summary
    from ..measure.pretravel import CalibrationModel

KINDS = (("ballbar", "ballbar trace"), ("probe", "probe points"), ("calibration", "probe calibration"))


@dataclass
class Inputs:
    """What the user asked for: ``postproc report``'s arguments."""

    program: tuple[str, bytes] | None  #: name and content
    request: Request
    machine: str | None  #: the machine profile's file
    profile: MachineProfile
    command: str  #: the command line, for the provenance
    band: float | None = None  #: mm: ``--band``, the deviation the part may have either side of the nominal


@dataclass
class Probed:
    """A probe file, and against the program's profile when there is one."""

    probe: ProbeFile
    profile: ProbedProfile | None
    notes: list[str] = field(default_factory=list)


@dataclass
class Run:
    """Everything the sections draw on."""

    inputs: Inputs
    reporter: Reporter
    pipeline: Pipeline | None = None  #: when a compensator or a model was given
    traces: list[BallbarTrace] = field(default_factory=list)
    probes: list[Probed] = field(default_factory=list)
    calibrations: list[CalibrationRun] = field(default_factory=list)
    calibration: CalibrationModel | None = None
    program: prediction.Program | None = None
    compensated: prediction.Program | None = None
    summary: Summary | None = None  #: of the compensation
    refused: str | None = None  #: why the program could not be compensated
    test: CircularTest | None = None  #: ISO 230-4 figures
    test_traces: tuple[BallbarTrace, ...] = ()  #: the traces of the test, centred as the diagnosis found
    diagnosis: Diagnosis | None = None
    undiagnosed: str | None = None  #: why there is no diagnosis
    machine: prediction.Machine | None = None  #: the diagnosis as a virtual lathe
    prediction: prediction.Prediction | None = None  #: along the program's profile
    when: dt.datetime = field(default_factory=provenance.moment)  #: the report's time
    figures: list[tuple[str, Figures]] = field(default_factory=list)  #: (what, the four figures)
    notes: list[str] = field(default_factory=list)  #: for the warnings section
    model_traces: str | None = None  #: with a saved model: where its traces came from, or why there are none
    model_measured: str | None = None  #: when the traces a saved model carries were measured

    def figure(self, label: str, deviations_mm) -> Figures | None:
        """The four figures of deviations (NaN left out), kept for the report's table."""
        values = np.asarray(deviations_mm, dtype=float)
        values = values[np.isfinite(values)]
        if values.size == 0:
            return None
        result = figures(values)
        self.figures.append((label, result))
        return result

    def probe_prediction(self, probed: Probed) -> tuple[np.ndarray, np.ndarray | None, float]:
        """The probed error the next pass repeats (screened, minus the stock of the probed pass),
        what the emitted correction makes of it, and the stock."""
        stock = self.stock()
        before = probed.profile.cleaned - stock
        result = self.prediction
        if result is None or result.correction is None:
            return before, None, stock
        deviations = probed.profile.deviations
        moved = prediction.read_surface(prediction.surface(self.compensated), deviations.nearest.foot,
                                        deviations.outward)
        # a touch on the spindle axis has no crossing when the path crosses the axis: use the stations' curve
        missing, known = ~np.isfinite(moved), np.isfinite(result.correction)
        if missing.any() and known.any():
            moved[missing] = np.interp(deviations.nearest.s[missing], result.stations.s[known],
                                       result.correction[known])
        return before, before + moved, stock

    def stock(self) -> float:
        """docs/formats.md §9.6: ``--option stock=MM``, how far outside this profile the probed pass was cut."""
        if self.pipeline is None:
            return 0.0
        for settings in self.pipeline.core.settings.values():
            if isinstance(settings.get("stock"), (int, float)):
                return float(settings["stock"])
        return 0.0


def gather(inputs: Inputs, reporter: Reporter) -> Run:
    """Fit, read, analyse, compensate and predict."""
    run = Run(inputs, reporter)
    _fit(run)
    _read(run)
    _analyse(run)
    _program(run)
    _predict(run)
    return run


def _fit(run: Run) -> None:
    request = run.inputs.request
    if request.plugins or request.model:
        from ..api import Pipeline

        saved = bool(request.model)  # a saved model carries its own measurements: these are the report's
        run.pipeline = Pipeline(request.plugins, [] if saved else request.ballbar, [] if saved else request.probe,
                                None if saved else request.calibration, request.model, request.options,
                                request.tolerance, "auto", run.inputs.profile, reporter=run.reporter)


def _read(run: Run) -> None:
    """The measurements, read again for the report (quietly when the pipeline already warned)."""
    from ..compensate.registry import readers

    request = run.inputs.request
    context = ReadContext(Reporter() if run.pipeline is not None else run.reporter)
    found = readers()
    run.traces = [read_measurement(path, "ballbar", found, context) for path in request.ballbar]
    if request.model:
        _model_traces(run)
    probes = [read_measurement(path, "probe", found, context) for path in request.probe]
    run.calibrations = [read_measurement(request.calibration, "calibration", found, context)] if request.calibration else []
    if run.calibrations:
        from ..measure.pretravel import fit_calibration

        run.calibration = fit_calibration(run.calibrations)
    run.probes = [Probed(probe, None) for probe in probes]


def _model_traces(run: Run) -> None:
    """With a saved model: the traces it carries when no trace was given, or why there are none.

    A compensator's model is its own data (docs/formats.md §13); a trace in it is recognised by
    the shape :func:`postproc.measure.traces.trace_model` gives it, wherever it sits, and read back
    with the checks a saved trace gets (:func:`postproc.measure.traces.trace_from_model`)."""
    from ..measure.traces import trace_from_model

    model = run.inputs.request.model
    recorded = [path for path, _ in run.pipeline.core.inputs[:-1]]
    if run.traces:
        given = {provenance.file_input("", path).sha256 for path in run.inputs.request.ballbar}
        fitted = {sha for _, sha in run.pipeline.core.inputs[:-1]}
        same = "are" if given <= fitted else "are not all"
        run.model_traces = (f"The traces shown are those given with --ballbar; they {same} the ones the model "
                            f"{model} was fitted from (by the SHA-256 it records).")
        return
    found = []
    for compensator in run.pipeline.core.compensators:
        try:
            data = compensator.model()
        except Exception:  # a model that cannot give its data has none to plot; its report says more
            continue
        found += [trace_from_model(item, direction) for item, direction in _saved_traces(data)]
    if found:
        from ..measure.readers.csvfile import parse_time
        from ..compensate.models import read as read_model
        from .plotting import moment_text

        run.traces = found
        moment = parse_time(str(read_model(model).get("measured", "")))
        run.model_measured = f"{moment_text(moment)} (model)" if moment is not None else None
        run.model_traces = (f"The traces are those the saved model {model} carries (fitted from "
                            f"{', '.join(recorded) or 'files it does not name'}).")
        return
    names = ", ".join(compensator.name for compensator in run.pipeline.core.compensators)
    run.model_traces = (f"The saved model {model} ({names}) keeps what it fitted, not the traces it was fitted from "
                        f"({', '.join(recorded) or 'files it does not name'}), so there is no ballbar plot and the "
                        "verdict is the model's own estimate: give the traces with --ballbar to show them and "
                        "predict from them (they are checked against the SHA-256 the model records).")


def _saved_traces(data, direction: str | None = None):
    """(trace data, direction) of every saved trace in a model's data, in order."""
    if isinstance(data, dict):
        if {"angles_deg", "deviations_mm", "radius_mm"} <= data.keys():
            yield data, data.get("direction", direction)
            return
        for key, value in data.items():
            yield from _saved_traces(value, key if key in ("ccw", "cw") else direction)
    elif isinstance(data, list):
        for value in data:
            yield from _saved_traces(value, direction)


def _program(run: Run) -> None:
    """The program's profile, the compensated program, and the probe points against the profile."""
    if run.inputs.program is None:
        return
    name, data = run.inputs.program
    profile = run.inputs.profile
    run.program = prediction.read_program(name, data, profile, run.reporter)
    if run.program.nominal is None:
        run.notes.append(f"{name}: no profile to predict or to compare the probe points with: {run.program.note}")
    else:
        for probed in run.probes:
            probed.profile = _against_profile(run, probed)
    if run.pipeline is None or run.program.nominal is None:
        return
    try:
        text, run.summary = _compensate(run.pipeline, name, data)
    except PostprocError as exc:
        if exc.exit_code not in (EXIT_BAD_INPUT, EXIT_REFUSED):
            raise
        where = f"{exc.location.prefix()}: " if exc.location is not None else ""
        run.refused = f"{where}{exc.message}"
        run.notes.append(f"{name}: the program could not be compensated: {run.refused}")
        return
    run.compensated = prediction.read_program(f"{name} (compensated)", text, profile, Reporter(),
                                              run.program.nominal.material)


def _predict(run: Run) -> None:
    """The profile before and after, from whatever there is to predict from."""
    if run.program is None or run.program.nominal is None:
        return
    compensators = run.pipeline.core.compensators if run.pipeline is not None else None
    run.prediction = prediction.predict(run.program, run.compensated, run.machine, compensators)


def _compensate(pipeline, name: str, data: bytes):
    """The compensated program, exactly as ``compensate`` writes it, and the run's summary."""
    with Source.from_text(data, name) as source, Spool(KEEP) as spool:
        summary = pipeline.compensate_source(source, spool)
        return spool.value(), summary


def _against_profile(run: Run, probed: Probed) -> ProbedProfile:
    """The probe file's deviations from the profile; a moved datum is reported, not fatal."""
    profile = run.program.nominal.profile
    lines = tuple(move.line for move in run.program.nominal.moves)
    reporter = Reporter() if run.pipeline is not None else run.reporter  # a probe compensator has warned already
    try:
        return probe_profile(probed.probe, profile, run.calibration, reporter=reporter, lines=lines)
    except SafetyError as exc:
        probed.notes.append(f"{exc.message}: shown all the same")
        run.notes.append(f"{probed.probe.path}: {exc.message}")
        return probe_profile(probed.probe, profile, run.calibration, reporter=Reporter(), force=True, lines=lines)


def _analyse(run: Run) -> None:
    """ISO 230-4 figures and the parametric diagnosis of the ballbar test."""
    if not run.traces:
        return
    test, notes = _test_traces(run)
    run.notes += notes
    try:
        run.diagnosis = diagnose(test)
    except MeasurementError as exc:
        run.undiagnosed = exc.message
        run.notes.append(f"no diagnosis: {exc.message}")
    if run.diagnosis is not None:
        problems, warnings = plausibility(run.diagnosis)
        run.notes += problems + warnings
        test = tuple(centred(test, run.diagnosis))
        run.machine = prediction.machine_of(run.diagnosis, test[0].centre)
    run.test_traces = test
    try:
        run.test = circular_test(test)
    except MeasurementError as exc:
        run.notes.append(f"no ISO 230-4 figures: {exc.message}")


def _test_traces(run: Run) -> tuple[tuple[BallbarTrace, ...], list[str]]:
    """The traces the ISO figures and the diagnosis are made of: one, or a ccw and a cw of one test."""
    traces = run.traces
    notes = []
    if len(traces) > 2:
        first = {}
        for trace in traces:
            first.setdefault(trace.direction, trace)
        traces = list(first.values())
        notes.append(f"{len(run.traces)} traces: the ISO figures and the diagnosis are of the first trace of each "
                     "direction (later ones, such as an iterative run's residuals, are not the machine itself)")
    if len(traces) == 1:
        return (traces[0],), notes
    try:
        return pair(list(traces)), notes
    except MeasurementError as exc:
        notes.append(f"{exc.message}: the ISO figures and the diagnosis are of the first trace alone")
        return (traces[0],), notes
