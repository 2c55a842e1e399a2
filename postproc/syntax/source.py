"""A part program's bytes: read once, kept in an anonymous temporary file, named as the user
named it.

Every program is read from its source exactly once (a pipe or a FIFO cannot be read again,
and a file could change between two reads), bounded in size, and copied into a temporary
file that has no name: a program can then be read as often as its interpretation needs (a
cycle's P..Q contour may lie before the cycle; the sequence numbers are scanned) without being
held in memory, and a run stopped at any moment, even by SIGKILL, leaves no copy behind.
"""

from __future__ import annotations

import bisect
import io
import os
import re
import stat
import sys
import tempfile
from functools import cached_property
from typing import BinaryIO, Iterator

from ..diagnostics import STDIN_NAME, Location, OutputError, ProgramError

CHUNK = 1 << 20
MAX_PROGRAM_BYTES = 2 * 1024**3  #: 2 GiB: far beyond any control's memory

_LABEL = re.compile(rb"(?m)^[ \t]*(?:/[1-9]?[ \t]*)?[Nn][ \t]*(\d+)")
# A program's start in a file that holds several (a main program and its local subprograms):
# O1234, :1234 or <NAME> opening a line. The control looks for a cycle's P and Q in the program
# that runs it, so each program may number its blocks N10, N20... again.
_PROGRAM = re.compile(rb"(?m)^[ \t%]*([Oo:][ \t]*\d[\d \t]*|<[^>\r\n]*>?)")
# A program's end: M30, M02 or M99 in a block that no block delete may skip, before any comment.
# A cycle's P and Q are looked for from the program's O number to the first end at or after the
# cycle (an M99 before it may be a conditional return).
_END = re.compile(rb"(?m)^(?![ \t]*/)[^(;\r\n]*?[Mm][ \t]*(?:0[ \t]*)*(?:3[ \t]*0|2|9[ \t]*9)(?![ \t]*\d)")
# A tape mark: '%' opening a line, after spaces or a byte order mark. The first one after any other
# text (or the second one) is the end of the tape: the control reads nothing after it, so nothing
# there is a block a cycle's P or Q, a program's start or its end can be.
_TAPE_MARK = re.compile(rb"(?m)^(?:[ \t]|\xef\xbb\xbf)*%")
_LEADER = re.compile(rb"(?:\xef\xbb\xbf)?[ \t\r\n]*")
# Searched in lower-cased text, each starting with a literal: an alternation or a
# case-blind pattern would be tried at every G of the program.
_GOTO = re.compile(rb"goto[ \t]*(\d+|[#\[])")
# M99 Pn returns to (in a main program: jumps to) the block with sequence number n; the
# interpreter follows neither that jump nor a call, so such a block is a jump target like a
# GOTO's.
# M98 Pp Qn (M198 too) calls the subprogram from its block Nn, and with no P the block Nn of
# the program itself: that block is entered from the call. A comment between the M code and
# the P or Q is no word of the block: the P or Q after it is still the target.
_BETWEEN = rb"(?![ \t]*\d)(?:[^\r\n(]|\([^\r\n)]*\))*?"
_RETURN = re.compile(rb"m[ \t]*(?:0[ \t]*)*9[ \t]*9" + _BETWEEN + rb"p[ \t]*(\d[\d \t]*|[#\[])")
_ENTRY = re.compile(rb"m[ \t]*(?:0[ \t]*)*(?:1[ \t]*)?9[ \t]*8" + _BETWEEN + rb"q[ \t]*(\d[\d \t]*|[#\[])")
# The control reads a block's words in any order: the P or Q may come before the M code.
_RETURN_AFTER = re.compile(rb"p[ \t]*(\d[\d \t]*|[#\[])[^\r\n(]*?m[ \t]*(?:0[ \t]*)*9[ \t]*9(?![ \t]*\d)")
_ENTRY_AFTER = re.compile(rb"q[ \t]*(\d[\d \t]*|[#\[])[^\r\n(]*?m[ \t]*(?:0[ \t]*)*(?:1[ \t]*)?9[ \t]*8(?![ \t]*\d)")
# A multiple repetitive cycle that runs the blocks from its P to its Q label (G70-G73): a block
# labelled with such a Q ends a finishing or roughing pass, wherever it stands in the program.
_CYCLE = rb"g[ \t]*(?:0[ \t]*)*7[ \t]*[0-3](?![ \t]*[\d.])"
_CYCLE_RANGE = tuple(re.compile(pattern) for pattern in (
    _CYCLE + rb"[^\r\n(]*?([pq])[ \t]*(\d[\d \t]*|[#\[])",
    rb"([pq])[ \t]*(\d[\d \t]*|[#\[])[^\r\n(]*?" + _CYCLE,
))
# The control ignores spaces, even inside a number: ``M 0 98 P 3 1000`` calls O1000 three times.
_CALLS = tuple(
    re.compile(rb"%s[ \t]*(?:0[ \t]*)*%s[ \t]*%s(?![ \t]*\d)[^\r\n(]*?p[ \t]*(\d[\d \t]*)" % code)
    for code in ((b"m", b"9", b"8"), (b"g", b"6", b"5"))
)


