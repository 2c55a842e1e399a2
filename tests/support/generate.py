"""Random FANUC lathe programs of the subset that both postproc and LinuxCNC's ``rs274`` read.

The differential test (``tests/interpret/test_interpreter_linuxcnc.py``) interprets each program twice, with
``postproc path`` and with ``rs274`` after ``to_linuxcnc``, and requires the same motions to
1e-4 mm.  So a program must be valid on a FANUC control *and* its every value must come out
of rs274's 4-decimal canonical output exactly:

* every length is a whole number of "ticks" of the program's resolution: 0.001 mm (G21,
  written with 3 decimals) or 0.0001 in (G20, 4 decimals); inch X diameters are an even
  number of ticks so that their radius is still a whole 0.0001 in, which rs274 prints
  exactly;
* inch programs use I/K arcs only: an R arc's centre is computed, and rs274 would print it
  rounded to 0.0001 in = 2.54 um, far beyond the comparison's tolerance;
* arcs are built geometrically (centre, radius, start angle from the current point, sweep)
  and re-checked after rounding: an I/K arc's start and end radii differ by less than
  0.001 mm (both controls' radius checks pass), an R arc stays clear of 180 degrees
  (where the centre flips side under rounding), and no arc closes on itself (a rounded
  end point equal to the start would turn a 350-degree arc into a full circle).

Conventions (docs/methods.md §2): radius coordinates x = X/2, z = Z; theta about
the centre: x = xc + r cos(theta), z = zc + r sin(theta); G02 = theta increasing, G03 =
theta decreasing.  I and K are incremental from the start point, and I is a radius value.

Everything is drawn from the ``random.Random`` given, so a seed names a program.
Standard library only.
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass
from decimal import Decimal

__all__ = ["program"]

X_RANGE_MM = (-20.0, 100.0)        # radius: diameters from -40 to 200 mm
Z_RANGE_MM = (-200.0, 200.0)
ARC_RADIUS_MM = (0.5, 100.0)
ARC_CHECK_MM = 0.001               # the radius check every written I/K arc passes
MIN_CHORD_MM = 0.05                # keeps a rounded end point off the start point
MIN_R_ARC_HEIGHT = 0.05            # centre to chord / |R|: about 6 degrees clear of 180
ARC_ATTEMPTS = 20
COMMENTS = ("ROUGH", "FINISH PASS", "FACE", "CHAMFER 45", "RADIUS R2", "OD TURN", "BORE")


@dataclass(frozen=True)
class Units:
    """A program's units: the G code, the size of one tick, the decimals written."""

    code: str
    mm_per_tick: float
    decimals: int
    x_ticks: int        # the diameter quantum, in ticks
    r_arcs: bool        # whether R arcs are exact in rs274's output
    feeds: tuple[str, str]  # an F for G99 (per revolution) and one for G98 (per minute)


METRIC = Units("G21", 0.001, 3, 1, True, ("0.15", "150."))
INCH = Units("G20", 0.00254, 4, 2, False, ("0.006", "6.0"))


@dataclass(frozen=True)
class Style:
    """How one program is typed: the variety a real corpus shows, drawn once per program."""

    lowercase: float        # probability that a line is written in lowercase
    numbered: float         # probability that a block has an N number
    n_step: int
    eob: str                # what ends a block as printed: '', ';', ';;', '; '
    tail_comments: bool     # a comment after the ';', and another ';' (N200 G01 Z.1 M09; (COOLANT OFF);)
    label: bool             # the O number on the '%' line: %O1200(PART), which the control skips
    crlf: bool
    spaces: bool            # words separated by spaces (FANUC needs none)
    short_g: float          # probability of G1 instead of G01
    short_number: float     # probability of X12.3 / X.5 instead of X12.300 / X0.500
    comments: float         # probability of a comment after a block
    modal: float            # probability of leaving out a G code that is already modal


def _style(rng: random.Random) -> Style:
    return Style(
        lowercase=rng.choice((0.0, 0.0, 0.2, 1.0)),
        numbered=rng.choice((0.0, 0.5, 1.0)),
        n_step=rng.choice((1, 5, 10)),
        eob=rng.choice(("", "", "", ";", ";", ";;", "; ")),
        tail_comments=rng.random() < 0.5,
        label=rng.random() < 0.2,
        crlf=rng.random() < 0.3,
        spaces=rng.random() < 0.8,
        short_g=rng.choice((0.0, 0.5, 1.0)),
        short_number=rng.choice((0.0, 0.3)),
        comments=rng.choice((0.0, 0.1)),
        modal=rng.choice((0.0, 0.5, 0.9)),
    )


