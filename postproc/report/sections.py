"""What goes in a report, section by section.

0. **The verdict**, first, before the contents: before and after against the band, pass or
   fail, in words and one chart (:mod:`.verdict`).
1. **Summary**: what was asked.
2. **Measurements**: the ballbar traces (the polar plot, deviation against angle, a table of
   the traces), the probe points (their deviation from the program's profile along its
   normal against arc length, the dropped nub or outliers marked; without a program, the
   touched points), the probe calibration (pretravel against direction, the model chosen).
3. **ISO 230-4 figures and the error diagnosis**: G, F, G(b), H and the parametric diagnosis
   with 1-sigma uncertainties (:mod:`postproc.measure.ballbar_analysis`), the model drawn over the
   traces.
4. **Fitted models**: each compensator's documentation, the options in force and its
   ``report()`` dict, shown whatever it holds (:mod:`.fitted`).
5. **Predicted profile before and after compensation** (with a program): the correction as
   the compensators ask for it and as the compensated program emits it, the profile the
   ballbar's machine would cut before and after, and the probed profile and what the
   correction makes of it (:mod:`.prediction`).
6. **The four figures** (docs/methods.md §12) of every deviation above, in one table.
7. **Warnings** of the run, 8. **Provenance** (:mod:`.provenance`), and 9. **References**:
   every page and section the text cites, with its title (:mod:`.citations`).

Every figure is named and in the unit of :mod:`.quantities`; a compensator's documentation is
read from its markup (:mod:`.docstring`).

Without a program, the report covers the measurements and the models alone. Without a
compensator, the measurements alone. What is computed is gathered first (:mod:`.run`);
here it is laid out, and the four figures of each set of deviations are collected on the way.
"""

from __future__ import annotations

import os

import numpy as np

from ..measure.ballbar_analysis import predict
from ..measure.ballbar_fit import arc_text
from ..diagnostics import Reporter
from ..measure.readers.ballbar import BallbarTrace
from .plotting import along_arc
from ..measure.probing import touched_points
from . import charts, citations, docstring, fitted, provenance, verdict
from .document import Document, Image, Part, Section, Table, Text, Verdict
from .quantities import FOUR
from .run import KINDS, Inputs, Run, gather

__all__ = ["Inputs", "build"]


def build(inputs: Inputs, reporter: Reporter) -> Document:
    """Read, fit, compensate and predict (:func:`.run.gather`), then lay the sections out: the
    verdict first (:mod:`.verdict`), the references to the pages the text cites last."""
    run = gather(inputs, reporter)
    sections = [_measurements(run), _iso(run), _models(run)]
    if run.program is not None:
        sections.append(_prediction(run))
    sections = [section for section in sections if section is not None]
    four = _four_figures(run)
    summary = _summary(run)
    warnings = _warnings(run)
    ordered = [summary, *sections, four] + ([warnings] if warnings else []) + [_provenance(run)]
    lead = verdict.section(run)
    cited = citations.section(_texts([lead, *ordered]))
    if cited is not None:
        ordered.append(cited)
    name = run.program.name if run.program else "measurements and model"
    subtitle = f"postproc report, {run.when.strftime('%Y-%m-%d %H:%M UTC')}"
    return Document(f"Compensation report: {name}", subtitle, ordered, lead)


def _texts(sections: list[Section]):
    """Every string of the sections a reader reads (for the citations in them)."""
    for section in sections:
        yield section.title
        for part in section.parts:
            if isinstance(part, Text):
                yield part.text
            elif isinstance(part, Table):
                yield part.caption
                yield from (cell for row in part.rows for cell in row)
            elif isinstance(part, Image):
                yield part.caption
            elif isinstance(part, Verdict):
                yield part.sentence
        yield from _texts(section.subsections)


# ---------------------------------------------------------------- measurements


def _measurements(run: Run) -> Section | None:
    subsections = []
    if run.traces:
        subsections.append(_ballbar(run))
    if run.probes:
        subsections.append(_probe(run))
    if run.calibrations:
        subsections.append(_calibration(run))
    about = [Text(run.model_traces, "note")] if run.model_traces else []
    if not subsections and not about:
        return None
    return Section("measurements", "Measurements", about, subsections)


