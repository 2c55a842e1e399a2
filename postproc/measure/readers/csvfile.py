"""The common shape of postproc's measurement files (docs/formats.md §3).

A magic line, ``# key = value`` header lines, one CSV header row, then data rows. Unknown
header keys are refused (a misspelt optional key must not fall back to its default) except
``x-`` keys, which are kept. Every format takes the optional key ``measured``: when the
measurement was taken, ISO 8601 with a time zone (a saved model records it). Every problem is
a MeasurementError in the fixed message forms: ``FILE:LINE: error:`` for a header line or data
row, ``FILE: error:`` for the whole file.
"""

from __future__ import annotations

import datetime as dt
import io
import math
import re
from array import array
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from ...files import inputs
from ...diagnostics import Location, MeasurementError
from .lengths import travel_problem

MAX_BYTES = 64 * 1024 * 1024  #: a measurement file larger than this is not a measurement file

COMMON_KEYS = {"measured"}  #: header keys every format takes

MAGICS = {
    "# postproc ballbar 1": "ballbar trace",
    "# postproc probe 1": "probe file",
    "# postproc probe-calibration 1": "probe calibration",
}
#: magic line -> how a table of that kind laid out otherwise is made into one
CONVERTERS = {"# postproc ballbar 1": "; an instrument's export laid out otherwise (its own columns, semicolons, "
                                      "tabs, decimal commas, um) is converted by postproc import-trace"}


@dataclass
class Table:
    """A measurement file, read but not yet interpreted."""

    path: str
    header: dict[str, tuple[str, int]]  #: key -> (value, line)
    extras: dict[str, str]  #: the x- keys
    columns: list[str]
    lines: np.ndarray  #: the file's line of each data row
    values: np.ndarray  #: (rows, columns): the data, as numbers
    #: the line of the CSV header row, where the header lines ended: where a missing key was due
    columns_line: int | None = None

    def where(self, line: int | None = None) -> Location:
        return Location(self.path, line)

    def error(self, message: str, line: int | None = None) -> MeasurementError:
        return MeasurementError(message, self.where(line))

    def column(self, name: str) -> np.ndarray:
        return self.values[:, self.columns.index(name)].copy()

    # -- header values --------------------------------------------------------------

    def missing(self, key: str, expected: str = "") -> MeasurementError:
        """A required key the header lacks, at the line where the header ended without it."""
        said = f" ({expected})" if expected else ""
        return self.error(f"the header key {key!r} is required{said}; the header lines end here without it",
                          self.columns_line)

    def number(self, key: str, default: float | None = None, positive: bool = False, required: bool = False,
               at_most: tuple[float, str] | None = None) -> float | None:
        """A header number; ``at_most``: (the largest plausible value, what a larger one most likely is)."""
        if key not in self.header:
            if required:
                raise self.missing(key)
            return default
        text, line = self.header[key]
        value = _float(text)
        if value is None:
            raise self.error(f"{key} = {text!r} is not a number", line)
        if positive and value <= 0:
            raise self.error(f"{key} must be positive, not {text}", line)
        if at_most is not None and value > at_most[0]:
            raise self.error(f"{key} = {text} is above {at_most[0]:g}: {at_most[1]}", line)
        return value

    def coordinate(self, key: str, default: float | None = None, required: bool = False) -> float | None:
        """A header coordinate, mm from the work origin, held to any lathe's travel
        (:func:`~postproc.measure.readers.lengths.travel_problem`: micrometres, inches)."""
        value = self.number(key, default, required=required)
        problem = None if value is None or key not in self.header else travel_problem(value)
        if problem:
            raise self.error(f"{key} = {self.header[key][0]}: {problem}", self.header[key][1])
        return value

    def choice(self, key: str, options: tuple[str, ...], default: str | None = None, required: bool = False,
               meaning: str = "") -> str | None:
        """One of ``options`` (any letter case); ``meaning`` says what each is, in the refusal."""
        said = f" ({meaning})" if meaning else ""
        if key not in self.header:
            if required:
                raise self.missing(key, f"{' or '.join(options)}{'; ' + meaning if meaning else ''}")
            return default
        text, line = self.header[key]
        value = text.strip().lower()
        if value not in options:
            raise self.error(f"{key} = {text!r}: expected {' or '.join(options)}{said}", line)
        return value

    def flag(self, key: str, default: bool = False) -> bool:
        value = self.choice(key, ("true", "false", "yes", "no", "1", "0"))
        return default if value is None else value in ("true", "yes", "1")


