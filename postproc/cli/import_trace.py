"""``postproc import-trace FILE --radius MM --direction ccw|cw``: a plain export to a postproc trace.

Instruments' software exports a ballbar test as a plain table: angle and deviation, or the
raw deviations in time order, comma-, semicolon-, tab- or space-separated, sometimes with a
decimal comma and a few lines of text above the numbers. What the table does not say (the
bar's length, the direction of the run, the test centre, where a raw capture starts and how
much of the circle it covers) comes from the options. The result is a trace in formats.md's
processed form (angles given) or raw form (``--start-angle``), written to ``-o`` or stdout,
and read back by postproc's own reader before it is written: a table that makes no valid
trace (too few samples, too short an arc, a reading beyond 1 mm, an angle twice) writes
nothing. Every bad cell is refused at its line and column.

Lines before the first row of numbers are the export's header; the last of them may name
the columns (``--columns deviation_um`` picks by name). After the first row of numbers every
line must be one (blank lines and ``#`` comments aside).
"""

from __future__ import annotations

import math
import os
from array import array
import sys
from dataclasses import dataclass

import click
import numpy as np

from ..diagnostics import Location, MeasurementError, OptionError, Reporter, UsageError
from ..measure.readers.ballbar import MAGIC, REPEATED, make_trace, open_ends, raw_samples, repeated_angle
from ..measure.readers.csvfile import lines as _lines, read_text
from ..files.output import STDOUT, write_atomically
from .common import ARC, FINITE, POSITIVE, examples, guard

DELIMITERS = {"comma": ",", "semicolon": ";", "tab": "\t", "space": None}
#: um; a trace in um whose largest deviation is below this (a ballbar's resolution) is in mm
MIN_LARGEST_UM = 0.1


@dataclass
class Table:
    """The numbers of a plain export as arrays (no Python object per row: an export may hold
    millions): each row's line, its values and the 1-based column each cell starts at."""

    path: str
    names: list[str]  #: the last header line's cells (may be empty)
    lines: np.ndarray  #: (rows,): the line of each row
    values: np.ndarray  #: (rows, cells)
    columns: np.ndarray  #: (rows, cells): the 1-based column each cell starts at
    text: str  #: the export, for the line a message shows

    @property
    def width(self) -> int:
        return self.values.shape[1]

    def where(self, row: int, cell: int) -> Location:
        """The position of a cell, with its line, for a message."""
        line = int(self.lines[row])
        return Location(self.path, line, int(self.columns[row, cell]), self.text.splitlines()[line - 1])


@click.command("import-trace", epilog=examples(
    "# angle and deviation in um, semicolons, decimal commas",
    "postproc import-trace export.csv --radius 100 --direction ccw --unit um --delimiter semicolon --decimal-comma -o ccw.csv",
    "# raw deviations in time order, a lathe's 220 deg arc from 200 deg",
    "postproc import-trace raw.txt --radius 100 --direction cw --start-angle 200 --capture-arc 220 -o cw.csv"))
@click.argument("file", metavar="FILE")
@click.option("--radius", type=POSITIVE, required=True, metavar="MM", help="Nominal bar length.")
@click.option("--direction", type=click.Choice(["ccw", "cw"]), required=True,
              help="ccw: the G03 run (theta decreasing); cw: the G02 run (theta increasing).")
@click.option("--center-x", type=FINITE, default=0.0, show_default=True, metavar="MM", help="Test centre x (radius mm).")
@click.option("--center-z", type=FINITE, default=0.0, show_default=True, metavar="MM", help="Test centre z.")
@click.option("--feed", type=POSITIVE, metavar="MM/MIN", help="The test's feed (for the servo lag).")
@click.option("--start-angle", type=FINITE, metavar="DEG",
              help="Raw deviations (no angle column): theta of the first reading.")
@click.option("--capture-arc", type=ARC, metavar="DEG", help="Raw deviations: the arc captured (default 360).")
@click.option("--columns", metavar="ANGLE,DEVIATION|DEVIATION",
              help="Which columns hold the angle and the deviation (1-based numbers or header names); "
                   "required when the rows have more cells than that.")
@click.option("--delimiter", default="auto", show_default=True, metavar="auto|comma|semicolon|tab|space|CHAR",
              help="What separates the cells.")
@click.option("--decimal-comma", is_flag=True, help="Numbers are written 1,25 (the delimiter is then not a comma).")
@click.option("--unit", type=click.Choice(["mm", "um"]), default="mm", show_default=True,
              help="The unit of the deviations.")
@click.option("--angle-offset", type=FINITE, default=0.0, show_default=True, metavar="DEG",
              help="theta of the export's 0 deg (an export with 0 at +Z: 90).")