class _Writer:
    """Turns blocks (lists of words) into program lines in one program's style."""

    def __init__(self, rng: random.Random, style: Style, units: Units):
        self.rng, self.style, self.units = rng, style, units
        self.lines: list[str] = []
        self.n = 0

    def number(self, ticks: int) -> str:
        """A length of ``ticks`` ticks, always with a decimal point: 12.300, or short: 12.3, 0., .5, -.5.

        FANUC reads a length without a decimal point as ticks, so the point is never left out.
        """
        text = f"{Decimal(ticks).scaleb(-self.units.decimals):.{self.units.decimals}f}"
        if self.rng.random() < self.style.short_number:
            text = text.rstrip("0")
            if ticks != 0 and text.lstrip("-").startswith("0."):
                text = text.replace("0.", ".", 1)
        return text

    def gcode(self, code: int) -> str:
        return f"G{code}" if self.rng.random() < self.style.short_g else f"G{code:02d}"

    def block(self, words: list[str]) -> None:
        """Write one block, with an optional N number, comment, ';' and lowercase."""
        if self.rng.random() < self.style.numbered:
            self.n += self.style.n_step
            words = [f"N{self.n}", *words]
        text = (" " if self.style.spaces else "").join(words)
        comment = f"({self.rng.choice(COMMENTS)})" if self.rng.random() < self.style.comments else ""
        if comment and self.style.eob and self.style.tail_comments:
            text += f"{self.style.eob.rstrip()} {comment};"
        else:
            text += (" " + comment if comment else "") + self.style.eob
        if self.rng.random() < self.style.lowercase:
            text = text.lower()
        self.lines.append(text)

    def raw(self, line: str) -> None:
        self.lines.append(line)

    def text(self) -> str:
        newline = "\r\n" if self.style.crlf else "\n"
        return newline.join(self.lines) + newline


@dataclass
class _State:
    """Where the tool is, in ticks (X as a diameter), and the modal motion code."""

    X: int
    Z: int
    motion: int

    def x_mm(self, units: Units) -> float:
        return self.X * units.mm_per_tick / 2.0

    def z_mm(self, units: Units) -> float:
        return self.Z * units.mm_per_tick


def _ticks(mm: float, units: Units, quantum: int = 1) -> int:
    return quantum * round(mm / units.mm_per_tick / quantum)


def _random_point(rng: random.Random, units: Units) -> tuple[int, int]:
    """A point of the working box, as (X diameter ticks, Z ticks)."""
    x = rng.uniform(*X_RANGE_MM)
    z = rng.uniform(*Z_RANGE_MM)
    return _ticks(2.0 * x, units, units.x_ticks), _ticks(z, units)


def _in_box(X: int, Z: int, units: Units) -> bool:
    x, z = X * units.mm_per_tick / 2.0, Z * units.mm_per_tick
    return X_RANGE_MM[0] <= x <= X_RANGE_MM[1] and Z_RANGE_MM[0] <= z <= Z_RANGE_MM[1]


def _motion_word(w: _Writer, state: _State, code: int) -> list[str]:
    """The G code, or nothing when it is modal and the style leaves it out."""
    if state.motion == code and w.rng.random() < w.style.modal:
        return []
    return [w.gcode(code)]


def _straight(w: _Writer, state: _State) -> list[str]:
    """A G00/G01 block: both axes, one axis, or (rarely) a zero-length move.

    Sometimes the G code first stands alone on a block (it only sets the modal motion, and
    neither interpreter may print a motion for it) and the move leaves it out.
    """
    rng, units = w.rng, w.units
    code = rng.choice((0, 1, 1, 1))
    X, Z = _random_point(rng, units)
    shape = rng.choices(("XZ", "X", "Z", "zero"), weights=(50, 22, 22, 6))[0]
    if shape == "zero":
        X, Z = state.X, state.Z
        shape = rng.choice(("XZ", "X", "Z"))
    X = X if "X" in shape else state.X
    Z = Z if "Z" in shape else state.Z
    axes = [f"{a}{w.number(v)}" for a, v in (("X", X), ("Z", Z)) if a in shape]
    if rng.random() < 0.1:
        axes.reverse()
    if rng.random() < 0.05:                  # the G code on a block of its own: modal, no motion
        w.block([w.gcode(code)])
        state.motion = code
    words = _motion_word(w, state, code) + axes
    state.X, state.Z, state.motion = X, Z, code
    return words


@dataclass(frozen=True)
class _Arc:
    """An arc as it will be written: end point and centre offset in ticks, R in ticks or None."""

    cw: bool
    X: int
    Z: int
    I: int
    K: int
    R: int | None


def _sweep_deg(rng: random.Random, r_arc: bool) -> float:
    """Sweep up to 350 degrees; an R arc keeps clear of 180 (R's sign only picks a side)."""
    if rng.random() < 0.3:
        return rng.choice((90.0, 270.0) if r_arc else (90.0, 180.0, 270.0))
    if r_arc:
        return rng.choice((rng.uniform(5.0, 175.0), rng.uniform(185.0, 350.0)))
    return rng.uniform(5.0, 350.0)


