"""The ``postproc`` command line (docs/formats.md §7, §8). Thin: it parses options,
calls the library and turns errors into messages and exit codes.

Only the program (or the CSV, or the report asked for) goes to stdout; every message goes
to stderr. On any non-zero exit no output program is written.
"""

from __future__ import annotations

import functools
import os
import sys

import click

from . import __version__
from . import profile as profiles
from .diagnostics import EXIT_INTERNAL, EXIT_WOULD_CHANGE, PostprocError, Reporter, UsageError
from .output import STDOUT, Spool
from .source import Source


def _reported(command):
    """Run a command; a PostprocError becomes its message and exit code."""

    @functools.wraps(command)
    def wrapper(*args, **kwargs):
        try:
            return command(*args, **kwargs)
        except PostprocError as exc:
            click.echo(str(exc), err=True)
            sys.exit(exc.exit_code)
        except (KeyboardInterrupt, click.exceptions.Exit, click.ClickException):
            raise
        except BrokenPipeError:
            sys.exit(EXIT_INTERNAL)
        except Exception as exc:  # a bug: say so in one line, keep the traceback for debugging
            if os.environ.get("POSTPROC_DEBUG"):
                raise
            click.echo(f"postproc: internal error: {exc.__class__.__name__}: {exc} "
                       "(set POSTPROC_DEBUG=1 to see where)", err=True)
            sys.exit(EXIT_INTERNAL)

    return wrapper


def _profile(machine: str | None) -> profiles.MachineProfile:
    return profiles.load(machine) if machine else profiles.DEFAULT


def _wrap(command: click.Command) -> None:
    """Give a command, and every subcommand of a group, the same error reporting."""
    if command.callback is not None:
        command.callback = _reported(command.callback)
    for sub in getattr(command, "commands", {}).values():
        _wrap(sub)


class _Commands(click.Group):
    """Commands in modules of their own are imported when used, so that ``postproc check``
    does not pay for numpy, scipy or matplotlib."""

    modules = {
        "artifact-find": "postproc.commands.artifact_find",
        "artifact-program": "postproc.commands.artifact_program",
        "ballbar": "postproc.commands.ballbar",
        "budget": "postproc.commands.budget",
        "import-trace": "postproc.commands.import_trace",
        "inspect": "postproc.commands.inspect",
        "probe-import": "postproc.commands.probe_import",
        "probe-program": "postproc.commands.probe_program",
        "report": "postproc.commands.report",
        "simulate": "postproc.commands.simulate",
    }

    def list_commands(self, ctx):
        return sorted(set(super().list_commands(ctx)) | set(self.modules))

    def get_command(self, ctx, name):
        if name in self.modules and name not in self.commands:
            import importlib

            command = importlib.import_module(self.modules[name]).command
            _wrap(command)
            self.add_command(command, name)
        return super().get_command(ctx, name)


class _Tee:
    """stderr that also goes to a log file (for CAM systems that do not show stderr)."""

    def __init__(self, stream, log):
        self.stream, self.log = stream, log

    def write(self, text: str) -> int:
        self.log.write(text)
        self.log.flush()
        return self.stream.write(text)

    def flush(self) -> None:
        self.stream.flush()

    def isatty(self) -> bool:
        return self.stream.isatty()


@click.group(cls=_Commands, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="postproc")
@click.option("--log", metavar="FILE", help="Copy every message to FILE (appended) as well as to stderr.")
def main(log: str | None = None) -> None:
    """Rewrite FANUC lathe part programs so that the next part is cut right."""
    if log:
        try:
            sys.stderr = _Tee(sys.stderr, open(log, "a", encoding="utf-8"))
        except OSError as exc:
            raise click.UsageError(f"--log {log}: {exc.strerror}") from None


@main.command()
@click.argument("inputs", nargs=-1, metavar="[INPUT...]")
@click.option("-o", "--output", "output", metavar="OUTPUT", help="Write the program here instead of stdout.")
@click.option("--out-dir", metavar="DIR", help="Write each program into DIR under its own name.")
@click.option("--plugin", "plugins", multiple=True, metavar="NAME", help="A compensator to apply, in order.")
@click.option("--ballbar", multiple=True, metavar="FILE", help="A ballbar trace.")
@click.option("--probe", multiple=True, metavar="FILE", help="Probe points.")
@click.option("--calibration", metavar="FILE", help="A probe calibration on an artifact.")
@click.option("--model", metavar="FILE", help="A saved compensation model.")
@click.option("--machine", metavar="FILE", help="A machine profile (TOML).")
@click.option("--tolerance", type=float, metavar="MM", help="Largest deviation of the emitted path.")
@click.option("--mode", type=click.Choice(["auto", "arc", "line"]), default="auto", show_default=True)
@click.option("--option", "options", multiple=True, metavar="[PLUGIN.]KEY=VALUE")
@click.option("--region", "regions", multiple=True, metavar="N100-N200|L10-L50|T01",
              help="Compensate only these blocks (several: their union).")
