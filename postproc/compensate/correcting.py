"""Correcting: each move split into pieces where an axis reverses, the pieces of a batch of steps
corrected in one call, and the targets the corrections make.

One phase of :class:`~postproc.compensate.rewrite.Rewriter`, as the interpreter keeps each of its
phases in a module of its own: the methods here work on the Rewriter's state and hold none of
their own."""

from __future__ import annotations

import math
from itertools import accumulate

import numpy as np

from ..diagnostics import Location, SafetyError
from ..geometry import QUADRANTS, Arc, Line, Segment, reversal_params_of, segment_of
from ..interpret.motion import ARC, CONTOUR, CORNER, LINE, RAPID, RUN, Move, Step
from . import monotone
from .compensator import Piece
from .edits import ALONG, Edit, Entry
from .segmenter import Target, measure_bends, sample_params

STEPS = (0.0005, 0.001)  #: the output grid's x and z steps (radius mm) of a metric diameter program
_TRAVELLED = (LINE, ARC, RAPID)  #: the kinds of move whose travel :func:`travel_after` follows
_QUARTER_TURNS = np.array(QUADRANTS) * (math.pi / 2)  #: where an axis of a circle reverses, radians


def sample_lines(parts: list[Piece]) -> None:
    """Sample the points of every straight piece in one array pass (``Line.point_at``'s
    arithmetic, point for point): a program of short lines has thousands of them."""
    straight = [piece for piece in parts if type(piece.segment) is Line and "points" not in piece.__dict__]
    if not straight:
        return
    counts = [len(piece.t) for piece in straight]
    ends = np.array([(piece.segment.x0, piece.segment.z0, piece.segment.x1, piece.segment.z1) for piece in straight])
    start = np.repeat(ends[:, :2], counts, axis=0)
    delta = np.repeat(ends[:, 2:] - ends[:, :2], counts, axis=0)  # x1 - x0, z1 - z0: the same subtractions
    _hand_out(straight, counts, start + np.concatenate([piece.t for piece in straight])[:, None] * delta)


def sample_arcs(parts: list[Piece]) -> None:
    """Sample the points of every arc piece in one array pass (``Arc.point_at``'s arithmetic,
    point for point, a spiral's radius drifting with the parameter): a CAM program has
    thousands of short arcs, and numpy called per arc was most of their cost."""
    arcs = [piece for piece in parts if type(piece.segment) is Arc and "points" not in piece.__dict__]
    if not arcs:
        return
    counts = [len(piece.t) for piece in arcs]
    segments = [piece.segment for piece in arcs]
    t = np.concatenate([piece.t for piece in arcs])
    theta0, sweep, r, drift, xc, zc = np.repeat(np.array(
        [(arc.theta0, arc.sweep, arc.r, 0.0 if arc.r1 is None else arc.r1 - arc.r, arc.xc, arc.zc) for arc in segments]),
        counts, axis=0).T
    theta = theta0 + t * sweep
    radius = r + t * drift  # radius_at's: r + 0.0 is r on a circle
    points = np.empty((len(t), 2))
    points[:, 0] = xc + radius * np.cos(theta)
    points[:, 1] = zc + radius * np.sin(theta)
    _hand_out(arcs, counts, points)


def _hand_out(pieces: list[Piece], counts: list[int], points: np.ndarray) -> None:
    """Give each piece its rows of the points sampled for them all (read-only), as its
    ``points`` cached property would compute them."""
    points.setflags(write=False)
    first = 0
    for piece, count in zip(pieces, counts):
        piece.__dict__["points"] = points[first : first + count]
        first += count


def _travel(dx: float, dz: float, last: tuple[int, int], steps: tuple[float, float]) -> tuple[int, int]:
    """Which way each axis runs over a piece that moves it by (dx, dz): the sign of that travel,
    or the way the axis last ran when it travels less than half a step of the output grid
    (an axis the control does not move keeps its backlash where it was; so does one that
    only wanders by less, as an arc does about an apex it barely passes)."""
    x = (dx > 0.0) - (dx < 0.0) if abs(dx) >= steps[0] / 2.0 else last[0]
    z = (dz > 0.0) - (dz < 0.0) if abs(dz) >= steps[1] / 2.0 else last[1]
    return x, z


