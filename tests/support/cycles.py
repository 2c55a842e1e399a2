"""The one-way rule of FANUC's G71/G72 contours, checked on a program's text as the control checks it.

Written apart from the rewriter (postproc.compensate.monotone) so that a test of one is not a test
of the other with itself. The control reads the cycle from its block (G71 or G72 with P and Q),
its type from the contour's first block (the approach from the start point: G71 type I when it
moves X only, type II when it gives Z too; G72 the other way round), and alarms when the finishing
shape from the approach's end on runs back in an axis the type needs one way: Z and X for G71
type I, Z for type II; X and Z for G72 type I, X for type II (PS0064, PS0329). An arc runs back
in an axis when it passes the axis's extreme inside its sweep, by at least half an increment.
"""

from __future__ import annotations

import math
import re

from support.interpret import steps

CYCLE = re.compile(r"G0?7([12])(?![0-9.])")
WORD = re.compile(r"([A-Z])\s*([-+]?[0-9.]+)")
#: mm: half the least increment of a metric program (0.001 mm; X in a radius program, Z), and of
#: X in a diameter program (0.0005 mm as a radius); a turn back by less is none the control can
#: command (an arc's apex a hair past its end)
NOISE = {True: 0.00025, False: 0.0005}


def _words(text: str) -> dict[str, str]:
    code = re.sub(r"\([^)]*\)", "", text.upper())
    return {letter: value for letter, value in WORD.findall(code)}


def _values(move, axis: int) -> list[float]:
    """The axis's values over a move: its end, after any extreme an arc passes inside its sweep."""
    end = (move.x1, move.z1)[axis]
    if move.xc is None:
        return [end]
    a0 = math.atan2(move.z0 - move.zc, move.x0 - move.xc)
    a1 = math.atan2(move.z1 - move.zc, move.x1 - move.xc)
    r0 = math.hypot(move.x0 - move.xc, move.z0 - move.zc)
    r1 = math.hypot(move.x1 - move.xc, move.z1 - move.zc)
    # angle measured from X towards Z: a G02 (clockwise seen from +Y in the ZX plane) increases it
    sweep = (a1 - a0) % (2 * math.pi) if move.cw else -((a0 - a1) % (2 * math.pi))
    if sweep == 0.0:
        sweep = 2 * math.pi if move.cw else -2 * math.pi
    found = []
    for k in range(-8, 9):
        angle = k * math.pi / 2
        along = (angle - a0) / sweep
        if 0.0 < along < 1.0 and abs(along * sweep) > 1e-12 and abs((1 - along) * sweep) > 1e-12:
            r = r0 + along * (r1 - r0)
            found.append((along, (move.xc + r * math.cos(angle), move.zc + r * math.sin(angle))[axis]))
    return [value for _, value in sorted(found)] + [end]


def _cycles(program) -> list[tuple[str, str, list]]:
    """Each G71/G72 cycle of the interpreted program: '1' or '2', its type as the contour's first
    block tells ('I' or 'II'), and the contour's steps from that block to its Q block."""
    found = []
    for index, step in enumerate(program):
        words = _words(step.block.text)
        match = CYCLE.search(step.block.text.upper())
        if match is None or "P" not in words or "Q" not in words:
            continue
        p, q = int(float(words["P"])), int(float(words["Q"]))
        contour = []
        for later in program[index + 1 :] + program[:index]:  # after the cycle, or placed before it
            if not contour and later.block.label != p:
                continue
            contour.append(later)
            if later.block.label == q:
                break
        approach = set(_words(contour[0].block.text))
        across = {"Z", "W"} if match.group(1) == "1" else {"X", "U"}
        found.append((match.group(1), "II" if approach & across else "I", contour))
    return found


def cycle_types(text: str, **profile) -> list[str]:
    """The G71/G72 cycles of a program with their types, as the control reads them from the
    first block of each contour: ['G71 type I', ...]."""
    return [f"G7{cycle} type {kind}" for cycle, kind, _ in _cycles(steps(text, **profile))]


def turn_backs(text: str, **profile) -> list[str]:
    """Where a G71/G72 contour of the program runs back in an axis its type needs one way, as
    'line N: X' entries; empty when every such contour runs one way."""
    found = []
    noise = NOISE[profile.get("diameter_x", True)]
    for cycle, kind, contour in _cycles(steps(text, **profile)):
        cutting = 1 if cycle == "1" else 0  # G71 cuts along Z, G72 along X: that axis always runs one way
        axes = (0, 1) if kind == "I" else (cutting,)
        start = [m for m in contour[0].moves if m.kind in ("line", "rapid", "arc")][-1]
        shape = [(s.block.line, m) for s in contour[1:] for m in s.moves if m.kind in ("line", "rapid", "arc")]
        for axis in axes:
            values = [(value, line) for line, move in shape for value in _values(move, axis)]
            way, reached = 0, (start.x1, start.z1)[axis]  # which way the axis runs (0: not yet), how far it has gone
            for value, line in values:
                if way == 0:
                    if abs(value - reached) > noise:
                        way, reached = (1 if value > reached else -1), value
                elif (value - reached) * way < -noise:
                    found.append(f"line {line}: {'XZ'[axis]}")
                    break
                elif (value - reached) * way > 0:
                    reached = value
    return found


