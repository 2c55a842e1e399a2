"""``postproc probe-program PROGRAM``: a FANUC probing program (macro B) for a program's profile.

N touches spread over the features of the nominal profile (its lines and arcs; the profile
and its material side as ``postproc simulate probe`` picks them): at least ``--per-feature``
on each, the rest by length, ``--inset`` clear of each feature's ends (more at a concave
corner, where the stylus needs room). Each is a skip move (G31) along the nominal normal into
the material from ``--clearance`` outside; the latched positions are printed with DPRNT in
the format ``postproc probe-import`` reads (:mod:`postproc.onmachine.probe_printout`), with a datum
touched before and after the profile when ``--datum-x/--datum-z`` give one. How the program
moves and what it assumes: :mod:`postproc.onmachine.probe_cycle`. The program goes to ``-o FILE`` or
stdout; to stderr a summary with the touches each feature got, and a warning for each
feature too short to hold one.
"""

from __future__ import annotations

import sys

import click

from ..compensate import progress
from ..diagnostics import Location, Reporter, UsageError
from ..measure.nominal import MATERIAL, nominal, read_program
from ..files.output import STDOUT, write_atomically
from ..onmachine.probe_cycle import DATUM_SURFACES, Cycle, code_digits, plan, self_check
from ..machine.profile import DEFAULT, load
from .common import COUNT, FINITE, FROM_LINE, MACHINE, NOT_NEGATIVE, POSITIVE, PROGRAM_NUMBER, TO_LINE, examples, guard

DEFAULTS = Cycle()
_PROGRAM_OPTIONS = (
    click.option("--tool", metavar="TNNNN", help="Select the probe with this T code (e.g. T0909)."),
    click.option("--probe-on", metavar="MNN", help="M code that switches the probe on (none: the machine does, e.g. "
                                                   "with the tool change); needs --probe-off."),
    click.option("--probe-off", metavar="MNN", help="M code that switches the probe off (none: the probe does, e.g. "
                                                    "on a timer); needs --probe-on."),
    click.option("--program-number", type=PROGRAM_NUMBER, default=DEFAULTS.program_number, show_default=True, metavar="N",
                 help="The O number of the probing program written."),
    MACHINE(help="A machine profile (TOML): G-code system, diameter mode, limits; without it, the embedded default."),
    click.option("-o", "--output", "output", default=STDOUT, metavar="FILE", help="Write the program here."),
)


def program_options(command):
    """The options of every probing program: the probe's T and M codes, the program number, the
    machine, where the program goes (``--tool --probe-on --probe-off --program-number --machine -o``)."""
    for option in reversed(_PROGRAM_OPTIONS):
        command = option(command)
    return command


@click.command("probe-program", epilog=examples(
    "# 24 touches along the finishing profile, the probe on T0909, M-codes to switch it",
    "postproc probe-program part.nc --points 24 --tool T0909 --probe-on M50 --probe-off M51 -o O8100.nc",
    "# one profile of the program, with a datum on the face",
    "postproc probe-program part.nc --from-line 20 --to-line 48 --datum-x 20 --datum-z 0 -o O8100.nc"))
@click.argument("program", default="-")
@click.option("--points", type=COUNT, default=DEFAULTS.points, show_default=True, metavar="N",
              help="Touches in all, spread over the profile's features.")
@click.option("--per-feature", type=COUNT, default=DEFAULTS.per_feature, show_default=True, metavar="N",
              help="The fewest touches on each feature (line or arc) with room for them: what omp-feedback and "
                   "tool-offset need to screen a feature.")
@FROM_LINE()
@TO_LINE()
@click.option("--material", type=click.Choice(MATERIAL), default="axis", show_default=True,
              help="Which side of the profile is material: towards the spindle axis, or left/right of the "
                   "direction of travel.")
@click.option("--inset", type=NOT_NEGATIVE, default=DEFAULTS.inset, show_default=True, metavar="MM",
              help="Keep the touches this far (along the profile) from both ends of every feature; more at a concave "
                   "corner, as the stylus needs.")
@click.option("--stylus-radius", type=POSITIVE, default=DEFAULTS.stylus_radius, show_default=True, metavar="MM",
              help="The stylus ball's radius: the touch points are offset by it along the normals.")
@click.option("--clearance", type=POSITIVE, default=DEFAULTS.clearance, show_default=True, metavar="MM",
              help="Each approach starts this far from the nominal surface.")
@click.option("--overtravel", type=POSITIVE, metavar="MM",
              help="How far beyond the nominal surface the skip move aims (default: the clearance).")
@click.option("--feed", type=POSITIVE, default=DEFAULTS.feed, show_default=True, metavar="MM/MIN",
              help="Probing feed of the skip moves (calibrate at the same feed).")
@click.option("--travel-feed", type=POSITIVE, default=DEFAULTS.travel_feed, show_default=True, metavar="MM/MIN",
              help="Feed of the moves near the part.")
@click.option("--datum-x", type=FINITE, metavar="MM", help="Datum point x (radius), with --datum-z.")
@click.option("--datum-z", type=FINITE, metavar="MM", help="Datum point z, with --datum-x.")
@click.option("--datum-on", type=click.Choice(DATUM_SURFACES), default="face", show_default=True,
              help="The datum point lies on a face (touched from +Z), a diameter (from +X), or both (a corner).")
@program_options
def command(program, points, per_feature, from_line, to_line, material, inset, stylus_radius, clearance, overtravel,
            feed, travel_feed, datum_x, datum_z, datum_on, tool, probe_on, probe_off, program_number, machine, output):
    """Write a FANUC probing program (G31, DPRNT) for the profile of a part program."""
    if (datum_x is None) != (datum_z is None):
        raise UsageError("a datum is a point: give --datum-x and --datum-z together")
    cycle = Cycle(points, stylus_radius, clearance, overtravel, feed, travel_feed, program_number, inset,
                  None if datum_x is None else (datum_x, datum_z), datum_on, code_digits(tool, "T"),
                  code_digits(probe_on, "M"), code_digits(probe_off, "M"), per_feature)
    cycle.check()  # the options first: before any file is read
    guard([("PROGRAM", program), ("--machine", machine)], [("-o", output)])
    profile = load(machine) if machine else DEFAULT
    reporter = Reporter(sys.stderr)
    name, moves = read_program(program, profile, reporter)
    planned = plan(moves, nominal(moves, from_line, to_line, material, name), cycle, profile)
    self_check(planned, profile)
    for feature, count in zip(planned.features, planned.spread.counts):
        if not count:
            reporter.warn(f"{feature.describe()} ({feature.length:.3f} mm) has no room for a touch clear of its ends: "
                          "not probed (omp-feedback leaves it as programmed)", Location(name))
    if tool is None:
        reporter.warn("no --tool: the probing program selects no tool; index the probe before it runs",
                      Location(name))
    write_atomically(output, planned.text.encode())
    reporter.close()
    datums = len(planned.touches) - len(planned.points)
    first, last = planned.lines
    progress.inform(f"{name}: probing program O{program_number:04d}: {len(planned.points)} points on lines "
                    f"{first}-{last}{f', {datums} datum touches' if datums else ''}; read its printout with "
                    "'postproc probe-import'")
    for feature, count, (start, end) in zip(planned.features, planned.spread.counts, planned.spread.insets):
        progress.inform(f"  {feature.describe()}: {count} point{'' if count == 1 else 's'}"
                        + (f", {start:.3f} mm from its start and {end:.3f} mm from its end" if count else ""))
