"""Input files read once, whole and bounded: the one way postproc reads a measurement, a
model, a machine profile or any other file it is given.

A pipe (``<(cat trace.csv)``), a FIFO, standard input or a device can be read only once, and
a regular file can change between two reads; so each input is read exactly once, up to a
bound that fits its kind (``/dev/zero`` ends in a clear error, not in a full memory), and
everything that needs it again (the reader, the SHA-256 a model or a report records, the
measurement time) gets the bytes of that one read. Inside a :func:`session` (a command-line
run, a Pipeline being fitted) a path read before is served from its first read.

Programs, which can be gigabytes, go through :class:`postproc.syntax.source.Source`, which keeps
its one read in an anonymous temporary file instead of memory.
"""

from __future__ import annotations

import contextlib
import contextvars
import hashlib
import os
import re
import stat
import sys
from dataclasses import dataclass
from functools import cached_property
from typing import Iterator

from ..diagnostics import STDIN_NAME, Location, PostprocError

CHUNK = 1 << 20

#: the snapshots (or the errors) of the paths read in the current session; None outside one
_session: contextvars.ContextVar[dict | None] = contextvars.ContextVar("postproc_inputs", default=None)


@dataclass(frozen=True)
class Snapshot:
    """One read of an input: its bytes and what the file system said of it then."""

    path: str  #: as the user gave it
    data: bytes
    regular: bool  #: a regular file (not a pipe, a FIFO or a device)
    mtime: float | None  #: a regular file's modification time at the read (seconds since the epoch)

    @cached_property
    def sha256(self) -> str:
        return hashlib.sha256(self.data).hexdigest()


@contextlib.contextmanager
def session() -> Iterator[None]:
    """Within it, every path is read once; nested sessions share the outermost one."""
    if _session.get() is not None:
        yield
        return
    token = _session.set({})
    try:
        yield
    finally:
        _session.reset(token)


def read(path: str, limit: int, error: type[PostprocError], what: str) -> Snapshot:
    """The bytes of the file at ``path``, read once (per session) and at most ``limit`` of them.

    ``what`` names the kind of file in messages ("a measurement file", "a model"); every
    problem is an ``error`` naming the file.
    """
    known = _session.get()
    if known is not None and path in known:
        found = known[path]
        if isinstance(found, PostprocError):  # a file that could not be read is not tried again
            raise found
        return found
    try:
        snapshot = _read(path, limit, error, what)
    except PostprocError as exc:
        if known is not None:
            known[path] = exc
        raise
    if known is not None:
        known[path] = snapshot
    return snapshot


def read_stdin(name: str, limit: int, error: type[PostprocError], what: str) -> Snapshot:
    """Standard input, read once and bounded as :func:`read` reads a file."""
    stream = getattr(sys.stdin, "buffer", None)
    if stream is None:
        raise error("cannot read standard input: it is closed", Location(name))
    chunks: list[bytes] = []
    size = 0
    try:
        while chunk := stream.read(min(CHUNK, limit + 1 - size)):
            chunks.append(chunk)
            size += len(chunk)
            if size > limit:
                raise error(f"more than {limit} bytes: too long for {what}", Location(name))
    except OSError as exc:
        raise error(f"cannot read standard input: {exc.strerror}", Location(name)) from None
    return Snapshot(name, b"".join(chunks), False, None)


def read_toml(path: str, limit: int, error: type[PostprocError], what: str) -> tuple[dict, str]:
    """A TOML file read once: its document and its text. A syntax error names its line; a
    document nested too deeply for the parser is refused as such."""
    import tomllib  # only when a TOML file is read: every run starts faster without it

    data = read(path, limit, error, what).data
    path = named(path)
    if data.startswith(b"\xef\xbb\xbf"):  # a UTF-8 byte order mark, as Windows editors save: not TOML, but harmless
        data = data[3:]
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise error("the file is not UTF-8 text", Location(path, data[: exc.start].count(b"\n") + 1)) from None
    try:
        return tomllib.loads(text), text
    except tomllib.TOMLDecodeError as exc:
        found = re.search(r"\(at line (\d+), column (\d+)\)", str(exc))
        message = re.sub(r"\s*\(at (line \d+, column \d+|end of document)\)", "", str(exc))
        where = Location(path)
        lines = text.splitlines()
        if found:
            line = int(found.group(1))
            where = Location(path, line, int(found.group(2)), lines[line - 1] if line <= len(lines) else None)
        elif "(at end of document)" in str(exc) and lines:  # something left open: where the text ends
            where = Location(path, len(lines), len(lines[-1]) + 1, lines[-1])
        raise error(f"not valid TOML: {message}", where) from None
    except RecursionError:
        raise error(f"nested too deeply to be {what}", Location(path)) from None


