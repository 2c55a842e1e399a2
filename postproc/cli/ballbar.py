"""``postproc ballbar FILE... [--json] [--plot FILE]``: ISO 230-4 / ISO 13041-6 figures and error diagnosis.

Any number of traces: each test is the traces of one circle (one radius and centre: its ccw
and cw runs, on one mount), whole circles or partial arcs (a lathe's XZ test runs about
220 deg), read by any installed reader. The ISO figures are per test, over the arcs as
measured; the parametric diagnosis is one joint fit to every trace, each test with its own
set-up centre (:mod:`postproc.measure.ballbar_analysis`). A human-readable report goes to stdout, or
with ``--json`` exactly one JSON object: the keys of formats.md (the ISO figures and the set-up
centre of the first test, the diagnosis of all) plus ``bidirectional_circular_deviation_mm``,
``servo_mismatch_mm`` and ``servo_lag_ms`` (X behind Z; the lag needs the feed in every header),
``apparent_squareness_rad`` (one direction only), ``setup_center_mm`` (the centre the reader
removed from each trace), ``captured_arc_deg`` (each direction's arc: ``start``, ``span``),
``trace_figures_um`` and ``fit_residual_um`` (the four figures), ``uncertainty`` (1 sigma, in
each key's own unit), ``tests`` (every test's figures, arcs and set-up centre),
``needs_both_directions``, ``warnings`` (results no machine gives, with their likely cause)
and ``notes``. A figure the traces cannot support is null. A diagnosis the arcs cannot
determine is refused (exit 3, naming the arc and the parameter) unless ``--no-diagnosis``
asks for the ISO figures alone. Errors are raised as PostprocError for the command line.
"""

from __future__ import annotations

import json
import sys

import click

from ..measure.ballbar_analysis import (CircularTest, Diagnosis, Estimate, centred, circular_test, diagnose, plausibility,
                                        tests)
from ..measure.ballbar_fit import arc_text
from ..diagnostics import Location, MeasurementError, Reporter, UsageError
from ..measure.readers.ballbar import BallbarTrace
from ..report.plotting import FIT, plot_traces
from .common import BALLBAR, COUNT, POSITIVE, examples, guard

BOTH_DIRECTIONS = ["bidirectional_circular_deviation_mm", "hysteresis_mm", "squareness_rad", "servo_mismatch_mm",
                   "servo_lag_ms"]
DIAGNOSIS = ["scaling_x", "scaling_z", "backlash_x_mm", "backlash_z_mm", "squareness_rad", "servo_mismatch_mm",
             "servo_lag_ms", "apparent_squareness_rad"]
DIRECTIONS = ("ccw", "cw")


@click.command("ballbar", epilog=examples(
    "# a whole-circle test in both directions: figures and diagnosis, with a polar plot",
    "postproc ballbar ccw.csv cw.csv --plot polar.png",
    "# the same traces as fit takes them; the figures alone, as JSON",
    "postproc ballbar --ballbar ccw.csv --ballbar cw.csv --no-diagnosis --json"))
@click.argument("files", nargs=-1, metavar="FILE...")
@BALLBAR(help="A trace, as fit and compensate take it (the same as FILE).")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of the report.")
@click.option("--plot", metavar="FILE", help="Write a polar plot of the traces (.png or .svg).")
@click.option("--averaging", type=COUNT, default=6, show_default=True, metavar="N",
              help="Raw form: readings averaged per sample.")
@click.option("--max-deviation", type=POSITIVE, default=1.0, show_default=True,
              metavar="MM", help="A deviation beyond this is not a plausible ballbar reading.")
