"""The nominal profile of a program: which feed moves make the surface, and which side is air.

What the probing cycles and routes, ``inspect`` and ``probe-program`` measure against, and what
the virtual lathe (:mod:`postproc.simulator`) cuts: geometry of the program, not of a machine.

The moves the control runs are the interpreter's moves in program order, except the
definitions of a G71-G73 contour (run later by G70, as ``replay`` moves) and a canned
cycle's own call (its roughing passes are not simulated). Rapids and threads are run too:
they matter for lost motion, but make no surface.

The profile is, by default, the first continuous chain of feed moves (G01/G02/G03) without
the moves at its ends that run along the spindle axis (both ends within ``ON_AXIS_MM`` of x = 0:
they turn no surface). A compensated program's lead-in to the pole ends a few micrometres off
the axis, on either side of it (the path moved on purpose), and is still such a move.
``first_line``/``last_line`` keep only moves whose source line lies in that range
(the first continuous chain of those): use them to leave out lead-in and lead-out moves
that would cut air on the real part but cut the virtual one.

Material side: ``axis`` (default) takes the material to lie between the profile and the
spindle axis (outside turning); ``left``/``right`` name it relative to the direction of travel
(a bore, say, is ``left`` when cut towards -Z). Normals point out of the material.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass

import numpy as np

from ..diagnostics import Location, OptionError, Reporter, SpreadError
from .features import MIN_TOUCHES, Feature, Spread, features, spread
from ..geometry import Profile, segment_of
from ..interpret.motion import ARC, CONTOUR, CYCLE, LINE, Move, Step
from ..machine.profile import DEFAULT, MachineProfile
from ..interpret.program import interpret_source
from ..syntax.source import Source

MATERIAL = ("axis", "left", "right")
ON_AXIS_MM = 0.01  #: a coordinate this close to 0 is on the spindle axis (compensation moves it by microns)


def read_program(path: str, profile: MachineProfile = DEFAULT, reporter: Reporter | None = None) -> tuple[str, list[Move]]:
    """The program's name and the moves the control runs, in order, with known ends."""
    name, moves, _ = program_moves(path, profile, reporter)
    return name, moves


def program_moves(path: str, profile: MachineProfile = DEFAULT,
                  reporter: Reporter | None = None) -> tuple[str, list[Move], list[Step]]:
    """As :func:`read_program`, and the program's G10 steps (the offsets it sets), in order."""
    reporter = reporter if reporter is not None else Reporter(sys.stderr)
    moves, settings = [], []
    with Source(path) as source:
        for step in interpret_source(source, profile, reporter):
            moves.extend(step.moves)
            if ("G", "10") in step.block.codes:
                settings.append(step)
        name = source.name
    return name, [move for move in moves if move.role != CONTOUR and move.kind != CYCLE and move.known], settings


def on_axis(move: Move) -> bool:
    return move.kind == LINE and abs(move.x0) < ON_AXIS_MM and abs(move.x1) < ON_AXIS_MM


def _cuts(move: Move) -> bool:
    return move.kind in (LINE, ARC) and segment_of(move).length > 0.0


def chain(moves: list[Move], first_line: int | None = None, last_line: int | None = None,
          program: str = "<program>") -> list[int]:
    """Indexes (into ``moves``) of the profile's moves, in order."""
    def wanted(move: Move) -> bool:
        return (_cuts(move) and (first_line is None or move.line >= first_line)
                and (last_line is None or move.line <= last_line))

    found: list[int] = []
    for index, move in enumerate(moves):
        if found and not (wanted(move) and _joins(moves[found[-1]], move)):
            if any(not on_axis(moves[i]) for i in found):
                break
            found = []
        if not found and wanted(move):
            found = [index]
        elif found and wanted(move):
            found.append(index)
    while found and on_axis(moves[found[0]]):
        found.pop(0)
    while found and on_axis(moves[found[-1]]):
        found.pop()
    if not found:
        lines = "" if first_line is None and last_line is None else f" between lines {first_line or 1} and {last_line or 'the end'}"
        raise OptionError(f"no feed moves that turn a surface{lines}", Location(program))
    return found


def _joins(previous: Move, move: Move) -> bool:
    return math.hypot(move.x0 - previous.x1, move.z0 - previous.z1) < 1e-9


