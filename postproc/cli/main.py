"""The ``postproc`` command line (docs/formats.md §7, §8). Thin: it parses options,
calls the library and turns errors into messages and exit codes.

Only the program (or the CSV, or the report asked for) goes to stdout; every message goes
to stderr. On any non-zero exit no output program is written.
"""

from __future__ import annotations

import functools
import gc
import os
import signal
import sys

import click

from .. import __version__
from ..compensate import progress
from ..machine import profile as profiles
from .common import (BALLBAR, CALIBRATION, COUNT, LOG, MACHINE, MODE, MODEL, OPTION, PLUGIN, POSITIVE, PROBE, PROJECT,
                     TOLERANCE, examples, guard)
from ..diagnostics import (EXIT_INTERNAL, EXIT_WOULD_CHANGE, Location, OptionError, OutputError, PostprocError,
                           Reporter, Stopped, UsageError, format_message)
from ..files.output import STDOUT, Spool
from ..syntax.source import Source

EXIT_INTERRUPTED = 128 + signal.SIGINT  #: 130: Ctrl-C, as the shell reports a program it stopped
EXIT_BROKEN_PIPE = 128 + signal.SIGPIPE  #: 141: the reader of stdout went away
MAX_JOBS = 1024  #: more processes than any machine runs at once: a typo, refused


def _stop(signum, frame):
    raise Stopped(signum)


def _reported(command):
    """Run a command, each of its inputs read once; a PostprocError becomes its message and exit code."""

    @functools.wraps(command)
    def wrapper(*args, **kwargs):
        from ..files.inputs import session

        try:
            _refuse_empty(kwargs)
            _say_project_values()
            with session():  # each input read once, whoever needs it again
                return command(*args, **kwargs)
        except PostprocError as exc:
            click.echo(str(exc), err=True)
            sys.exit(exc.exit_code)
        except (click.exceptions.Exit, click.ClickException, BrokenPipeError):  # a closed pipe: ends quietly
            raise
        except Exception as exc:  # a bug: say so in one line, keep the traceback for debugging
            if os.environ.get("POSTPROC_DEBUG"):
                raise
            click.echo(f"postproc: internal error: {exc.__class__.__name__}: {exc} "
                       "(set POSTPROC_DEBUG=1 to see where)", err=True)
            sys.exit(EXIT_INTERNAL)

    return wrapper


def _refuse_empty(values: dict) -> None:
    """An empty value (``--machine ""``, most often a shell variable that was never set) is a
    usage error, never the option left out: an empty ``--machine`` would drop the profile's
    soft limits, an empty ``-o`` write to stdout."""
    command = click.get_current_context().command
    for param in command.params:
        value = values.get(param.name)
        if value == "" or (isinstance(value, (tuple, list)) and "" in value):
            shown = param.opts[0] if isinstance(param, click.Option) else param.human_readable_name
            raise UsageError(f"{shown} is empty (a shell variable that is not set?): give a value, or leave the "
                             "option out (nothing was written)")


def _say_project_values() -> None:
    """Name the values this run takes from the project file, once on stderr (not with --quiet):
    a plain ``postproc compensate part.nc`` that applies a model must say where the model came from."""
    from click.core import ParameterSource

    context = click.get_current_context()
    project = context.find_root().meta.get(PROJECT)
    if project is None or not project.path:
        return
    taken = [param.opts[0] if isinstance(param, click.Option) else param.name for param in context.command.params
             if context.get_parameter_source(param.name) is ParameterSource.DEFAULT_MAP]
    if taken:
        from ..compensate.progress import inform

        inform(f"{project.path}: project file: {', '.join(taken)} from it (--no-project ignores it)")


def _profile(machine: str | None) -> profiles.MachineProfile:
    return profiles.load(machine) if machine else profiles.DEFAULT


def _wrap(command: click.Command) -> None:
    """Give a command, and every subcommand of a group, the same error reporting."""
    if command.callback is not None:
        command.callback = _reported(command.callback)
    for sub in getattr(command, "commands", {}).values():
        _wrap(sub)


