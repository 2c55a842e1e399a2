"""Progress on a terminal, and ``--quiet``: what postproc says besides its results and errors.

A long run (a program of thousands of blocks, a batch, a fit) draws one progress line on stderr
when, and only when, stderr is a terminal: a pipe, a log or a CAM system's capture gets the same
bytes as before, nothing more. The line is click's progress bar (click is already the command
line's library; a second one would add nothing a single line needs). It is updated every
:data:`EVERY` blocks, not per block, so the hot path pays one integer test per block.

Messages written while the line is shown (a warning, a batch's summary line) first clear it, so
that no message is glued to the bar: :class:`Terminal` is stderr on a terminal and does that.

``--quiet`` keeps only errors: warnings are still collected (a report, a saved model and the
exit code see them) but not shown, and the information lines (summaries, "ok") are not written.
"""

from __future__ import annotations

import sys
from contextlib import contextmanager
from typing import Iterator

import click

from ..diagnostics import Reporter, say

EVERY = 1024  #: blocks between two updates of a program's progress line
MIN_BLOCKS = 4000  #: a program shorter than this is done before a progress line would help
_CLEAR = "\r\x1b[2K"  #: back to the start of the line, erase it
_SHOW_CURSOR = "\x1b[?25h"  #: click hides the cursor while it draws

_bar: "_Bar | None" = None  #: the progress line on screen (one at a time: a batch's programs draw none)
_terminal = None  #: the terminal under stderr (see :class:`Terminal`), which the line is drawn on


def set_quiet(quiet: bool) -> None:
    """``--quiet``: show errors only (warnings are kept, not shown)."""
    Reporter.silent = quiet


def quiet() -> bool:
    return Reporter.silent


def inform(text: str) -> None:
    """An information line on stderr (a summary, "ok"); with ``--quiet``, only in the ``--log``."""
    if not Reporter.silent:
        click.echo(text, err=True)
    else:
        say(text, sys.stderr)


def shown() -> bool:
    """Whether a progress line would be drawn now: the command line runs on a terminal
    (:func:`on_terminal`; a program using postproc as a library gets none), not quiet, and no
    line is on the screen already."""
    return _bar is None and _terminal is not None and not Reporter.silent


def _isatty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError, OSError):
        return False


class _Silent:
    """The progress line when none is drawn: every call does nothing."""

    def advance(self, steps: int = 1, item: str | None = None) -> None:
        pass


class _Bar:
    """One progress line, drawn with click's bar on the terminal itself (never into a ``--log``)."""

    def __init__(self, total: int, label: str, stream, count: bool):
        self.stream = stream
        self.drawn = False  #: the line is on the screen (not erased since it was last drawn)
        self.bar = click.progressbar(length=total, label=label, file=stream, show_pos=count, show_percent=True,
                                     show_eta=True, item_show_func=lambda item: item)

    def advance(self, steps: int = 1, item: str | None = None) -> None:
        """``steps`` more done; ``item``, what is being done now (shown after the bar)."""
        if steps:
            self.bar.update(steps, item)
        else:
            self.bar.current_item = item
            self.bar.render_progress()
        self.drawn = True

    def clear(self) -> None:
        """Erase the line (a message is about to be written); it is drawn again at the next update.
        Only once: a message comes in several writes (its text, then its newline)."""
        if self.drawn:
            self.stream.write(_CLEAR)
            self.drawn = False
            self.bar._last_line = None  # click draws only a changed line: make the next one count as changed


@contextmanager
def bar(total: int, label: str, minimum: int = 1, count: bool = False) -> Iterator[_Bar | _Silent]:
    """A progress line over ``total`` steps, when :func:`shown` and ``total`` reaches ``minimum``;
    erased when the work ends (or fails), so that the summary or the error starts a clean line.
    ``count`` shows the steps done (programs of a batch); else a percentage only (a program's
    blocks are counted as written, a replaced block being several, so only the share is true)."""
    global _bar
    if total < minimum or not shown():
        yield _Silent()
        return
    stream = _terminal
    _bar = _Bar(total, label, stream, count)
    try:
        _bar.advance(0)
        yield _bar
    finally:
        _bar = None
        stream.write(_CLEAR + _SHOW_CURSOR)
        stream.flush()


class Terminal:
    """stderr on a terminal: a message erases the progress line before it is written. Made by
    :func:`on_terminal`; the line itself is drawn on the terminal underneath, so that a ``--log``
    copy of stderr never holds it."""

    def __init__(self, stream):
        self.terminal = stream

    def write(self, text: str) -> int:
        if _bar is not None and text:
            _bar.clear()
        return self.terminal.write(text)

    def flush(self) -> None:
        self.terminal.flush()

    def isatty(self) -> bool:
        return True

    def __getattr__(self, name):  # fileno, encoding, errors...: the terminal's own
        return getattr(self.terminal, name)


def on_terminal(stream):
    """stderr for this run: ``stream`` itself, or a :class:`Terminal` over it when it is one."""
    global _terminal
    if not _isatty(stream):
        return stream
    _terminal = stream
    return Terminal(stream)


def off_terminal() -> None:
    """The run is over: no line is drawn on that terminal any more."""
    global _terminal
    _terminal = None


def lines(source) -> int:
    """The number of lines of a program, counted a chunk at a time (only when a line is drawn)."""
    from ..syntax.source import count_lines

    return sum(count_lines(chunk, 0, len(chunk)) for chunk in source.chunks())
