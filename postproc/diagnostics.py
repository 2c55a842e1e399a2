"""Errors, warnings, their message forms and the exit codes: the one place that defines them.

Message forms (docs/formats.md §7.2, and §7.3 for the exit codes):

- ``FILE:LINE:COL: error: message`` for a program, followed by the source line and a caret;
- ``FILE:LINE: error: message`` for a data row or header line of a measurement file;
- ``FILE: error: message`` for a whole file;
- warnings the same with ``warning:``.

Lines and columns are 1-based everywhere. Every error the user can cause is a
:class:`PostprocError`; its ``exit_code`` is what the command line returns, and on any
non-zero exit no output program is written. Anything else that escapes a command is a bug:
exit 5, "internal error", never a refusal.

Every exception class of postproc is here, but for the few a module raises and catches
within itself as control flow (private, named with a leading underscore) and the command
line's own usage errors (``commands.common.BadValue``, a click exception).
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from typing import TextIO

EXIT_OK = 0
EXIT_WOULD_CHANGE = 1  #: ``--check`` found that the output would differ from the input
EXIT_USAGE = 2  #: the command line itself is wrong
EXIT_BAD_INPUT = 3  #: a program, measurement, model or option value is wrong
EXIT_REFUSED = 4  #: refused for safety: maximum correction, soft limits, self-check, double compensation
EXIT_INTERNAL = 5  #: a bug, in postproc or in a plugin

STDIN_NAME = "<stdin>"


@dataclass(frozen=True, slots=True)
class Location:
    """Where a diagnostic points: a file, optionally a 1-based line and column."""

    file: str  #: path as the user gave it, or ``<stdin>``
    line: int | None = None  #: 1-based line number
    col: int | None = None  #: 1-based column (characters, not bytes)
    source: str | None = None  #: the text of that line, for the caret display

    def prefix(self) -> str:
        parts = [STDIN_NAME if self.file == "-" else self.file]  # a file given as -, standard input
        if self.line is not None:
            parts.append(str(self.line))
            if self.col is not None:
                parts.append(str(self.col))
        return ":".join(parts)

    def caret(self) -> str:
        """The source line and a caret under the column, or an empty string."""
        if self.source is None or self.col is None:
            return ""
        shown = self.source.rstrip("\r\n")
        pad = "".join("\t" if ch == "\t" else " " for ch in shown[: self.col - 1])
        return f"    {shown}\n    {pad}^"


def format_message(severity: str, message: str, location: Location | None) -> str:
    """One diagnostic in the fixed form, with the caret lines for program positions."""
    if location is None:
        return f"postproc: {severity}: {message}"
    text = f"{location.prefix()}: {severity}: {message}"
    caret = location.caret()
    return f"{text}\n{caret}" if caret else text


def out_of_range(number: float, whole: bool = False, above: float | None = None, at_least: float | None = None,
                 at_most: float | None = None) -> str | None:
    """What an option's number must be, said the one way every option says it ("must be
    positive", "must be a whole number from 1 to 9999"), or None when it is within its range.
    A value outside the range is a wrong option value: exit 3, whichever command or plugin."""
    if ((above is None or number > above) and (at_least is None or number >= at_least)
            and (at_most is None or number <= at_most)):
        return None
    if above == 0 and at_least is None and at_most is None:
        rule = "positive"
    elif at_least is not None and at_most is not None:
        rule = f"from {at_least:g} to {at_most:g}"
    elif at_least is not None:
        rule = f"{at_least:g} or more"
    else:
        rule = " and ".join([f"above {above:g}"] * (above is not None) + [f"at most {at_most:g}"] * (at_most is not None))
    return f"must be a whole number, {rule}" if whole else f"must be {rule}"


class PostprocError(Exception):
    """Base of every error postproc reports to its user."""

    exit_code = EXIT_BAD_INPUT

    def __init__(self, message: str, location: Location | None = None):
        super().__init__(message)
        self.message = message
        self.location = location

    def __str__(self) -> str:
        return format_message("error", self.message, self.location)

    def at(self, location: Location) -> "PostprocError":
        """The same error placed at ``location`` when it has none yet."""
        if self.location is None:
            self.location = location
        return self


class UsageError(PostprocError):
    """The command line does not make sense (an option without its companion, and so on)."""

    exit_code = EXIT_USAGE


class ProgramError(PostprocError):
    """A part program is wrong: its syntax, or what it asks the control to do."""


class ProgramSyntaxError(ProgramError):
    """A block the grammar does not accept."""


class InterpretationError(ProgramError):
    """A block that parses but that the control would refuse (arc check, missing P/Q label...)."""


class MeasurementError(PostprocError):
    """A measurement file (ballbar trace, probe points, calibration) is wrong or unusable."""


class ModelError(PostprocError):
    """A saved compensation model cannot be used."""


class OptionError(PostprocError):
    """An option value is wrong (a tolerance of zero, a key no compensator declares...)."""


class SafetyError(PostprocError):
    """The run is refused because its output could damage tool or part."""

    exit_code = EXIT_REFUSED


class UnplannableBlock(SafetyError):
    """A block no sequence of blocks can replace within the tolerance; ``limit`` names what
    stops it (output resolution, the arc radius check, the minimum block time, the tolerance)."""

    def __init__(self, message: str, location: Location | None = None, limit: str = "", cause: str = ""):
        super().__init__(message, location)
        self.limit = limit
        self.cause = cause or message  #: the message without its remedies


class PluginError(PostprocError):
    """A compensator plugin failed or returned something the core cannot use."""

    exit_code = EXIT_INTERNAL

    def __init__(self, plugin: str, message: str, location: Location | None = None):
        super().__init__(f"plugin {plugin!r}: {message}", location)
        self.plugin = plugin


class InternalError(PostprocError):
    """A bug in postproc itself."""

    exit_code = EXIT_INTERNAL


class OutputError(PostprocError):
    """The output cannot be written (directory missing or read-only, disk full...)."""


class Inseparable(MeasurementError):
    """The traces cannot tell some parameters apart (or from a set-up centre): no solution is unique."""

    def __init__(self, message: str, location: Location | None, names: tuple[str, ...]):
        super().__init__(message, location)
        self.names = names


class Undetermined(Inseparable):
    """A parameter's uncertainty is too large for its value to mean anything."""


