"""The printout of a postproc probing program, and the probe file made from it.

The probing program (:mod:`postproc.onmachine.probe_cycle`) prints one line per record with ``DPRNT``
between ``POPEN`` and ``PCLOS``; the control sends them through its RS-232 port or onto its
memory card. This module is the one place that defines those lines: it writes the ``DPRNT``
statements and reads the lines back (docs/formats.md §16). Format 1, one run per file:

    POSTPROC PROBE V 1 O 8100 G 21 D 2 R   3.0000 N  36      header: format version, program number,
                                                             G20/G21 units, X divisor (2: X is a
                                                             diameter), stylus radius, points
    DATUM BEFORE X 195.9997 Z  13.0061 I  .00000 K -1.00000  a datum touch before the profile
    POINT   1 X   5.3426 Z  61.0619 I -.05233 K -.99863      profile touch 1 (of N, in order)
    ...
    DATUM AFTER X 195.9995 Z  13.0068 I  .00000 K -1.00000   the same datum, after the profile
    END                                                      the program finished

X and Z are the latched skip positions ``#5061``/``#5062`` (the stylus centre at the trigger,
in the program's units, X a diameter when D is 2); I and K the unit direction of the skip move
(into the material). A datum touched along Z (K = -1, a face) gives ``datum_*_z_mm``, one
touched along X (I = -1, a diameter) ``datum_*_x_mm``: the stylus-centre coordinate, as
``postproc simulate probe`` writes it.

The reader takes what a control and a PC's receiving software make of these lines: leading
and trailing spaces, CR LF (or CR CR LF) line ends, ``%`` lines and feed characters (NUL, DC2,
DC4) around the data, blank lines, leading zeros printed as spaces or not at all, a sign
before or after that padding, numbers such as ``-.5000``, ``0.5000``, ``12.`` or ``+3``. A
line it cannot read is refused with its line number.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from ..files import inputs
from ..diagnostics import STDIN_NAME, Location, MeasurementError, OptionError, Reporter
from ..measure.readers.csvfile import MAX_BYTES
from ..measure.readers.lengths import RADII, UNITS, misreading, stylus_problem, travel_problem
from ..measure.readers.probe import PROBE_MAGIC, UNIT_TOLERANCE

VERSION = 1  #: the printout format written and read here
DIGITS_POSITION = "[44]"  #: X, Z and R: 4 integer and 4 decimal digits (0.1 um)
DIGITS_DIRECTION = "[15]"  #: I and K: 1 integer and 5 decimal digits
POINT, BEFORE, AFTER = "point", "datum before", "datum after"
#: a --stylus-radius within this share of the printed one times a misreading's factor is that misreading
STYLUS_AGREES = 0.005

# Macro variables the probing program sets for the printout (local variables of the main program).
VAR_INDEX, VAR_I, VAR_K = 1, 2, 3
VAR_RADIUS, VAR_VERSION, VAR_PROGRAM, VAR_UNITS, VAR_DIVISOR, VAR_COUNT = 4, 5, 6, 7, 8, 9

_FEED = re.compile(r"[\x00\x11-\x14\x1a]")  # NUL leader, DC1-DC4 device control, ^Z end of file
_NUMBER = r"[+-]?[ \t]*(?:\d+(?:\.\d*)?|\.\d+)"


def _record(*parts: str) -> re.Pattern:
    """A line's pattern: words separated by optional blanks, each number captured by name."""
    pieces = []
    for part in parts:
        if part.startswith("?"):
            pieces.append(f"(?P<{part[1:]}>{_NUMBER})")
        else:
            pieces.append(part)
    return re.compile(r"[ \t]*".join(pieces) + r"\Z", re.IGNORECASE)


_HEADER = _record("POSTPROC", "PROBE", "V", "?version", "O", "?program", "G", "?units", "D", "?divisor", "R",
                  "?radius", "N", "?count")
_POINT = _record("POINT", "?index", "X", "?x", "Z", "?z", "I", "?i", "K", "?k")
_DATUM = _record("DATUM", "(?P<phase>BEFORE|AFTER)", "X", "?x", "Z", "?z", "I", "?i", "K", "?k")
_END = _record("END")
_EXPECTED = {
    "POSTPROC": "POSTPROC PROBE V 1 O <program> G <20|21> D <1|2> R <stylus radius> N <points>",
    "POINT": "POINT <n> X <x> Z <z> I <approach x> K <approach z>",
    "DATUM": "DATUM BEFORE|AFTER X <x> Z <z> I <approach x> K <approach z>",
    "END": "END",
}


# ---------------------------------------------------------------------------- writing