def _ballbar(run: Run) -> Section:
    traces = run.traces
    rows = []
    for trace in traces:
        centre = trace.setup_centre
        rows.append((trace.path, f"{trace.direction} ({'G02' if trace.cw else 'G03'})", f"{trace.radius:g}",
                     f"{trace.centre[0]:g}, {trace.centre[1]:g}", "" if trace.feed is None else f"{trace.feed:g}",
                     str(len(trace.angles)), arc_text(trace), "raw" if trace.raw else "processed",
                     "not removed (centered)" if trace.centered else f"{centre[0] * 1000:+.2f}, {centre[1] * 1000:+.2f}"))
        run.figure(f"ballbar trace {trace.direction}: {trace.path}", trace.deviations)
    parts: list[Part] = [
        Table(("file", "direction", "radius (mm)", "centre x, z (mm)", "feed (mm/min)", "samples", "captured arc",
               "form", "set-up centre removed x, z (um)"), tuple(rows), "ballbar traces"),
        charts.polar(traces, "The traces about the nominal circle, seen from +Y (Z to the right, X up), the "
                             "deviation magnified as stated on the plot, with the test's ISO 230-4 figures and the "
                             "diagnosis (docs/methods.md §3.3, §3.4, §15).",
                     run.test, run.diagnosis, run.model_measured),
    ]
    series = [(_trace_label(trace, traces), *along_arc(trace)) for trace in traces]
    if run.diagnosis is not None:
        for trace in run.test_traces:
            start, span = trace.arc
            grid = start + np.linspace(0.0, span, max(int(span), 2) + 1)
            series.append((f"{trace.direction} model (diagnosis)", grid,
                           predict(run.diagnosis, grid, trace.direction, trace.radius)))
    partial = [f"{t.path}: {arc_text(t)}" for t in traces if t.arc[1] < 360.0]
    parts.append(charts.against_angle(series, "Deviation against theta (0 deg = +X, 90 deg = +Z), set-up centre removed; "
                                              "with the diagnosed model where there is one."
                                      + (f" Partial arcs, drawn as measured (ISO 13041-6): {'; '.join(partial)}."
                                         if partial else "")))
    return Section("ballbar", "Ballbar traces", parts)


def _trace_label(trace: BallbarTrace, traces: list[BallbarTrace]) -> str:
    same = [t for t in traces if t.direction == trace.direction]
    number = next(i for i, t in enumerate(same, 1) if t is trace)
    return f"{trace.direction}{f' #{number}' if len(same) > 1 else ''} measured"


def _probe(run: Run) -> Section:
    subsections = []
    for index, probed in enumerate(run.probes, 1):
        probe = probed.probe
        datum = "; ".join(f"{axis}: {probe.datum_before[axis]:g} before, {probe.datum_after[axis]:g} after"
                          for axis in sorted(probe.datum_before)) or "not probed"
        facts = Table(("item", "value"), (
            ("file", probe.path), ("stylus radius (mm)", f"{probe.stylus_radius:g}"),
            ("touches", str(len(probe.centres))), ("datum", datum),
            ("repeatability (mm)", "not given" if probe.repeatability is None else f"{probe.repeatability:g}"),
            ("calibration", run.inputs.request.calibration or "none (pretravel k = 0)"),
        ), "probe file", numeric=False)
        parts: list[Part] = [facts]
        profiled = probed.profile
        if profiled is None:
            points, _ = touched_points(probe, run.calibration)
            parts.append(charts.touched_points(points, "Touched points (stylus centre plus stylus radius and pretravel "
                                                       "along the approach)."))
            parts.append(Text("Give the program the profile was cut with to see the deviation along its normal.",
                              "note"))
        else:
            s = profiled.deviations.nearest.s
            parts.append(charts.probe_deviations(s, profiled.deviation, profiled.cleaned, profiled.kept,
                                                 "Deviation from the program's profile along its normal (+ = material "
                                                 "left) against arc length from the profile's start."))
            measured = run.figure(f"probe measured: {probe.path}", profiled.deviation)
            cleaned = run.figure(f"probe screened: {probe.path}", profiled.cleaned)
            parts.append(Table(("deviation", *FOUR, "points"),
                               (fitted.figure_row("as measured", measured), fitted.figure_row("screened", cleaned)),
                               "the four figures"))
            calibration = set(run.calibration.report()) if run.calibration is not None else set()
            parts += [Text(note, "note") for note in profiled.notes if note not in calibration]
        parts += [Text(note, "warning") for note in probed.notes]
        subsections.append(Section(f"probe-{index}", f"Probe points {index}", parts))
    return Section("probe", "Probe points", [], subsections)