def _draw_arc(rng: random.Random, state: _State, units: Units) -> _Arc:
    """An arc from the current point: centre, radius, start angle and sweep, rounded to ticks."""
    cw = rng.random() < 0.5
    r_arc = units.r_arcs and rng.random() < 0.4
    radius = math.exp(rng.uniform(*map(math.log, ARC_RADIUS_MM)))
    if rng.random() < 0.3:                   # fillets start on an axis: I or K is zero
        theta0 = math.radians(rng.choice((0.0, 90.0, 180.0, 270.0)))
    else:
        theta0 = rng.uniform(0.0, 2.0 * math.pi)
    sweep = math.radians(_sweep_deg(rng, r_arc))
    theta1 = theta0 + (sweep if cw else -sweep)
    x0, z0 = state.x_mm(units), state.z_mm(units)
    xc, zc = x0 - radius * math.cos(theta0), z0 - radius * math.sin(theta0)
    x1, z1 = xc + radius * math.cos(theta1), zc + radius * math.sin(theta1)
    R = None
    if r_arc:
        R = _ticks(radius, units) * (-1 if sweep > math.pi else 1)
    return _Arc(cw, _ticks(2.0 * x1, units, units.x_ticks), _ticks(z1, units),
                _ticks(xc - x0, units), _ticks(zc - z0, units), R)


def _arc_ok(arc: _Arc, state: _State, units: Units) -> bool:
    """Whether the rounded arc is one both controls accept and place the same way."""
    t = units.mm_per_tick
    dx, dz = (arc.X - state.X) * t / 2.0, (arc.Z - state.Z) * t
    chord = math.hypot(dx, dz)
    if chord < MIN_CHORD_MM or not _in_box(arc.X, arc.Z, units):
        return False
    if arc.R is not None:
        radius = abs(arc.R) * t
        return radius > chord / 2.0 and math.sqrt(radius**2 - (chord / 2.0) ** 2) >= MIN_R_ARC_HEIGHT * radius
    r_start = math.hypot(arc.I * t, arc.K * t)
    r_end = math.hypot(dx - arc.I * t, dz - arc.K * t)
    return abs(r_start - r_end) < ARC_CHECK_MM


def _arc_words(w: _Writer, arc: _Arc) -> list[str]:
    """X Z and R, or I and K (one of them left out, sometimes, when it is zero)."""
    words = [f"X{w.number(arc.X)}", f"Z{w.number(arc.Z)}"]
    if arc.R is not None:
        return words + [f"R{w.number(arc.R)}"]
    for letter, ticks in (("I", arc.I), ("K", arc.K)):
        if ticks != 0 or w.rng.random() < 0.5:
            words.append(f"{letter}{w.number(ticks)}")
    return words


def _arc(w: _Writer, state: _State) -> list[str] | None:
    """A G02/G03 block, or None when no drawn arc survived rounding (rare)."""
    for _ in range(ARC_ATTEMPTS):
        arc = _draw_arc(w.rng, state, w.units)
        if _arc_ok(arc, state, w.units):
            code = 2 if arc.cw else 3
            words = _motion_word(w, state, code) + _arc_words(w, arc)
            state.X, state.Z, state.motion = arc.X, arc.Z, code
            return words
    return None


def _header(w: _Writer, rng: random.Random, units: Units) -> None:
    """%, O number, G18, units, feed mode and an F word, in varying order and grouping."""
    header = f"O{rng.randint(1, 9999):04d}" + (" (DIFF TEST)" if rng.random() < 0.5 else "")
    if w.style.label:  # on the tape mark's line: a label the control skips
        w.raw("%" + header)
    else:
        w.raw("%")
        w.raw(header)
    per_rev = rng.random() < 0.7
    modes = ["G18", units.code, "G99" if per_rev else "G98"]
    rng.shuffle(modes)
    feed = f"F{units.feeds[0] if per_rev else units.feeds[1]}"
    if rng.random() < 0.5:
        w.block(modes + [feed])
    else:
        for code in modes:
            w.block([code])
        w.block([feed])


def program(rng: random.Random) -> str:
    """A complete random program: header, a rapid start point, 5-40 moves, M30."""
    units = rng.choice((METRIC, INCH))
    w = _Writer(rng, _style(rng), units)
    _header(w, rng, units)
    X, Z = _random_point(rng, units)
    w.block([w.gcode(0), f"X{w.number(X)}", f"Z{w.number(Z)}"])
    state = _State(X, Z, 0)
    for _ in range(rng.randint(5, 40)):
        words = _arc(w, state) if rng.random() < 0.4 else None
        w.block(words or _straight(w, state))
    w.block(["M30"])
    w.raw("%")
    return w.text()
