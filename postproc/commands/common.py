"""What every command shares: option types for numbers, and the rule that no output is an input.

Numbers: ``float`` would take ``inf`` and ``nan`` (and ``1e999``); every number a command takes
is a length, a feed, an angle or a time, so a value that is not finite is refused as it is
read: exit 3 (a wrong option value, formats.md) with the message in postproc's own form.
Whether a value must also be positive, or within a bound, is the command's or the library's
to say (:mod:`postproc.bounds`), with the message that names the rule.

Outputs: :func:`guard` refuses, before anything is read or written, an output (``-o``, a plot,
a report, the ``--log`` file) that is one of the command's inputs.
"""

from __future__ import annotations

import math
import sys

import click

from ..diagnostics import EXIT_BAD_INPUT, UsageError, format_message
from ..output import refuse_overwrite

LOG = "postproc.log"  #: the click context's meta key of the ``--log`` file


class BadValue(click.ClickException):
    """A wrong option value found while the command line is read: exit 3, postproc's message form."""

    exit_code = EXIT_BAD_INPUT

    def show(self, file=None) -> None:
        click.echo(format_message("error", self.message, None), file=file, err=file is None)


class Finite(click.ParamType):
    """A finite number (a float); with ``positive``, above zero as well."""

    name = "number"

    def __init__(self, positive: bool = False):
        self.positive = positive

    def convert(self, value, param, ctx):
        if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value):
            number = float(value)
        else:
            option = max(param.opts, key=len) if param is not None and param.opts else "value"
            try:
                number = float(value)
            except (TypeError, ValueError):
                raise BadValue(f"{option} {value}: not a number") from None
            if not math.isfinite(number):
                raise BadValue(f"{option} {value}: not a finite number")
        if self.positive and not number > 0:
            option = max(param.opts, key=len) if param is not None and param.opts else "value"
            raise BadValue(f"{option} {value}: must be positive")
        return number


FINITE = Finite()
POSITIVE = Finite(positive=True)


def guard(inputs, outputs) -> None:
    """Refuse an output that is an input or another output: ``inputs`` and ``outputs`` are
    (option, path) pairs; the ``--log`` file counts as an output. A log that is an input or
    another output is detached first, so that the refusal itself is not appended to the file
    the refusal protects."""
    inputs = [(option, path) for option, path in inputs if path]
    log = click.get_current_context().meta.get(LOG)
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