def pieces(move: Move, last: tuple[int, int] = (0, 0), steps: tuple[float, float] = STEPS,
           turns: list[float] | None = None, segment: Segment | None = None) -> list[Piece]:
    """A move split where an axis reverses, so direction-dependent corrections act per side.

    ``last`` is the direction each axis last travelled in before the move; ``steps`` the
    output grid's steps in x and z (radius mm). Only reversals the grid can see count
    (:func:`_turns`; ``turns``: what it gives for an arc move, when already worked out;
    ``segment``: the move's :func:`segment_of`, likewise).
    """
    if segment is None:
        segment = segment_of(move)
    if isinstance(segment, Line):
        bounds = [0.0, 1.0]
    else:
        bounds = [0.0, *(_turns(segment, steps) if turns is None else turns), 1.0]
    result = []
    for a, b in zip(bounds, bounds[1:]):
        if isinstance(segment, Line) or (len(bounds) == 2 and segment.r1 is None):
            part = segment  # the whole move: part(0, 1) would be the same arc
        else:
            part = _part(segment, a, b)
        (x0, z0), (x1, z1) = part.start, part.end
        last = _travel(x1 - x0, z1 - z0, last, steps)
        result.append(Piece(move, part, sample_params(part), *last))
    return result


def _part(arc: Arc, a: float, b: float) -> Arc:
    """``arc.part(a, b)``, the same floats: its radii worked out with floats rather than through
    ``radius_at``'s arrays (one multiplication and one addition either way)."""
    r, r1 = arc.r, arc.r1
    if r1 is None:
        return Arc(arc.xc, arc.zc, r, arc.theta0 + a * arc.sweep, (b - a) * arc.sweep)
    return Arc(arc.xc, arc.zc, r + a * (r1 - r), arc.theta0 + a * arc.sweep, (b - a) * arc.sweep, r + b * (r1 - r))


def _turns(arc: Arc, steps: tuple[float, float], found: list[float] | None = None) -> list[float]:
    """The parameters where an axis of the arc reverses, as far as the output grid can see.

    A reversal counts when the axis travels at least half a grid step on either side of it
    (up to the arc's ends or the axis's next reversal) and leaves a piece of at least one
    step each way. Less is below what the control commands: an R arc whose end lies a hair
    past an apex (its centre, worked out from R, sits nanometres off the end's axis) turns
    the axis back by picometres, and a piece that short has no block of its own.

    ``found``: the arc's :meth:`Arc.reversal_params`, when already worked out.
    """
    if found is None:
        found = arc.reversal_params()
    if not found:
        return found
    length = arc.length
    shortest = max(steps) / length if length > 0.0 else math.inf
    theta0, sweep, r, r1 = arc.theta0, arc.sweep, arc.r, arc.r1
    kept: list[float] = []
    previous = 0.0
    for index, t in enumerate(found):
        theta = theta0 + t * sweep
        axis = 0 if abs(math.sin(theta)) < 0.5 else 1  # x turns where sin(theta) = 0, z where cos(theta) = 0
        same = [u for u in found if u != t and (abs(math.sin(theta0 + u * sweep)) < 0.5) == (axis == 0)]
        before = max([u for u in same if u < t], default=0.0)
        after = min([u for u in same if u > t], default=1.0)
        cosine_or_sine = (math.cos, math.sin)[axis]

        def value(u: float) -> float:  # the axis about the centre at parameter u, the radius drifting on a spiral
            return cosine_or_sine(theta0 + u * sweep) * (r if r1 is None else r + u * (r1 - r))  # arc.radius_at(u)

        here = value(t)
        travel = min(abs(here - value(before)), abs(value(after) - here))
        following = found[index + 1] if index + 1 < len(found) else 1.0
        if travel >= steps[axis] / 2.0 and t - previous >= shortest and following - t >= shortest:
            kept.append(t)
            previous = t
    return kept


