"""``postproc ballbar FILE... [--json] [--plot FILE]``: ISO 230-4 figures and error diagnosis of traces.

One trace, or the ccw and the cw trace of one test. A human-readable report goes to stdout,
or with ``--json`` exactly one JSON object: the keys of formats.md plus
``bidirectional_circular_deviation_mm``, ``servo_mismatch_mm`` and ``servo_lag_ms`` (X behind Z;
the lag needs the feed in both headers), ``apparent_squareness_rad`` (one trace only),
``setup_center_mm`` (the centre the reader removed from each trace), ``trace_figures_um`` and
``fit_residual_um`` (the four figures), ``uncertainty`` (1 sigma, in each key's own unit),
``needs_both_directions`` and ``notes``. A figure a trace cannot support is null: with one
trace G(b), H, squareness and servo mismatch (``needs_both_directions`` lists them); with a
trace that does not go round the circle, the whole diagnosis. Errors are raised as
PostprocError for the command line to report.
"""

from __future__ import annotations

import json
import sys

import click

from ..ballbar_analysis import MAX_GAP_DEG, CircularTest, Diagnosis, Estimate, circular_test, diagnose
from ..diagnostics import Reporter, UsageError
from ..measurements.ballbar import BallbarTrace, read_ballbar
from ..plotting import plot_traces
from .common import POSITIVE, guard

BOTH_DIRECTIONS = ["bidirectional_circular_deviation_mm", "hysteresis_mm", "squareness_rad", "servo_mismatch_mm",
                   "servo_lag_ms"]
DIAGNOSIS = ["scaling_x", "scaling_z", "backlash_x_mm", "backlash_z_mm", "squareness_rad", "servo_mismatch_mm",
             "servo_lag_ms", "apparent_squareness_rad"]


@click.command("ballbar")
@click.argument("files", nargs=-1, required=True, metavar="FILE...")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of the report.")
@click.option("--plot", metavar="FILE", help="Write a polar plot of the traces (.png or .svg).")
@click.option("--averaging", type=click.IntRange(min=1), default=6, show_default=True, metavar="N",
              help="Raw form: readings averaged per sample.")
@click.option("--max-deviation", type=POSITIVE, default=1.0, show_default=True,
              metavar="MM", help="A deviation beyond this is not a plausible ballbar reading.")
def command(files, as_json, plot, averaging, max_deviation):
    """ISO 230-4 figures and error diagnosis of one ballbar trace, or of a ccw and a cw trace."""
    if len(files) > 2:
        raise UsageError(f"give one trace or a ccw and a cw trace of one test, not {len(files)} files")
    guard([("FILE", name) for name in files], [("--plot", plot)])
    reporter = Reporter(sys.stderr)
    traces = [read_ballbar(name, reporter, averaging, max_deviation) for name in files]
    test = circular_test(traces)
    full = all(trace.full for trace in traces)
    diagnosis = diagnose(traces) if full else None
    if plot:
        plot_traces(traces, plot)
    if as_json:
        click.echo(json.dumps(_result(traces, test, diagnosis), indent=2, allow_nan=False))
    else:
        click.echo(_report(traces, test, diagnosis))
    reporter.close()


def _result(traces: list[BallbarTrace], test: CircularTest, diagnosis: Diagnosis | None) -> dict:
    """The JSON object: every key always present, null where the traces cannot support it."""
    by_direction = {d.direction: d for d in test.by_direction}
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
    centre = diagnosis.centre_offset if diagnosis else (None, None)
    return {
        "radius_mm": traces[0].radius,
        "center_mm": {"x": traces[0].centre[0], "z": traces[0].centre[1]},
        "traces": {d: next((t.path for t in traces if t.direction == d), None) for d in ("ccw", "cw")},
        "circular_deviation_mm": {d: by_direction[d].circular_deviation if d in by_direction else None
                                  for d in ("ccw", "cw")},
        "radial_deviation_mm": {d: {"min": by_direction[d].radial_min, "max": by_direction[d].radial_max}
                                if d in by_direction else None for d in ("ccw", "cw")},
        "bidirectional_circular_deviation_mm": test.bidirectional_deviation,
        "hysteresis_mm": test.hysteresis,
        "trace_figures_um": {d: by_direction[d].figures.as_dict() if d in by_direction else None
                             for d in ("ccw", "cw")},
        **{key: _value(estimate) for key, estimate in fields.items()},
        "center_offset_mm": {"x": _value(centre[0]), "z": _value(centre[1])},
        "setup_center_mm": {d: next(({"x": t.setup_centre[0], "z": t.setup_centre[1]} for t in traces
                                     if t.direction == d), None) for d in ("ccw", "cw")},
        "uncertainty": {**{key: _sigma(estimate) for key, estimate in fields.items()},
                        "center_offset_mm": {"x": _sigma(centre[0]), "z": _sigma(centre[1])}},
        "fit_residual_um": diagnosis.residual.as_dict() if diagnosis else None,
        "needs_both_directions": BOTH_DIRECTIONS if len(traces) == 1 else [],
        "notes": _notes(traces, diagnosis),
    }


