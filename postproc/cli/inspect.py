"""``postproc inspect PROGRAM --probe FILE --band MM``: in tolerance, or re-cut with compensation?

The question the source's loop asks after each on-machine inspection (docs/methods.md §9.8: cut,
inspect with the probe, are the errors acceptable?). The probe file is read against the
nominal profile of PROGRAM (its first chain of feed moves, or the moves of ``--from-line``
to ``--to-line``, as ``postproc simulate`` picks it) through :func:`postproc.measure.probing.probe_profile`:
the calibration applied (k = 0 and a warning without one), the datum stability check
(refused with exit 4 unless ``--force``), the deviations along the nominal normal (positive =
material left) and the screening of the nub and outliers, whose replacements are reported.

Verdict: every cleaned deviation within +-band: "in tolerance", exit 0; otherwise "re-cut
with compensation", exit 1, with the ``postproc compensate ... --plugin omp-feedback`` command
line that does it. stdout carries the report (with ``--json``, one JSON object: ``in_tolerance``,
``verdict``, ``command``, ``band_mm``, ``figures_um`` as probed and cleaned, ``largest_deviation``,
``outside``, ``notes``, ``dropped`` and every point); warnings and errors go to stderr.
"""

from __future__ import annotations

import json
import os
import shlex
import sys

import click
import numpy as np

from ..compensate import progress
from ..diagnostics import EXIT_WOULD_CHANGE, Reporter
from ..machine import bounds
from ..measure.figures import figures
from ..geometry import Profile, segment_of
from ..measure.readers.registry import ReadContext, read as read_measurement
from ..measure.nominal import chain, read_program
from ..compensate.registry import readers
from ..measure.pretravel import fit_calibration
from ..measure.probing import FORCE_FLAG, ProbedProfile, probe_profile
from ..machine.profile import DEFAULT, load
from .common import CALIBRATION, POSITIVE, FROM_LINE, MACHINE, TO_LINE, examples, guard

EXIT_RECUT = EXIT_WOULD_CHANGE  #: as ``--check``: the part would change if the loop goes on
IN_TOLERANCE, RECUT = "in tolerance", "re-cut with compensation"


def compensate_command(program: str, probe: str, calibration: str | None, machine: str | None, force: bool) -> str:
    """The command line that re-cuts the profile with the probed deviations inverted."""
    parts = ["postproc", "compensate", program, "--plugin", "omp-feedback", "--probe", probe]
    if calibration:
        parts += ["--calibration", calibration]
    if machine:
        parts += ["--machine", machine]
    if force:
        parts.append(FORCE_FLAG)
    if program != "-":
        root, extension = os.path.splitext(program)
        parts += ["-o", f"{root}-omp{extension or '.nc'}"]
    return shlex.join(parts)


@click.command("inspect", epilog=examples(
    "# in a +-5 um band (exit 0), or re-cut (exit 1, with the command that does it)",
    "postproc inspect part.nc --probe pass1.csv --calibration artifact.csv --band 0.005",
    "# one profile of the program, as JSON",
    "postproc inspect part.nc --probe pass1.csv --band 0.005 --from-line 20 --to-line 48 --json"))
@click.argument("program", default="-")
@click.option("--probe", "probe_path", required=True, metavar="FILE", help="Probe points measured on the part.")
@CALIBRATION()
@click.option("--band", type=POSITIVE, required=True, metavar="MM",
              help="Tolerance: every cleaned deviation must lie within +-MM.")