def _calibration(run: Run) -> Section:
    model = run.calibration
    rows = tuple((c.path, f"{c.stylus_radius:g}", f"{c.artifact_radius:g}",
                  f"{c.artifact_centre[0]:g}, {c.artifact_centre[1]:g}", str(len(c.centres))) for c in run.calibrations)
    theta = np.concatenate([model.frame.unwrap(c.theta) for c in run.calibrations])
    k = np.concatenate([c.factors() for c in run.calibrations])
    low, high = model.span
    grid = np.linspace(low, high, 200)
    parts: list[Part] = [
        Table(("file", "stylus radius (mm)", "artifact radius (mm)", "artifact centre x, z (mm)", "touches"), rows,
              "probe calibration"),
        charts.calibration(theta, k, (grid, np.atleast_1d(model.k_of(grid))),
                           "Pretravel k = measured minus artifact radius at each touch, and the model fitted to it."),
        *[Text(line, "note") for line in model.report()],
    ]
    return Section("calibration", "Probe calibration", parts)


# ---------------------------------------------------------------- ISO figures and diagnosis


def _iso(run: Run) -> Section | None:
    if not run.traces:
        return None
    parts: list[Part] = []
    test = run.test
    if test is not None:
        rows = []
        for d in test.by_direction:
            rows.append((f"G, circular deviation ({d.direction})", f"{d.circular_deviation * 1000:.3f}"))
            rows.append((f"F, radial deviation ({d.direction}), min .. max",
                         f"{d.radial_min * 1000:+.3f} .. {d.radial_max * 1000:+.3f}"))
        if test.hysteresis is not None:
            rows.append(("G(b), bidirectional circular deviation", f"{test.bidirectional_deviation * 1000:.3f}"))
            rows.append(("H, circular hysteresis", f"{test.hysteresis * 1000:.3f}"))
        partial = [f"{t.path}: {arc_text(t)}" for t in run.test_traces if t.arc[1] < 360.0]
        if partial:
            rows.append(("captured arcs (partial: ISO 13041-6, the lathe's test code)", "; ".join(partial)))
        parts.append(Table(("ISO 230-4 / ISO 13041-6 (lathes)", "um"), tuple(rows),
                           "ISO 230-4 circular test (ISO 13041-6 for lathes), over the arcs as measured",
                           key="iso-230-4"))
    diagnosis = run.diagnosis
    if diagnosis is not None:
        entries = {"scaling_x": diagnosis.scaling_x, "scaling_z": diagnosis.scaling_z,
                   "backlash_x_mm": diagnosis.backlash_x, "backlash_z_mm": diagnosis.backlash_z,
                   "squareness_rad": diagnosis.squareness, "servo_mismatch_mm": diagnosis.servo_mismatch,
                   "servo_lag_ms": diagnosis.servo_lag_ms, "apparent_squareness_rad": diagnosis.apparent_squareness,
                   "setup_centre_x_mm": diagnosis.centre_offset[0], "setup_centre_z_mm": diagnosis.centre_offset[1]}
        parameters = {name: {"value": e.value, "sigma": e.sigma} for name, e in entries.items() if e is not None}
        parts.append(fitted.parameters_table(parameters, "parametric diagnosis of the machine (1 sigma)",
                                             key="diagnosis"))
        residual = diagnosis.residual
        run.figures.append(("ballbar diagnosis: traces minus model", residual))
        parts.append(Text(f"Fit residual (traces minus the diagnosed model): {residual}.", "note"))
        parts.append(Text("Model: e_x = a_x (x - xc) + s (z - zc) - (b_x / 2) sign(v_x) - m v_x / |v|, "
                          "e_z = a_z (z - zc) - (b_z / 2) sign(v_z), about the test centre (xc, zc).", "note"))
    else:
        parts.append(Text(f"No parametric diagnosis: {run.undiagnosed or 'the traces cannot support one'}.", "note"))
    return Section("iso", "ISO 230-4 / ISO 13041-6 figures and the error diagnosis", parts)