def _laid_out_otherwise(magic: str, row: str) -> str:
    """The converter's hint for a data row separated by semicolons or tabs, else nothing."""
    return CONVERTERS.get(magic, "") if ";" in row or "\t" in row else ""


def _float(text: str) -> float | None:
    try:
        value = float(text.strip())
    except ValueError:
        return None
    return value if math.isfinite(value) else None


def _decode(path: str, data: bytes) -> str:
    if not data.strip():
        raise MeasurementError("the file is empty", Location(path))
    if data.startswith((b"\xff\xfe", b"\xfe\xff")) or (len(data) > 1 and data[1:2] == b"\x00" and data[0:1] != b"\x00"):
        raise MeasurementError("the file is UTF-16 text; save it as UTF-8 (or ASCII)", Location(path))
    if b"\x00" in data:
        raise MeasurementError("this is a binary file, not a measurement table", Location(path))
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        raise MeasurementError(
            "a byte that is not UTF-8 (a Latin-1 file?); save the file as UTF-8", Location(path, line)
        ) from None


def parse_time(text: str) -> dt.datetime | None:
    """An ISO 8601 time with its time zone (``2026-11-20T14:05:00+01:00``, ``...Z``), or None: a
    time without a zone names no moment."""
    try:
        moment = dt.datetime.fromisoformat(text.strip())
    except (TypeError, ValueError):
        return None
    return moment if moment.tzinfo is not None and moment.utcoffset() is not None else None


def measured_time(path: str) -> dt.datetime | None:
    """The ``measured`` header key of a postproc measurement file (from its one read), or None."""
    try:
        data = snapshot(path).data
    except MeasurementError:
        return None
    for line in data.decode("utf-8", "replace").splitlines()[1:]:
        text = line.strip()
        if text and not text.startswith("#"):
            return None
        key, _, value = text[1:].partition("=")
        if key.strip() == "measured":
            return parse_time(value)
    return None


def read_text(path: str) -> str:
    """A measurement file's text, from its one read: at most MAX_BYTES, UTF-8 (a BOM dropped)."""
    return _decode(inputs.named(path), snapshot(path).data)


def snapshot(path: str) -> inputs.Snapshot:
    """The one read of a measurement file (:mod:`postproc.files.inputs`), at most MAX_BYTES."""
    return inputs.read(path, MAX_BYTES, MeasurementError, "a measurement file")


def read_table(path: str, magic: str, allowed: set[str], column_sets: list[list[str]]) -> Table:
    """Read a file of the format whose first line is ``magic``.

    ``allowed`` are the header keys the format knows; ``column_sets`` the header rows it
    accepts (each a list of column names, in any order). The data come back as arrays: a trace
    of millions of samples is read in C (:func:`_fast_values`) and holds no Python object per
    row; what that cannot read (a blank line, a comment, a bad cell) is read line by line, which
    finds the problem and names its line.
    """
    text = read_text(path)
    path = inputs.named(path)
    reading = lines(text)
    _, first, _ = next(reading)
    if first.strip() != magic:
        other = MAGICS.get(first.strip())
        if other is not None:
            raise MeasurementError(f"this is a postproc {other}, not a {MAGICS[magic]}", Location(path, 1))
        raise MeasurementError(f"the first line must be {magic!r}, not {first[:40]!r}", Location(path, 1))

    allowed = allowed | COMMON_KEYS
    header: dict[str, tuple[str, int]] = {}
    extras: dict[str, str] = {}
    for number, line, end in reading:
        text_line = line.strip()
        if not text_line:
            continue
        if not text_line.startswith("#"):
            break
        body = text_line[1:].strip()
        if not body:
            continue
        if "=" not in body:
            raise MeasurementError(f"a header line must read '# key = value', not {text_line!r}", Location(path, number))
        key, value = (part.strip() for part in body.split("=", 1))
        if key.startswith("x-"):
            extras[key] = value
            continue
        if key not in allowed and key not in COMMON_KEYS:
            raise MeasurementError(
                f"unknown header key {key!r} (known: {', '.join(sorted(allowed | COMMON_KEYS))}; keys of your own "
                "start with x-)", Location(path, number),
            )
        if key == "measured" and parse_time(value) is None:
            raise MeasurementError(f"measured = {value!r}: expected an ISO 8601 time with a time zone, such as "
                                   "2026-11-20T14:05:00+01:00", Location(path, number))
        if key in header:
            raise MeasurementError(f"header key {key!r} given twice (first on line {header[key][1]})", Location(path, number))
        header[key] = (value, number)
    else:
        raise MeasurementError("no CSV header row and no data after the header lines", Location(path))

    columns = [name.strip() for name in line.split(",")]
    if sorted(columns) not in [sorted(c) for c in column_sets]:
        expected = " or ".join(",".join(c) for c in column_sets)
        raise MeasurementError(f"the CSV header row must be {expected}, not {line.strip()!r}"
                               f"{CONVERTERS.get(magic, '')}", Location(path, number))
    values = _fast_values(text[end:], len(columns))
    if values is not None:
        rows = np.arange(number + 1, number + 1 + len(values))
    else:
        rows, values = _values_by_line(path, magic, columns, reading)
    if not len(values):
        raise MeasurementError("the file has no data rows", Location(path))
    return Table(path, header, extras, columns, rows, values, columns_line=number)


