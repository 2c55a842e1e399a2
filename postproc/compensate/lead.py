"""The lines a compensated program's provenance block comes after: the opening tape mark and
the program number (formats.md §12), with the blank lines among them.

Read as the control reads a tape: the first ``%`` opens it and the next closes it, so a ``%``
after the opening one, or after the program number (an empty program: ``%``, ``O1234``, ``%``),
is no part of the lead: the header goes before it, where the control reads it. A second
program number starts another program and is no part of the lead either. A program with no
tape mark or no program number has a shorter lead (nothing at all: the header comes first)."""

from __future__ import annotations

_MOST = 8  #: lines in a lead at most (blank lines included)


class Lead:
    """The lead lines, taken one written line at a time until the first that is not one."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self._seen: set[str] = set()
        self._open = True

    def takes(self, text: str) -> bool:
        """Whether ``text``, the next line written, still comes before the header (kept if so)."""
        if not self._open:
            return False
        stripped = text.strip().lstrip("\ufeff")  # a byte order mark before the tape mark
        kind = "" if not stripped else "%" if stripped[0] == "%" else "O" if stripped[0] in "Oo<:" else None
        if kind is None or kind in self._seen or (kind == "%" and "O" in self._seen) or len(self.lines) >= _MOST:
            self._open = False
            return False
        if kind:
            self._seen.add(kind)
        self.lines.append(text)
        return True
