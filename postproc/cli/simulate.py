"""``postproc simulate ballbar|cut|probe|calibrate|inspect``: the virtual lathe on the command line.

Each subcommand writes one file in its formats.md form (the surface of ``cut`` in postproc's
own form) to ``-o FILE`` or stdout; ``inspect`` prints the four figures, or with ``--json`` one
JSON object with them and the deviation at each point. The machine, probe and set-up come
from the ``[simulation]`` table of ``--machine FILE.toml`` (none: a perfect machine); options
override the table's defaults. The same ``--seed`` gives the same file. Errors are raised as
PostprocError for the command line to report.
"""

from __future__ import annotations

import dataclasses
import json
import sys

import click

from ..diagnostics import Reporter, UsageError
from ..measure.features import MIN_TOUCHES
from ..measure.nominal import MATERIAL
from ..files.output import STDOUT, write_atomically
from ..simulator import ballbar_test, calibrate, cut, generator, inspect, load, nominal, probe_profile, program_test
from ..simulator.files import calibration_text, cmm_probe_text, probe_text, read_surface, surface_text, trace_text
from ..simulator.nominal import run_program
from .common import ARC, COUNT, FINITE, FROM_LINE, MACHINE, NOT_NEGATIVE, OVERTRAVEL, POINTS, POSITIVE, SEED, TO_LINE, examples, guard


def check_table(profile, origin: str) -> None:
    """Refuse a profile's ``[simulation]`` table as ``simulate`` would read it (for ``profile
    show``, which checks what it does not print)."""
    from ..simulator.config import from_table

    from_table(profile.extra["simulation"], profile, origin)


def _machine(function):
    return MACHINE(help="A machine profile (TOML) with a [simulation] table; without it, a perfect machine.")(function)


def _seed(function):
    return click.option("--seed", type=SEED, metavar="N", help="Seed of the noise (default: the table's seed).")(function)


def _output(function):
    return click.option("-o", "--output", "output", default=STDOUT, metavar="FILE",
                        help="Write the file here instead of stdout.")(function)


def _profile_options(function):
    function = click.option("--material", type=click.Choice(MATERIAL), default="axis", show_default=True,
                            help="Which side of the profile is material: towards the spindle axis, or left/right "
                                 "of the direction of travel.")(function)
    function = TO_LINE()(function)
    function = FROM_LINE()(function)
    return click.argument("program", default="-")(function)


def _provenance(command: str, machine: str | None, seed: int | None = None, program: str | None = None) -> dict:
    facts: dict[str, object] = {"simulated-by": f"postproc simulate {command}", "machine": machine or "perfect"}
    if seed is not None:
        facts["seed"] = seed
    if program is not None:
        facts["program"] = program
    return facts


def _setup(machine, program, from_line, to_line, material):
    simulation, profile = load(machine)
    reporter = Reporter(sys.stderr)
    name, moves, wear = run_program(program, profile, reporter)
    reporter.close()
    return simulation, name, moves, nominal(moves, from_line, to_line, material, name), wear


def _surface(path, simulation, moves, profile_of, wear):
    return read_surface(path) if path else cut(moves, profile_of, simulation, wear)


@click.group("simulate", epilog=examples(
    "postproc simulate ballbar --machine samples/machines/v40r-sim.toml --direction cw -o cw.csv",
    "postproc simulate probe part.nc --machine samples/machines/v40r-sim.toml -o pass1.csv"))
def command() -> None:
    """The virtual lathe: ballbar tests, cuts, probing and inspection (docs/methods.md §8)."""


@command.command("ballbar", epilog=examples(
    "# a whole-circle test in both directions on the sample lathe",
    "postproc simulate ballbar --machine samples/machines/v40r-sim.toml --direction ccw -o ccw.csv",
    "postproc simulate ballbar --machine samples/machines/v40r-sim.toml --direction cw -o cw.csv",
    "# a lathe's 220 deg arc, as the instrument's raw readings",
    "postproc simulate ballbar --machine samples/machines/v40r-sim.toml --start-angle 200 --capture-arc 220 "
    "--overtravel 2 --form raw -o ccw-raw.csv"))
@_machine
@_seed
@click.option("--direction", type=click.Choice(["ccw", "cw"]), default="ccw", show_default=True,
              help="ccw: the G03 run (theta decreasing); cw: the G02 run.")
@click.option("--form", type=click.Choice(["processed", "raw"]), default="processed", show_default=True,
              help="processed: angle and deviation (docs/formats.md §4); raw: the instrument's readings in time order.")