@click.option("--no-diagnosis", is_flag=True, help="The ISO figures alone, without the parametric diagnosis.")
def command(files, ballbar, as_json, plot, averaging, max_deviation, no_diagnosis):
    """ISO 230-4 / 13041-6 figures and error diagnosis of ballbar traces: one or several tests, any arc."""
    from ..measure.readers.registry import ReadContext, read
    from ..compensate.registry import readers

    files = files + ballbar
    if not files:
        raise UsageError("no trace was given: postproc ballbar FILE... (or --ballbar FILE, as fit takes them)")
    guard([("FILE", name) for name in files], [("--plot", plot)])
    reporter = Reporter(sys.stderr)
    context = ReadContext(reporter, averaging, max_deviation)
    found = readers()
    traces = [read(name, "ballbar", found, context) for name in files]
    grouped = tests(traces)
    diagnosis, warnings = None, []
    if not no_diagnosis:
        try:
            diagnosis = diagnose(traces)
        except MeasurementError as exc:
            raise MeasurementError(f"{exc.message} (--no-diagnosis gives the ISO figures alone)", exc.location) from None
        problems, cautions = plausibility(diagnosis)
        warnings = problems + cautions
        for text in warnings:
            reporter.warn(text, Location(traces[0].path))
        grouped = tests(centred(traces, diagnosis))
    figures = [circular_test(test) for test in grouped]
    if plot:
        plot_traces([trace for test in grouped for trace in test], plot, test=figures[0],
                    diagnosis=FIT if diagnosis is None else diagnosis)
    if as_json:
        click.echo(json.dumps(_result(grouped, figures, diagnosis, warnings), indent=2, allow_nan=False))
    else:
        click.echo(_report(grouped, figures, diagnosis, warnings))
    reporter.close()


def _by_direction(test: tuple[BallbarTrace, ...], value) -> dict:
    return {d: next((value(t) for t in test if t.direction == d), None) for d in DIRECTIONS}


def _test_result(test: tuple[BallbarTrace, ...], circular: CircularTest,
                 centre: tuple[Estimate, Estimate] | None) -> dict:
    """One test's keys: the ISO figures, its arcs, its set-up centre."""
    by_direction = {d.direction: d for d in circular.by_direction}
    return {
        "radius_mm": test[0].radius,
        "center_mm": {"x": test[0].centre[0], "z": test[0].centre[1]},
        "traces": _by_direction(test, lambda t: t.path),
        "captured_arc_deg": _by_direction(test, lambda t: {"start": t.arc[0], "span": t.arc[1]}),
        "circular_deviation_mm": {d: by_direction[d].circular_deviation if d in by_direction else None
                                  for d in DIRECTIONS},
        "radial_deviation_mm": {d: {"min": by_direction[d].radial_min, "max": by_direction[d].radial_max}
                                if d in by_direction else None for d in DIRECTIONS},
        "bidirectional_circular_deviation_mm": circular.bidirectional_deviation,
        "hysteresis_mm": circular.hysteresis,
        "trace_figures_um": {d: by_direction[d].figures.as_dict() if d in by_direction else None for d in DIRECTIONS},
        "center_offset_mm": {"x": _value(centre[0] if centre else None), "z": _value(centre[1] if centre else None)},
        "setup_center_mm": _by_direction(test, lambda t: {"x": t.setup_centre[0], "z": t.setup_centre[1]}),
        "repeats": [t.path for t in test if t is not next(r for r in test if r.direction == t.direction)],
    }


def _result(grouped, figures: list[CircularTest], diagnosis: Diagnosis | None, warnings: list[str]) -> dict:
    """The JSON object: every key always present, null where the traces cannot support it."""
    fields = dict.fromkeys(DIAGNOSIS) if diagnosis is None else {
        "scaling_x": diagnosis.scaling_x,
        "scaling_z": diagnosis.scaling_z,
        "backlash_x_mm": diagnosis.backlash_x,
        "backlash_z_mm": diagnosis.backlash_z,
        "squareness_rad": diagnosis.squareness,
        "servo_mismatch_mm": diagnosis.servo_mismatch,
        "servo_lag_ms": diagnosis.servo_lag_ms,
        "apparent_squareness_rad": diagnosis.apparent_squareness,
    }
    centres = list(diagnosis.centres) if diagnosis else [None] * len(grouped)
    every = [_test_result(test, circular, centre) for test, circular, centre in zip(grouped, figures, centres)]
    first = every[0]
    single = all(len(test) == 1 for test in grouped) and len({t.direction for test in grouped for t in test}) == 1
    centre = centres[0]
    return {
        **first,
        **{key: _value(estimate) for key, estimate in fields.items()},
        "uncertainty": {**{key: _sigma(estimate) for key, estimate in fields.items()},
                        "center_offset_mm": {"x": _sigma(centre[0] if centre else None),
                                             "z": _sigma(centre[1] if centre else None)}},
        "fit_residual_um": diagnosis.residual.as_dict() if diagnosis else None,
        "tests": every,
        "needs_both_directions": BOTH_DIRECTIONS if single else [],
        "warnings": warnings,
        "notes": _notes(grouped, diagnosis),
    }