def _with_quiet(command: click.Command) -> click.Command:
    """``-q``/``--quiet`` after the command name too (``postproc compensate ... -q``), as before it."""
    if not any(param.name == "quiet" for param in command.params):
        command.params.append(click.Option(["-q", "--quiet"], **QUIET))
    for sub in getattr(command, "commands", {}).values():
        _with_quiet(sub)
    return command


class _Commands(click.Group):
    """Commands in modules of their own are imported when used, so that ``postproc check``
    does not pay for numpy, scipy or matplotlib."""

    modules = {
        "artifact-find": "postproc.cli.artifact_find",
        "artifact-program": "postproc.cli.artifact_program",
        "ballbar": "postproc.cli.ballbar",
        "budget": "postproc.cli.budget",
        "import-trace": "postproc.cli.import_trace",
        "inspect": "postproc.cli.inspect",
        "probe-import": "postproc.cli.probe_import",
        "probe-program": "postproc.cli.probe_program",
        "report": "postproc.cli.report",
        "simulate": "postproc.cli.simulate",
    }

    own_process = False  #: whether this run is the process's own (set by :meth:`main`)

    def list_commands(self, ctx):
        return sorted(set(super().list_commands(ctx)) | set(self.modules))

    def main(self, args=None, *rest, **extra):
        """With no ``args`` (the console script, ``python -m``) the command line is the whole
        process; called with its arguments (a test, a caller's script) it is a guest in another's."""
        _Commands.own_process = args is None
        if args is None:
            _one_blas_thread()
        return super().main(args, *rest, **extra)

    def invoke(self, ctx):
        """Run the command; end as the shell expects on Ctrl-C (130), on SIGTERM or SIGHUP
        (128 + the signal) and when the reader of stdout has gone (141, quietly)."""
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt:
            click.echo("postproc: interrupted; no file was left half-written", err=True)
            sys.exit(EXIT_INTERRUPTED)
        except Stopped as stop:
            click.echo(f"postproc: stopped by {signal.Signals(stop.signum).name}; no file was left half-written",
                       err=True)
            sys.exit(128 + stop.signum)
        except BrokenPipeError:
            _quiet_stdout()
            sys.exit(EXIT_BROKEN_PIPE)

    def get_command(self, ctx, name):
        if name in self.modules and name not in self.commands:
            import importlib

            command = importlib.import_module(self.modules[name]).command
            _wrap(command)
            self.add_command(command, name)
        command = super().get_command(ctx, name)
        return _with_quiet(command) if command is not None else None


def _quiet_stdout() -> None:
    """Point stdout at /dev/null, so that the interpreter's last flush into a closed pipe says nothing."""
    try:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    except (AttributeError, OSError, ValueError):  # no real descriptor (a test runner's capture)
        pass


class _Tee:
    """stderr that also goes to a log file (for CAM systems that do not show stderr)."""

    def __init__(self, stream, log):
        self.stream, self.log = stream, log

    def write(self, text: str) -> int:
        if self.log is not None:
            try:
                self.log.write(text)
                self.log.flush()
            except OSError as exc:  # a full disk under the log must not lose the message itself
                self.detach_log()
                self.stream.write(format_message("warning", f"--log: cannot write the log ({exc.strerror}); "
                                                            "messages go to stderr only", None) + "\n")
        return self.stream.write(text)

    def write_log(self, text: str) -> None:
        """Into the log alone: what ``--quiet`` keeps off the terminal (diagnostics.say)."""
        if self.log is not None:
            try:
                self.log.write(text)
                self.log.flush()
            except OSError:
                self.detach_log()

    def detach_log(self) -> None:
        """Stop copying to the log (it turned out to be one of the run's inputs, or cannot be written)."""
        log, self.log = self.log, None
        if log is not None:
            try:
                log.close()
            except OSError:
                pass

    def flush(self) -> None:
        self.stream.flush()

    def isatty(self) -> bool:
        return self.stream.isatty()


def _quiet(ctx: click.Context, param, value: bool) -> None:
    """``-q``/``--quiet``, before the command or in it: errors only, from here on."""
    if value:
        progress.set_quiet(True)
        ctx.find_root().call_on_close(lambda: progress.set_quiet(False))