@click.option("--radius", type=POSITIVE, metavar="MM", help="Test radius (default: the table's).")
@click.option("--center-x", type=FINITE, metavar="MM", help="Test centre x (radius mm).")
@click.option("--center-z", type=FINITE, metavar="MM", help="Test centre z.")
@click.option("--feed", type=POSITIVE, metavar="MM/MIN", help="Feed (default: the table's).")
@click.option("--start-angle", type=FINITE, metavar="DEG", help="theta of the first captured sample (default: the table's).")
@click.option("--capture-arc", type=ARC, metavar="DEG",
              help="The arc captured (default: the table's, 360; a lathe's XZ test: about 220).")
@click.option("--overtravel", type=OVERTRAVEL, metavar="DEG",
              help="Arc run before and after the capture (default: the table's, 180; a partial arc: a few).")
@click.option("--program", metavar="FILE",
              help="Run the bar along this program's feed moves on the test circle (a test program, compensated or "
                   "not): its direction and feed are the program's; the centre and radius those of its arcs unless "
                   "given.")
@click.option("--centered", is_flag=True,
              help="Mark the trace centered = true: the bar was not re-mounted since the trace whose set-up centre "
                   "counts (an iteration's later traces).")
@_output
def ballbar(machine, seed, direction, form, radius, center_x, center_z, feed, start_angle, capture_arc, overtravel,
            program, centered, output):
    """A ballbar trace: the 720 deg test of docs/methods.md §3 in one direction, or a partial arc, or the
    bar along a program's feed moves."""
    guard([("--machine", machine), ("--program", program)], [("-o", output)])
    simulation, profile = load(machine)
    seed = simulation.seed if seed is None else seed
    if program is not None:
        run = _program_ballbar(simulation, profile, program, seed, form, radius, center_x, center_z, feed, start_angle,
                               capture_arc, overtravel, direction)
        provenance = _provenance("ballbar", machine, seed, run[1])
        write_atomically(output, trace_text(run[0], provenance, centered).encode())
        return
    centre = None
    if center_x is not None or center_z is not None:
        centre = (simulation.ballbar.center_x_mm if center_x is None else center_x,
                  simulation.ballbar.center_z_mm if center_z is None else center_z)
    run = ballbar_test(simulation, generator(seed, f"ballbar-{direction}-{form}"), direction, form, radius, centre, feed,
                       start_angle, capture_arc, overtravel)
    write_atomically(output, trace_text(run, _provenance("ballbar", machine, seed), centered).encode())


def _program_ballbar(simulation, profile, program, seed, form, radius, center_x, center_z, feed, start_angle,
                     capture_arc, overtravel, direction):
    """(the run, the program's name) of ``simulate ballbar --program``; the options a program settles refused."""
    source = click.get_current_context().get_parameter_source
    given = [name for name, value in (("--feed", feed), ("--overtravel", overtravel)) if value is not None]
    given += ["--form raw"] if form == "raw" else []
    if given:
        raise UsageError(f"{' and '.join(given)}: with --program the program sets the feed and the moves, and the "
                         "trace is written processed")
    if (center_x is None) != (center_z is None):
        raise UsageError("a centre is a point: give --center-x and --center-z together (or neither: the program's arcs)")
    reporter = Reporter(sys.stderr)
    name, moves, _ = run_program(program, profile, reporter)
    reporter.close()
    centre = None if center_x is None else (center_x, center_z)
    run = program_test(simulation, generator(seed, "ballbar-program"), moves, name, radius, centre, start_angle,
                       capture_arc)
    if source("direction") == click.core.ParameterSource.COMMANDLINE and direction != run.direction:
        raise UsageError(f"--direction {direction}: the program runs the circle {run.direction} "
                         f"({'G02' if run.direction == 'cw' else 'G03'})")
    return run, name


@command.command("cut", epilog=examples(
    "# the surface the sample part's program leaves on the sample lathe",
    "postproc simulate cut samples/programs/hemishell.nc --machine samples/machines/v40r-sim.toml -o surface.csv"))
@_profile_options
@_machine
@_output
def cut_command(program, from_line, to_line, material, machine, output):
    """The surface a program's profile leaves: a dense polyline ordered along the path."""
    guard([("PROGRAM", program), ("--machine", machine)], [("-o", output)])
    simulation, name, moves, profile_of, wear = _setup(machine, program, from_line, to_line, material)
    surface = cut(moves, profile_of, simulation, wear)
    write_atomically(output, surface_text(surface, _provenance("cut", machine, program=name)).encode())


@command.command("probe", epilog=examples(
    "# probe the surface just cut (or one from 'simulate cut'): 24 touches",
    "postproc simulate probe samples/programs/hemishell.nc --from-line 10 --to-line 10 --machine samples/machines/v40r-sim.toml --points 24 -o pass1.csv",
    "postproc simulate probe samples/programs/hemishell.nc --from-line 10 --to-line 10 --machine samples/machines/v40r-sim.toml --surface surface.csv -o pass1.csv"))