def travel_after(move: Move, last: tuple[int, int], steps: tuple[float, float] = STEPS,
                 turns: list[float] | None = None, arc: Arc | None = None) -> tuple[int, int]:
    """The direction each axis last travelled in, once ``move`` has run: an arc's is that of
    its last piece (as :func:`pieces` splits it; ``turns`` as there, ``arc`` its ``segment``).

    Worked out with floats, not the geometry's arrays: it runs for every move of the
    program, compensated or not."""
    if not move.known or move.kind not in (LINE, ARC, RAPID) or not move.exact:
        return (0, 0) if not move.known else last
    if move.xc is None:
        return _travel(move.x1 - move.x0, move.z1 - move.z0, last, steps)
    if (move.x0, move.z0) == (move.xc, move.zc) == (move.x1, move.z1):
        return last
    if arc is None:
        arc = segment_of(move)
    if arc.sweep == 0.0:
        return last
    if turns is None:
        turns = _turns(arc, steps)
    (x0, z0) = _part(arc, turns[-1], 1.0).start if turns else (move.x0, move.z0)
    return _travel(move.x1 - x0, move.z1 - z0, last, steps)


class Correcting:
    """Correcting, mixed into :class:`~postproc.compensate.rewrite.Rewriter`."""

    def _candidate(self, step: Step, move: Move) -> bool:
        return (
            step.interpreted
            and not step.shared
            and move.kind in (LINE, ARC)
            and move.exact
            and move.known
            and (move.kind == ARC or (move.x0, move.z0) != (move.x1, move.z1))  # a line of no length: nothing to move
            and move.role in (RUN, CONTOUR, CORNER)
            and step.block.delete is None
            and not (step.contour_start and step.cycle in monotone.ONE_WAY_CYCLES)  # the approach: it meets the shape
            and self.selects(step, move)
        )

    def _correct(self, batch: list[Entry]) -> None:
        """Give each motion step of the batch its edits (None for a move left as it is).

        The per-move work is :meth:`_candidate`, :func:`pieces` and :func:`travel_after`,
        written out for the moves a CAM program is made of: an arc's geometry and turns are
        worked out once for the batch (:meth:`_arcs_of`), a candidate line is one piece whose
        travel is the axis directions after it."""
        motions = [entry for entry in batch if entry.motion]
        if not motions:
            return
        arcs = self._arcs_of(motions)
        wanted: list[tuple[Entry, int, list[Piece]]] = []
        last = self._last_travel
        selects = self.selects
        for entry in motions:
            step = entry.step
            moves = step.moves
            entry.edits = [None] * len(moves)
            steps = self._steps(step)
            open_ = (step.interpreted and not step.shared and step.block.delete is None
                     and not (step.contour_start and step.cycle in monotone.ONE_WAY_CYCLES))
            for index, move in enumerate(moves):
                if move.role not in ALONG:
                    continue
                kind = move.kind
                if move.xc is None and move.exact and kind in _TRAVELLED and move.known:  # a line
                    after = _travel(move.x1 - move.x0, move.z1 - move.z0, last, steps)  # travel_after's
                    if (open_ and kind != RAPID and (kind == ARC or (move.x0, move.z0) != (move.x1, move.z1))
                            and selects(step, move)):  # _candidate's
                        segment = Line(move.x0, move.z0, move.x1, move.z1)  # pieces': one, moving as it leaves
                        wanted.append((entry, index, [Piece(move, segment, sample_params(segment), *after)]))
                    last = after
                    continue
                segment, turns = arcs.get(id(move), (None, None))
                if open_ and kind in (LINE, ARC) and move.exact and move.known and selects(step, move):
                    wanted.append((entry, index, pieces(move, last, steps, turns, segment)))
                last = travel_after(move, last, steps, turns, segment)
        self._last_travel = last
        if wanted:
            self._edits(wanted)

    def _edits(self, wanted: list[tuple[Entry, int, list[Piece]]]) -> None:
        """The corrections of the wanted moves' pieces, in one call, and the edits they make."""
        every = [piece for _, _, parts in wanted for piece in parts]
        sample_lines(every)
        sample_arcs(every)
        shifts = self.corrector(every)
        given = [shift for shift in shifts if shift is not None]
        if not given:
            return
        rows = [len(piece.t) for piece in every]
        bounds = list(accumulate(rows, initial=0))  # piece i's rows: bounds[i]:bounds[i + 1]
        # the largest correction of each corrected piece, and every target's points, in one pass each
        joined = np.concatenate(given) if len(given) > 1 else given[0]
        starts = np.cumsum([0] + [len(shift) for shift in given[:-1]])
        sizes = iter(np.maximum.reduceat(np.hypot(joined[:, 0], joined[:, 1]), starts).tolist())
        if len(given) == len(shifts):  # every piece corrected, as a model of the machine corrects them
            wanted_d = shifts
        else:
            wanted_d = [np.zeros((n, 2)) if shift is None else shift for shift, n in zip(shifts, rows)]
            joined = np.concatenate(wanted_d)
        points = np.concatenate([piece.points for piece in every]) + joined
        limit = self.max_correction
        first = 0
        lines: list[Target] = []  # the straight targets, for measure_bends
        for entry, index, parts in wanted:
            last = first + len(parts)
            largest = -1.0  # no piece corrected
            for i in range(first, last):
                if shifts[i] is not None:
                    size = next(sizes)
                    if size > limit and entry.refusal is None:  # raised in program order
                        entry.refusal = SafetyError(f"a correction of {size:.4f} mm exceeds the maximum correction "
                                                    f"{limit:g} mm (--max-correction)",
                                                    Location(self.file, parts[i - first].move.line))
                    if size > largest:
                        largest = size
            if largest <= 0.0:  # none corrected, or none moved
                first = last
                continue
            if entry.kept or (entry.step.block.fields is None and self._macro_kept(entry)):
                first = last
                continue  # left as it is: its correction is not applied (a canonical block reads no macro variable)
            if largest > self.largest:
                self.largest = largest
            targets = []
            for i, piece in enumerate(parts, first):
                target = Target(piece.segment, piece.t, wanted_d[i])
                target.__dict__["points"] = points[bounds[i] : bounds[i + 1]]  # Target.along's, in one pass
                targets.append(target)
            first = last
            if len(targets) > 1:
                targets = _merge_continuous(targets, self._tolerance(entry.step) / 10.0)
            entry.edits[index] = Edit(parts[0].move, targets)
            if type(targets[0].nominal) is Line:
                lines.append(targets[0])
        measure_bends(lines)

    def _arcs_of(self, motions: list[Entry]) -> dict[int, tuple[Arc, list[float]]]:
        """The arc of every arc move of the batch's motion steps and its :func:`_turns` (by ``id``
        of the move), their reversal parameters found in one array pass: :func:`pieces` and
        :func:`travel_after` both need them, for every arc of the program. An arc whose every
        reversal lies where :func:`_turns` cannot keep it (:func:`_unseen_turns`) has none, its
        reversal parameters left unworked."""
        arcs: list[Arc] = []
        owners: list[tuple[Move, tuple[float, float]]] = []
        for entry in motions:
            steps = self._steps(entry.step)
            for move in entry.step.moves:
                if move.kind == ARC and move.xc is not None and move.known and move.exact:
                    arcs.append(segment_of(move))
                    owners.append((move, steps))
        if not arcs:
            return {}
        unseen = _unseen_turns(arcs, np.array([steps for _, steps in owners])).tolist()
        seen = iter(reversal_params_of([arc for arc, none in zip(arcs, unseen) if not none]))
        return {id(move): (arc, [] if none else _turns(arc, steps, next(seen)))
                for (move, steps), arc, none in zip(owners, arcs, unseen)}