@dataclass(frozen=True)
class Nominal:
    """The nominal profile of a program and the side of it that is material."""

    moves: tuple[Move, ...]  #: the profile's moves, in order
    indexes: tuple[int, ...]  #: their places in the program's list of moves
    profile: Profile
    material: str  #: "left" or "right" of the direction of travel
    program: str = "<program>"

    @property
    def outward_sign(self) -> float:
        """+1 when the outward normal is the left normal of the direction of travel."""
        return 1.0 if self.material == "right" else -1.0

    def outward(self, segment: np.ndarray, param: np.ndarray) -> np.ndarray:
        """Unit normals out of the material at places given as (segment index, parameter)."""
        return self.outward_sign * self.profile.left_normals(np.asarray(segment), np.asarray(param, dtype=float))

    def places(self, s) -> tuple[np.ndarray, np.ndarray]:
        """Points and outward normals of the profile at arc lengths ``s`` (at a join: the later segment's)."""
        offsets = self.profile.offsets
        s = np.atleast_1d(np.asarray(s, dtype=float))
        segment = np.clip(np.searchsorted(offsets, s, side="right") - 1, 0, len(self.profile.segments) - 1)
        param = np.clip((s - offsets[segment]) / np.diff(offsets)[segment], 0.0, 1.0)
        points = np.array([self.profile.segments[i].point_at(t) for i, t in zip(segment, param)]).reshape(-1, 2)
        return points, self.outward(segment, param)

    def stations(self, count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``count`` places evenly spaced along the profile, both ends included: points, outward normals, s."""
        s = np.linspace(0.0, self.profile.length, count)
        return *self.places(s), s

    @property
    def features(self) -> tuple[Feature, ...]:
        """The profile's lines and arcs (:mod:`postproc.measure.features`), named by their source lines."""
        return features(self.profile, tuple(move.line for move in self.moves))

    def spread(self, count: int, inset: float = 0.0, minimum: int = MIN_TOUCHES, radius: float = 0.0,
               clearance: float = 0.0) -> Spread:
        """``count`` touches over the features, ``minimum`` on each, clear of their ends by ``inset``
        and of concave corners by what a stylus of ``radius`` approaching from ``clearance`` out
        needs (:func:`postproc.measure.features.spread`).

        :raises OptionError: no feature has room, or ``count`` is below the minimum on each."""
        try:
            return spread(self.features, count, inset, minimum, outward_sign=self.outward_sign, radius=radius,
                          clearance=clearance)
        except SpreadError as exc:
            if exc.wanted is None:
                raise OptionError(f"--inset {inset:g} leaves nothing of the {self.profile.length:.3f} mm profile to "
                                  "probe (a feature also keeps clear of a concave corner by what the stylus needs)",
                                  Location(self.program)) from None
            raise OptionError(f"--points {count}: {exc}; give --points {exc.wanted} or more, or fewer per feature "
                              "(--per-feature)", Location(self.program)) from None


def nominal(moves: list[Move], first_line: int | None = None, last_line: int | None = None, material: str = "axis",
            program: str = "<program>") -> Nominal:
    """The profile a program cuts (see the module's rules)."""
    if material not in MATERIAL:
        raise OptionError(f"material side {material!r}: expected one of {', '.join(MATERIAL)}")
    indexes = chain(moves, first_line, last_line, program)
    chosen = tuple(moves[i] for i in indexes)
    profile = Profile(tuple(segment_of(move) for move in chosen))
    if material == "axis":
        material = _side_of_axis(profile, program)
    return Nominal(chosen, tuple(indexes), profile, material, program)


def _side_of_axis(profile: Profile, program: str) -> str:
    """The side of the profile that faces the spindle axis: close it along the axis and see."""
    outline = [segment.point_at(np.linspace(0.0, 1.0, 65)) for segment in profile.segments]
    points = np.concatenate(outline)
    closing = np.array([[0.0, points[-1, 1]], [0.0, points[0, 1]]])
    polygon = np.concatenate([points, closing])
    x, z = polygon[:, 0], polygon[:, 1]
    area = 0.5 * float(np.sum(x * np.roll(z, -1) - np.roll(x, -1) * z))
    if abs(area) < 1e-9 * max(1.0, profile.length) ** 2:
        raise OptionError("cannot tell which side of the profile is material; give the material side (left or right)",
                          Location(program))
    # a clockwise outline (negative area, x across and z up) has its inside on the right
    return "right" if area < 0 else "left"