class LabelIndex:
    """Which labels control may jump to (a GOTO's, an M99 P's, an M98 Q's), which programs are called from where, and (scanned
    only when a cycle asks) where each sequence number stands."""

    def __init__(self, goto_targets=None, computed_goto: bool = False, calls=None, scan=None, cycle_scan=None):
        self.goto_targets: set[int] = goto_targets or set()
        self._cycle_scan = cycle_scan
        self._cycle_ranges: tuple[set, set] | None = None if cycle_scan else (set(), set())
        self.computed_goto = computed_goto  #: a GOTO whose target is an expression: any label may be a target
        self.calls: dict[int, int] = calls or {}  #: program number -> places that call it (M98/G65)
        self._scan = scan
        self._lines: dict[int, list[int]] | None = None if scan else {}
        self._counts: dict[int, int] | None = None if scan else {}
        self._programs: list[int] = []  # the line of each program's O number (or <NAME>)
        self._names: list[str] = []  # and that number or name, as written
        self._ends: list[int] = []  # the lines of the blocks that end a program (M30, M02, M99)
        self._unread: dict[int, int] = {}  # label -> its first line after the end of the tape ('%')

    def _labels(self) -> None:
        if self._lines is None:
            self._lines, self._counts, programs, self._ends, self._unread = self._scan()
            self._programs = [line for line, _ in programs]
            self._names = [name for _, name in programs]

    @property
    def lines(self) -> dict[int, list[int]]:
        """Label -> the line numbers of the blocks that carry it, in order."""
        self._labels()
        return self._lines

    @property
    def unread(self) -> dict[int, int]:
        """Label -> the first line carrying it after the end of the tape (the closing '%'), where
        the control reads nothing: no cycle finds its P or Q there."""
        self._labels()
        return self._unread

    def program_of(self, line: int) -> tuple[str, int, int | None]:
        """The program that runs the block on ``line``: its name (``O0002``, ``<NAME>``, or the
        line it starts on when it has no O number), its first line, and its last (None: the end
        of the file). It runs from its O number to its first end (M30, M02, M99) at or after
        ``line``, and at most to the next O number."""
        self._labels()
        here = bisect.bisect_right(self._programs, line)
        first = self._programs[here - 1] if here else 1
        last = self._programs[here] - 1 if here < len(self._programs) else None
        end = bisect.bisect_left(self._ends, line)
        if end < len(self._ends) and (last is None or self._ends[end] <= last):
            last = self._ends[end]
        name = self._names[here - 1] if here else f"the program from line {first}"
        return name, first, last

    def in_program_of(self, label: int, line: int) -> list[int]:
        """The lines of the blocks carrying ``label`` in the program that runs the block on
        ``line`` (:meth:`program_of`): the control looks for a cycle's P and Q there only."""
        _, first, last = self.program_of(line)
        return [place for place in self._lines.get(label, ()) if first <= place and (last is None or place <= last)]

    @property
    def cycle_starts(self) -> set[int | None]:
        """The P labels of the program's G70-G73 cycles (None for one an expression gives: any
        label may be it); scanned when first asked, as only a split labelled block asks."""
        return self._ranges()[0]

    @property
    def cycle_ends(self) -> set[int | None]:
        """The Q labels of the program's G70-G73 cycles, as :attr:`cycle_starts`."""
        return self._ranges()[1]

    def _ranges(self) -> tuple[set[int | None], set[int | None]]:
        if self._cycle_ranges is None:
            self._cycle_ranges = self._cycle_scan()
        return self._cycle_ranges

    @property
    def counts(self) -> dict[int, int]:
        """Label -> how many blocks carry it."""
        self._labels()
        return self._counts