@click.option("--max-correction", type=float, metavar="MM", help="Refuse corrections larger than this.")
@click.option("--force", is_flag=True, help="Compensate a program compensated before; use a failed datum check.")
@click.option("--keep-unplannable", is_flag=True,
              help="Leave a block that cannot be held within the tolerance uncompensated (a warning) instead of refusing.")
@click.option("--diff", is_flag=True, help="Write a unified diff of the change to stdout instead of the program.")
@click.option("--check", "check_only", is_flag=True, help="Write nothing; exit 1 if the program would change.")
@click.option("--jobs", type=click.IntRange(min=1), default=1, show_default=True, help="Programs compensated at once.")
@click.option("--report", "report_file", metavar="FILE", help="Write what each compensator fitted, and how well, as JSON.")
@_reported
def compensate(inputs, output, out_dir, plugins, ballbar, probe, calibration, model, machine, tolerance, mode,
               options, regions, max_correction, force, keep_unplannable, diff, check_only, jobs, report_file):
    """Compensate part programs; with no compensator, write the input back byte for byte."""
    from .api import Pipeline

    inputs = inputs or ("-",)
    if output and out_dir:
        raise UsageError("give -o or --out-dir, not both")
    if len(inputs) > 1 and not (out_dir or diff or check_only):
        raise UsageError("several inputs need --out-dir (or --diff or --check)")
    if (ballbar or probe or calibration) and not plugins:
        raise UsageError("measurements were given but no compensator (--plugin) to use them")
    if options and not plugins and not model:
        raise UsageError("--option was given but no compensator (--plugin) to take it")
    if regions and not plugins and not model:
        raise UsageError("--region was given but no compensator (--plugin) to compensate it")
    if (diff or check_only) and (output or out_dir):
        raise UsageError("--diff and --check write no program: give no -o or --out-dir")
    reporter = Reporter(sys.stderr)
    pipeline = Pipeline(plugins, ballbar, probe, calibration, model, options, tolerance, mode, _profile(machine),
                        max_correction, force, regions, reporter, keep_unplannable=keep_unplannable)
    if diff or check_only:
        changed = [name for name in inputs if _review(pipeline, name, diff)]
        reporter.close()
        if report_file:
            _write_report(pipeline, report_file)
        if check_only and changed:
            for name in changed:
                click.echo(f"{name}: would be changed", err=True)
            sys.exit(EXIT_WOULD_CHANGE)
        return
    if out_dir:
        from . import batch

        jobs_list = [(name, os.path.join(out_dir, os.path.basename(name))) for name in inputs]
        code = batch.run(jobs_list, pipeline, jobs)
        reporter.close()
        if report_file:
            _write_report(pipeline, report_file)
        if code:
            sys.exit(code)
        return
    summary = pipeline.compensate_file(inputs[0], output or STDOUT)
    reporter.close()
    if report_file:
        _write_report(pipeline, report_file)
    if pipeline.core is not None:
        click.echo(
            f"{summary.name}: {summary.replaced} blocks replaced by {summary.emitted}; largest correction "
            f"{summary.largest_correction * 1000:.2f} um; largest deviation from the intended path "
            f"{summary.largest_deviation * 1000:.3f} um",
            err=True,
        )


def _write_report(pipeline, path: str) -> None:
    """The compensators' reports (fitted parameters, uncertainties, figures, dropped points) as JSON."""
    import json

    from .output import write_atomically

    reports = pipeline.core.report() if pipeline.core is not None else []
    write_atomically(path, (json.dumps({"compensators": reports}, indent=1, default=_jsonable) + "\n").encode())


def _jsonable(value):
    if hasattr(value, "tolist"):
        return value.tolist()
    if hasattr(value, "as_dict"):
        return value.as_dict()
    return str(value)


def _review(pipeline, name: str, diff: bool) -> bool:
    """Compensate without writing; print a unified diff if asked. Whether the program changes."""
    import difflib

    with Source(name) as source:
        original = source.read_bytes()
        changed_bytes = pipeline.compensated(source)
        if changed_bytes == original and not diff:
            return False
        before = original.decode("utf-8", "surrogateescape").splitlines(keepends=True)
        after = changed_bytes.decode("utf-8", "surrogateescape").splitlines(keepends=True)
        if diff:
            for line in difflib.unified_diff(before, after, source.name, f"{source.name} (compensated)"):
                sys.stdout.write(line if line.endswith("\n") else line + "\n")
        return changed_bytes != original