def lines(text: str, start: int = 0, number: int = 1) -> Iterator[tuple[int, str, int]]:
    """(line number, line, offset after it) of ``text`` from ``start``, split as str.splitlines
    splits (CR LF, CR and the other Unicode line ends), a block at a time, so that a long file
    is never held as a list of its lines."""
    block = 1 << 16
    while start < len(text):
        parts = text[start: start + block].splitlines(keepends=True)
        if start + block < len(text):
            parts.pop()  # may be cut short (or a CR LF cut in two): read again with the next block
            if not parts:
                block *= 2
                continue
        for part in parts:
            start += len(part)
            yield number, part.rstrip(_LINE_ENDS), start
            number += 1


#: what str.splitlines ends a line at
_LINE_ENDS = "\r\n\x0b\x0c\x1c\x1d\x1e\x85\u2028\u2029"
#: what the data of a plain numeric table is made of, and a blank line among them
_NUMERIC = b"0123456789+-.eE, \t\r\n"
_BLANK = re.compile(r"(?:^|\n)[ \t\r]*\n")


def _fast_values(data: str, width: int) -> np.ndarray | None:
    """The data rows as an array, parsed in C, or None when the line-by-line reading must decide.

    Taken only where both readings agree by construction: digits, signs, points, exponents,
    commas and spaces alone (no text, no nan or inf, no comment), CR only before LF, no blank
    line among the rows (so that row i is line i after the header row), every row as wide as
    the header row and every value finite. numpy's reader converts a cell as float() does."""
    data = data.rstrip()
    if not data:
        return None
    raw = data.encode("ascii", "replace")
    if raw.translate(None, _NUMERIC) or raw.count(b"\r") != raw.count(b"\r\n") or _BLANK.search(data):
        return None
    try:
        values = np.loadtxt(io.BytesIO(raw), delimiter=",", comments=None, ndmin=2, dtype=float, encoding="ascii")
    except ValueError:
        return None
    if values.shape[1] != width or not np.isfinite(values).all():
        return None
    return values


def _values_by_line(path: str, magic: str, columns: list[str], reading) -> tuple[np.ndarray, np.ndarray]:
    """The data rows read one line at a time; the first problem is refused at its line."""
    rows, values = array("q"), array("d")
    for row_number, line, _ in reading:
        text = line.strip()
        if not text:
            continue
        if text.startswith("#"):
            raise MeasurementError("a header line after the data started", Location(path, row_number))
        cells = text.split(",")
        if len(cells) != len(columns):
            raise MeasurementError(f"{len(cells)} values where the header row has {len(columns)}"
                                   f"{_laid_out_otherwise(magic, text)}", Location(path, row_number))
        for name, cell in zip(columns, cells):
            value = _float(cell)
            if value is None:
                raise MeasurementError(f"{name} = {cell.strip()!r} is not a finite number{_laid_out_otherwise(magic, text)}",
                                       Location(path, row_number))
            values.append(value)
        rows.append(row_number)
    return np.array(rows, dtype=np.int64), np.array(values, dtype=float).reshape(len(rows), len(columns))