def header_statement() -> str:
    """The DPRNT block of the header; the program sets the variables it prints first."""
    return (f"DPRNT[POSTPROC*PROBE*V#{VAR_VERSION}[10]*O#{VAR_PROGRAM}[40]*G#{VAR_UNITS}[20]"
            f"*D#{VAR_DIVISOR}[10]*R#{VAR_RADIUS}[34]*N#{VAR_COUNT}[40]]")


def touch_statement(record: str) -> str:
    """The DPRNT block printed right after a touch's G31: the latched #5061/#5062 and the approach."""
    position = f"X#5061{DIGITS_POSITION}*Z#5062{DIGITS_POSITION}"
    direction = f"I#{VAR_I}{DIGITS_DIRECTION}*K#{VAR_K}{DIGITS_DIRECTION}"
    if record == POINT:
        return f"DPRNT[POINT*#{VAR_INDEX}[40]*{position}*{direction}]"
    phase = {BEFORE: "BEFORE", AFTER: "AFTER"}[record]
    return f"DPRNT[DATUM*{phase}*{position}*{direction}]"


END_STATEMENT = "DPRNT[END]"


# ---------------------------------------------------------------------------- reading


@dataclass(frozen=True, slots=True)
class Reading:
    """One touch as printed, in the printout's units."""

    line: int  #: 1-based line of the printout
    record: str  #: point, datum before or datum after
    index: int  #: the point's number (datums: 0)
    x: float  #: #5061 as printed (a diameter when the divisor is 2)
    z: float
    i: float  #: approach direction as printed
    k: float


@dataclass(frozen=True)
class Printout:
    """A probing run as the control printed it."""

    path: str
    program: int  #: the probing program's number
    inch: bool  #: G20: lengths are inches
    divisor: int  #: 2 when X is printed as a diameter
    stylus_radius: float  #: in the printout's units
    count: int  #: points the program touches
    points: tuple[Reading, ...]
    datum_before: tuple[Reading, ...] = ()
    datum_after: tuple[Reading, ...] = ()
    header_line: int = 1

    @property
    def scale(self) -> float:
        """Millimetres per printed unit."""
        return 25.4 if self.inch else 1.0


def _number(text: str) -> float:
    return float(re.sub(r"[ \t]", "", text))


def _lines(path: str) -> list[tuple[int, str]]:
    """The printout's lines, numbered as an editor numbers them, cleaned of line ends and feed characters."""
    if path == STDIN_NAME:
        data = inputs.read_stdin(path, MAX_BYTES, MeasurementError, "a printout").data
    else:
        data = inputs.read(path, MAX_BYTES, MeasurementError, "a printout").data
    if not data.strip():
        raise MeasurementError("the printout is empty", Location(path))
    try:
        text = data.decode("ascii")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        raise MeasurementError("not an ASCII printout (if every line looks garbled, set the receiving software to "
                               "the control's serial settings: 7 data bits, even parity)",
                               Location(path, line)) from None
    separator = "\n" if "\n" in text else "\r"
    return [(number, _FEED.sub("", raw).strip(" \t\r")) for number, raw in enumerate(text.split(separator), start=1)]


def _expected(text: str) -> str:
    word = re.match(r"[A-Za-z]*", text).group(0).upper()
    if word in _EXPECTED:
        return f"a {word} line reads '{_EXPECTED[word]}'"
    return "expected " + ", ".join(f"'{form}'" for form in _EXPECTED.values())


def _integer(match: re.Match, name: str, where: Location, what: str) -> int:
    value = _number(match.group(name))
    if value != math.floor(value):
        raise MeasurementError(f"{what} must be a whole number, not {match.group(name).strip()}", where)
    return int(value)


def read_printout(path: str) -> Printout:
    """Read the DPRNT printout of one probing run (``-``: standard input).

    :raises MeasurementError: at the line of anything that is not a record of the format, a
        record out of its place (a second run, a missing or extra point, a datum after the
        points it should precede), or at the file when the run is incomplete.
    """
    path = STDIN_NAME if path == "-" else path
    header = None
    readings: list[Reading] = []
    ended: int | None = None
    last = 1
    for number, text in _lines(path):
        if not text or set(text) == {"%"}:
            continue
        last, where = number, Location(path, number)
        if ended is not None:
            raise MeasurementError(f"more printout after END (line {ended}): give one run per file", where)
        match = _HEADER.match(text)
        if match:
            if header is not None:
                raise MeasurementError(f"a second run starts here (the first at line {header[0]}): give one run "
                                       "per file", where)
            header = (number, match)
            continue
        if header is None:
            raise MeasurementError("the printout must start with the header line of a postproc probing program "
                                   f"('{_EXPECTED['POSTPROC']}'); " + _expected(text), where)
        if _END.match(text):
            ended = number
            continue
        point, datum = _POINT.match(text), _DATUM.match(text)
        if point is None and datum is None:
            raise MeasurementError(f"cannot read this line: {_expected(text)}", where)
        match = point or datum
        if point:
            record, index = POINT, _integer(point, "index", where, "a point's number")
        else:
            record, index = (BEFORE if datum.group("phase").upper() == "BEFORE" else AFTER), 0
        values = [_number(match.group(name)) for name in ("x", "z", "i", "k")]
        readings.append(Reading(number, record, index, *values))
    if header is None:
        raise MeasurementError("no header line of a postproc probing program found "
                               f"('{_EXPECTED['POSTPROC']}')", Location(path))
    return _checked(path, header, readings, ended, last)