@click.option("--reverse-angles", is_flag=True, help="The export's angles run from +Z towards +X (theta the other way).")
@click.option("--centered", is_flag=True, help="The deviations are already centred: no set-up centre is removed.")
@click.option("-o", "--output", "output", default=STDOUT, metavar="FILE", help="Write the trace here instead of stdout.")
def command(file, radius, direction, center_x, center_z, feed, start_angle, capture_arc, columns, delimiter,
            decimal_comma, unit, angle_offset, reverse_angles, centered, output):
    """A plain CSV/TSV export of a ballbar test (angle and deviation, or raw deviations) to a postproc trace."""
    from ..measure.parameters import bar_length_problem

    problem = bar_length_problem(radius)
    if problem:
        raise OptionError(f"--radius {radius:g}: {problem}")
    if capture_arc is not None and start_angle is None:
        raise UsageError("--capture-arc belongs to raw deviations: give --start-angle as well")
    if decimal_comma and delimiter == "comma":
        raise UsageError("--decimal-comma: the delimiter cannot be a comma as well")
    guard([("FILE", file)], [("-o", output)])
    reporter = Reporter(sys.stderr)
    table = read_export(file, delimiter, decimal_comma)
    raw = start_angle is not None
    picked = _columns(table, columns, raw)
    scale = 0.001 if unit == "um" else 1.0
    deviations = table.values[:, picked[-1]] * scale
    beyond = np.flatnonzero(np.abs(deviations) > 1.0)
    if beyond.size:
        raise MeasurementError(f"deviation {deviations[beyond[0]]:g} mm is beyond 1 mm: not a plausible ballbar reading "
                               f"(micrometres read as millimetres? give --unit um)", table.where(beyond[0], picked[-1]))
    if unit == "um" and np.abs(deviations).max() < MIN_LARGEST_UM / 1000.0:
        raise MeasurementError(f"with --unit um every deviation is within {np.abs(deviations).max() * 1000:.3g} um, "
                               f"below {MIN_LARGEST_UM:g} um: no ballbar reads a machine that round (millimetres "
                               "read as micrometres? leave out --unit um)", Location(file))
    sign = -1.0 if reverse_angles else 1.0
    header = {"radius_mm": f"{radius:.10g}", "direction": direction, "center_x_mm": f"{center_x:.10g}",
              "center_z_mm": f"{center_z:.10g}"}
    if feed is not None:
        header["feed_mm_min"] = f"{feed:.10g}"
    if raw:
        capture = 360.0 if capture_arc is None else capture_arc
        problem = open_ends(deviations) if capture == 360.0 else None
        if problem:
            raise MeasurementError(f"{problem}; give the arc they span with --capture-arc",
                                   table.where(len(deviations) - 1, picked[-1]))
        header |= {"start_angle_deg": f"{start_angle:.10g}", "capture_arc_deg": f"{capture:.10g}"}
        angles, samples = raw_samples(deviations, start_angle, capture, direction == "cw", 6, reporter, file)
        rows = _rows("deviation_mm", deviations)
    else:
        angles = angle_offset + sign * table.values[:, picked[0]]
        again = repeated_angle(np.mod(angles, 360.0))
        if again is not None:
            raise MeasurementError(f"angle {angles[again[0]]:g} deg again (first on line {table.lines[again[1]]}): "
                                   f"{REPEATED}", table.where(again[0], picked[0]))
        samples = deviations
        rows = _rows("angle_deg,deviation_mm", np.mod(angles, 360.0), deviations)
    # the trace postproc's reader will make of it, refused here with the export's name if it is none
    make_trace(file, radius, direction, angles, samples, (center_x, center_z), feed, centered, raw,
               averaging=6 if raw else 1)
    if centered:
        header["centered"] = "true"
    header["x-imported-from"] = os.path.basename(file)
    text = "\n".join([MAGIC, *(f"# {key} = {value}" for key, value in header.items()), rows]) + "\n"
    write_atomically(output, text.encode())
    reporter.close()


def _rows(names: str, *columns: np.ndarray) -> str:
    """The CSV header row and the data rows (10 significant digits), a block at a time."""
    block = 1 << 16
    parts = [names]
    for first in range(0, len(columns[0]), block):
        parts.append("\n".join(",".join(f"{value:.10g}" for value in row)
                               for row in zip(*(column[first: first + block].tolist() for column in columns))))
    return "\n".join(parts)