# -- failures a module reports to its caller ---------------------------------------------------
# Raised by one step of the work and caught by its caller, which turns them into one of the
# errors above with the file and position it knows (a corner that cannot be made is an
# InterpretationError of its block, a plan that cannot be made an UnplannableBlock). Not
# PostprocErrors: one that escapes its caller is a bug, and exits 5.


class FitError(ValueError):
    """The data do not determine the fit (too few points, collinear points, an unfixed axis)."""


class MacroValueError(ValueError):
    """An expression the control would alarm on (division by zero, SQRT of a negative...)."""


#: The limits that can stop a plan (PlanError.limit).
RESOLUTION, RADIUS_CHECK, TOLERANCE = "output resolution", "arc radius check", "tolerance"


class PlanError(ValueError):
    """No sequence of blocks on the control's grid follows the target within tolerance.

    ``limit`` names what stops it (RESOLUTION, RADIUS_CHECK or TOLERANCE); ``needed`` is the
    tolerance (mm) the nearest plan found keeps to, None if none was found below 0.1 mm."""

    def __init__(self, message: str, limit: str = TOLERANCE, needed: float | None = None):
        super().__init__(message)
        self.limit = limit
        self.needed = needed


class SpreadError(ValueError):
    """The touches cannot be spread: no feature has room for one (``wanted`` None), or fewer
    touches were asked for than ``wanted``, the minimum on every feature with room."""

    def __init__(self, message: str, wanted: int | None = None):
        super().__init__(message)
        self.wanted = wanted


class CornerError(ValueError):
    """The corner cannot be made (too large for its moves, or the moves are parallel)."""


class Collision(Exception):
    """The stylus overlaps the surface before its approach starts."""


# -- the end of a run by a signal --------------------------------------------------------------


class Stopped(BaseException):
    """A signal that ends the run (SIGTERM, SIGHUP): raised where the program is, so that every
    spool and temporary file is dropped on the way out. A BaseException, as KeyboardInterrupt
    is, so that no ``except Exception`` in a plugin swallows it."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


@dataclass(frozen=True, slots=True)
class Diagnostic:
    """A warning: the run goes on, and the user should know why."""

    message: str
    location: Location | None = None

    def __str__(self) -> str:
        return format_message("warning", self.message, self.location)


class Reporter:
    """Collects warnings and writes them to a stream as they happen.

    Repeats of the same warning text are shown ``limit`` times and then counted, so a
    million-block program with one habit does not bury the other messages.
    """

    silent = False  #: ``--quiet``: warnings are collected (reports and models see them), not shown

    def __init__(self, stream: TextIO | None = None, limit: int = 20):
        self.stream = stream
        self.limit = limit
        self.warnings: list[Diagnostic] = []
        self._seen: dict[tuple[str, Location | None], int] = {}
        #: where a warning that names no place is about: the program being compensated, while it
        #: is (a compensator knows a move's line, not the program's name)
        self.about: Location | None = None

    def warn(self, message: str, location: Location | None = None) -> None:
        key = (message, self.about)  # counted per program: a batch's 21st program is warned as its first was
        count = self._seen.get(key, 0) + 1
        self._seen[key] = count
        warning = Diagnostic(message, location or self.about)
        if count <= self.limit:
            self.warnings.append(warning)
            if self.stream is not None:
                say(str(warning), self.stream)

    def close(self) -> None:
        """Say how many repeated warnings were not shown."""
        if self.stream is None:
            return
        for (message, about), count in self._seen.items():
            if count > self.limit:
                where = about.prefix() if about is not None else "postproc"
                say(f"{where}: warning: {count - self.limit} more like: {message}", self.stream)


def say(text: str, stream: TextIO) -> None:
    """A line that is not an error (a warning, a summary) on ``stream``; with ``--quiet``
    (:attr:`Reporter.silent`) only into the ``--log`` file behind it, if there is one: quiet
    keeps the terminal to errors, the log still gets what it would get."""
    if not Reporter.silent:
        print(text, file=stream)
        return
    log_only = getattr(stream, "write_log", None)
    if log_only is not None:
        log_only(text + "\n")


def stderr_reporter() -> Reporter:
    return Reporter(sys.stderr)
