"""What every command shares: option types for numbers, and the rule that no output is an input.

Numbers: ``float`` would take ``inf`` and ``nan`` (and ``1e999``), and click's ``int`` and
``IntRange`` refuse with a usage error (exit 2); every number a command takes is a length, a
feed, an angle, a time or a count with a range that makes sense, so a value that is not a
number, not finite or outside that range is refused as it is read: exit 3 (a wrong option
value, formats.md) with one message in postproc's own form that names the option, the value
and the range (:class:`Number`). Rules that need more than a range (a tolerance in um, a
bound from the machine profile) are the command's or the library's to say
(:mod:`postproc.machine.bounds`), with the message that names the rule.

Outputs: :func:`guard` refuses, before anything is read or written, an output (``-o``, a plot,
a report, the ``--log`` file) that is one of the command's inputs.
"""

from __future__ import annotations

import math
import sys

import click

from ..diagnostics import EXIT_BAD_INPUT, UsageError, format_message, out_of_range
from ..files.output import refuse_overwrite

LOG = "postproc.log"  #: the click context's meta key of the ``--log`` file
PROJECT = "postproc.cli.project"  #: the click context's meta key of the project file in use


class BadValue(click.ClickException):
    """A wrong option value found while the command line is read: exit 3, postproc's message form."""

    exit_code = EXIT_BAD_INPUT

    def show(self, file=None) -> None:
        click.echo(format_message("error", self.message, None), file=file, err=file is None)


class Number(click.ParamType):
    """A finite number (a float), or with ``whole`` a whole number, within its range (``above``,
    ``at_least``, ``at_most``): anything else is refused as it is read, naming the option, the
    value and the range (:func:`~postproc.diagnostics.out_of_range`), exit 3. One type for
    every number a command takes, so that ``--averaging 0`` and ``--max-deviation 0`` are
    refused alike (click's own ``IntRange`` and ``int`` are usage errors, exit 2)."""

    def __init__(self, whole: bool = False, above: float | None = None, at_least: float | None = None,
                 at_most: float | None = None):
        self.whole = whole
        self.range = {"above": above, "at_least": at_least, "at_most": at_most}
        self.name = "integer" if whole else "number"

    def convert(self, value, param, ctx):
        option = max(param.opts, key=len) if param is not None and param.opts else "value"
        if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and not (
                self.whole and value != int(value)):
            number = int(value) if self.whole else float(value)
        elif self.whole:
            try:
                number = int(str(value).strip())
            except ValueError:
                raise BadValue(f"{option} {value}: not a whole number") from None
        else:
            try:
                number = float(value)
            except (TypeError, ValueError):
                raise BadValue(f"{option} {value}: not a number") from None
            if not math.isfinite(number):
                raise BadValue(f"{option} {value}: not a finite number")
        problem = out_of_range(number, self.whole, **self.range)
        if problem:
            raise BadValue(f"{option} {value}: {problem}")
        return number


FINITE = Number()
POSITIVE = Number(above=0)
NOT_NEGATIVE = Number(at_least=0)
COUNT = Number(whole=True, at_least=1)  #: a count of things, or a source line number
SEED = Number(whole=True, at_least=0)  #: a random generator's seed
PROGRAM_NUMBER = Number(whole=True)  #: a FANUC program number: its range, 1 to 9999, the probing cycle says
POINTS = Number(whole=True, at_least=2)  #: points along a profile: both its ends at least
ARC = Number(above=0, at_most=360)  #: an arc captured, degrees
OVERTRAVEL = Number(at_least=0, at_most=180)  #: a ballbar test's over-travel, degrees


def guard(inputs, outputs) -> None:
    """Refuse an output that is an input or another output: ``inputs`` and ``outputs`` are
    (option, path) pairs; the ``--log`` file counts as an output, the project file in use as an
    input. A log that is an input or another output is detached first, so that the refusal
    itself is not appended to the file the refusal protects."""
    context = click.get_current_context()
    project = context.find_root().meta.get(PROJECT)
    inputs = [(option, path) for option, path in inputs if path]
    piped = [option for option, path in inputs if path == "-"]
    if len(piped) > 1:
        raise UsageError(f"standard input (-) is given {len(piped)} times ({', '.join(piped)}): it is read once, as "
                         "one file; give the others as files (or as <(command) in bash)")
    if project is not None and project.path:  # the project file is read by every run
        inputs.append(("the project file", project.path))
    log = context.meta.get(LOG)
    if log is not None:
        try:
            refuse_overwrite(inputs, [("--log", log)])
            refuse_overwrite([], [("--log", log), *outputs])
        except UsageError:
            detach = getattr(sys.stderr, "detach_log", None)
            if detach is not None:
                detach()
            raise
    refuse_overwrite(inputs, [*outputs, *([("--log", log)] if log is not None else [])])