def read_export(path: str, delimiter: str = "auto", decimal_comma: bool = False) -> Table:
    """The rows of numbers of a plain export, each cell placed; a bad one refused at its line and column."""
    whole = read_text(path)
    separator = _separator(whole, delimiter, decimal_comma)
    names: list[str] = []
    numbers, values, columns = array("q"), array("d"), array("q")
    width = 0
    for number, line, _ in _lines(whole):
        text = line.strip()
        if not text or text.startswith("#"):
            continue
        cells = _cells(line, separator)
        row = [_number(cell, decimal_comma) for cell, _ in cells]
        if all(value is not None for value in row):
            if numbers and len(cells) != width:
                raise MeasurementError(f"{len(cells)} cells where the rows above have {width}",
                                       Location(path, number, cells[-1][1], line))
            width = len(cells)
            numbers.append(number)
            values.extend(row)
            columns.extend(col for _, col in cells)
            continue
        if numbers:
            bad = next(i for i, value in enumerate(row) if value is None)
            cell, col = cells[bad]
            text_line = all(value is None for value in row)
            raise MeasurementError(f"{cell!r} is not a finite number"
                                   + (" (a line of text after the data started?)" if text_line else ""),
                                   Location(path, number, col, line))
        names = [cell.strip().strip('"').lower() for cell, _ in cells]
    if not numbers:
        raise MeasurementError("no rows of numbers in the file (numbers written 1,25 need --decimal-comma; cells "
                               "separated otherwise than by tab, semicolon, comma or spaces need --delimiter)",
                               Location(path))
    count = len(numbers)
    return Table(path, names, np.array(numbers, dtype=np.int64), np.array(values).reshape(count, width),
                 np.array(columns, dtype=np.int64).reshape(count, width), whole)


def _separator(text: str, delimiter: str, decimal_comma: bool) -> str | None:
    """The cell separator: the one asked for, or the first of tab, semicolon, comma the data use; None: spaces."""
    if delimiter != "auto":
        if delimiter in DELIMITERS:
            return DELIMITERS[delimiter]
        if len(delimiter) != 1 or delimiter.isdigit() or delimiter in ".-+":
            raise UsageError(f"--delimiter {delimiter!r}: give auto, comma, semicolon, tab, space or one character")
        return delimiter
    sample = _last_rows(text, 5)
    for candidate in ("\t", ";") + (() if decimal_comma else (",",)):
        if sample and all(candidate in line for line in sample):
            return candidate
    return None


def _last_rows(text: str, count: int) -> list[str]:
    """The last ``count`` lines that are neither blank nor a comment, from the end of the text."""
    tail = 1 << 12
    while True:
        lines = text[-tail:].splitlines()
        whole = tail >= len(text)
        sample = [line for line in (lines if whole else lines[1:]) if line.strip() and not line.lstrip().startswith("#")]
        if whole or len(sample) >= count:
            return sample[-count:]
        tail *= 4


def _cells(line: str, separator: str | None) -> list[tuple[str, int]]:
    """The cells of a line with the 1-based column each starts at."""
    cells, start = [], 0
    if separator is None:
        for part in line.split():
            start = line.index(part, start)
            cells.append((part, start + 1))
            start += len(part)
        return cells
    for part in line.split(separator):
        cells.append((part, start + 1 + (len(part) - len(part.lstrip()))))
        start += len(part) + 1
    return cells


def _number(cell: str, decimal_comma: bool) -> float | None:
    text = cell.strip().strip('"')
    if decimal_comma:
        text = text.replace(",", ".")
    try:
        value = float(text)
    except ValueError:
        return None
    return value if math.isfinite(value) else None


def _columns(table: Table, spec: str | None, raw: bool) -> list[int]:
    """0-based indices of (angle, deviation), or of (deviation,) for raw readings."""
    width = table.width
    wanted = 1 if raw else 2
    if spec is None:
        if width == 1 and not raw:
            raise UsageError(f"{table.path} has one column (raw deviations?): give --start-angle, and --capture-arc "
                             "if the capture is less than 360 deg")
        if width > wanted:  # which of them is which would be a guess
            named = f" ({', '.join(table.names)})" if len(table.names) == width else ""
            what = ("which holds the raw deviations with --columns DEVIATION" if raw else
                    "which hold the angle and the deviation with --columns ANGLE,DEVIATION")
            raise UsageError(f"{table.path} has {width} columns{named}: say {what} (1-based numbers or header names)")
        return [0] if raw else [0, 1]
    parts = [part.strip() for part in spec.split(",")]
    if len(parts) != wanted:
        raise UsageError(f"--columns {spec}: give {'the deviation column (raw, --start-angle)' if raw else 'ANGLE,DEVIATION'}")
    picked = []
    for part in parts:
        if part.isdigit():
            index = int(part) - 1
        elif part.lower() in table.names:
            index = table.names.index(part.lower())
        else:
            raise UsageError(f"--columns {spec}: {part!r} is neither a column number nor a header name "
                             f"({', '.join(table.names) or 'the file names none'})")
        if not 0 <= index < width:
            raise UsageError(f"--columns {spec}: the rows have {width} cells")
        picked.append(index)
    return picked