@_profile_options
@click.option("--surface", metavar="FILE", help="The surface to probe (from 'simulate cut'); default: cut it now.")
@click.option("--points", type=POINTS, metavar="N", help="Touches along the profile (default: the table's).")
@click.option("--inset", type=NOT_NEGATIVE, metavar="MM",
              help="Spread the touches over the profile's features as probe-program does, this far from each "
                   "feature's ends (default: evenly along the whole profile, both ends included).")
@click.option("--per-feature", type=COUNT, default=MIN_TOUCHES, show_default=True, metavar="N",
              help="With --inset: the fewest touches on each feature.")
@_machine
@_seed
@_output
def probe(program, from_line, to_line, material, surface, points, inset, per_feature, machine, seed, output):
    """A probe file: touches spread along the profile, the datum before and after."""
    guard([("PROGRAM", program), ("--surface", surface), ("--machine", machine)], [("-o", output)])
    simulation, name, moves, profile_of, wear = _setup(machine, program, from_line, to_line, material)
    seed = simulation.seed if seed is None else seed
    run = probe_profile(_surface(surface, simulation, moves, profile_of, wear), profile_of, simulation,
                        generator(seed, "probe"), points, inset, per_feature)
    write_atomically(output, probe_text(run, _provenance("probe", machine, seed, name)).encode())


@command.command("calibrate", epilog=examples(
    "postproc simulate calibrate --machine samples/machines/v40r-sim.toml -o artifact.csv",
    "postproc simulate calibrate --machine samples/machines/v40r-sim.toml --step-deg 10 --seed 7 -o artifact.csv"))
@_machine
@_seed
@click.option("--radius", type=POSITIVE, metavar="MM", help="Artifact radius (default: the table's).")
@click.option("--center-x", type=FINITE, metavar="MM", help="Artifact centre x (radius mm).")
@click.option("--center-z", type=FINITE, metavar="MM", help="Artifact centre z.")
@click.option("--step-deg", type=POSITIVE, metavar="DEG", help="Angle between touches (default: the table's).")
@_output
def calibrate_command(machine, seed, radius, center_x, center_z, step_deg, output):
    """A probe calibration on the sphere artifact: touches over its top 180 deg."""
    guard([("--machine", machine)], [("-o", output)])
    simulation, _ = load(machine)
    seed = simulation.seed if seed is None else seed
    changes = {key: value for key, value in (("radius_mm", radius), ("center_x_mm", center_x),
                                             ("center_z_mm", center_z), ("step_deg", step_deg)) if value is not None}
    artifact = dataclasses.replace(simulation.artifact, **changes)
    run = calibrate(simulation, generator(seed, "calibrate"), artifact)
    write_atomically(output, calibration_text(run, _provenance("calibrate", machine, seed)).encode())


@command.command("inspect", epilog=examples(
    "# a virtual CMM on the part the program cuts: the four figures",
    "postproc simulate inspect samples/programs/hemishell.nc --machine samples/machines/v40r-sim.toml",
    "postproc simulate inspect samples/programs/hemishell.nc --surface surface.csv --json"))
@_profile_options
@click.option("--surface", metavar="FILE", help="The surface to inspect (from 'simulate cut'); default: cut it now.")
@click.option("--points", type=POINTS, metavar="N", help="Points along the profile (default: the table's).")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of the figures.")
@click.option("--inset", type=NOT_NEGATIVE, metavar="MM",
              help="Spread the points over the profile's features, this far from each feature's ends, as "
                   "'simulate probe --inset' does (default: evenly along the whole profile, both ends included).")
@click.option("--probe-file", metavar="FILE",
              help="Also write the CMM's points as a probe file (docs/formats.md §5), as a CMM measuring "
                   "independently of the machine's axes reports them: for error-map's --probe.")
@_machine
@_seed
def inspect_command(program, from_line, to_line, material, surface, points, as_json, inset, probe_file, machine, seed):
    """A virtual CMM: deviations from the nominal profile along its normal, and the four figures."""
    simulation, name, moves, profile_of, wear = _setup(machine, program, from_line, to_line, material)
    seed = simulation.seed if seed is None else seed
    result = inspect(_surface(surface, simulation, moves, profile_of, wear), profile_of, simulation,
                     generator(seed, "inspect"), points, inset)
    if probe_file:
        write_atomically(probe_file, cmm_probe_text(result, simulation.probe.stylus_radius_mm,
                                                    _provenance("inspect", machine, seed, name)).encode())
    if as_json:
        click.echo(json.dumps({"program": name, **result.as_dict()}, indent=2, allow_nan=False))
    else:
        click.echo(f"{name}: {result.figures}")
