"""``postproc artifact-program``: one round of finding the calibration sphere, as a FANUC probing program.

A touch straight down on the pole at the estimated centre's x, then one from +X and one from
-X at its z (docs/methods.md §9.2.1; :mod:`postproc.onmachine.artifact_cycle`). The printout goes through
``postproc probe-import`` to a probe file, and ``postproc artifact-find`` says where the centre
is or where to take the next round. The program goes to ``-o FILE`` or stdout, a summary to
stderr.
"""

from __future__ import annotations

import sys

import click

from ..compensate import progress
from ..onmachine.artifact_cycle import NAME, plan_round
from ..diagnostics import Location, Reporter
from ..files.output import write_atomically
from ..onmachine.probe_cycle import Cycle, code_digits, self_check
from ..machine.profile import DEFAULT, load
from .common import FINITE, POSITIVE, examples, guard
from .probe_program import DEFAULTS, program_options


@click.command("artifact-program", epilog=examples(
    "# the first round, the centre estimated by eye; the probe on T0909",
    "postproc artifact-program --center-x 80 --center-z 30 --artifact-radius 25.4 --clearance 3 --tool T0909 -o O8100.nc",
    "# the next round, at the last round's finding (artifact-find prints this line)",
    "postproc artifact-program --center-x 80.0123 --center-z 29.9871 --artifact-radius 25.4 -o O8101.nc"))
@click.option("--center-x", type=FINITE, required=True, metavar="MM",
              help="The estimated centre's x (radius): by eye for the first round, the last round's finding after.")
@click.option("--center-z", type=FINITE, required=True, metavar="MM", help="The estimated centre's z.")
@click.option("--artifact-radius", type=POSITIVE, required=True, metavar="MM", help="The sphere's certified radius.")
@click.option("--stylus-radius", type=POSITIVE, default=DEFAULTS.stylus_radius, show_default=True, metavar="MM",
              help="The stylus ball's radius.")
@click.option("--clearance", type=POSITIVE, default=DEFAULTS.clearance, show_default=True, metavar="MM",
              help="Each approach starts this far outside the estimated ball: more than the estimate's error.")
@click.option("--overtravel", type=POSITIVE, metavar="MM",
              help="How far inside the estimated ball the skip move aims (default: the clearance).")
@click.option("--feed", type=POSITIVE, default=DEFAULTS.feed, show_default=True, metavar="MM/MIN",
              help="Probing feed of the skip moves (the calibration's).")
@click.option("--travel-feed", type=POSITIVE, default=DEFAULTS.travel_feed, show_default=True, metavar="MM/MIN",
              help="Feed of the moves near the ball.")
@program_options
def command(center_x, center_z, artifact_radius, stylus_radius, clearance, overtravel, feed, travel_feed, tool,
            probe_on, probe_off, program_number, machine, output):
    """Write a FANUC probing program for one round of finding the calibration sphere's centre."""
    cycle = Cycle(3, stylus_radius, clearance, overtravel, feed, travel_feed, program_number, 0.0, None, "face",
                  code_digits(tool, "T"), code_digits(probe_on, "M"), code_digits(probe_off, "M"))
    cycle.check()  # the options first: before any file is read
    guard([("--machine", machine)], [("-o", output)])
    profile = load(machine) if machine else DEFAULT
    reporter = Reporter(sys.stderr)
    planned = plan_round((center_x, center_z), artifact_radius, cycle, profile)
    self_check(planned, profile)
    if tool is None:
        reporter.warn("no --tool: the probing program selects no tool; index the probe before it runs", Location(NAME))
    write_atomically(output, planned.text.encode())
    reporter.close()
    progress.inform(f"artifact: probing program O{program_number:04d}: the pole, +X and -X of a {artifact_radius:g} "
                    f"mm ball at x {center_x:g} z {center_z:g}; read its printout with 'postproc probe-import', then "
                    "'postproc artifact-find'")