def _unseen_turns(arcs: list[Arc], steps: np.ndarray) -> np.ndarray:
    """Whether each arc's reversals all lie where :func:`_turns` keeps none of them (``steps``:
    each arc's grid steps in x and z, mm, one row per arc): worked out for all the arcs in one
    array pass from bounds on where the reversals lie, False where the bounds cannot tell.

    A spiral moves an axis's apex off its quarter turn by ``atan(dr / (r |sweep|))`` along the
    sweep: the way its radius drifts, never further than ``|dr| / (r |sweep|)``
    (``reversal_params_of``'s reach; a micro-radian to spare either way). ``_turns`` keeps no reversal within one grid step of
    either end (in parameter, ``step / length``), nor one the axis reaches from the end (or
    leaves towards it) by less than half a step: the tool travels at most
    ``|sweep| r_max + |dr|`` per unit of parameter, so nearer than that half step over this
    speed no axis travels enough. A CAM program's arcs start on an axis (I or K zero) and their
    radii drift by the rounding of the end point: each such arc has a reversal picometres past
    its start, which no output grid sees."""
    theta0 = np.array([arc.theta0 for arc in arcs])
    sweep = np.array([arc.sweep for arc in arcs])
    r = np.array([arc.r for arc in arcs])
    end = np.array([arc.end_radius for arc in arcs])
    span = np.abs(sweep)
    drift = np.abs(end - r)
    smallest = np.minimum(r, end)
    length = span * (r + end) / 2.0  # Arc.length
    speed = span * np.maximum(r, end) + drift
    margin = 1e-9  # a parameter's rounding (to 12 places) and the arithmetic, with room to spare
    sign = np.where(sweep >= 0, 1.0, -1.0)
    along = np.remainder(sign[:, None] * (_QUARTER_TURNS[None, :] - theta0[:, None]), math.tau)
    with np.errstate(all="ignore"):  # no sweep, no radius, no length: an infinite reach, an empty stretch
        reach = drift / (smallest * span)
        reach = np.where(np.isfinite(reach) & (smallest > 0.0), reach, math.inf)
        back = np.where(end < r, reach, 0.0)[:, None] + 1e-6  # a shrinking radius: the apex comes earlier
        ahead = np.where(end > r, reach, 0.0)[:, None] + 1e-6
        shortest = np.where(length > 0.0, steps.max(axis=1) / length, math.inf)
        travel = np.where(speed > 0.0, steps.min(axis=1) / 2.0 * (1.0 - 1e-6) / speed, math.inf)
        edge = np.maximum(shortest, travel) - margin  # in parameter, from either end
        low = (edge * span)[:, None]  # along the sweep, below it: too near the start
        high = ((1.0 - edge) * span)[:, None]  # above it: too near the end
        bottom, top = along - back, along + ahead
        near_start = (top < low) & ((bottom >= 0.0) | (bottom + math.tau > high))
        near_end = (bottom > high) & ((top <= math.tau) | (top - math.tau < low))
    return (near_start | near_end).all(axis=1) | (span == 0.0)


def _merge_continuous(targets: list[Target], gap: float) -> list[Target]:
    """Pieces of one arc whose corrections meet are planned as one target."""
    merged = [targets[0]]
    for target in targets[1:]:
        last = merged[-1]
        if (
            isinstance(last.nominal, Arc)
            and isinstance(target.nominal, Arc)
            and math.dist(last.end, target.start) <= gap
        ):
            a, b = last.nominal, target.nominal
            end = b.end_radius
            whole = Arc(a.xc, a.zc, a.r, a.theta0, a.sweep + b.sweep, None if abs(end - a.r) < 1e-12 else end)
            share = a.sweep / whole.sweep
            t = np.concatenate([last.t * share, share + target.t[1:] * (1 - share)])
            d = np.concatenate([last.d, target.d[1:]])
            merged[-1] = Target(whole, t, d)
        else:
            merged.append(target)
    return merged