def _checked(path: str, header: tuple[int, re.Match], readings: list[Reading], ended: int | None,
             last: int) -> Printout:
    """The run as printed, held to the format; ``last``: the last line that is not blank."""
    line, match = header
    where = Location(path, line)
    version = _integer(match, "version", where, "the format version")
    if version != VERSION:
        raise MeasurementError(f"printout format V {version} is not known (this postproc reads V {VERSION})", where)
    units = _integer(match, "units", where, "the units' G code")
    if units not in (20, 21):
        raise MeasurementError(f"units G {units}: expected G 20 (inch) or G 21 (mm)", where)
    divisor = _integer(match, "divisor", where, "the X divisor")
    if divisor not in (1, 2):
        raise MeasurementError(f"X divisor D {divisor}: expected 2 (X a diameter) or 1 (X a radius)", where)
    radius = _number(match.group("radius"))
    if not radius > 0:
        raise MeasurementError(f"stylus radius R {radius:g}: it must be positive", where)
    scale = 25.4 if units == 20 else 1.0
    problem = stylus_problem(radius * scale)
    if problem:
        raise MeasurementError(f"stylus radius R {radius:g} (G {units}): {problem}", where)
    count = _integer(match, "count", where, "the number of points")
    if count < 1:
        raise MeasurementError(f"N {count}: the run must touch at least one point", where)
    program = _integer(match, "program", where, "the program number")

    points = [r for r in readings if r.record == POINT]
    before = [r for r in readings if r.record == BEFORE]
    after = [r for r in readings if r.record == AFTER]
    for reading in readings:
        _unit(path, reading)
        for name, value in (("X", reading.x / divisor), ("Z", reading.z)):
            problem = travel_problem(value * scale)
            if problem:
                raise MeasurementError(f"{name} {value * divisor if name == 'X' else value:g} (G {units}"
                                       f"{', D %d' % divisor if name == 'X' else ''}) is {value * scale:g} mm: "
                                       f"{problem}", Location(path, reading.line))
    first_point = points[0].line if points else None
    last_point = points[-1].line if points else None
    for reading in before:
        if first_point is not None and reading.line > first_point:
            raise MeasurementError(f"a DATUM BEFORE line after the first point (line {first_point})",
                                   Location(path, reading.line))
    for reading in after:
        if last_point is not None and reading.line < last_point:
            raise MeasurementError(f"a DATUM AFTER line before the last point (line {last_point})",
                                   Location(path, reading.line))
    for expected, reading in enumerate(points, start=1):
        if reading.index != expected:
            what = "a point is missing before it" if reading.index > expected else "out of order or repeated"
            raise MeasurementError(f"point {reading.index} where point {expected} was expected: {what}",
                                   Location(path, reading.line))
    if ended is None:
        raise MeasurementError(f"the printout ends here without END: the probing program did not finish "
                               f"({len(points)} of {count} points printed)", Location(path, last))
    if len(points) != count:
        raise MeasurementError(f"{len(points)} points printed but the header (line {line}) announces {count}",
                               Location(path, ended))
    _datum_axes(path, before, after, ended)
    return Printout(path, program, units == 20, divisor, radius, count, tuple(points), tuple(before), tuple(after),
                    line)


def _unit(path: str, reading: Reading) -> None:
    length = math.hypot(reading.i, reading.k)
    if abs(length - 1.0) > UNIT_TOLERANCE:
        raise MeasurementError(f"the approach I {reading.i:g} K {reading.k:g} has length {length:.6f}; it must be "
                               f"a unit vector (within {UNIT_TOLERANCE:g})", Location(path, reading.line))


def datum_axis(reading: Reading, path: str) -> str:
    """``x`` for a touch along X (a diameter), ``z`` for one along Z (a face)."""
    if abs(reading.i) >= 1.0 - UNIT_TOLERANCE:
        return "x"
    if abs(reading.k) >= 1.0 - UNIT_TOLERANCE:
        return "z"
    raise MeasurementError(f"a datum touch must run along X or Z, not along I {reading.i:g} K {reading.k:g}",
                           Location(path, reading.line))