QUIET = dict(is_flag=True, expose_value=False, is_eager=True, callback=_quiet,
             help="Show errors only: no warnings, no summary lines, no progress.")


@click.group(cls=_Commands, context_settings={"help_option_names": ["-h", "--help"]}, epilog=examples(
    "# look at a ballbar test, fit a model from it, compensate a program with it",
    "postproc ballbar ccw.csv cw.csv --plot polar.png",
    "postproc fit --plugin parametric --ballbar ccw.csv --ballbar cw.csv -o lathe3.json",
    "postproc compensate part.nc --model lathe3.json -o part-comp.nc",
    "# every command's own examples: postproc COMMAND --help"))
@click.version_option(__version__, prog_name="postproc")
@click.option("--log", metavar="FILE", help="Copy every message to FILE (appended) as well as to stderr.")
@click.option("-q", "--quiet", **QUIET)
@click.option("--project", "project_file", metavar="FILE",
              help="The project file to use, instead of the postproc.toml found from the working directory up.")
@click.option("--no-project", is_flag=True, help="Use no project file.")
@click.pass_context
def main(ctx: click.Context, log: str | None = None, project_file: str | None = None, no_project: bool = False) -> None:
    """Rewrite FANUC lathe part programs so that the next part is cut right.

    Defaults a shop sets once (the machine profile, the model, the tolerance) go in a
    postproc.toml in the working directory or a parent: see 'postproc profile show'."""
    _catch(ctx, signal.SIGTERM)
    _catch(ctx, signal.SIGHUP)
    if log == "":
        raise click.UsageError("--log is empty (a shell variable that is not set?): give a file, or leave the "
                               "option out")
    _on_terminal(ctx)
    if log:
        try:
            sys.stderr = _Tee(sys.stderr, open(log, "a", encoding="utf-8"))
        except OSError as exc:
            raise click.UsageError(f"--log {log}: {exc.strerror}") from None
        ctx.meta[LOG] = log
    if project_file and no_project:
        raise click.UsageError("give --project FILE or --no-project, not both")
    try:
        _use_project(ctx, project_file, no_project)
    except PostprocError as exc:
        click.echo(str(exc), err=True)
        sys.exit(exc.exit_code)


def _use_project(ctx: click.Context, path: str | None, none: bool) -> None:
    """Read the project file (docs/formats.md §19) and make its values the defaults of the
    command about to run (click's default_map: an option on the command line wins)."""
    from . import project as projects

    found = projects.Project(None, "none: --no-project") if none else projects.load(path)
    ctx.meta[PROJECT] = found
    name = ctx.invoked_subcommand
    if found.values and name:
        command = ctx.command.get_command(ctx, name)
        if command is not None:
            ctx.default_map = {name: _defaults(command, name, found)}


def _defaults(command: click.Command, name: str, found) -> dict:
    if isinstance(command, click.Group):
        return {sub: _defaults(each, sub, found) for sub, each in command.commands.items()}
    return found.defaults(name, {param.name for param in command.params})


def _compensation(plugins, model, options):
    """The compensation of this run: the command line's (``--plugin`` or ``--model``) sets the
    project file's plugins, model and options aside together; from the project file alone, a
    model wins over plugins (which are then ``fit``'s)."""
    given = (plugins and not _from_file("plugins")) or (model and not _from_file("model"))
    if given or model:
        plugins = () if _from_file("plugins") else plugins
        options = () if _from_file("options") else options
    if given and _from_file("model"):
        model = None
    if not (plugins or model) and _from_file("options"):  # settings for compensators the run does not use
        options = ()
    return plugins, model, options


def _from_file(name: str) -> bool:
    """Whether this option's value came from the project file."""
    from click.core import ParameterSource

    return click.get_current_context().get_parameter_source(name) is ParameterSource.DEFAULT_MAP


def _on_terminal(ctx: click.Context) -> None:
    """On a terminal, stderr erases the progress line before each message (:mod:`postproc.compensate.progress`)."""
    stderr = sys.stderr
    sys.stderr = progress.on_terminal(stderr)
    if sys.stderr is not stderr:
        def restore():
            sys.stderr = stderr
            progress.off_terminal()

        ctx.call_on_close(restore)


