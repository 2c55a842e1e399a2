"""``postproc artifact-find ROUND...``: the calibration sphere's centre and apparent radius from its rounds.

Each ROUND is a probe file (docs/formats.md §5) of one round of ``postproc artifact-program``'s
touches (the pole, +X and -X, imported with ``postproc probe-import``), in the order taken. The
circle through the last round's touches is the finding (docs/methods.md §9.2.1,
:mod:`postproc.measure.artifact`); it counts when it lies within ``--tolerance`` of where that round was
taken. Then, with ``--sweep FILE`` (the calibration touches over the ball, a probe file or a calibration file whose artifact it replaces),
the calibration file (formats.md §6) stating the found centre and apparent radius goes to
``-o FILE`` or stdout; without, the finding is only reported. Not yet converged: exit 1, with
the command line of the next round on stderr and nothing written.
"""

from __future__ import annotations

import os
import sys

import click

from ..machine import bounds
from ..measure.artifact import TOLERANCE, Finding, finding, round_from_touches
from .inspect import EXIT_RECUT
from ..diagnostics import Location, MeasurementError, UsageError
from ..measure.readers.probe import CALIBRATION_MAGIC, Touches, read_calibration, read_probe
from ..files.output import STDOUT, write_atomically
from .common import POSITIVE, examples, guard


@click.command("artifact-find", epilog=examples(
    "# the first round's touches: exit 1 and the next round's artifact-program command, until it settles",
    "postproc artifact-find round1.csv --artifact-radius 25.4",
    "# settled: the calibration file from the sweep over the ball, with the found centre and apparent radius",
    "postproc artifact-find round1.csv round2.csv --artifact-radius 25.4 --sweep sweep.csv -o calibration.csv"))
@click.argument("rounds", nargs=-1, required=True)
@click.option("--artifact-radius", type=POSITIVE, required=True, metavar="MM", help="The sphere's certified radius.")
@click.option("--tolerance", type=POSITIVE, default=TOLERANCE, show_default=True, metavar="MM",
              help="The finding counts when it lies this close to where its round was taken (above the probe's "
                   "repeatability).")
@click.option("--sweep", metavar="FILE", help="The calibration touches over the ball, a probe file or a calibration "
                                              "file: write the calibration file with the found centre and apparent "
                                              "radius.")
@click.option("-o", "--output", "output", default=STDOUT, metavar="FILE", help="Write the calibration file here.")
def command(rounds, artifact_radius, tolerance, sweep, output):
    """Locate the calibration sphere from rounds of pole and side touches; write its calibration file."""
    guard([("ROUND", name) for name in rounds] + [("--sweep", sweep)], [("-o", output)])
    bounds.bounded(tolerance, "--tolerance", bounds.MAX_TOLERANCE,
                   "so coarse that a round far off the ball's centre would count as settled")
    if output != STDOUT and sweep is None:
        raise UsageError("-o writes the calibration file, which needs the calibration's touches: give --sweep FILE")
    files = [read_probe(path) for path in rounds]
    stylus = files[0].stylus_radius
    for probe in files[1:]:
        if abs(probe.stylus_radius - stylus) > 1e-9:
            raise MeasurementError(f"stylus_radius_mm = {probe.stylus_radius:g}, where {files[0].path} has {stylus:g}: "
                                   "the rounds of one finding are taken with one stylus", Location(probe.path))
    taken = [round_from_touches(probe, artifact_radius) for probe in files]
    for number, (probe, found) in enumerate(zip(files, taken), 1):
        click.echo(f"{probe.path}: round {number} at x {found.estimate[0]:.4f} z {found.estimate[1]:.4f}: centre "
                   f"x {found.centre[0]:.4f} z {found.centre[1]:.4f}, apparent radius "
                   f"{found.radius - stylus:.4f} mm, {1000.0 * found.moved:.1f} um from where it was taken", err=True)
    result = finding(taken, stylus, artifact_radius, tolerance)
    if result is None:
        (x, z), last = taken[-1].centre, files[-1].path
        click.echo(f"{last}: not converged ({1000.0 * taken[-1].moved:.1f} um, more than {1000.0 * tolerance:g} um): "
                   f"take the next round at the finding: postproc artifact-program --center-x {x:.4f} --center-z "
                   f"{z:.4f} --artifact-radius {artifact_radius:g} --stylus-radius {stylus:g}", err=True)
        sys.exit(EXIT_RECUT)
    click.echo(f"{files[-1].path}: {result.describe()}", err=True)
    if sweep is not None:
        write_atomically(output, calibration_text(read_sweep(sweep), result, [p.path for p in files]).encode())


def read_sweep(path: str) -> Touches:
    """The calibration touches: a probe file, or a calibration file whose artifact the finding replaces."""
    try:
        with open(path, encoding="utf-8", errors="replace") as handle:
            first = handle.readline().strip()
    except OSError:
        first = ""  # the probe file reader names the file and what is wrong with it
    return read_calibration(path) if first == CALIBRATION_MAGIC else read_probe(path)


def calibration_text(touches: Touches, found: Finding, rounds: list[str]) -> str:
    """The calibration file (formats.md §6) of a sweep's touches about the found artifact."""
    if abs(touches.stylus_radius - found.stylus_radius) > 1e-9:
        raise MeasurementError(f"stylus_radius_mm = {touches.stylus_radius:g}, where the rounds have "
                               f"{found.stylus_radius:g}: calibrate with the stylus the artifact was found with",
                               Location(touches.path))
    keys = {"stylus_radius_mm": f"{found.stylus_radius:.10g}", "artifact_radius_mm": f"{found.apparent_radius:.7f}",
            "artifact_center_x_mm": f"{found.centre[0]:.7f}", "artifact_center_z_mm": f"{found.centre[1]:.7f}",
            "x-artifact-certified-radius-mm": f"{found.artifact_radius:.10g}",
            "x-artifact-found-by": "postproc artifact-find " + " ".join(os.path.basename(r) for r in rounds),
            "x-sweep": os.path.basename(touches.path)}
    rows = ["x_mm,z_mm,approach_x,approach_z"]
    rows += [f"{x:.7f},{z:.7f},{ax:.7f},{az:.7f}" for (x, z), (ax, az) in zip(touches.centres, touches.approach)]
    return "\n".join([CALIBRATION_MAGIC] + [f"# {key} = {value}" for key, value in keys.items()] + rows) + "\n"
