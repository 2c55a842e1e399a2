"""The report's first screen: before, after, the band, pass or fail.

The question a shop asks of the report: *will the next part be in tolerance?* The answer is
read off the deviations the report already has, in the order of the evidence:

1. **probe points on this program's part** (each probe file): the deviation as measured on
   the part (screened) is *before*; the next pass is taken to repeat it and the emitted
   correction moves it (:meth:`.run.Run.probe_prediction`): *after*;
2. **a ballbar test**: *before* is this program cut on the machine the test measured (its
   parametric diagnosis as a virtual lathe), *after* the compensated program cut on it
   (:mod:`.prediction`);
3. with neither, **the model alone**: *before* is the error the compensators correct (minus
   the correction they ask for), *after* what the emitted program leaves of it (the emitted
   correction minus the intended one): the model's own estimate, not a measurement;
4. without a program, **the ballbar's test circle**: *before* the traces as measured (set-up
   centre removed), *after* what the diagnosed model leaves (traces minus model), when a
   compensator was asked for.

**The band** is a deviation from the nominal along its normal that the part may have on
either side: ``--band MM``, or else the tolerance in force (``--tolerance`` or the machine
profile's default, docs/formats.md §8.1), said so on the screen. **Pass** when every
deviation after compensation lies within +-band (the largest |deviation| at most the band),
as ``postproc inspect`` judges a probed part (docs/methods.md §9.8); with several sources of
evidence, every one must pass. Without a compensator the measured deviation itself is judged.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from ..measure.ballbar_analysis import predict
from . import charts
from .document import Part, Section, Table, Text, Verdict
from .quantities import UM
from .run import Run

PASS, FAIL, NONE = "pass", "fail", "none"
SLACK = 1e-9  #: mm: a deviation this close to the band is on it, so within it


@dataclass(frozen=True)
class Evidence:
    """One source's deviations before and after compensation, mm (NaN where not read)."""

    source: str  #: "probe file hemishell-pass1.csv"
    before_is: str  #: what before is: "measured on the part"
    after_is: str  #: what after is: "predicted after compensation"
    where: np.ndarray  #: s along the profile (mm) or theta (deg)
    before: np.ndarray
    after: np.ndarray | None
    measured: bool  #: before is a measurement itself (drawn as points)
    by_compensators: bool = True  #: after is what the compensators given do (not a model's best case)

    def largest(self, which: str) -> float:
        values = getattr(self, which)
        values = np.abs(values[np.isfinite(values)]) if values is not None else np.zeros(0)
        return float(values.max()) if values.size else float("nan")

    def mean_abs(self, which: str) -> float:
        values = getattr(self, which)
        values = np.abs(values[np.isfinite(values)]) if values is not None else np.zeros(0)
        return float(values.mean()) if values.size else float("nan")


@dataclass(frozen=True)
class Band:
    half_width: float  #: mm
    origin: str  #: where it comes from, for the screen

    def holds(self, deviation: float) -> bool:
        return deviation <= self.half_width + SLACK


def band_of(run: Run) -> Band:
    inputs = run.inputs
    if inputs.band is not None:
        return Band(inputs.band, "as given with --band")
    if inputs.request.tolerance is not None:
        return Band(inputs.request.tolerance, "the tolerance in force (--tolerance); give --band MM for the "
                                              "part's own tolerance")
    return Band(inputs.profile.default_tolerance(False),
                f"the tolerance in force (machine profile {inputs.profile.name}'s default for mm programs); "
                "give --band MM for the part's own tolerance")


def evidence(run: Run) -> list[Evidence]:
    """Every source of before and after there is, strongest first (the module's list)."""
    found: list[Evidence] = []
    result = run.prediction
    if result is not None:
        for probed in run.probes:
            if probed.profile is None:
                continue
            before, after, _ = run.probe_prediction(probed)
            found.append(Evidence(f"probe file {os.path.basename(probed.probe.path)}",
                                  f"measured on the part ({len(before)} points, screened)",
                                  "predicted after compensation", probed.profile.deviations.nearest.s, before,
                                  after, True))
        s = result.stations.s
        if result.before is not None:
            found.append(Evidence("ballbar test", "this program cut on the machine the ballbar measured",
                                  "the compensated program cut on it", s, result.before, result.after, False))
        if not found and result.intended is not None and result.correction is not None:
            found.append(Evidence("model alone, no measurement given",
                                  "the error the model says it corrects (minus its correction)",
                                  "what the emitted program leaves of that error", s, -result.intended,
                                  result.correction - result.intended, False))
    elif run.diagnosis is not None and run.test_traces:
        compensating = run.pipeline is not None
        where, before, after = [], [], []
        for trace in run.test_traces:
            where.append(trace.angles)
            before.append(trace.deviations)
            after.append(trace.deviations - predict(run.diagnosis, trace.angles, trace.direction, trace.radius))
        found.append(Evidence("ballbar test circle, no program given", "the traces as measured",
                              "what the diagnosed error model leaves (traces minus model: the best a model of "
                              "these errors does)", np.concatenate(where), np.concatenate(before),
                              np.concatenate(after) if compensating else None, True, by_compensators=False))
    return found