def _catch(ctx: click.Context, signum: int) -> None:
    """Turn a signal into :class:`Stopped` for this run (the main thread only: signals go there)."""
    import threading

    if threading.current_thread() is not threading.main_thread():
        return
    previous = signal.signal(signum, _stop)
    ctx.call_on_close(lambda: signal.signal(signum, previous))


@main.command(epilog=examples(
    "# review what a saved model would change, then compensate into a new file",
    "postproc compensate part.nc --model lathe3.json --diff",
    "postproc compensate part.nc --model lathe3.json -o part-comp.nc",
    "# fit from this morning's ballbar traces and compensate in one run",
    "postproc compensate part.nc --plugin parametric --ballbar ccw.csv --ballbar cw.csv -o out.nc",
    "# every program of a job into out/, two at a time; exit 1 if any would change",
    "postproc compensate *.nc --model lathe3.json --out-dir out/ --jobs 2",
    "postproc compensate *.nc --model lathe3.json --check",
    "# only the finishing pass, to 2 um",
    "postproc compensate part.nc --model lathe3.json --region N200-N300 --tolerance 0.002 -o out.nc"))
@click.argument("inputs", nargs=-1, metavar="[INPUT...]")
@click.option("-o", "--output", "output", metavar="FILE", help="Write the program here instead of stdout.")
@click.option("--out-dir", metavar="DIR", help="Write each program into DIR under its own name.")
@PLUGIN()
@BALLBAR()
@PROBE()
@CALIBRATION()
@MODEL(help="A compensation model saved by 'postproc fit', instead of --plugin and measurements.")
@MACHINE()
@TOLERANCE()
@MODE()
@OPTION()
@click.option("--region", "regions", multiple=True, metavar="N100-N200|L10-L50|T01",
              help="Compensate only these blocks: N100-N200, L10-L50 (L10: line 10 alone) or a tool; several: their union.")
@click.option("--max-correction", type=POSITIVE, metavar="MM", help="Refuse corrections larger than this.")
@click.option("--force", is_flag=True, help="Compensate a program compensated before; use a failed datum check.")
@click.option("--keep-unplannable", is_flag=True,
              help="Leave a block that cannot be held within the tolerance uncompensated (a warning) instead of refusing.")
@click.option("--macro-values", type=click.Choice(["refuse", "keep", "numbers"]), default="refuse", show_default=True,
              help="A block to compensate whose X, Z, I, K or R reads a macro variable: refuse the program, keep the "
                   "block uncompensated, or write its values as numbers (it no longer follows the variable).")
@click.option("--diff", is_flag=True, help="Write a unified diff of the change to stdout instead of the program.")
@click.option("--check", "check_only", is_flag=True, help="Write nothing; exit 1 if the program would change.")
@click.option("--jobs", type=COUNT, default=1, show_default=True, metavar="N",
              help="Programs compensated at once (with --out-dir).")