# ---------------------------------------------------------------- fitted models


def _models(run: Run) -> Section:
    pipeline = run.pipeline
    if pipeline is None:
        return Section("models", "Fitted models", [Text(
            "No compensator was selected (--plugin or --model): the report covers the measurements only.", "note")])
    core = pipeline.core
    subsections = []
    for item, compensator in zip(core.installed, core.compensators):
        name = compensator.name
        parts: list[Part] = [docstring.inline(item.cls.summary() or name)]
        if run.inputs.request.model:
            parts.append(Text(f"Loaded from the saved model {run.inputs.request.model}.", "note"))
        try:
            report = compensator.report()
            if not isinstance(report, dict):
                raise TypeError(f"report() returned {type(report).__name__}, not a dict")
        except Exception as exc:  # a plugin's report must not take the whole report down
            parts.append(Text(f"{name}: report() failed: {exc.__class__.__name__}: {exc}", "warning"))
            run.notes.append(f"{name}: report() failed: {exc.__class__.__name__}: {exc}")
        else:
            shown, found = fitted.render(name, report)
            parts += shown
            run.figures += found
        settings = core.settings.get(name, {})
        if settings:
            parts.append(Table(("option", "value in force"), tuple((k, repr(v)) for k, v in settings.items()),
                               f"{name}: options", numeric=False))
        documentation = docstring.parts(item.cls.__doc__ or "", skip_summary=True)
        what = [Section(f"doc-{name}", f"What {name} does (its documentation)", documentation)] if documentation else []
        subsections.append(Section(f"model-{name}", f"{name} {item.version}", parts, what))
    return Section("models", "Fitted models", [], subsections)


# ---------------------------------------------------------------- prediction


def _prediction(run: Run) -> Section:
    program = run.program
    parts: list[Part] = []
    if program.nominal is None:
        parts.append(Text(f"{program.name} turns no surface to predict: {program.note}", "note"))
        return Section("prediction", "Predicted profile before and after compensation", parts)
    moves = program.nominal.moves
    parts.append(Text(f"The profile: lines {moves[0].line} to {moves[-1].line} of {program.name}, {len(moves)} feed "
                      f"moves, {program.nominal.profile.length:.3f} mm long; material on the "
                      f"{program.nominal.material} of the direction of travel.", "note"))
    if run.summary is not None:
        s = run.summary
        parts.append(Text(f"Compensation: {s.replaced} blocks replaced by {s.emitted}; largest correction "
                          f"{s.largest_correction * 1000:.2f} um; largest deviation of the emitted path from the "
                          f"intended one {s.largest_deviation * 1000:.3f} um."))
    elif run.refused:
        parts.append(Text(f"Compensation refused: {run.refused}", "warning"))
    elif run.pipeline is None:
        parts.append(Text("No compensator: only the profile before compensation is predicted.", "note"))
    machine, result = run.machine, run.prediction
    s = result.stations.s
    lines, shapes, rows = [], [], []
    stations = result.stations

    def add(label: str, deviations, style: str, where=s, points=stations.points, normals=stations.normals) -> None:
        if deviations is None:
            return
        lines.append((label, where, deviations, style))
        shapes.append((label, points, normals, deviations, style))
        found = run.figure(f"predicted: {label}", deviations)
        if found is not None:
            rows.append(fitted.figure_row(label, found))

    add("before (ballbar model)", result.before, "C1-")  # the colours of before and after in the verdict
    add("after (ballbar model)", result.after, "C0-")
    add("correction intended", result.intended, "C2:")
    add("correction as emitted", result.correction, "C3--")
    for probed in run.probes:
        if probed.profile is None:
            continue
        before, after, stock = run.probe_prediction(probed)
        deviations = probed.profile.deviations
        at = (deviations.nearest.s, deviations.nearest.foot, deviations.outward)
        add(f"before (probed, {os.path.basename(probed.probe.path)})", before, "o", *at)
        add(f"after (probed, {os.path.basename(probed.probe.path)})", after, "s", *at)
        if stock:
            parts.append(Text(f"{probed.probe.path}: the probed pass was cut {stock:g} mm outside this profile "
                              "(option stock): that much is taken off its deviations.", "note"))
    if lines:
        parts.append(charts.along_profile(lines, "Deviation along the profile's normal (+ = material left) "
                                                 "against arc length from the profile's start."))
        parts.append(charts.profile_shape(stations.points, shapes, "The nominal profile and the predicted ones, "
                                                                   "seen from +Y (Z to the right, X up)."))
        parts.append(Table(("profile", *FOUR, "points"), tuple(rows),
                           "the four figures of each", key="prediction-figures"))
    else:
        parts.append(Text("Nothing to predict from: give ballbar traces, probe points or a compensator.", "note"))
    if machine is not None:
        parts += [Text(note, "note") for note in machine.notes]
    if result.correction is not None and result.before is None and not any(p.profile for p in run.probes):
        parts.append(Text("Without measurements the error the model corrects is minus its correction; "
                          "give the measurements to predict the residual.", "note"))
    if any(p.profile is not None for p in run.probes):
        parts.append(Text("Probed profiles: the next pass is taken to repeat the probed error (screened, as the "
                          "probe compensators use it); after = before + the correction at each probed point.", "note"))
    parts += [Text(note, "note") for note in result.notes]
    return Section("prediction", "Predicted profile before and after compensation", parts)