def _notes(grouped, diagnosis: Diagnosis | None) -> list[str]:
    """What the traces could not support, and why."""
    traces = [trace for test in grouped for trace in test]
    notes = []
    directions = {t.direction for t in traces}
    if len(directions) == 1:
        notes.append(f"one direction ({traces[0].direction}) only: G(b), H, squareness and servo mismatch need a ccw "
                     "and a cw trace; one trace sees only squareness plus its share of servo mismatch "
                     "(apparent_squareness_rad)")
    partial = [t for t in traces if t.arc[1] < 360.0]
    if partial:
        notes.append("partial arcs (ISO 13041-6): " + "; ".join(f"{t.path} {arc_text(t)}" for t in partial)
                     + "; every figure is over the arc as measured")
    if len(grouped) > 1:
        notes.append(f"{len(grouped)} tests: the diagnosis is one fit to all of them, each with its own set-up centre; "
                     "the top-level ISO figures are the first test's, 'tests' has every one")
    if diagnosis is None:
        notes.append("no parametric diagnosis (--no-diagnosis)")
    return notes


def _value(estimate: Estimate | None) -> float | None:
    return None if estimate is None else estimate.value


def _sigma(estimate: Estimate | None) -> float | None:
    return None if estimate is None else estimate.sigma


def _report(grouped, figures: list[CircularTest], diagnosis: Diagnosis | None, warnings: list[str]) -> str:
    """The report for people: micrometres, and ppm / urad for the dimensionless parameters."""
    lines = []
    for index, (test, circular) in enumerate(zip(grouped, figures)):
        centre = test[0].centre
        lines.append(f"ballbar test{f' {index + 1}' if len(grouped) > 1 else ''}: R {test[0].radius:g} mm about "
                     f"x {centre[0]:g}, z {centre[1]:g} mm")
        lines += [f"  {t.direction:<4}{t.path} ({len(t.angles)} samples, {arc_text(t)})" for t in test]
        lines.append("ISO 230-4 (ISO 13041-6 for lathes), over the arcs as measured")
        for d in circular.by_direction:
            lines.append(f"  {d.direction:<4}circular deviation G {d.circular_deviation * 1000:.2f} um, radial deviation F "
                         f"{d.radial_min * 1000:+.2f} .. {d.radial_max * 1000:+.2f} um")
        if circular.hysteresis is not None:
            lines.append(f"  bidirectional circular deviation G(b) {circular.bidirectional_deviation * 1000:.2f} um, "
                         f"circular hysteresis H {circular.hysteresis * 1000:.2f} um")
        lines += [f"  {d.direction:<4}{d.figures}" for d in circular.by_direction]
    if diagnosis is not None:
        lines.append("parametric diagnosis (1 sigma)" + (f", {len(grouped)} tests in one fit" if len(grouped) > 1 else ""))
        rows = [("scaling X", diagnosis.scaling_x, 1e6, "ppm"), ("scaling Z", diagnosis.scaling_z, 1e6, "ppm"),
                ("backlash X", diagnosis.backlash_x, 1e3, "um"), ("backlash Z", diagnosis.backlash_z, 1e3, "um"),
                ("squareness (X per Z)", diagnosis.squareness, 1e6, "urad"),
                ("servo mismatch (X lags Z)", diagnosis.servo_mismatch, 1e3, "um"),
                ("servo lag (X behind Z)", diagnosis.servo_lag_ms, 1.0, "ms"),
                ("squareness + servo mismatch", diagnosis.apparent_squareness, 1e6, "urad")]
        for index, (x, z) in enumerate(diagnosis.centres):
            suffix = f" (test {index + 1})" if len(diagnosis.centres) > 1 else ""
            rows += [(f"set-up centre x{suffix}", x, 1e3, "um"), (f"set-up centre z{suffix}", z, 1e3, "um")]
        lines += [f"  {name:<28}{e.value * unit:+9.3f} +- {e.sigma * unit:.3f} {symbol}"
                  for name, e, unit, symbol in rows if e is not None]
        lines.append(f"  fit residual: {diagnosis.residual}")
    lines += [f"warning: {text}" for text in warnings]
    lines += [f"note: {note}" for note in _notes(grouped, diagnosis)]
    return "\n".join(lines)