@click.option("--report", "report_file", metavar="FILE", help="Write what each compensator fitted, and how well, as JSON.")
@_reported
def compensate(inputs, output, out_dir, plugins, ballbar, probe, calibration, model, machine, tolerance, mode,
               options, regions, max_correction, force, keep_unplannable, macro_values, diff, check_only, jobs,
               report_file):
    """Compensate part programs; with no compensator, write the input back byte for byte."""
    _settling()
    from ..api import Pipeline

    plugins, model, options = _compensation(plugins, model, options)
    if not (plugins or model) and _from_file("macro_values"):
        macro_values = "refuse"  # the project's choice for compensated blocks: none are compensated
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
    if macro_values != "refuse" and not plugins and not model:
        raise UsageError("--macro-values was given but no compensator (--plugin) to compensate the blocks")
    if (diff or check_only) and (output or out_dir):
        raise UsageError("--diff and --check write no program: give no -o or --out-dir")
    destinations = _destinations(inputs, out_dir) if out_dir else []
    read = [("INPUT", name) for name in inputs] + [("--ballbar", name) for name in ballbar] + \
        [("--probe", name) for name in probe] + [("--calibration", calibration), ("--model", model),
                                                 ("--machine", machine)]
    written = [("-o", output or (STDOUT if not (out_dir or diff or check_only) else None))]
    written += [("--out-dir", path) for _, path in destinations] + [("--report", report_file)]
    guard(read, written)
    workers = _workers(jobs, len(inputs)) if out_dir else 1
    reporter = Reporter(sys.stderr)
    pipeline = Pipeline(plugins, ballbar, probe, calibration, model, options, tolerance, mode, _profile(machine),
                        max_correction, force, regions, reporter, keep_unplannable=keep_unplannable,
                        macro_values=macro_values)
    _settled()
    if diff or check_only:
        changed = [name for name in inputs if _review(pipeline, name, diff)]
        _nothing_applied(pipeline, reporter, written=False)
        reporter.close()
        if report_file:
            _write_report(pipeline, report_file)
        if check_only and changed:
            for name in changed:
                progress.inform(f"{name}: would be changed")
            sys.exit(EXIT_WOULD_CHANGE)
        return
    if out_dir:
        from . import batch

        created = _make_directory(out_dir)
        _nothing_applied(pipeline, reporter)
        code = batch.run(destinations, pipeline, workers)
        reporter.close()
        if report_file:
            _write_report(pipeline, report_file)
        if code:
            if created:
                _remove_if_empty(created)
            sys.exit(code)
        return
    summary = pipeline.compensate_file(inputs[0], output or STDOUT)
    _nothing_applied(pipeline, reporter)
    reporter.close()
    if report_file:
        _write_report(pipeline, report_file)
    if pipeline.core is not None:
        progress.inform(
            f"{summary.name}: {summary.replaced} blocks replaced by {summary.emitted}; largest correction "
            f"{summary.largest_correction * 1000:.2f} um; largest deviation from the intended path "
            f"{summary.largest_deviation * 1000:.3f} um")


#: the variables that set how many threads numpy's BLAS starts (OpenBLAS, as in numpy's wheels; MKL)
BLAS_THREADS = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def _one_blas_thread() -> None:
    """numpy's BLAS starts a pool of threads, one per cpu, when numpy is imported: some 60 ms of
    CPU and 40 ms of a small job's time here, a fifth of it, for nothing: postproc's vectors and
    matrices are a few hundred numbers, which BLAS works on in the calling thread, and ``--jobs``
    runs its programs in processes of their own. In the command line's own process, before numpy
    is imported, one thread is asked for, unless the user has set the variable."""
    for name in BLAS_THREADS:
        os.environ.setdefault(name, "1")


#: the collector's thresholds in the command line's own process: a young-generation collection
#: every 10,000 allocations (Python's default: 700), the older ones 50 and 100 of those apart
COLLECT_EVERY = (10_000, 50, 100)


def _settling() -> None:
    """A compensation's start, before it imports numpy and the engine and builds its compensators:
    from here on the cyclic garbage collector looks for cycles a tenth as often
    (:data:`COLLECT_EVERY`). What is imported and built now lives until the process ends
    (:func:`_settled`): at Python's default thresholds a small job collected some 30 times over
    it (about 1.5 ms). The run's own objects (blocks, moves, arrays, cuts) are acyclic and freed
    by reference counting as the program streams: looking for cycles among them a tenth as often
    saves about 4 % of a large compensation's CPU, peak memory unchanged. Only in the command
    line's own process: a caller's (a test, a script that calls :func:`main` with arguments)
    keeps its collector as it set it."""
    if _Commands.own_process:
        gc.set_threshold(*COLLECT_EVERY)


def _settled() -> None:
    """Everything imported and built so far (numpy, the package's modules, the fitted or loaded
    compensators) lives until the process ends: the cyclic garbage collector is told to leave it
    out of every later collection, and out of the last one at exit (``gc.freeze``): some 20 ms of
    a small job, a tenth of its time, none of it for anything collectable. Only in the command
    line's own process: a caller's keeps its objects collectable."""
    if _Commands.own_process:
        gc.freeze()