# ---------------------------------------------------------------- summary, four figures, warnings, provenance


def _summary(run: Run) -> Section:
    request = run.inputs.request
    compensators = "none"
    if run.pipeline is not None:
        compensators = ", ".join(f"{item.cls.name} {item.version}" for item in run.pipeline.core.installed)
    rows = [("program", run.program.name if run.program else "none: measurements and model only"),
            ("compensators", compensators + (f" (saved model {request.model})" if request.model else ""))]
    for kind, role in KINDS:
        files = getattr(request, kind)
        files = [files] if isinstance(files, str) else list(files or [])
        if files:
            rows.append((role, ", ".join(files)))
    parts: list[Part] = [Table(("item", "value"), tuple(rows), "what was asked", numeric=False)]
    return Section("summary", "Summary", parts)


def _four_figures(run: Run) -> Section:
    rows = tuple(fitted.figure_row(label, f) for label, f in run.figures)
    if not rows:
        return Section("four-figures-section", "The four figures", [Text("No deviations to summarise.", "note")])
    return Section("four-figures-section", "The four figures", [
        Text("Mean, mean absolute, RMS and standard deviation (population, ddof = 0) of each set of deviations, "
             "in micrometres (docs/methods.md §12)."),
        Table(("deviations", *FOUR, "points"), rows,
              "the four figures", key="four-figures")])


def _warnings(run: Run) -> Section | None:
    texts = [str(warning) for warning in run.reporter.warnings] + run.notes
    if not texts:
        return None
    return Section("warnings", "Warnings", [Text(text, "warning") for text in dict.fromkeys(texts)])


def _provenance(run: Run) -> Section:
    inputs = run.inputs
    request = inputs.request
    files: list[provenance.Input] = []
    if inputs.program is not None:
        files.append(provenance.data_input("program", *inputs.program))
    extras = {trace.path: trace.extras for trace in run.traces}
    extras.update({p.probe.path: p.probe.extras for p in run.probes})
    extras.update({c.path: c.extras for c in run.calibrations})
    for kind, role in KINDS:
        paths = getattr(request, kind)
        for path in ([paths] if isinstance(paths, str) else list(paths or [])):
            notes = "; ".join(f"{key} = {value}" for key, value in extras.get(path, {}).items())
            files.append(provenance.file_input(role, path, notes))
    plugins, settings = [], {}
    if request.model:
        files.append(provenance.file_input("saved model", request.model))
        files += [provenance.Input("measurement (recorded in the model)", path, sha, None)
                  for path, sha in run.pipeline.core.inputs[:-1]]
    if inputs.machine:
        files.append(provenance.file_input("machine profile", inputs.machine))
    if run.pipeline is not None:
        core = run.pipeline.core
        plugins = [(item.cls.name, item.version, item.distribution) for item in core.installed]
        settings = core.settings
    tolerance = (f"{request.tolerance:g} mm" if request.tolerance is not None else
                 f"default ({inputs.profile.default_tolerance(False):g} mm in mm programs, "
                 f"{inputs.profile.default_tolerance(True):g} mm in inch programs)")
    return provenance.section(files, inputs.profile, inputs.machine, plugins, settings, tolerance, inputs.command,
                              run.when)

