"""A part program's bytes: a seekable file, named as the user named it.

Standard input is copied to a temporary file first, so that every program can be read
twice (a cycle's P..Q contour may lie before the cycle) and scanned for its sequence
numbers without being held in memory.
"""

from __future__ import annotations

import io
import os
import re
import shutil
import sys
import tempfile
from functools import cached_property
from typing import BinaryIO, Iterator

from .diagnostics import STDIN_NAME, Location, ProgramError

MAX_PROGRAM_BYTES = 2 * 1024**3  #: 2 GiB: far beyond any control's memory

_LABEL = re.compile(rb"(?m)^[ \t]*(?:/[1-9]?[ \t]*)?[Nn][ \t]*(\d+)")
# Searched in lower-cased text, each starting with a literal: an alternation or a
# case-blind pattern would be tried at every G of the program.
_GOTO = re.compile(rb"goto[ \t]*(\d+|[#\[])")
# The control ignores spaces, even inside a number: ``M 0 98 P 3 1000`` calls O1000 three times.
_CALLS = tuple(
    re.compile(rb"%s[ \t]*(?:0[ \t]*)*%s[ \t]*%s(?![ \t]*\d)[^\r\n(]*?p[ \t]*(\d[\d \t]*)" % code)
    for code in ((b"m", b"9", b"8"), (b"g", b"6", b"5"))
)


class LabelIndex:
    """Which labels a GOTO may jump to, which programs are called from where, and (scanned
    only when a cycle asks) where each sequence number stands."""

    def __init__(self, goto_targets=None, computed_goto: bool = False, calls=None, scan=None):
        self.goto_targets: set[int] = goto_targets or set()
        self.computed_goto = computed_goto  #: a GOTO whose target is an expression: any label may be a target
        self.calls: dict[int, int] = calls or {}  #: program number -> places that call it (M98/G65)
        self._scan = scan
        self._lines: dict[int, list[int]] | None = None if scan else {}
        self._counts: dict[int, int] | None = None if scan else {}

    def _labels(self) -> None:
        if self._lines is None:
            self._lines, self._counts = self._scan()

    @property
    def lines(self) -> dict[int, list[int]]:
        """Label -> its first two line numbers."""
        self._labels()
        return self._lines

    @property
    def counts(self) -> dict[int, int]:
        """Label -> how many blocks carry it."""
        self._labels()
        return self._counts


class Source:
    """A program to read: a path, or ``-`` for standard input."""

    def __init__(self, path: str):
        self.name = STDIN_NAME if path == "-" else path
        self._temp: str | None = None
        if path == "-":
            handle = tempfile.NamedTemporaryFile(prefix="postproc-stdin-", suffix=".nc", delete=False)
            with handle:
                shutil.copyfileobj(sys.stdin.buffer, handle)
            self._temp = handle.name
            self.path = handle.name
        else:
            self.path = path
        try:
            size = os.path.getsize(self.path)
        except OSError as exc:
            raise ProgramError(f"cannot read program: {exc.strerror}", Location(self.name)) from None
        if os.path.isdir(self.path):
            raise ProgramError("is a directory, not a program", Location(self.name))
        if size > MAX_PROGRAM_BYTES:
            raise ProgramError(f"program is {size} bytes; the limit is {MAX_PROGRAM_BYTES}", Location(self.name))
        self.size = size

    @classmethod
    def from_text(cls, text: str | bytes, name: str = "<text>") -> "Source":
        """A source for a program held in memory (the Python API)."""
        data = text.encode("utf-8", "surrogateescape") if isinstance(text, str) else text
        handle = tempfile.NamedTemporaryFile(prefix="postproc-", suffix=".nc", delete=False)
        with handle:
            handle.write(data)
        source = cls(handle.name)
        source._temp = handle.name
        source.name = name
        return source

    def open_binary(self) -> BinaryIO:
        try:
            return open(self.path, "rb")
        except OSError as exc:
            raise ProgramError(f"cannot read program: {exc.strerror}", Location(self.name)) from None

    def lines(self) -> Iterator[str]:
        """Each line with its ending (LF, CRLF or a lone CR); bytes that are not UTF-8 survive as
        surrogates, so writing a line back gives its bytes again."""
        with self.open_binary() as raw:
            yield from io.TextIOWrapper(raw, encoding="utf-8", errors="surrogateescape", newline="")

    @cached_property
    def labels(self) -> LabelIndex:
        """GOTO targets and subprogram calls, found by a quick scan; label places on demand."""
        targets: set[int] = set()
        calls: dict[int, int] = {}
        computed = False
        for chunk in self._chunks():
            chunk = chunk.lower()
            called = {match.start(1): match.group(1) for pattern in _CALLS for match in pattern.finditer(chunk)}
            for spelled in called.values():  # one P word is one call, whichever code reads it
                number = int(spelled.replace(b" ", b"").replace(b"\t", b""))
                number = number % 10000 if number > 9999 else number  # M98 P31234: 3 times O1234
                calls[number] = calls.get(number, 0) + 1
            for match in _GOTO.finditer(chunk):
                target = match.group(1)
                if target.isdigit():
                    targets.add(int(target))
                else:
                    computed = True
        return LabelIndex(targets, computed, calls, scan=self._label_places)

    def _label_places(self) -> tuple[dict[int, list[int]], dict[int, int]]:
        """Scan the whole program, a chunk at a time, for the lines of its sequence numbers."""
        lines: dict[int, list[int]] = {}
        counts: dict[int, int] = {}
        line = 1
        for chunk in self._chunks():
            last = 0
            for match in _LABEL.finditer(chunk):
                start = match.start()
                line += _count_lines(chunk, last, start)
                last = start
                label = int(match.group(1))
                counts[label] = counts.get(label, 0) + 1
                places = lines.setdefault(label, [])
                if len(places) < 2:
                    places.append(line)
            line += _count_lines(chunk, last, len(chunk))
        return lines, counts

    def _chunks(self, size: int = 1 << 20) -> Iterator[bytes]:
        """The file in pieces that end at a line ending, so that no line is split."""
        with self.open_binary() as raw:
            rest = b""
            while True:
                data = raw.read(size)
                if not data:
                    if rest:
                        yield rest
                    return
                data = rest + data
                cut = max(data.rfind(b"\n"), data.rfind(b"\r"))
                if cut < 0 or (data[cut:cut + 1] == b"\r" and cut == len(data) - 1):
                    rest = data
                    continue
                yield data[: cut + 1]
                rest = data[cut + 1 :]

    def read_bytes(self) -> bytes:
        with self.open_binary() as raw:
            return raw.read()

    def close(self) -> None:
        if self._temp is not None:
            try:
                os.unlink(self._temp)
            except OSError:
                pass
            self._temp = None

    def __enter__(self) -> "Source":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _count_lines(data: bytes, start: int, stop: int) -> int:
    """Line endings in ``data[start:stop]``: LF, CRLF and a lone CR each end one line."""
    return data.count(b"\n", start, stop) + data.count(b"\r", start, stop) - data.count(b"\r\n", start, stop)