def judge(found: list[Evidence], band: Band) -> tuple[str, str]:
    """(state, headline)."""
    if not found:
        return NONE, "NO VERDICT: nothing to judge"
    if all(e.after is not None for e in found):
        worst = max(e.largest("after") for e in found)
        if not np.isfinite(worst):
            return NONE, "NO VERDICT: no deviation after compensation could be predicted"
        if band.holds(worst):
            return PASS, f"PASS: within \u00b1{_um(band.half_width)} after compensation"
        return FAIL, f"FAIL: {_um(worst)} after compensation, outside \u00b1{_um(band.half_width)}"
    worst = max(e.largest("before") for e in found)
    if band.holds(worst):
        return PASS, f"PASS as measured: within \u00b1{_um(band.half_width)}, no compensation asked"
    return FAIL, f"FAIL as measured: {_um(worst)}, outside \u00b1{_um(band.half_width)}; no compensator given"


def section(run: Run) -> Section:
    """The verdict: the answer in a few words and in a sentence, the numbers, and one chart."""
    band = band_of(run)
    found = evidence(run)
    state, headline = judge(found, band)
    if run.refused:
        state, headline = NONE, "NO VERDICT: the program could not be compensated"
    parts: list[Part] = [Verdict(state, headline, _figures(found, band), _sentence(run, found, band)),
                         Text(f"The band: \u00b1{_um(band.half_width)} about the nominal, along its normal: "
                              f"{band.origin}.", "note")]
    if found:
        parts.append(_chart(found, band, run.prediction is not None))
        parts.append(_table(found, band))
    return Section("verdict", "Verdict", parts)


def _figures(found: list[Evidence], band: Band) -> str:
    """The numbers: the largest deviation before -> after, for each source."""
    shown = []
    for e in found:
        text = f"before {_um(e.largest('before'))}"
        if e.after is not None:
            text += f" \u2192 after {_um(e.largest('after'))}"
        shown.append(text + (f" ({e.source})" if len(found) > 1 else ""))
    return ("largest deviation: " + "; ".join(shown) + f"; band \u00b1{_um(band.half_width)}") if shown else ""


def _sentence(run: Run, found: list[Evidence], band: Band) -> str:
    compensators = ""
    if run.pipeline is not None:
        compensators = " with " + ", ".join(item.cls.name for item in run.pipeline.core.installed)
    said = []
    for e in found:
        text = (f"Before ({e.source}), {e.before_is}: largest {_um(e.largest('before'))}, "
                f"{_within(band, e.largest('before'))}.")
        if e.after is not None:
            by = compensators if e.by_compensators else ""
            text += (f" After compensation{by}, {e.after_is}: largest {_um(e.largest('after'))}, "
                     f"{_within(band, e.largest('after'))}.")
        said.append(text)
    if run.refused:
        said.append(f"Compensation refused: {run.refused}")
    elif not found:
        said.append(_nothing(run))
    elif all(e.after is None for e in found):
        said.append("No compensator was given: the measured deviation itself is judged.")
    return " ".join(said)


def _nothing(run: Run) -> str:
    if run.program is not None and run.program.nominal is None:
        return f"{run.program.name} turns no profile to predict: {run.program.note}."
    if run.program is None:
        return "No program and no ballbar diagnosis: give the program, or ballbar traces of the machine."
    return "No measurement and no compensator: give ballbar traces, probe points, a compensator or a model."


def _um(mm: float) -> str:
    return "n/a" if not np.isfinite(mm) else f"{mm * 1000:.2f} {UM}"


def _within(band: Band, largest: float) -> str:
    if not np.isfinite(largest):
        return "not predicted"
    return "within the band" if band.holds(largest) else "outside the band"


def _chart(found: list[Evidence], band: Band, along_profile: bool) -> Part:
    series = []
    for e in found:
        series.append((f"before: {e.source}", e.where, e.before, "before", e.measured))
        if e.after is not None:
            series.append((f"after: {e.source}", e.where, e.after, "after", e.measured))
    xlabel = "s, arc length along the profile (mm)" if along_profile else "theta (deg, 0 = +X, 90 = +Z)"
    return charts.verdict(series, band.half_width, xlabel,
                          f"Deviation from the nominal along its normal (+ = material left), before and after "
                          f"compensation; the band \u00b1{_um(band.half_width)} shaded.")


def _table(found: list[Evidence], band: Band) -> Table:
    rows = []
    for e in found:
        for which, what in (("before", e.before_is), ("after", e.after_is)):
            if getattr(e, which) is None:
                continue
            largest = e.largest(which)
            rows.append((f"{which}: {e.source}", what, f"{largest * 1000:.3f}", f"{e.mean_abs(which) * 1000:.3f}",
                         _within(band, largest)))
    return Table(("deviations", "what they are", f"largest |e| ({UM})", f"mean |e| ({UM})",
                  f"band \u00b1{band.half_width * 1000:g} {UM}"), tuple(rows), "before and after, against the band",
                 key="verdict-figures", numeric=False)