def _datum_axes(path: str, before: list[Reading], after: list[Reading], ended: int) -> None:
    seen: dict[str, dict[str, Reading]] = {}
    for phase, readings in (("BEFORE", before), ("AFTER", after)):
        axes: dict[str, Reading] = {}
        for reading in readings:
            axis = datum_axis(reading, path)
            if axis in axes:
                raise MeasurementError(f"a second DATUM {phase} touch along {axis.upper()} (the first at line "
                                       f"{axes[axis].line})", Location(path, reading.line))
            axes[axis] = reading
        seen[phase] = axes
    unmatched = sorted(set(seen["BEFORE"]) ^ set(seen["AFTER"]))
    if unmatched:
        axis = unmatched[0]
        reading = seen["BEFORE"].get(axis) or seen["AFTER"][axis]
        other = "AFTER" if axis in seen["BEFORE"] else "BEFORE"
        raise MeasurementError(f"the datum along {axis.upper()} has no DATUM {other} touch: the stability check "
                               "needs the same datum before and after the profile", Location(path, reading.line))


# ---------------------------------------------------------------------------- the probe file


@dataclass(frozen=True)
class ProbeData:
    """What a probe file (docs/formats.md §5) holds, in radius millimetres."""

    stylus_radius: float
    centres: np.ndarray  #: (n, 2) reported stylus centres x, z
    approach: np.ndarray  #: (n, 2) unit directions into the material
    datum_before: dict[str, float]  #: axis -> reported stylus-centre coordinate
    datum_after: dict[str, float]
    repeatability: float | None


def probe_data(printout: Printout, stylus_radius: float | None = None, repeatability: float | None = None,
               reporter: Reporter | None = None) -> ProbeData:
    """The printout in the probe file's terms: radius mm, unit approach vectors, the datum keys.

    :param stylus_radius: mm; the stylus the file names (default: the one the program was written for).
        One larger than any stylus, or the printed one in another unit, is refused (OptionError)
        with that cause; any other is used with a warning (naming a diameter where it is one).
    """
    scale = printout.scale
    printed = printout.stylus_radius * scale
    if stylus_radius is None:
        stylus_radius = printed
    elif abs(stylus_radius - printed) > 1e-6:
        def agrees(meant: float) -> bool:
            return abs(meant - printed) <= STYLUS_AGREES * printed

        cause = stylus_problem(stylus_radius) or misreading(stylus_radius, agrees, UNITS)
        if cause:
            raise OptionError(f"--stylus-radius {stylus_radius:g}: the probing program was written for a stylus "
                              f"radius of {printed:g} mm; {cause}")
        if reporter is not None:
            # twice or half the radius may be another stylus fitted, or a diameter: said, not refused
            said = misreading(stylus_radius, agrees, RADII[len(UNITS):])
            reporter.warn(f"the probing program was written for a stylus radius of {printed:g} mm; "
                          f"{stylus_radius:g} mm is used (--stylus-radius){'; ' + said if said else ''}",
                          Location(printout.path, printout.header_line))

    def centre(reading: Reading) -> tuple[float, float]:
        return reading.x / printout.divisor * scale, reading.z * scale

    def unit(reading: Reading) -> tuple[float, float]:
        length = math.hypot(reading.i, reading.k)
        return reading.i / length, reading.k / length

    def datum(readings: tuple[Reading, ...]) -> dict[str, float]:
        found = {}
        for reading in readings:
            axis = datum_axis(reading, printout.path)
            found[axis] = centre(reading)[0 if axis == "x" else 1]
        return found

    return ProbeData(stylus_radius, np.array([centre(r) for r in printout.points], dtype=float).reshape(-1, 2),
                     np.array([unit(r) for r in printout.points], dtype=float).reshape(-1, 2),
                     datum(printout.datum_before), datum(printout.datum_after), repeatability)


def _mm(value: float) -> str:
    text = f"{value:.7f}"
    return "0.0000000" if text == "-0.0000000" else text


def probe_file_text(data: ProbeData, provenance: dict[str, object]) -> str:
    """The probe file (docs/formats.md §5); provenance goes into ``x-`` keys."""
    lines = [PROBE_MAGIC, f"# stylus_radius_mm = {data.stylus_radius:.10g}"]
    for axis in sorted(data.datum_before):
        lines.append(f"# datum_before_{axis}_mm = {_mm(data.datum_before[axis])}")
        lines.append(f"# datum_after_{axis}_mm = {_mm(data.datum_after[axis])}")
    if data.repeatability is not None:
        lines.append(f"# repeatability_mm = {data.repeatability:.10g}")
    lines += [f"# x-{key} = {value}" for key, value in provenance.items()]
    lines.append("x_mm,z_mm,approach_x,approach_z")
    lines += [f"{_mm(x)},{_mm(z)},{_mm(ax)},{_mm(az)}" for (x, z), (ax, az) in zip(data.centres, data.approach)]
    return "\n".join(lines) + "\n"
