"""Closing the loop on the machine: a FANUC probing program for a part program's profile.

The program touches N points spread over the features of the nominal profile (its lines and
arcs, :mod:`postproc.measure.features`; the profile and its material side as ``postproc simulate
probe`` picks them, :mod:`postproc.measure.nominal`): at least ``per_feature`` on every
feature, the rest shared out by length, evenly spaced along each feature and ``inset`` clear
of its ends (more at a concave corner, where the stylus needs room), and optionally a datum
before and after them (docs/methods.md §9.3, the stability check). Per feature, because the probe
compensators screen and correct each feature from its own touches.
Each touch, with n the outward normal of the nominal surface at its point Q, R the stylus
radius and c the clearance:

1. the route to its approach start ``A = Q + (R + c) n`` (:mod:`postproc.onmachine.probe_route`: near
   the part at the travel feed, along the envelope at rapid);
2. ``G31`` from A towards ``Q + (R - overtravel) n``, beyond the surface, at the probing feed:
   the skip stops the move where the probe triggers and latches the position in #5061 (X)
   and #5062 (Z);
3. an alarm (#3000) if it never triggered (the latched position is then the move's end);
4. ``DPRNT`` of the latched position and the approach (:mod:`postproc.onmachine.probe_printout`);
5. ``G01`` back out to A.

FANUC details it minds: G40 (no G31 under nose radius compensation), feed per minute (G98
in G-code system A, G94 in B and C: with the spindle stopped a feed per revolution would not
move), F on every G01 and G31 block, X as a diameter in diameter mode (the latched #5061 is
one too), absolute positions only (the next block after a skip starts from the latched point),
the positions on the control's grid and the printed approach the direction of the rounded
move, POPEN before the first DPRNT and PCLOS after the last, local variables of the main
program (#1-#9) for the numbers the printout carries, and a header line that makes the
printout self-describing. The probe's tool offset must put the programmed point at the
stylus centre; ``tool`` selects it (T word), ``probe_on``/``probe_off`` are the machine's
M codes that switch the probe on and off. They come as a pair: a program that switches the probe
on and not off leaves it on after the cycle (its battery drained, a false trigger the next
skip move takes for a touch), and one that switches it off and not on may run its skip moves
with the probe off, the stylus driven into the part. ``none`` says, for one of the two, that
the machine does it by itself (a probe that switches off on a timer, or on with the tool change).
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
from dataclasses import dataclass

import numpy as np

from ..diagnostics import InternalError, Location, OptionError, Reporter, SafetyError, UsageError
from ..compensate.emitter import Style
from ..measure.features import MIN_TOUCHES, Feature, Spread
from ..geometry import segment_of
from ..interpret.motion import ARC, Move
from ..measure.nominal import Nominal
from ..measure.readers.lengths import stylus_problem
from .probe_printout import (AFTER, BEFORE, END_STATEMENT, POINT, VAR_COUNT, VAR_DIVISOR, VAR_I, VAR_INDEX, VAR_K,
                             VAR_PROGRAM, VAR_RADIUS, VAR_UNITS, VAR_VERSION, VERSION, header_statement,
                             touch_statement)
from .probe_route import Envelope, Leg, Router, Surfaces
from ..machine.profile import DEFAULT, MachineProfile
from ..interpret.program import interpret_source
from ..syntax.source import Source

DATUM_SURFACES = ("face", "diameter", "both")
FAN_STEP = math.radians(10.0)  #: the standoff path turns round a convex corner in steps this small
_OUTWARD = {"face": (0.0, 1.0), "diameter": (1.0, 0.0)}
BY_ITSELF = "none"  #: ``--probe-on none`` / ``--probe-off none``: the machine switches the probe, no M code


@dataclass(frozen=True, slots=True)
class Cycle:
    """What the probing program does. Lengths in mm (radius), feeds in mm/min."""

    points: int = 36
    stylus_radius: float = 3.0
    clearance: float = 1.0  #: each approach starts this far from the nominal surface
    overtravel: float | None = None  #: how far beyond the nominal surface G31 aims (default: the clearance)
    feed: float = 50.0  #: G31
    travel_feed: float = 1000.0  #: G01 moves near the part
    program_number: int = 8100
    inset: float = 0.5  #: arc length kept free of touches at both ends of every feature
    datum: tuple[float, float] | None = None  #: (x, z) the datum touch aims at, radius mm
    datum_on: str = "face"  #: face (touched from +Z), diameter (from +X) or both
    tool: str | None = None  #: T word digits, e.g. "0909"
    probe_on: str | None = None  #: M code digits, or BY_ITSELF
    probe_off: str | None = None  #: M code digits, or BY_ITSELF
    per_feature: int = MIN_TOUCHES  #: the fewest touches on each feature with room for them

    @property
    def reach(self) -> float:
        """How far beyond the nominal surface the skip moves aim."""
        return self.clearance if self.overtravel is None else self.overtravel

    def check(self) -> None:
        """:raises OptionError: a value the program cannot be written with."""
        if self.points < 1:
            raise OptionError(f"--points {self.points}: at least one point is needed")
        for name, value in (("--stylus-radius", self.stylus_radius), ("--clearance", self.clearance),
                            ("--overtravel", self.reach), ("--feed", self.feed),
                            ("--travel-feed", self.travel_feed)):
            if not (math.isfinite(value) and value > 0):
                raise OptionError(f"{name} {value:g}: must be positive")
        problem = stylus_problem(self.stylus_radius)
        if problem:
            raise OptionError(f"--stylus-radius {self.stylus_radius:g}: {problem}")
        if not (math.isfinite(self.inset) and self.inset >= 0):
            raise OptionError(f"--inset {self.inset:g}: must not be negative")
        if self.per_feature < 1:
            raise OptionError(f"--per-feature {self.per_feature}: at least one touch per feature")
        if not 1 <= self.program_number <= 9999:
            raise OptionError(f"--program-number {self.program_number}: a FANUC program number is 1 to 9999")
        if self.datum_on not in DATUM_SURFACES:
            raise OptionError(f"datum surface {self.datum_on!r}: expected one of {', '.join(DATUM_SURFACES)}")
        for name, value, letter in (("--tool", self.tool, "T"), ("--probe-on", _code(self.probe_on), "M"),
                                    ("--probe-off", _code(self.probe_off), "M")):
            if value is not None and not re.fullmatch(r"\d{1,8}", value):
                raise OptionError(f"{name} {value}: expected the digits of a {letter} code, e.g. "
                                  f"{'0909' if letter == 'T' else '55'}{'' if letter == 'T' else ', or none'}")
        if self.tool is not None:
            _check_tool(self.tool)
        on, off = _code(self.probe_on), _code(self.probe_off)
        for name, value in (("--probe-on", on), ("--probe-off", off)):
            if value is not None and int(value) in RESERVED_M:
                raise OptionError(f"{name} M{value}: M{int(value):02d} {RESERVED_M[int(value)]} on a FANUC control, it "
                                  "cannot switch the probe; give the machine builder's M code for it (e.g. M55)")
        if on is not None and off is not None and int(on) == int(off):
            raise OptionError(f"--probe-on M{self.probe_on} and --probe-off M{self.probe_off}: one M code cannot "
                              "switch the probe both on and off")
        _check_pair(self.probe_on, self.probe_off)


def _by_itself(value: str | None) -> bool:
    return value is not None and value.lower() == BY_ITSELF


def _code(value: str | None) -> str | None:
    """The M code digits of a switch, None for no code (not given, or the machine's own)."""
    return None if value is None or _by_itself(value) else value


def _check_pair(on: str | None, off: str | None) -> None:
    """The probe's switches come in pairs: one given without the other leaves the probe on after
    the cycle, or runs the skip moves with it off. ``none`` for the other says the machine
    switches it by itself.

    :raises UsageError: one switch given, the other not.
    """
    if on is not None and off is None:
        raise UsageError(f"--probe-on {'none' if _by_itself(on) else 'M' + on} without --probe-off: the probing "
                         "program would leave the probe switched on after the cycle; give --probe-off MNN, the M code "
                         "that switches it off, or --probe-off none if the probe switches itself off (a timer)")
    if off is not None and on is None:
        raise UsageError(f"--probe-off {'none' if _by_itself(off) else 'M' + off} without --probe-on: the probing "
                         "program would run its skip moves with the probe off unless something else switched it on; "
                         "give --probe-on MNN, the M code that switches it on, or --probe-on none if the machine "
                         "switches it on by itself (with the tool change)")


#: M codes whose meaning a FANUC control fixes (or every lathe builder gives them): never the probe's switch
RESERVED_M = {0: "stops the program", 1: "is the optional stop", 2: "ends the program", 3: "starts the spindle",
              4: "starts the spindle", 5: "stops the spindle", 8: "switches the coolant on",
              9: "switches the coolant off", 30: "ends the program and rewinds it", 98: "calls a subprogram",
              99: "returns from a subprogram"}


def _check_tool(digits: str) -> None:
    """A T code that selects a tool and its offset. A lathe's T code is the tool and its offset
    in two digits each (T0909) or, in the short form, one each (T99); any other length (T9,
    T123456) reads as a tool number of zero or one the turret does not have. T0 (any number of
    zeros) selects no tool and cancels the offset; tool 0 is no tool, and offset 0 cancels the
    offset, which must put the programmed point at the stylus centre."""
    said = f"--tool T{digits}"
    if int(digits) == 0:
        raise OptionError(f"{said}: T0 selects no tool and cancels the tool offset; give the probe's tool and "
                          "offset, e.g. T0909")
    if len(digits) not in (2, 4):
        raise OptionError(f"{said}: a lathe's T code is the tool and its offset, two digits each (T0909) or one "
                          f"each (T99); T{digits} would read as another tool or none; give the probe's tool and "
                          "offset, e.g. T0909")
    half = len(digits) // 2
    tool, offset = digits[:half], digits[half:]
    if int(tool) == 0:
        raise OptionError(f"{said}: tool {tool} is no tool; give the probe's tool and offset, e.g. T{offset}{offset}")
    if int(offset) == 0:
        raise OptionError(f"{said}: offset {offset} cancels the tool offset, which must put the programmed point at the "
                          f"stylus centre; give the probe's offset, e.g. T{tool}{tool}")


def code_digits(text: str | None, letter: str) -> str | None:
    """``T0909``, ``t0909`` or ``0909`` -> ``0909``."""
    if text is None:
        return None
    text = text.strip()
    return text[1:] if text[:1].upper() == letter else text


@dataclass(frozen=True, slots=True)
class Touch:
    """One touch: where it aims, where its skip move starts and ends, and how the stylus gets there."""

    record: str  #: point, datum before or datum after (probe_printout)
    index: int  #: the point's number, 1-based; 0 for a datum
    target: tuple[float, float]  #: the nominal surface point Q
    outward: tuple[float, float]  #: unit normal out of the material at Q
    start: tuple[float, float]  #: approach start A, on the control's grid
    end: tuple[float, float]  #: the G31 end point, on the grid
    approach: tuple[float, float]  #: unit direction of the rounded skip move, into the material
    route: tuple[Leg, ...]  #: from the previous touch's start (or the envelope's corner) to ``start``

    @property
    def name(self) -> str:
        return f"point {self.index}" if self.record == POINT else self.record


@dataclass(frozen=True)
class ProbingProgram:
    """A planned probing program and its text."""

    program: str  #: the part program's name
    cycle: Cycle
    touches: tuple[Touch, ...]
    home: tuple[float, float]  #: where the program starts and ends (the envelope's corner)
    leave: tuple[Leg, ...]  #: from the last touch's start back home
    lines: tuple[int, int]  #: source lines of the profile's first and last move
    features: tuple[Feature, ...] = ()  #: the profile's lines and arcs
    spread: Spread | None = None  #: how many touches each feature got, and the room kept at its ends
    text: str = ""
    title: str = ""  #: what the program probes, for its heading (default: the profile's lines and points)

    @property
    def points(self) -> tuple[Touch, ...]:
        return tuple(t for t in self.touches if t.record == POINT)


# ---------------------------------------------------------------------------- where to touch


def stations(nominal: Nominal, count: int, inset: float = 0.0, minimum: int = MIN_TOUCHES, radius: float = 0.0,
             clearance: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``count`` touches over the profile's features (:meth:`Nominal.spread`): points, normals, s."""
    s = nominal.spread(count, inset, minimum, radius, clearance).s
    return *nominal.places(s), s


def standoff_path(nominal: Nominal, s0: float, s1: float, distance: float, step: float) -> np.ndarray:
    """The profile offset by ``distance`` out of the material from ``s0`` to ``s1``, turning round corners."""
    offsets = nominal.profile.offsets
    cuts = [s0] + [float(o) for o in offsets[1:-1] if s0 < o < s1] + [s1]
    pieces: list[np.ndarray] = []
    turning_from = None  # the normal at the end of the piece before
    for a, b in zip(cuts, cuts[1:]):
        s = np.linspace(a, b, max(1, math.ceil((b - a) / step)) + 1)
        index = int(np.clip(np.searchsorted(offsets, (a + b) / 2.0, side="right") - 1, 0, len(offsets) - 2))
        param = (s - offsets[index]) / (offsets[index + 1] - offsets[index])
        normals = nominal.outward(np.full(len(s), index), param)
        points = nominal.profile.segments[index].point_at(param)
        if turning_from is not None:
            pieces.append(_fan(points[0], turning_from, normals[0], distance))
        pieces.append(points + distance * normals)
        turning_from = normals[-1]
    return np.concatenate(pieces)


def _fan(vertex: np.ndarray, before: np.ndarray, after: np.ndarray, distance: float) -> np.ndarray:
    """Points at ``distance`` round a corner, turning the normal from ``before`` to ``after``."""
    turn = math.atan2(before[0] * after[1] - before[1] * after[0], float(before @ after))
    count = math.ceil(abs(turn) / FAN_STEP)
    angles = turn * np.arange(1, count) / count if count > 1 else np.zeros(0)
    c, s = np.cos(angles), np.sin(angles)
    rotated = np.column_stack([c * before[0] - s * before[1], s * before[0] + c * before[1]])
    return (vertex + distance * rotated).reshape(-1, 2)


# ---------------------------------------------------------------------------- planning


def _known_points(moves: list[Move]) -> list[tuple[float, float]]:
    points = []
    for move in moves:
        for x, z in ((move.x0, move.z0), (move.x1, move.z1)):
            if x is not None and z is not None:
                points.append((x, z))
        if move.kind == ARC and move.known:
            points += [tuple(p) for p in segment_of(move).point_at(np.linspace(0.0, 1.0, 33))]
    return points


def _unit(vector) -> tuple[float, float]:
    v = np.asarray(vector, dtype=float)
    return tuple(float(c) for c in v / np.linalg.norm(v))


class _Planner:
    def __init__(self, moves: list[Move], nominal: Nominal, cycle: Cycle, profile: MachineProfile):
        self.nominal = nominal
        self.cycle = cycle
        self.profile = profile
        self.grid = profile.grid(False)
        self.program = nominal.program
        self.moves = moves

    def plan(self) -> ProbingProgram:
        cycle = self.cycle
        spread = self.nominal.spread(cycle.points, cycle.inset, cycle.per_feature, cycle.stylus_radius, cycle.clearance)
        s = spread.s
        points, normals = self.nominal.places(s)
        datums = self._datums()
        targets = [tuple(p) for p in points] + [q for q, _ in datums]
        grow = cycle.stylus_radius + cycle.clearance
        envelope = Envelope.around(_known_points(self.moves) + targets, grow)
        self.router = Router(Surfaces(self.moves), envelope, cycle.stylus_radius, cycle.clearance)
        sequence = ([(BEFORE, 0, q, n, None) for q, n in datums]
                    + [(POINT, i + 1, points[i], normals[i], s[i]) for i in range(len(points))]
                    + [(AFTER, 0, q, n, None) for q, n in datums])
        touches: list[Touch] = []
        previous = None  # (exact start, outward, s, name) of the touch before
        for record, index, q, n, station in sequence:
            q, n = np.asarray(q, dtype=float), np.asarray(n, dtype=float)
            start = q + grow * n
            name = f"point {index}" if record == POINT else record
            line = self.router.blocked(start, q + cycle.stylus_radius * n)
            if line is not None:
                raise SafetyError(
                    f"{name} (x {q[0]:.3f} z {q[1]:.3f}): the stylus would meet the surface of line {line} before "
                    f"it reaches the point; keep the touches farther from the ends of the features (--inset MM), "
                    f"narrow the stretch (--from-line/--to-line) or choose another datum", Location(self.program))
            route = self._route(previous, (start, n, station, name), envelope)
            a = self.grid.snap(*start)
            e = self.grid.snap(*(q + (cycle.stylus_radius - cycle.reach) * n))
            touches.append(Touch(record, index, (float(q[0]), float(q[1])), (float(n[0]), float(n[1])), a, e,
                                 _unit(np.subtract(e, a)), tuple(route)))
            previous = (start, n, station, name)
        leave = tuple(self._route(previous, None, envelope))
        first, last = self.nominal.moves[0].line, self.nominal.moves[-1].line
        planned = ProbingProgram(self.program, cycle, tuple(touches), envelope.corner, leave, (first, last),
                                 self.nominal.features, spread)
        within_limits(planned, self.profile)
        return planned

    def _datums(self) -> list[tuple[tuple[float, float], tuple[float, float]]]:
        cycle = self.cycle
        if cycle.datum is None:
            return []
        surfaces = ("face", "diameter") if cycle.datum_on == "both" else (cycle.datum_on,)
        return [(cycle.datum, _OUTWARD[surface]) for surface in surfaces]

    def _route(self, previous, following, envelope: Envelope) -> list[Leg]:
        """Legs from the previous touch's start (None: the corner) to the following one's (None: the corner).

        A touch is given as (exact start, outward normal, arc length on the profile or None, name).
        """
        router, cycle = self.router, self.cycle
        if previous is not None and following is not None and previous[2] is not None and following[2] is not None:
            path = standoff_path(self.nominal, previous[2], following[2], cycle.stylus_radius + cycle.clearance,
                                 cycle.clearance)
            path[0], path[-1] = previous[0], following[0]
            near = router.simplify(path)
            if near is not None:
                return [Leg(float(x), float(z), rapid=False) for x, z in near]
        ends = []
        for touch, way_to in ((previous, "out from"), (following, "in to")):
            if touch is None:
                ends.append((envelope.corner, envelope.corner))
                continue
            way = router.escape(touch[0], touch[1])
            if way is None:
                raise SafetyError(f"no clear way {way_to} {touch[3]}: neither along its normal nor along +Z or +X "
                                  "does the stylus reach the space above or beyond the part; narrow the stretch "
                                  "(--from-line/--to-line, --inset)", Location(self.program))
            ends.append((tuple(float(c) for c in touch[0]), way))
        (a, a_exit), (b, b_exit) = ends
        legs = router.via_envelope(a, a_exit, b_exit, b)
        if previous is None:
            legs = legs[1:]  # the program starts at the corner: nothing to leave
        if following is None:
            legs = legs[:-1]  # the envelope's path already ends at the corner, at rapid
        return legs


def within_limits(planned: ProbingProgram, profile: MachineProfile) -> None:
    """:raises SafetyError: a position of the program outside the machine profile's soft limits."""
    limits = {"x": profile.x_limits, "z": profile.z_limits}
    if limits["x"] is None and limits["z"] is None:
        return
    places = [planned.home] + [(leg.x, leg.z) for leg in planned.leave]
    for touch in planned.touches:
        places += [(leg.x, leg.z) for leg in touch.route] + [touch.start, touch.end]
    for x, z in places:
        for axis, value in (("x", x), ("z", z)):
            span = limits[axis]
            if span is not None and not span[0] - 1e-9 <= value <= span[1] + 1e-9:
                raise SafetyError(f"the probing program would move {axis} to {value:.3f} mm, outside the soft "
                                  f"limits {span[0]:g}..{span[1]:g} of the machine profile", Location(planned.program))


def plan(moves: list[Move], nominal: Nominal, cycle: Cycle, profile: MachineProfile = DEFAULT) -> ProbingProgram:
    """The probing program for ``nominal``, a profile of the program whose moves are ``moves``.

    :raises OptionError: a setting the program cannot be written with.
    :raises SafetyError: a touch the stylus cannot reach without meeting another surface first,
        a touch with no clear way to it, a move outside the soft limits.
    """
    cycle.check()
    planned = _Planner(moves, nominal, cycle, profile).plan()
    return dataclasses.replace(planned, text=program_text(planned, profile))


# ---------------------------------------------------------------------------- the program's text


class _Text:
    """Blocks in the control's units and style: X a diameter in diameter mode, decimal points always."""

    def __init__(self, profile: MachineProfile):
        self.grid = profile.grid(False)
        self.style = Style()
        self.lines: list[str] = []
        self.at: tuple[float, float] | None = None

    def number(self, value: float, decimals: int | None = None) -> str:
        return self.style.number(value, self.grid.decimals if decimals is None else decimals)

    def xz(self, x: float, z: float) -> str:
        return f"X{self.number(self.grid.x_word(x))} Z{self.number(self.grid.z_word(z))}"

    def difference(self, variable: str, value: float) -> str:
        """``#5061-12.5`` or ``#5061+12.5``: no sign right after an operator."""
        return f"{variable}{'+' if value < 0 else '-'}{self.number(abs(value))}"

    def add(self, *lines: str) -> None:
        self.lines.extend(lines)

    def move(self, leg: Leg, feed: float) -> None:
        position = self.grid.snap(leg.x, leg.z)
        if position == self.at:
            return
        self.add(f"G00 {self.xz(*position)}" if leg.rapid else f"G01 {self.xz(*position)} F{self.number(feed, 1)}")
        self.at = position


def _comment(text: str) -> str:
    """A comment a control reads: upper case, no parentheses, letters, digits and plain punctuation."""
    return "(" + re.sub(r"[^A-Z0-9 .,/_=+-]", "", text.upper()).strip() + ")"


def program_text(planned: ProbingProgram, profile: MachineProfile = DEFAULT) -> str:
    """The FANUC program (macro B) of a planned probing run."""
    cycle = planned.cycle
    text = _Text(profile)
    system = profile.gcode_system
    per_minute = "G98" if system == "A" else "G94"
    absolute = "" if system == "A" else " G90"
    name = os.path.basename(planned.program)
    first, last = planned.lines
    text.add("%", f"O{cycle.program_number:04d} " + _comment(f"POSTPROC PROBING {name}"),
             _comment((planned.title or f"PROFILE LINES {first}-{last}, {len(planned.points)} POINTS")
                      + f", STYLUS R{cycle.stylus_radius:g} MM, CLEARANCE {cycle.clearance:g} MM"),
             _comment(f"PRINTOUT FORMAT {VERSION}: READ IT WITH POSTPROC PROBE-IMPORT"),
             _comment("THE PROBE OFFSET MUST PUT THE PROGRAMMED POINT AT THE STYLUS CENTRE"),
             _comment("START WITH THE PROBE CLEAR OF THE PART, AS AFTER A TOOL CHANGE"),
             f"G18 G21 G40{absolute} {per_minute}", "M05")
    if cycle.tool is not None:
        text.add(f"T{cycle.tool}")
    if _by_itself(cycle.probe_on):
        text.add(_comment("THE MACHINE SWITCHES THE PROBE ON"))
    elif cycle.probe_on is not None:
        text.add(f"M{cycle.probe_on} " + _comment("PROBE ON"))
    header = ((VAR_RADIUS, text.number(text.grid.z_word(cycle.stylus_radius), 4)), (VAR_VERSION, str(VERSION)),
              (VAR_PROGRAM, str(cycle.program_number)), (VAR_UNITS, "21"),
              (VAR_DIVISOR, "2" if profile.diameter_x else "1"), (VAR_COUNT, str(len(planned.points))))
    text.add(*(f"#{variable}={value}" for variable, value in header))
    home_x, home_z = text.grid.snap(*planned.home)
    text.add(f"G00 Z{text.number(text.grid.z_word(home_z))}", f"G00 X{text.number(text.grid.x_word(home_x))}")
    text.at = (home_x, home_z)
    text.add("POPEN", header_statement())
    half_step = text.number(text.grid.step / 2.0, text.grid.decimals + 1)
    for touch in planned.touches:
        text.add(_comment(touch.name))
        if touch.record == POINT:
            text.add(f"#{VAR_INDEX}={touch.index}")
        text.add(f"#{VAR_I}={text.number(touch.approach[0], 6)}", f"#{VAR_K}={text.number(touch.approach[1], 6)}")
        for leg in touch.route:
            text.move(leg, cycle.travel_feed)
        text.move(Leg(*touch.start, rapid=False), cycle.travel_feed)
        off_x = text.difference("#5061", text.grid.x_word(touch.end[0]))
        off_z = text.difference("#5062", text.grid.z_word(touch.end[1]))
        text.add(f"G31 {text.xz(*touch.end)} F{text.number(cycle.feed, 1)}",
                 f"IF[[ABS[{off_x}]+ABS[{off_z}]]LT{half_step}]THEN#3000=1" + _comment(f"NO TOUCH AT {touch.name}"),
                 touch_statement(touch.record))
        text.at = None  # the skip stopped somewhere short of the end
        text.move(Leg(*touch.start, rapid=False), cycle.travel_feed)
    text.add(END_STATEMENT, "PCLOS")
    for leg in planned.leave:
        text.move(leg, cycle.travel_feed)
    if _by_itself(cycle.probe_off):
        text.add(_comment("THE PROBE SWITCHES ITSELF OFF"))
    elif cycle.probe_off is not None:
        text.add(f"M{cycle.probe_off} " + _comment("PROBE OFF"))
    text.add("M30", "%")
    return "\n".join(text.lines) + "\n"


def self_check(planned: ProbingProgram, profile: MachineProfile = DEFAULT) -> None:
    """Interpret the written program as postproc interprets any: every skip move must start at its
    touch's approach start and aim at its end.

    :raises InternalError: the text does not say what was planned.
    """
    skips = []
    with Source.from_text(planned.text, f"O{planned.cycle.program_number:04d}") as source:
        for step in interpret_source(source, profile, Reporter()):
            if ("G", "31") in [(letter, value) for letter, value in step.block.codes]:
                move = step.moves[0]
                skips.append((move.x0, move.z0, step.block))
    if len(skips) != len(planned.touches):
        raise InternalError(f"the probing program has {len(skips)} skip moves for {len(planned.touches)} touches")
    grid = profile.grid(False)
    for (x0, z0, block), touch in zip(skips, planned.touches):
        values = dict(block.codes)
        end = (grid.x_of(float(values["X"])), grid.z_of(float(values["Z"])))
        if x0 is None or math.hypot(x0 - touch.start[0], z0 - touch.start[1]) > 1e-9 or \
                math.hypot(end[0] - touch.end[0], end[1] - touch.end[1]) > 1e-9:
            raise InternalError(f"line {block.line} of the probing program does not run {touch.name} as planned")