def _nothing_applied(pipeline, reporter: Reporter, written: bool = True) -> None:
    """With no compensator, say that the programs went out unchanged: in a script, an empty
    $PLUGIN must not send an uncompensated part to the machine without a word."""
    if pipeline.core is None:
        reporter.warn("no compensator was given (--plugin or --model): nothing was applied"
                      + ("; the program is written back unchanged" if written else ""))


def _destinations(inputs: tuple[str, ...], out_dir: str) -> list[tuple[str, str]]:
    """Each input and the file it is written to in ``out_dir``; two inputs of one name are refused,
    as is standard input, which has no name to write under."""
    if "-" in inputs:
        raise UsageError("--out-dir writes each program under its own name; standard input (-) has none: give -o")
    firsts: dict[str, str] = {}
    for name in inputs:
        base = os.path.basename(name)
        if base in firsts:
            raise UsageError(f"{firsts[base]} and {name} have the same name: in --out-dir {out_dir} one would "
                             "overwrite the other; compensate them into different folders")
        firsts[base] = name
    return [(name, os.path.join(out_dir, os.path.basename(name))) for name in inputs]


def _workers(jobs: int, programs: int) -> int:
    """``--jobs``, at most one process per program and per CPU (saying so when fewer run)."""
    if jobs > MAX_JOBS:
        raise OptionError(f"--jobs {jobs}: far more processes than a machine runs at once (at most {MAX_JOBS}); "
                           "give about the number of CPUs")
    try:
        cpus = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cpus = os.cpu_count() or 1
    workers = max(1, min(jobs, programs, cpus))
    if workers < jobs:
        runs = "1 process runs" if workers == 1 else f"{workers} processes run"
        counted = f"{programs} program{'s' * (programs != 1)}, {cpus} CPU{'s' * (cpus != 1)}"
        progress.inform(format_message("warning", f"--jobs {jobs}: {runs} ({counted})", None))
    return workers


def _make_directory(path: str) -> list[str]:
    """Create ``--out-dir`` (and its parents) if it does not exist, as ``mkdir -p`` does; the
    folders created, the deepest first. A file where the folder should be is refused."""
    if os.path.isdir(path):
        return []
    if os.path.lexists(path):
        raise UsageError(f"--out-dir {path}: exists and is not a directory; give a folder")
    missing, folder = [], os.path.abspath(path)
    while not os.path.lexists(folder):
        missing.append(folder)
        folder = os.path.dirname(folder)
    try:
        os.makedirs(path)
    except FileExistsError:
        if not os.path.isdir(path):
            raise UsageError(f"--out-dir {path}: exists and is not a directory; give a folder") from None
        return []
    except OSError as exc:
        from ..files.output import explain

        raise OutputError(f"cannot create the output folder: {explain(exc)}", Location(path)) from None
    return missing


def _remove_if_empty(created: list[str]) -> None:
    """Take away the folders this run created (the deepest first) when no program was written
    into them: a failed run leaves the tree as it found it."""
    for folder in created:
        try:
            os.rmdir(folder)
        except OSError:
            return


def _write_report(pipeline, path: str) -> None:
    """The compensators' reports (fitted parameters, uncertainties, figures, dropped points) as JSON."""
    import json

    from ..files.output import write_atomically

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


@main.command(epilog=examples(
    "# a parametric model from a ballbar test in both directions, with the machine's state",
    "postproc fit --plugin parametric --ballbar ccw.csv --ballbar cw.csv --note 'warmed up 2 h' -o lathe3.json",
    "# a profile model from a probed first pass",
    "postproc fit --plugin omp-feedback --probe pass1.csv --calibration artifact.csv -o pass1.json",
    "# then: postproc compensate part.nc --model lathe3.json -o out.nc"))