def _notes(traces: list[BallbarTrace], diagnosis: Diagnosis | None) -> list[str]:
    """What the traces could not support, and why."""
    notes = []
    if len(traces) == 1:
        notes.append(f"one direction ({traces[0].direction}) only: G(b), H, squareness and servo mismatch need a ccw "
                     "and a cw trace; one trace sees only squareness plus its share of servo mismatch "
                     "(apparent_squareness_rad)")
    if diagnosis is None:
        notes.append(f"the parametric diagnosis needs traces round the whole circle (no gap over {MAX_GAP_DEG:g} deg)")
    return notes


def _value(estimate: Estimate | None) -> float | None:
    return None if estimate is None else estimate.value


def _sigma(estimate: Estimate | None) -> float | None:
    return None if estimate is None else estimate.sigma


def _report(traces: list[BallbarTrace], test: CircularTest, diagnosis: Diagnosis | None) -> str:
    """The report for people: micrometres, and ppm / urad for the dimensionless parameters."""
    centre = traces[0].centre
    lines = [f"ballbar test: R {traces[0].radius:g} mm about x {centre[0]:g}, z {centre[1]:g} mm"]
    lines += [f"  {t.direction:<4}{t.path} ({len(t.angles)} samples)" for t in traces]
    lines.append("ISO 230-4")
    for d in test.by_direction:
        lines.append(f"  {d.direction:<4}circular deviation G {d.circular_deviation * 1000:.2f} um, radial deviation F "
                     f"{d.radial_min * 1000:+.2f} .. {d.radial_max * 1000:+.2f} um")
    if test.hysteresis is not None:
        lines.append(f"  bidirectional circular deviation G(b) {test.bidirectional_deviation * 1000:.2f} um, "
                     f"circular hysteresis H {test.hysteresis * 1000:.2f} um")
    lines += [f"  {d.direction:<4}{d.figures}" for d in test.by_direction]
    if diagnosis is not None:
        lines.append("parametric diagnosis (1 sigma)")
        rows = [("scaling X", diagnosis.scaling_x, 1e6, "ppm"), ("scaling Z", diagnosis.scaling_z, 1e6, "ppm"),
                ("backlash X", diagnosis.backlash_x, 1e3, "um"), ("backlash Z", diagnosis.backlash_z, 1e3, "um"),
                ("squareness (X per Z)", diagnosis.squareness, 1e6, "urad"),
                ("servo mismatch (X lags Z)", diagnosis.servo_mismatch, 1e3, "um"),
                ("servo lag (X behind Z)", diagnosis.servo_lag_ms, 1.0, "ms"),
                ("squareness + servo mismatch", diagnosis.apparent_squareness, 1e6, "urad"),
                ("set-up centre x", diagnosis.centre_offset[0], 1e3, "um"),
                ("set-up centre z", diagnosis.centre_offset[1], 1e3, "um")]
        lines += [f"  {name:<28}{e.value * unit:+9.3f} +- {e.sigma * unit:.3f} {symbol}"
                  for name, e, unit, symbol in rows if e is not None]
        lines.append(f"  fit residual: {diagnosis.residual}")
    lines += [f"note: {note}" for note in _notes(traces, diagnosis)]
    return "\n".join(lines)