# -- options shared by several commands: one name, one metavar, one help, one completion -------------


def complete_compensators(ctx, param, incomplete: str):
    """Shell completion of ``--plugin``: the installed compensators, each with its summary."""
    from click.shell_completion import CompletionItem

    return [CompletionItem(name, help=summary) for name, summary in _compensators() if name.startswith(incomplete)]


def complete_options(ctx, param, incomplete: str):
    """Shell completion of ``--option``: ``PLUGIN.KEY=`` for every key the compensators selected
    so far (``--plugin``) declare, and ``KEY=`` alone for a key only one of them takes; with no
    ``--plugin`` yet, every installed compensator's keys."""
    from click.shell_completion import CompletionItem

    from ..compensate.registry import compensators

    try:
        found = compensators()
    except Exception:  # a broken plugin must not break the shell: it is named when a command runs
        return []
    selected = list(dict.fromkeys((ctx.params.get("plugins") if ctx is not None else None) or ()))
    chosen = [(name, found[name]) for name in selected if name in found] if selected else sorted(found.items())
    keys = [(f"{name}.{option.key}=", option.help) for name, item in chosen for option in item.cls.options]
    if selected:
        owners: dict[str, list[str]] = {}
        for name, item in chosen:
            for option in item.cls.options:
                owners.setdefault(option.key, []).append(option.help)
        keys += [(f"{key}=", helps[0]) for key, helps in owners.items() if len(helps) == 1]
    return [CompletionItem(key, help=text) for key, text in keys if key.startswith(incomplete)]


def _compensators() -> list[tuple[str, str]]:
    from ..compensate.registry import compensators

    try:
        return [(name, item.cls.summary()) for name, item in sorted(compensators().items())]
    except Exception:  # a broken plugin must not break the shell: it is named when a command runs
        return []


def _shared(*declarations, **attributes):
    """An option several commands take, spelled once; a command may say its own help."""

    def option(help: str | None = None, **more):
        return click.option(*declarations, **{**attributes, **more, **({"help": help} if help else {})})

    return option


MACHINE = _shared("--machine", metavar="FILE",
                  help="A machine profile (TOML, docs/formats.md §15); without it, the project file's "
                       "(postproc.toml), else the embedded FANUC 18i-T lathe.")
PLUGIN = _shared("--plugin", "plugins", multiple=True, metavar="NAME", shell_complete=complete_compensators,
                 help="A compensator to apply, in order ('postproc plugins' lists them).")
BALLBAR = _shared("--ballbar", multiple=True, metavar="FILE",
                  help="A ballbar trace (docs/formats.md §4); give each direction and test.")
PROBE = _shared("--probe", multiple=True, metavar="FILE", help="Probe points measured on a part (docs/formats.md §5).")
CALIBRATION = _shared("--calibration", metavar="FILE",
                      help="A probe calibration on an artifact (docs/formats.md §6).")
MODEL = _shared("--model", metavar="FILE", help="A compensation model saved by 'postproc fit'.")
OPTION = _shared("--option", "options", multiple=True, metavar="[PLUGIN.]KEY=VALUE", shell_complete=complete_options,
                 help="A compensator's setting (docs/formats.md §9); PLUGIN. when several take KEY.")
TOLERANCE = _shared("--tolerance", type=POSITIVE, metavar="MM",
                    help="Largest deviation of the emitted path from the corrected one, mm (0.002 is 2 um).")
MODE = _shared("--mode", type=click.Choice(["auto", "arc", "line"]), default="auto", show_default=True,
               help="auto: the fewest blocks, arcs or lines; arc: arcs wherever the target is curved; line: G01 only.")
FROM_LINE = _shared("--from-line", type=COUNT, metavar="N", help="Profile: moves from this source line.")
TO_LINE = _shared("--to-line", type=COUNT, metavar="N", help="Profile: moves up to this source line.")


def examples(*lines: str) -> str:
    """A command's Examples section for ``--help``: comment lines and commands, shown as written
    (click's ``\\b`` keeps the lines from being re-wrapped). Every line starting with
    ``postproc`` is parsed by the tests, so an example cannot drift from the options."""
    return "\b\nExamples:\n" + "\n".join(f"  {line}" for line in lines)
