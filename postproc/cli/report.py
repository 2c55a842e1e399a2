"""``postproc report [PROGRAM] [measurements...] -o report.html``: one self-contained HTML report.

The measurement options are those of ``compensate`` (``--plugin``, ``--ballbar``, ``--probe``,
``--calibration``, ``--model``, ``--option``, ``--machine``, ``--tolerance``); with ``--model``
the measurements given are shown beside the saved model (which is not fitted again). The
report opens with its verdict: before and after compensation against the band (``--band``,
else the tolerance in force), pass or fail (:mod:`postproc.report.verdict`); then the
measurements, the ISO 230-4 figures and the fitted models with their uncertainty, the profile
of PROGRAM predicted before and after compensation, the four figures of each, and the
provenance (:mod:`postproc.report`). Without PROGRAM it covers the measurements and the
models; without a compensator, the measurements alone. The file is written all or nothing
(stdout without ``-o``); errors are raised as PostprocError for the command line to report.
"""

from __future__ import annotations

import shlex
import sys

import click

from ..compensate import progress
from ..machine import bounds
from ..diagnostics import Reporter, UsageError
from ..files.output import STDOUT, write_atomically
from .common import (BALLBAR, CALIBRATION, MACHINE, MODEL, OPTION, PLUGIN, POSITIVE, PROBE, TOLERANCE, examples,
                     guard)


@click.command("report", epilog=examples(
    "# the ballbar test, the model fitted from it and the program it compensates",
    "postproc report part.nc --plugin parametric --ballbar ccw.csv --ballbar cw.csv -o report.html",
    "# a saved model's report",
    "postproc report --model lathe3.json -o lathe3.html"))
@click.argument("program", required=False, metavar="[PROGRAM]")
@click.option("-o", "--output", "output", default=STDOUT, metavar="FILE", help="Write the report here (HTML).")
@PLUGIN(help="A compensator to fit and report, in order ('postproc plugins' lists them).")
@BALLBAR()
@PROBE()
@CALIBRATION()
@MODEL()
@OPTION()
@MACHINE()
@TOLERANCE()
@click.option("--band", type=POSITIVE, metavar="MM",
              help="The part's tolerance: the verdict passes when every deviation after compensation lies within "
                   "+-MM of the nominal (default: the tolerance in force).")
def command(program, output, plugins, ballbar, probe, calibration, model, options, machine, tolerance, band):
    """An HTML report: measurements, ISO figures, fitted models, predicted profile, provenance."""
    from ..machine import profile as profiles
    from ..compensate.request import Request
    from ..report.html import render
    from ..report.sections import Inputs, build
    from ..syntax.source import Source

    if options and not plugins and not model:
        raise UsageError("--option was given but no compensator (--plugin) to take it")
    if not (program or plugins or model or ballbar or probe or calibration):
        raise UsageError("nothing to report on: give a program, measurements or a compensator")
    guard([("PROGRAM", program), ("--calibration", calibration), ("--model", model), ("--machine", machine)]
          + [("--ballbar", name) for name in ballbar] + [("--probe", name) for name in probe], [("-o", output)])
    if band is not None:
        bounds.bounded(band, "--band", bounds.MAX_BAND, "wider than any band a compensated part is judged against")
    reporter = Reporter(sys.stderr)
    loaded = None
    if program is not None:
        with Source(program) as source:
            loaded = (source.name, source.read_bytes())
    request = Request(plugins=list(plugins), ballbar=list(ballbar), probe=list(probe), calibration=calibration,
                      model=model, options=list(options), tolerance=tolerance)
    profile = profiles.load(machine) if machine else profiles.DEFAULT
    inputs = Inputs(loaded, request, machine, profile, _command_line(program, output, request, machine, band), band)
    document = build(inputs, reporter)
    write_atomically(output, render(document, "Made by postproc report; self-contained: no external resources.").encode())
    reporter.close()
    if output != STDOUT:
        shown = ([document.lead] if document.lead is not None else []) + document.sections
        images = sum(1 for _ in _images(shown))
        progress.inform(f"{output}: report written ({len(shown)} sections, {images} figures)")


def _images(sections):
    from ..report.document import Image

    for section in sections:
        yield from (part for part in section.parts if isinstance(part, Image))
        yield from _images(section.subsections)


def _command_line(program, output, request, machine, band) -> str:
    words = ["postproc", "report"] + ([program] if program else [])
    for flag, values in (("--plugin", request.plugins), ("--ballbar", request.ballbar), ("--probe", request.probe),
                         ("--calibration", [request.calibration] if request.calibration else []),
                         ("--model", [request.model] if request.model else []), ("--option", request.options),
                         ("--machine", [machine] if machine else []),
                         ("--tolerance", [f"{request.tolerance:g}"] if request.tolerance is not None else []),
                         ("--band", [f"{band:g}"] if band is not None else [])):
        for value in values:
            words += [flag, value]
    return shlex.join(words + ["-o", output])
