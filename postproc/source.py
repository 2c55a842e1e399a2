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
from dataclasses import dataclass, field
from functools import cached_property
from typing import BinaryIO, Iterator

from .diagnostics import STDIN_NAME, Location, ProgramError

MAX_PROGRAM_BYTES = 2 * 1024**3  #: 2 GiB: far beyond any control's memory

_LABEL = re.compile(rb"(?m)^[ \t]*(?:/[1-9]?[ \t]*)?[Nn][ \t]*(\d+)")
_GOTO = re.compile(rb"(?i)goto[ \t]*(\d+|[#\[])")
_CALL = re.compile(rb"(?i)(?:m[ \t]*0*98|g[ \t]*0*65)[^\r\n(]*?p[ \t]*(\d+)")


@dataclass
class LabelIndex:
    """Where each sequence number stands, and which labels a GOTO may jump to."""

    lines: dict[int, list[int]] = field(default_factory=dict)  #: label -> up to 2 line numbers
    counts: dict[int, int] = field(default_factory=dict)  #: label -> occurrences
    goto_targets: set[int] = field(default_factory=set)
    computed_goto: bool = False  #: a GOTO whose target is an expression: any label may be a target
    calls: dict[int, int] = field(default_factory=dict)  #: program number -> places that call it (M98/G65)


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

    def lines(self) -> Iterator[tuple[str, str]]:
        """``(text, eol)`` for each line; bytes that are not UTF-8 survive as surrogates."""
        with self.open_binary() as raw:
            stream = io.TextIOWrapper(raw, encoding="utf-8", errors="surrogateescape", newline="")
            for line in stream:
                if line.endswith("\n"):
                    if line.endswith("\r\n"):
                        yield line[:-2], "\r\n"
                    else:
                        yield line[:-1], "\n"
                elif line.endswith("\r"):
                    yield line[:-1], "\r"
                else:
                    yield line, ""

    @cached_property
    def labels(self) -> LabelIndex:
        """Scan the whole program once, a chunk at a time, for sequence numbers and GOTO targets."""
        index = LabelIndex()
        line = 1
        for chunk in self._chunks():
            last = 0
            for match in _LABEL.finditer(chunk):
                start = match.start()
                line += _count_lines(chunk, last, start)
                last = start
                label = int(match.group(1))
                index.counts[label] = index.counts.get(label, 0) + 1
                places = index.lines.setdefault(label, [])
                if len(places) < 2:
                    places.append(line)
            line += _count_lines(chunk, last, len(chunk))
            for match in _CALL.finditer(chunk):
                number = int(match.group(1))
                number = number % 10000 if number > 9999 else number  # M98 P31234: 3 times O1234
                index.calls[number] = index.calls.get(number, 0) + 1
            for match in _GOTO.finditer(chunk):
                target = match.group(1)
                if target.isdigit():
                    index.goto_targets.add(int(target))
                else:
                    index.computed_goto = True
        return index

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
