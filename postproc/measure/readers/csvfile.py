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
import math
from dataclasses import dataclass, field

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
    rows: list[tuple[int, list[float]]] = field(default_factory=list)  #: (line, values)
    #: the line of the CSV header row, where the header lines ended: where a missing key was due
    columns_line: int | None = None

    def where(self, line: int | None = None) -> Location:
        return Location(self.path, line)

    def error(self, message: str, line: int | None = None) -> MeasurementError:
        return MeasurementError(message, self.where(line))

    def column(self, name: str) -> list[float]:
        index = self.columns.index(name)
        return [values[index] for _, values in self.rows]

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
    accepts (each a list of column names, in any order).
    """
    lines = read_text(path).splitlines()
    path = inputs.named(path)
    first = lines[0].strip()
    if first != magic:
        other = MAGICS.get(first)
        if other is not None:
            raise MeasurementError(f"this is a postproc {other}, not a {MAGICS[magic]}", Location(path, 1))
        raise MeasurementError(f"the first line must be {magic!r}, not {lines[0][:40]!r}", Location(path, 1))

    allowed = allowed | COMMON_KEYS
    header: dict[str, tuple[str, int]] = {}
    extras: dict[str, str] = {}
    number = 1
    for number in range(2, len(lines) + 1):
        text = lines[number - 1].strip()
        if not text:
            continue
        if not text.startswith("#"):
            break
        body = text[1:].strip()
        if not body:
            continue
        if "=" not in body:
            raise MeasurementError(f"a header line must read '# key = value', not {text!r}", Location(path, number))
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

    columns = [name.strip() for name in lines[number - 1].split(",")]
    if sorted(columns) not in [sorted(c) for c in column_sets]:
        expected = " or ".join(",".join(c) for c in column_sets)
        raise MeasurementError(f"the CSV header row must be {expected}, not {lines[number - 1].strip()!r}"
                               f"{CONVERTERS.get(magic, '')}", Location(path, number))
    table = Table(path, header, extras, columns, columns_line=number)
    for row_number in range(number + 1, len(lines) + 1):
        text = lines[row_number - 1].strip()
        if not text:
            continue
        if text.startswith("#"):
            raise MeasurementError("a header line after the data started", Location(path, row_number))
        cells = text.split(",")
        if len(cells) != len(columns):
            raise MeasurementError(f"{len(cells)} values where the header row has {len(columns)}"
                                   f"{_laid_out_otherwise(magic, text)}", Location(path, row_number))
        values = []
        for name, cell in zip(columns, cells):
            value = _float(cell)
            if value is None:
                raise MeasurementError(f"{name} = {cell.strip()!r} is not a finite number{_laid_out_otherwise(magic, text)}",
                                       Location(path, row_number))
            values.append(value)
        table.rows.append((row_number, values))
    if not table.rows:
        raise MeasurementError("the file has no data rows", Location(path))
    return table