def toml_key(path: str, text: str, key: str, table: str | None = None, occurrence: int = 1) -> Location:
    """Where ``key`` is written in a TOML text (at the top, or in ``[table]``, the
    ``occurrence``-th ``[[table]]`` of an array of tables): its line and column, with the line
    for the caret; a key that names a table (``[key]``, ``[key.sub]``, ``[[key]]``) where its
    header is; the file alone when it cannot be found (a key in an inline table, say)."""
    current = None
    opened = None
    seen = 0  # headers of ``table`` passed
    pattern = re.compile(rf"^(\s*)(?:{re.escape(key)}|\"{re.escape(key)}\"|'{re.escape(key)}')\s*=")
    named = key if table is None else f"{table}.{key}"
    for number, line in enumerate(text.splitlines(), 1):
        header = re.match(r"^\s*\[+\s*([^\]]+?)\s*\]", line)
        if header:
            current = ".".join(part.strip().strip("\"'") for part in header.group(1).split("."))
            seen += current == table
            if opened is None and (current == named or current.startswith(named + ".")):
                opened = Location(path, number, header.start(1) + 1, line)
            continue
        found = pattern.match(line)
        if found and current == table and (table is None or seen == occurrence):
            return Location(path, number, len(found.group(1)) + 1, line)
    return opened or Location(path)


def spellings(data: dict, path: str, text: str | None, error: type[PostprocError]) -> dict[str, str]:
    """Each key of a TOML table as read (``-`` for ``_``: ``max-correction`` is
    ``max_correction``) -> as written; one key in both spellings is refused, since which of
    them would win is a guess."""
    written: dict[str, str] = {}
    for key in data:
        name = key.replace("-", "_")
        if name in written:
            raise error(f"{name} is given twice, as {written[name]!r} and as {key!r}; keep one",
                        toml_key(path, text, key) if text is not None else Location(path))
        written[name] = key
    return written


def did_you_mean(word: str, known) -> str:
    """``; did you mean 'x_limits'?`` for the known word nearest a misspelt one, or nothing."""
    import difflib

    close = difflib.get_close_matches(word, sorted(known), n=1, cutoff=0.6)
    return f"; did you mean '{close[0]}'?" if close else ""


def recorded(path: str) -> Snapshot | None:
    """The snapshot of ``path`` read in this session, if any (without reading it)."""
    known = _session.get()
    found = None if known is None else known.get(path)
    return found if isinstance(found, Snapshot) else None


def named(path: str) -> str:
    """A path as messages name it: ``-`` is standard input, ``<stdin>``."""
    return STDIN_NAME if path == "-" else path


def _read(path: str, limit: int, error: type[PostprocError], what: str) -> Snapshot:
    if path == "-":  # a measurement, model or profile piped in: `cat trace.csv | postproc ballbar -`
        return read_stdin(STDIN_NAME, limit, error, what)
    where = Location(path)
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_CLOEXEC", 0))
    except OSError as exc:
        raise error(f"cannot read the file: {exc.strerror}", where) from None
    try:
        info = os.fstat(fd)
        if stat.S_ISDIR(info.st_mode):
            raise error(f"is a directory, not {what}", where)
        regular = stat.S_ISREG(info.st_mode)
        if regular and info.st_size > limit:
            raise error(f"the file is {info.st_size} bytes; {what} is at most {limit}", where)
        chunks: list[bytes] = []
        size = 0
        while True:
            chunk = os.read(fd, min(CHUNK, limit + 1 - size))
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
            if size > limit:
                raise error(f"more than {limit} bytes: too long for {what} (a device or a stream that does not end?)",
                            where)
    except OSError as exc:
        raise error(f"cannot read the file: {exc.strerror}", where) from None
    finally:
        os.close(fd)
    return Snapshot(path, b"".join(chunks), regular, info.st_mtime if regular else None)