# ---------------------------------------------------------------------- generated contours

def contour_case(seed: int) -> dict:
    """A G71 or G72 cycle (type I or II) whose contour runs one way in X and Z, up or down each,
    in lines and arcs (some along an axis, some ending tangent to one: at the limit of running
    one way), with its program in diameter or radius, and a smooth correction of a few microns.

    Returns the program ``text``, the profile's ``diameter_x``, the per-piece ``correct``ion and
    what was drawn (``cycle``, ``type``)."""
    import numpy as np

    rng = np.random.default_rng(seed)
    cycle = int(rng.choice([71, 72]))
    kind = "I" if rng.random() < 0.6 else "II"
    diameter = bool(rng.random() < 0.7)
    sx, sz = int(rng.choice([1, -1])), int(rng.choice([1, -1]))
    window = (math.atan2(0.0, sx), math.atan2(sz, 0.0))  # directions whose travel is (sx, sz)-wards
    lo, hi = sorted(window)
    if hi - lo > math.pi:  # the quadrant straddles +-180 deg
        lo, hi = hi, lo + 2 * math.pi
    x = float(rng.uniform(3.0, 15.0)) if sx > 0 else float(rng.uniform(45.0, 60.0))
    z = float(rng.uniform(-5.0, 5.0))
    start_shape = (x, z)
    blocks = []
    for _ in range(int(rng.integers(2, 7))):
        if rng.random() < 0.45:  # a line, often along an axis
            choice = rng.random()
            psi = lo if choice < 0.25 else hi if choice < 0.5 else float(rng.uniform(lo, hi))
            length = float(rng.uniform(1.0, 8.0))
            x, z = x + length * math.cos(psi), z + length * math.sin(psi)
            blocks.append(("G01", x, z, None))
        else:  # an arc turning within the quadrant, often from or to an axis
            a, b = sorted(rng.uniform(lo, hi, 2).tolist())
            if rng.random() < 0.3:
                a = lo
            if rng.random() < 0.3:
                b = hi
            if b - a < math.radians(5.0):
                b = min(hi, a + math.radians(5.0))
                a = b - math.radians(5.0)
            psi0, psi1 = (a, b) if rng.random() < 0.5 else (b, a)
            turn = 1.0 if psi1 > psi0 else -1.0
            r = float(rng.uniform(2.0, 12.0))
            phi0, phi1 = psi0 - turn * math.pi / 2, psi1 - turn * math.pi / 2
            xc, zc = x - r * math.cos(phi0), z - r * math.sin(phi0)
            x, z = xc + r * math.cos(phi1), zc + r * math.sin(phi1)
            blocks.append(("G02" if turn > 0 else "G03", x, z, r))
    xs = [start_shape[0]] + [b[1] for b in blocks]
    zs = [start_shape[1]] + [b[2] for b in blocks]
    stock_x = (max(xs) + 2.0) if sx > 0 else (min(xs) - 2.0)  # the stock side: where X runs to
    stock_z = (min(zs) - 2.0) if sz > 0 else (max(zs) + 2.0)  # the side Z runs from
    scale = 2.0 if diameter else 1.0

    def number(value: float) -> str:
        return f"{round(value, 3) + 0.0:.3f}"

    if cycle == 71:
        start = (stock_x, start_shape[1] if kind == "I" else stock_z)
        approach = f"N10 G00 X{number(start_shape[0] * scale)}" + ("" if kind == "I" else f" Z{number(start_shape[1])}")
    else:
        start = (start_shape[0] if kind == "I" else stock_x, (max(zs) + 2.0) if sz < 0 else (min(zs) - 2.0))
        approach = f"N10 G00 Z{number(start_shape[1])}" + ("" if kind == "I" else f" X{number(start_shape[0] * scale)}")
    lines = ["G18 G21 G99", f"G00 X{number(start[0] * scale)} Z{number(start[1])}",
             f"G{cycle} {'U' if cycle == 71 else 'W'}1. R0.5",
             f"G{cycle} P10 Q20 U{0.2 * sx:.1f} W{0.1 * sz:.1f} F0.2", approach]
    for index, (code, bx, bz, r) in enumerate(blocks):
        label = "N20 " if index == len(blocks) - 1 else ""
        arc = "" if r is None else f" R{number(r)}"
        feed = " F0.1" if index == 0 else ""
        lines.append(f"{label}{code} X{number(bx * scale)} Z{number(bz)}{arc}{feed}")
    lines += ["G70 P10 Q20", "G00 X200. Z200.", "M30"]
    ax, kx, px = rng.uniform(-0.006, 0.006), rng.uniform(0.05, 1.2), rng.uniform(0, 2 * math.pi)
    az, kz, pz = rng.uniform(-0.006, 0.006), rng.uniform(0.05, 1.2), rng.uniform(0, 2 * math.pi)
    offset = rng.uniform(-0.003, 0.003, 2)

    def correct(piece):
        points = piece.points
        shift = np.column_stack([ax * np.sin(kx * points[:, 1] + px), az * np.sin(kz * points[:, 0] + pz)])
        return shift + offset

    return {"text": "\n".join(lines) + "\n", "diameter_x": diameter, "correct": correct,
            "cycle": f"G{cycle} type {kind}"}