@FROM_LINE()
@TO_LINE()
@MACHINE()
@click.option("--force", is_flag=True, help="Use the points even though the datum moved.")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of the report.")
def command(program, probe_path, calibration, band, from_line, to_line, machine, force, as_json):
    """Deviations of probed points from the nominal profile: in tolerance (exit 0) or re-cut (exit 1)."""
    bounds.bounded(band, "--band", bounds.MAX_BAND, "wider than any band a compensated part is judged against")
    guard([("PROGRAM", program), ("--probe", probe_path), ("--calibration", calibration), ("--machine", machine)], [])
    profile = load(machine) if machine else DEFAULT
    reporter = Reporter(sys.stderr)
    name, moves = read_program(program, profile, reporter)
    chosen = [moves[i] for i in chain(moves, from_line, to_line, name)]
    nominal = Profile(tuple(segment_of(move) for move in chosen))
    installed = readers()
    context = ReadContext(reporter)
    probe = read_measurement(probe_path, "probe", installed, context)
    model = fit_calibration(read_measurement(calibration, "calibration", installed, context)) if calibration else None
    probed = probe_profile(probe, nominal, model, reporter=reporter, force=force,
                           lines=tuple(move.line for move in chosen))
    result = _result(name, probe_path, calibration, band, (chosen[0].line, chosen[-1].line), nominal, probed)
    ranking = set(model.report()[2:]) if model is not None else set()  # every candidate's score: --json only
    result["summary"] = [note for note in result["notes"] if note not in ranking]
    result["command"] = None if result["in_tolerance"] else compensate_command(program, probe_path, calibration,
                                                                               machine, force)
    reporter.close()
    click.echo(_report(result) if not as_json else json.dumps({k: v for k, v in result.items() if k != "summary"},
                                                              indent=2, allow_nan=False))
    if not result["in_tolerance"]:
        progress.inform(f"{name}: {RECUT}: {result['outside']} of {result['points']} points outside +-{band:g} mm")
        sys.exit(EXIT_RECUT)


def _result(name: str, probe_path: str, calibration: str | None, band: float, lines: tuple[int, int],
            nominal: Profile, probed: ProbedProfile) -> dict:
    cleaned = probed.cleaned
    outside = np.abs(cleaned) > band + 1e-12
    worst = int(np.argmax(np.abs(cleaned)))
    in_tolerance = not bool(outside.any())
    return {
        "program": name,
        "probe": probe_path,
        "calibration": calibration,
        "lines": list(lines),
        "profile_length_mm": nominal.length,
        "band_mm": band,
        "points": len(cleaned),
        "in_tolerance": in_tolerance,
        "verdict": IN_TOLERANCE if in_tolerance else RECUT,
        "largest_deviation": {"point": worst + 1, "row": probed.rows[worst], "deviation_mm": float(cleaned[worst])},
        "outside": int(outside.sum()),
        "figures_um": {"probed": figures(probed.deviation).as_dict(), "cleaned": figures(cleaned).as_dict()},
        "notes": list(probed.notes),
        "dropped": [{"point": d.index + 1, "row": d.row, "kind": d.kind, "deviation_mm": d.deviation,
                     "replacement_mm": d.replacement} for d in probed.screening.dropped],
        "deviations": [{"point": i + 1, "row": row, "x_mm": float(p[0]), "z_mm": float(p[1]), "s_mm": float(s),
                        "deviation_mm": float(d), "cleaned_mm": float(c), "kept": bool(k)}
                       for i, (row, p, s, d, c, k) in enumerate(zip(probed.rows, probed.touched,
                                                                    probed.deviations.nearest.s, probed.deviation,
                                                                    cleaned, probed.kept))],
    }


def _report(result: dict) -> str:
    first, last = result["lines"]
    worst = result["largest_deviation"]
    figures_um = result["figures_um"]

    def four(f: dict) -> str:
        return (f"mean {f['mean_um']:+.2f} um, mean |e| {f['mean_abs_um']:.2f} um, RMS {f['rms_um']:.2f} um, "
                f"sigma {f['std_um']:.2f} um ({f['count']} points)")

    lines = [f"{result['program']}: {result['points']} points of {result['probe']} against lines {first}-{last} "
             f"({result['profile_length_mm']:.3f} mm of profile), band +-{result['band_mm']:g} mm"]
    lines += [f"  {note}" for note in result.pop("summary")]
    lines += [f"probed:  {four(figures_um['probed'])}", f"cleaned: {four(figures_um['cleaned'])}",
              f"largest cleaned deviation {worst['deviation_mm']:+.4f} mm at point {worst['point']} "
              f"(row {worst['row']}); {result['outside']} of {result['points']} points outside the band",
              result["verdict"]]
    if result["command"]:
        lines.append(f"  {result['command']}")
    return "\n".join(lines)