@PLUGIN(required=True, help="The compensator to fit ('postproc plugins' lists them).")
@BALLBAR()
@PROBE()
@CALIBRATION()
@OPTION()
@MACHINE()
@click.option("--note", metavar="TEXT", help="The machine's state, e.g. 'warmed up 2 h'.")
@click.option("--force", is_flag=True, help="Use measurements that failed a check (the datum check).")
@click.option("-o", "--output", "output", metavar="FILE", default="-", help="Where the model goes (JSON).")
@_reported
def fit(plugins, ballbar, probe, calibration, options, machine, note, force, output):
    """Fit a compensator's model from measurements and save it (apply it with compensate --model)."""
    plugins, _, options = _compensation(plugins, None, options)
    from ..compensate.models import saved
    from ..files.output import write_atomically
    from ..compensate.pipeline import Pipeline
    from ..compensate.request import Request

    guard([("--ballbar", name) for name in ballbar] + [("--probe", name) for name in probe]
          + [("--calibration", calibration), ("--machine", machine)], [("-o", output)])
    reporter = Reporter(sys.stderr)
    request = Request(plugins=list(plugins), ballbar=list(ballbar), probe=list(probe), calibration=calibration,
                      options=list(options), force=force)
    pipeline = Pipeline(request, _profile(machine), reporter)
    measured = [*ballbar, *probe, *([calibration] if calibration else [])]
    write_atomically(output, saved(pipeline.saved_model(note), Location(measured[0] if measured else output)))
    reporter.close()


@main.command(epilog=examples(
    "postproc check part.nc",
    "postproc check part.nc --machine lathe3.toml",
    "# from a pipe",
    "cat part.nc | postproc check"))
@click.argument("input", default="-")
@MACHINE()
@_reported
def check(input, machine):
    """Parse and interpret a program: diagnostics only, no output program."""
    from ..compensate.contours import WrittenContours
    from ..interpret.program import tally_source

    guard([("INPUT", input), ("--machine", machine)], [])
    reporter = Reporter(sys.stderr)
    profile = _profile(machine)
    with Source(input) as source:
        blocks, moves = tally_source(source, profile, reporter, WrittenContours(source.name, profile, reporter))
        name = source.name
    reporter.close()
    progress.inform(f"{name}: ok: {blocks} lines, {moves} moves, {len(reporter.warnings)} warnings")


@main.command(epilog=examples(
    "# the tool path as CSV, one row per motion",
    "postproc path part.nc -o path.csv",
    "# draw it, with the path a model would cut (the correction magnified)",
    "postproc path part.nc --plot path.png --model lathe3.json"))
@click.argument("input", default="-")
@MACHINE()
@click.option("-o", "--output", "output", metavar="FILE", help="Write the CSV here instead of stdout.")
@click.option("--plot", metavar="FILE", help="Draw the path (and the compensated one) to a .png or .svg.")
@PLUGIN(help="With --plot: a compensator whose corrected path is drawn too.")
@BALLBAR(help="With --plot and --plugin: a ballbar trace for the compensator.")
@PROBE(help="With --plot and --plugin: probe points for the compensator.")
@CALIBRATION(help="With --plot and --plugin: a probe calibration on an artifact.")
@MODEL(help="With --plot: a saved model whose corrected path is drawn too.")
@OPTION(help="With --plot and --plugin: a compensator's setting, as compensate takes it.")
@TOLERANCE(help="With --plot and a compensator: as compensate takes it (mm).")
@MODE(help="With --plot and a compensator: as compensate takes it.")
@click.option("--macro-values", type=click.Choice(["refuse", "keep", "numbers"]), default="refuse",
              help="With --plot and a compensator: as compensate takes it.")