@main.command()
@click.option("--plugin", "plugins", multiple=True, required=True, metavar="NAME", help="The compensator to fit.")
@click.option("--ballbar", multiple=True, metavar="FILE", help="A ballbar trace.")
@click.option("--probe", multiple=True, metavar="FILE", help="Probe points.")
@click.option("--calibration", metavar="FILE", help="A probe calibration on an artifact.")
@click.option("--option", "options", multiple=True, metavar="[PLUGIN.]KEY=VALUE")
@click.option("--machine", metavar="FILE", help="A machine profile (TOML).")
@click.option("--note", metavar="TEXT", help="The machine's state, e.g. 'warmed up 2 h'.")
@click.option("--force", is_flag=True, help="Use measurements that failed a check (the datum check).")
@click.option("-o", "--output", "output", metavar="FILE", default="-", help="Where the model goes (JSON).")
@_reported
def fit(plugins, ballbar, probe, calibration, options, machine, note, force, output):
    """Fit a compensator's model from measurements and save it (apply it with compensate --model)."""
    from .models import dumps
    from .output import write_atomically
    from .pipeline import Pipeline
    from .request import Request

    reporter = Reporter(sys.stderr)
    request = Request(list(plugins), list(ballbar), list(probe), calibration, None, list(options), force=force)
    pipeline = Pipeline(request, _profile(machine), reporter)
    write_atomically(output, dumps(pipeline.saved_model(note)).encode())
    reporter.close()


@main.command()
@click.argument("input", default="-")
@click.option("--machine", metavar="FILE", help="A machine profile (TOML).")
@_reported
def check(input, machine):
    """Parse and interpret a program: diagnostics only, no output program."""
    from .program import tally_source

    reporter = Reporter(sys.stderr)
    with Source(input) as source:
        blocks, moves = tally_source(source, _profile(machine), reporter)
        name = source.name
    reporter.close()
    click.echo(f"{name}: ok: {blocks} lines, {moves} moves, {len(reporter.warnings)} warnings", err=True)


@main.command()
@click.argument("input", default="-")
@click.option("--machine", metavar="FILE", help="A machine profile (TOML).")
@click.option("-o", "--output", "output", metavar="FILE", help="Write the CSV here instead of stdout.")
@click.option("--plot", metavar="FILE", help="Draw the path (and the compensated one) to a .png or .svg.")
@click.option("--plugin", "plugins", multiple=True, metavar="NAME", help="With --plot: a compensator to draw.")
@click.option("--ballbar", multiple=True, metavar="FILE")
@click.option("--probe", multiple=True, metavar="FILE")
@click.option("--calibration", metavar="FILE")
@click.option("--model", metavar="FILE")
@click.option("--option", "options", multiple=True, metavar="[PLUGIN.]KEY=VALUE")
@click.option("--tolerance", type=float, metavar="MM")
@click.option("--mode", type=click.Choice(["auto", "arc", "line"]), default="auto")
@_reported
def path(input, machine, output, plot, plugins, ballbar, probe, calibration, model, options, tolerance, mode):
    """The interpreted tool path as CSV, one row per motion; --plot draws it."""
    from .pathcsv import path_rows
    from .program import interpret_source

    profile = _profile(machine)
    reporter = Reporter(sys.stderr)
    if (plugins or model) and not plot:
        raise UsageError("compensators here only draw the compensated path: give --plot")
    with Source(input) as source:
        with Spool(output or STDOUT) as spool:
            for line in path_rows(interpret_source(source, profile, reporter)):
                spool.write(line.encode() + b"\n")
            spool.commit()
        if plot:
            from .api import Pipeline
            from .pathplot import plot_paths

            nominal = [m for s in interpret_source(source, profile, Reporter()) for m in s.moves if m.role != "contour"]
            compensated = None
            if plugins or model:
                pipeline = Pipeline(plugins, ballbar, probe, calibration, model, options, tolerance, mode, profile,
                                    reporter=reporter)
                text = pipeline.compensate_text(source.read_bytes().decode("utf-8", "surrogateescape"), source.name)
                with Source.from_text(text, source.name) as changed:
                    compensated = [m for s in interpret_source(changed, profile, Reporter()) for m in s.moves
                                   if m.role != "contour"]
            plot_paths(nominal, compensated, plot, source.name)
    reporter.close()


@main.group()
def profile():
    """Machine profiles."""


@profile.command("show")
@click.option("--machine", metavar="FILE", help="A machine profile (TOML); without it, the embedded default.")
@_reported
def profile_show(machine):
    """Print the machine profile in force, as TOML."""
    from .profile import to_toml

    click.echo(to_toml(_profile(machine)), nl=False)


@main.command("plugins")
@_reported
def list_plugins():
    """The installed compensators, one per line: name, version, description."""
    from .plugins import compensators

    for name, item in sorted(compensators().items()):
        click.echo(f"{name} {item.version} {item.cls.summary()}")



if __name__ == "__main__":
    main()
