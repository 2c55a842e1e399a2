"""``postproc probe-import PRINTOUT``: the DPRNT printout of a probing program as a probe file.

The printout is what the control sent through its RS-232 port or wrote to its memory card
while the program of ``postproc probe-program`` ran (``-``: standard input); its format and
what the reader tolerates: :mod:`postproc.onmachine.probe_printout`. The probe file (docs/formats.md
§5: stylus centres in radius mm, unit approach vectors, the datum keys) goes to ``-o
FILE`` or stdout, written atomically; a line that is not a record of the printout is refused
with its line number (exit 3) and nothing is written.
"""

from __future__ import annotations

import os
import sys

import click

from ..compensate import progress
from ..diagnostics import Reporter
from ..files.output import STDOUT, write_atomically
from ..onmachine.probe_printout import probe_data, probe_file_text, read_printout
from .common import POSITIVE, examples, guard


@click.command("probe-import", epilog=examples(
    "# the DPRNT printout of O8100, captured from the control, as a probe file",
    "postproc probe-import o8100-printout.txt -o pass1.csv",
    "postproc probe-import o8100-printout.txt --stylus-radius 3 -o pass1.csv"))
@click.argument("printout")
@click.option("--stylus-radius", type=POSITIVE, metavar="MM",
              help="The stylus radius the probe file names (default: the one the program was written for).")
@click.option("--repeatability", type=POSITIVE, default=0.003, show_default=True, metavar="MM",
              help="The machine's repeatability: the datum check's limit (docs/methods.md §1: X +-0.003 mm).")
@click.option("-o", "--output", "output", default=STDOUT, metavar="FILE", help="Write the probe file here.")
def command(printout, stylus_radius, repeatability, output):
    """Turn the DPRNT printout of a postproc probing program into a probe file."""
    guard([("PRINTOUT", printout)], [("-o", output)])
    reporter = Reporter(sys.stderr)
    run = read_printout(printout)
    data = probe_data(run, stylus_radius, repeatability, reporter)
    provenance = {"imported-by": "postproc probe-import", "printout": os.path.basename(run.path),
                  "probing-program": f"O{run.program:04d}"}
    write_atomically(output, probe_file_text(data, provenance).encode())
    reporter.close()
    datum = ", datum " + " and ".join(sorted(data.datum_before)) if data.datum_before else ", no datum"
    progress.inform(f"{run.path}: {len(data.centres)} points{datum}")