@_reported
def path(input, machine, output, plot, plugins, ballbar, probe, calibration, model, options, tolerance, mode,
         macro_values):
    """The interpreted tool path as CSV, one row per motion; --plot draws it."""
    from ..report.pathcsv import path_rows
    from ..interpret.program import interpret_source

    if (plugins or model) and not plot:
        raise UsageError("compensators here only draw the compensated path: give --plot")
    guard([("INPUT", input), ("--machine", machine), ("--model", model), ("--calibration", calibration)]
          + [("--ballbar", name) for name in ballbar] + [("--probe", name) for name in probe],
          [("-o", output or STDOUT), ("--plot", plot)])
    profile = _profile(machine)
    reporter = Reporter(sys.stderr)
    pipeline = None
    if plugins or model:  # the measurements checked before anything is written
        from ..api import Pipeline

        pipeline = Pipeline(plugins, ballbar, probe, calibration, model, options, tolerance, mode, profile,
                            reporter=reporter, macro_values=macro_values)
    with Source(input) as source, Spool(output or STDOUT) as spool:
        for line in path_rows(interpret_source(source, profile, reporter)):
            spool.write(line.encode() + b"\n")
        if plot:
            from ..report.pathplot import plot_paths

            nominal = [m for s in interpret_source(source, profile, Reporter()) for m in s.moves if m.role != "contour"]
            compensated = None
            if pipeline is not None:
                with Source.from_text(pipeline.compensated(source), source.name) as changed:
                    compensated = [m for s in interpret_source(changed, profile, Reporter()) for m in s.moves
                                   if m.role != "contour"]
            plot_paths(nominal, compensated, plot, source.name)
        spool.commit()
    reporter.close()


@main.group(epilog=examples("postproc profile init lathe3.toml", "postproc profile show --machine lathe3.toml"))
def profile():
    """Machine profiles, and the project file that names one."""


@profile.command("show", epilog=examples(
    "# the profile in force here (the project file's, or the embedded default), and where it came from",
    "postproc profile show",
    "postproc profile show --machine lathe3.toml"))
@MACHINE()
@_reported
def profile_show(machine):
    """Print the machine profile in force, as TOML, after two comment lines: the project file
    used and where the profile came from. The whole profile is checked first (its
    ``[simulation]`` table too, which is not printed): a bad one prints nothing."""
    from click.core import ParameterSource

    from ..machine.profile import to_toml

    context = click.get_current_context()
    shown = _profile(machine)  # checked whole before anything is printed
    if shown.extra.get("simulation") is not None:
        from .simulate import check_table

        check_table(shown, machine)
    project = context.find_root().meta.get(PROJECT)
    if project is not None and project.path:
        click.echo(f"# project file: {project.path}")
    else:
        click.echo(f"# project file: {project.searched if project is not None else 'none'}")
    source = context.get_parameter_source("machine")
    origin = ("the project file" if source is ParameterSource.DEFAULT_MAP else "--machine") if machine else None
    click.echo(f"# machine profile: {machine} (from {origin})" if machine else "# machine profile: the embedded default")
    click.echo(to_toml(shown), nl=False)


@profile.command("init", epilog=examples(
    "# a profile of your lathe to edit: every key, its default and what it means",
    "postproc profile init lathe3.toml",
    "postproc profile init lathe3.toml --name lathe3"))
@click.argument("file", metavar="FILE")
@click.option("--name", metavar="NAME", help="The profile's name (models record it); default: the file's name.")
@_reported
def profile_init(file, name):
    """Write a commented starter machine profile to FILE (never over an existing file)."""
    from ..machine.profile import starter

    if name is not None and not name.strip():
        raise OptionError(f"--name {name!r}: a profile's name cannot be blank")
    try:
        text = starter(name or os.path.splitext(os.path.basename(file))[0] or "lathe")
    except ValueError as exc:  # a byte of the command line that is not UTF-8
        raise OptionError(f"the profile's name (--name, else the file's name): {exc}; give --name as text") from None
    if file == "-":
        click.echo(text, nl=False)
        return
    from ..files.output import Spool

    exists = UsageError(f"{file} exists: profile init never overwrites a file; give a new name")
    if os.path.lexists(file):
        raise exists
    with Spool(file) as spool:  # complete or not at all: a full disk leaves no empty profile behind
        spool.write(text.encode("utf-8"))
        try:
            spool.commit(new=True)
        except FileExistsError:
            raise exists from None
    progress.inform(f"{file}: starter machine profile written; edit it, then check it with "
                    f"'postproc profile show --machine {file}'")


@main.command("plugins", epilog=examples("postproc plugins"))
@_reported
def list_plugins():
    """The installed compensators, one per line: name, version, description."""
    from ..compensate.registry import compensators

    for name, item in sorted(compensators().items()):
        click.echo(f"{name} {item.version} {item.cls.summary()}")



if __name__ == "__main__":
    main()