_LINE_END = re.compile(rb"[\r\n(]")
_RANGE_WORD = re.compile(rb"([pq])[ \t]*(\d[\d \t]*|[#\[])")


def _cycle_range(chunk: bytes, start: int, ranges: dict[bytes, set[int | None]]) -> None:
    """Add the P and Q labels of the cycle block read from ``start`` to its end (or its first
    comment); None for one an expression gives."""
    end = _LINE_END.search(chunk, start)
    for letter, value in _RANGE_WORD.findall(chunk, start, end.start() if end else len(chunk)):
        value = value.replace(b" ", b"").replace(b"\t", b"")
        ranges[letter].add(int(value) if value.isdigit() else None)


def _anonymous(name: str) -> BinaryIO:
    """The anonymous temporary file a program is copied into; a full disk is said as such."""
    from ..files.output import temporary

    return temporary(Location(name), "a copy of the program")[1]


class Source:
    """A program to read: a path, or ``-`` for standard input."""

    def __init__(self, path: str):
        self.name = STDIN_NAME if path == "-" else path
        self.path = path
        self._file = _anonymous(self.name)  # anonymous: nothing to clean up after a kill
        self.size = 0
        try:
            if path == "-":
                self._copy_stream(sys.stdin.buffer if sys.stdin is not None else None)
            else:
                self._copy_file(path)
            self._keep(b"", flush=True)
        except BaseException:
            try:
                self._file.close()
            except OSError:  # the flush of what could not be kept fails again
                pass
            raise

    @classmethod
    def from_text(cls, text: str | bytes, name: str = "<text>") -> "Source":
        """A source for a program held in memory (the Python API)."""
        data = text.encode("utf-8", "surrogateescape") if isinstance(text, str) else text
        source = cls.__new__(cls)
        source.name = source.path = name
        source._file = _anonymous(name)
        source._keep(data, flush=True)
        source.size = len(data)
        return source

    def _copy_file(self, path: str) -> None:
        try:
            fd = os.open(path, os.O_RDONLY | getattr(os, "O_CLOEXEC", 0))
        except OSError as exc:
            raise ProgramError(f"cannot read program: {exc.strerror}", Location(self.name)) from None
        try:
            info = os.fstat(fd)
            if stat.S_ISDIR(info.st_mode):
                raise ProgramError("is a directory, not a program", Location(self.name))
            regular = stat.S_ISREG(info.st_mode)
            if regular and info.st_size > MAX_PROGRAM_BYTES:
                raise ProgramError(f"program is {info.st_size} bytes; the limit is {MAX_PROGRAM_BYTES}",
                                   Location(self.name))
            with open(fd, "rb", buffering=0, closefd=False) as raw:
                self._copy(raw, regular)
        except OSError as exc:
            raise ProgramError(f"cannot read program: {exc.strerror}", Location(self.name)) from None
        finally:
            os.close(fd)

    def _copy_stream(self, stream) -> None:
        if stream is None:
            raise ProgramError("cannot read program: standard input is closed", Location(self.name))
        try:
            self._copy(stream, False)
        except OSError as exc:
            raise ProgramError(f"cannot read program: {exc.strerror}", Location(self.name)) from None

    def _copy(self, raw, regular: bool) -> None:
        """Copy the input into the spool file, at most MAX_PROGRAM_BYTES. A stream that is not a
        regular file (a device, a pipe) is stopped at its first NUL byte: text programs have none,
        and ``/dev/zero`` or ``/dev/urandom`` would otherwise be read to the limit."""
        while chunk := raw.read(CHUNK):
            if not regular and b"\x00" in chunk:
                raise self._binary(chunk[: chunk.index(b"\x00")])
            if self.size + len(chunk) > MAX_PROGRAM_BYTES:
                raise ProgramError(f"more than {MAX_PROGRAM_BYTES} bytes: no control holds such a program (a device "
                                   "or a stream that does not end?)", Location(self.name))
            self._keep(chunk)
            self.size += len(chunk)

    def _keep(self, chunk: bytes, flush: bool = False) -> None:
        try:
            self._file.write(chunk)
            if flush:
                self._file.flush()
        except OSError as exc:
            from ..files.output import explain

            raise OutputError(f"cannot keep a copy of the program in {tempfile.gettempdir()} (TMPDIR): "
                              f"{explain(exc)}", Location(self.name)) from None

    def _binary(self, head: bytes) -> ProgramError:
        """The error for a stream with a NUL byte, placed at it (after what was copied so far)."""
        self._keep(head, flush=True)
        self.size += len(head)
        line, last = 1, b""
        for chunk in self.chunks():
            line += count_lines(chunk, 0, len(chunk))
            last = chunk
        text = last[max(last.rfind(b"\n"), last.rfind(b"\r")) + 1 :].decode("utf-8", "surrogateescape")
        return ProgramError("a NUL byte: this is binary data, not a text program; nothing more was read",
                            Location(self.name, line, len(text) + 1, text))

    def open_binary(self) -> BinaryIO:
        """A reader of its own (its own position) over the program's bytes."""
        return io.BufferedReader(_View(self._file.fileno(), self.size), CHUNK)

    def lines(self) -> Iterator[str]:
        """Each line with its ending (LF, CRLF or a lone CR); bytes that are not UTF-8 survive as
        surrogates, so writing a line back gives its bytes again."""
        with self.open_binary() as raw:
            yield from io.TextIOWrapper(raw, encoding="utf-8", errors="surrogateescape", newline="")

    @cached_property
    def labels(self) -> LabelIndex:
        """Jump targets (GOTO n, M99 Pn, M98 Qn) and subprogram calls, found by a quick scan; label places on demand."""
        targets: set[int] = set()
        calls: dict[int, int] = {}
        computed = False
        for chunk in self.chunks():
            chunk = chunk.lower()
            called = {match.start(1): match.group(1) for pattern in _CALLS for match in pattern.finditer(chunk)}
            for spelled in called.values():  # one P word is one call, whichever code reads it
                number = int(spelled.replace(b" ", b"").replace(b"\t", b""))
                number = number % 10000 if number > 9999 else number  # M98 P31234: 3 times O1234
                calls[number] = calls.get(number, 0) + 1
            for pattern in (_GOTO, _RETURN, _ENTRY, _RETURN_AFTER, _ENTRY_AFTER):
                for match in pattern.finditer(chunk):
                    target = match.group(1).replace(b" ", b"").replace(b"\t", b"")
                    if target.isdigit():
                        targets.add(int(target))
                    else:
                        computed = True
        return LabelIndex(targets, computed, calls, scan=self._label_places, cycle_scan=self._cycle_ranges)

    def _cycle_ranges(self) -> tuple[set[int | None], set[int | None]]:
        """The P and the Q labels of every G70-G73 cycle in the file, a chunk at a time."""
        ranges: dict[bytes, set[int | None]] = {b"p": set(), b"q": set()}
        for chunk in self.chunks():
            chunk = chunk.lower()
            for pattern in _CYCLE_RANGE:
                for match in pattern.finditer(chunk):
                    _cycle_range(chunk, match.start(), ranges)
        return ranges[b"p"], ranges[b"q"]

    def _label_places(self) -> tuple[dict[int, list[int]], dict[int, int], list[tuple[int, str]], list[int],
                                     dict[int, int]]:
        """Scan the program, a chunk at a time, for the lines of its sequence numbers, of the
        program numbers that start each program the file holds (with the number), and of the
        blocks that end a program, up to the end of the tape (the closing '%', as the reader
        reads it); and the labels after that end, which the control never reads."""
        lines: dict[int, list[int]] = {}
        counts: dict[int, int] = {}
        programs: list[tuple[int, str]] = []
        ends: list[int] = []
        unread: dict[int, int] = {}
        line = 1
        opened = ended = False  # a '%' read; the end of the tape read
        for chunk in self.chunks():
            found = [(match.start(), "label", match) for match in _LABEL.finditer(chunk)]
            found += [(match.start(1), "program", match) for match in _PROGRAM.finditer(chunk)]
            found += [(match.start(), "end", match) for match in _END.finditer(chunk)]
            if not ended:
                found += [(match.start(), "tape", match) for match in _TAPE_MARK.finditer(chunk)]
            found.sort(key=lambda item: item[0])
            last = 0
            for start, kind, match in found:
                line += count_lines(chunk, last, start)
                last = start
                if ended:
                    if kind == "label":
                        unread.setdefault(int(match.group(1)), line)
                    continue
                if kind == "tape":
                    ended = opened or _LEADER.match(chunk, 0, start).end() < start
                    opened = True
                    continue
                if kind == "program":
                    name = match.group(1).decode("ascii", "replace")
                    programs.append((line, "O" + re.sub(r"[ \t]", "", name[1:]) if name[0] in "Oo:" else name))
                    continue
                if kind == "end":
                    ends.append(line)
                    continue
                label = int(match.group(1))
                counts[label] = counts.get(label, 0) + 1
                lines.setdefault(label, []).append(line)
            line += count_lines(chunk, last, len(chunk))
            opened = opened or _LEADER.match(chunk).end() < len(chunk)  # text before any '%': the next one ends the tape
        return lines, counts, programs, ends, unread

    def chunks(self, size: int = 1 << 20) -> Iterator[bytes]:
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
        self._file.close()

    def __enter__(self) -> "Source":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def count_lines(data: bytes, start: int, stop: int) -> int:
    """Line endings in ``data[start:stop]``: LF, CRLF and a lone CR each end one line."""
    return data.count(b"\n", start, stop) + data.count(b"\r", start, stop) - data.count(b"\r\n", start, stop)


class _View(io.RawIOBase):
    """Reads a file descriptor from a position of its own (``pread``), so that several readers
    of one spooled program never move each other's place."""

    def __init__(self, fd: int, size: int):
        super().__init__()
        self._fd, self._size, self._at = fd, size, 0

    def readable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def readinto(self, buffer) -> int:
        count = min(len(buffer), self._size - self._at)
        if count <= 0:
            return 0
        data = os.pread(self._fd, count, self._at)
        buffer[: len(data)] = data
        self._at += len(data)
        return len(data)

    def seek(self, offset: int, whence: int = io.SEEK_SET) -> int:
        base = {io.SEEK_SET: 0, io.SEEK_CUR: self._at, io.SEEK_END: self._size}[whence]
        self._at = max(0, base + offset)
        return self._at

    def tell(self) -> int:
        return self._at
