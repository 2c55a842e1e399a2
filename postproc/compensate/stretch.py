"""A long stretch of blocks that move nothing, behind a motion step whose join waits for the next
move: each block's text kept in an anonymous temporary file, not in memory.

The rewriter settles the join of two moves only when the second is read (the first move's end
may have to meet the second's corrected start, or go back to its nominal end), and the blocks
between them are written after the first. Held as steps, a stretch of 300,000 coolant codes or
comments took 313 MB; settled early (the first move sent back to its nominal end without the
second), the join came out otherwise than with a short stretch, and under G41/G42 was refused.
A block that moves nothing and does not rely on the motion mode in force is written exactly as
it was read, whatever the join: past the window its text goes to the :class:`Spool`, with what
writing it does to the rewriter's motion modes (:class:`Stretch`), and the join is settled
when the next move comes, as for a short stretch. Memory stays flat however long the stretch."""

from __future__ import annotations

import itertools
import tempfile
from typing import Iterator, TextIO

from ..diagnostics import Location, OutputError

#: The mode a stretch leaves in force is the one it found (a stretch that sets none)
SAME = object()


class Stretch:
    """Consecutive blocks of a window that move nothing, their text in the spool: how many, and
    the motion modes writing them leaves (as :meth:`~postproc.compensate.writing.Writing._write`
    would, block by block): the mode in force after them, from the one they find (:meth:`after`),
    the program's own mode after the last (``original``) and the last known (``known``)."""

    __slots__ = ("blocks", "from_none", "from_some", "original", "known")

    def __init__(self) -> None:
        self.blocks = 0
        self.from_none = None  # the mode in force after them, when none was before
        self.from_some = SAME  # ... when one was: SAME while no block has set another
        self.original = None
        self.known = SAME  # the last mode the program was known to be in, SAME while none is

    def add(self, motion, sets_mode: bool) -> None:
        """One more block: ``motion``, the program's motion mode at it; ``sets_mode``, whether
        its own G code sets one (else it takes the mode in force where none is)."""
        self.blocks += 1
        if sets_mode or self.from_none is None:
            self.from_none = motion
        if sets_mode or self.from_some is None:
            self.from_some = motion
        self.original = motion
        if motion is not None:
            self.known = motion

    def after(self, mode):
        """The motion mode in force after the stretch, from ``mode`` in force before it."""
        if mode is None:
            return self.from_none
        return mode if self.from_some is SAME else self.from_some


class Spool:
    """The text of the stretches of one window, in order, in an anonymous temporary file (made
    when first needed; no name, so that a run stopped at any moment leaves nothing behind).
    Written while the window fills, read back once as it is written out, then emptied."""

    def __init__(self, file: str) -> None:
        self.file = file  #: the program's name, for an error
        self._text: TextIO | None = None
        self._reading = False
        self.used = False  #: whether it holds text not yet read back

    def write(self, text: str) -> None:
        try:
            if self._text is None:
                self._text = tempfile.TemporaryFile("w+", encoding="utf-8", errors="surrogateescape", newline="")
            self._text.write(text)
        except OSError as exc:
            from ..files.output import explain

            raise OutputError(f"cannot hold a long stretch of blocks that move nothing in {tempfile.gettempdir()} "
                              f"(TMPDIR) while the join around it waits for the next move: {explain(exc)}",
                              Location(self.file)) from None
        self.used = True

    def lines(self, count: int) -> Iterator[str]:
        """The next ``count`` blocks' text, each line with its ending, as written."""
        assert self._text is not None
        if not self._reading:
            self._text.seek(0)
            self._reading = True
        return itertools.islice(self._text, count)

    def empty(self) -> None:
        """Everything read back: the file is emptied for the next window's stretches."""
        if self._text is not None:
            self._text.seek(0)
            self._text.truncate()
        self._reading = self.used = False

    def close(self) -> None:
        if self._text is not None:
            self._text.close()
            self._text = None
        self._reading = self.used = False
