"""Differential-test support: run LinuxCNC's standalone interpreter ``rs274``.

``rs274`` comes from the Debian bookworm package ``linuxcnc-uspace``
(``apt-get install -y --no-install-recommends linuxcnc-uspace``).  It needs no
display, no HAL and no realtime: ``rs274 -g prog.ngc`` interprets the program in
batch mode and prints one canonical machining call per line on stdout, e.g.::

       10 N..... STRAIGHT_TRAVERSE(0.0000, 0.0000, 57.1500, 0.0000, 0.0000, 0.0000)
       12 N20    STRAIGHT_FEED(10.7500, 0.0000, -1.0000, 0.0000, 0.0000, 0.0000)
       13 N..... ARC_FEED(0.0000, 57.1500, 0.0000, 0.0000, 1, 0.0000, 0.0000, 0.0000, 0.0000)

* STRAIGHT_TRAVERSE / STRAIGHT_FEED(x, y, z, a, b, c)
* ARC_FEED(first_end, second_end, first_axis, second_axis, rotation,
  axis_end_point, a, b, c).  In the XZ plane (G18) the first axis is Z and
  the second is X: ARC_FEED(z_end, x_end, z_centre, x_centre, rot, y_end, ...).
  rotation = +1 for G3 (counter-clockwise seen from +Y), -1 for G2.
* Lengths are in the *current program units* (inches after G20) with exactly
  4 decimals (0.0001 mm, or 0.0001 in = 2.54 um after G20: compare with a
  tolerance); in G7 (diameter mode) X is already reported as a radius.
* The dummy machine starts at X0 Y0 Z0.
* On an error rs274 prints the message and the offending line on stderr and
  exits with status 1 (stderr always starts with a line ``executing``).

Conventions of this project (docs/methods.md §2): radius coordinates
x = X/2, z = Z, millimetres; theta about a centre: x = xc + r cos(theta),
z = zc + r sin(theta); G02 = clockwise seen from +Y = theta increasing ('cw'),
G03 = theta decreasing ('ccw').  LinuxCNC's G18 G2/G3 are the same physical
arcs as FANUC lathe G02/G03 (both are defined as seen from +Y), so no
direction swap is needed; rotation -1 -> 'cw', +1 -> 'ccw'.

Standard library only.
"""

from __future__ import annotations

import functools
import math
import os
import re
import shutil
import subprocess
import tempfile
from dataclasses import dataclass, field
from decimal import Decimal, InvalidOperation

__all__ = [
    "Move",
    "RS274Error",
    "rs274_available",
    "run_rs274",
    "parse_canon",
    "to_linuxcnc",
    "arc_sweep_deg",
]

MM_PER_INCH = 25.4


@dataclass(frozen=True)
class Move:
    """One motion in radius coordinates, millimetres, XZ plane.

    ``kind`` is 'rapid', 'line' or 'arc'; centre and ``direction`` ('cw' for
    FANUC G02 = theta increasing, 'ccw' for G03 = theta decreasing) only for
    arcs.  An arc whose end equals its start is a full circle.  ``line`` is
    the N number rs274 printed for the block (``to_linuxcnc`` numbers blocks
    with their 1-based source line); it does not take part in equality.
    """

    kind: str
    x_start: float
    z_start: float
    x_end: float
    z_end: float
    x_center: float | None = None
    z_center: float | None = None
    direction: str | None = None
    line: int | None = field(default=None, compare=False)


class RS274Error(RuntimeError):
    """rs274 failed or reported an interpreter error."""

    def __init__(self, message: str, *, stderr: str = "", stdout: str = "",
                 returncode: int | None = None, program: str = ""):
        super().__init__(message)
        self.stderr = stderr
        self.stdout = stdout
        self.returncode = returncode
        self.program = program


# --------------------------------------------------------------------------
# running rs274


def _rs274_path() -> str | None:
    env = os.environ.get("RS274")
    if env:
        return env if os.access(env, os.X_OK) else None
    return shutil.which("rs274") or (
        "/usr/bin/rs274" if os.access("/usr/bin/rs274", os.X_OK) else None)


@functools.lru_cache(maxsize=1)
def rs274_available() -> bool:
    """True when an ``rs274`` binary is found and interprets a trivial program."""
    exe = _rs274_path()
    if exe is None:
        return False
    try:
        with tempfile.TemporaryDirectory(prefix="rs274_probe_") as tmp:
            prog = os.path.join(tmp, "probe.ngc")
            with open(prog, "w", encoding="ascii") as fh:
                fh.write("G21 G18 G7\nG0 X2 Z1\nM2\n")
            proc = subprocess.run([exe, "-g", prog], cwd=tmp, stdin=subprocess.DEVNULL,
                                  capture_output=True, text=True, timeout=20)
        return proc.returncode == 0 and "STRAIGHT_TRAVERSE(1.0000" in proc.stdout
    except (OSError, subprocess.SubprocessError):
        return False


def run_rs274(gcode_text: str, *, arc_tolerance_mm: float | None = None,
              timeout: float = 60.0) -> list[Move]:
    """Interpret LinuxCNC G-code with rs274 and return its XZ moves.

    ``gcode_text`` is LinuxCNC syntax (see ``to_linuxcnc`` for FANUC input) and
    must end the program (M2/M30/%).  ``arc_tolerance_mm`` sets
    ``[RS274NGC] CENTER_ARC_RADIUS_TOLERANCE_MM`` through a generated INI file
    (default 0.0283 mm, minimum 0.001; LinuxCNC rejects an I/K arc only when
    |r_end - r_start| exceeds this AND 0.1 % of the radius, or exceeds 100x this).
    Raises RS274Error with rs274's stderr when rs274 reports an error.
    """
    exe = _rs274_path()
    if exe is None:
        raise RS274Error("rs274 not found (apt-get install linuxcnc-uspace)")
    with tempfile.TemporaryDirectory(prefix="rs274_") as tmp:
        prog = os.path.join(tmp, "program.ngc")
        text = gcode_text if gcode_text.endswith("\n") else gcode_text + "\n"
        with open(prog, "w", encoding="utf-8") as fh:
            fh.write(text)
        cmd = [exe]
        if arc_tolerance_mm is not None:
            # LinuxCNC refuses values below 0.001 mm / 0.00004 in (MIN_CENTER_ARC_...)
            tol = float(arc_tolerance_mm)
            if not tol >= 0.001:
                raise ValueError("arc_tolerance_mm must be >= 0.001 (LinuxCNC's minimum)")
            ini = os.path.join(tmp, "rs274.ini")
            with open(ini, "w", encoding="ascii") as fh:
                fh.write("[RS274NGC]\n")
                fh.write(f"CENTER_ARC_RADIUS_TOLERANCE_MM = {tol:.6f}\n")
                fh.write(f"CENTER_ARC_RADIUS_TOLERANCE_INCH = "
                         f"{max(tol / MM_PER_INCH, 0.00004):.8f}\n")
            cmd += ["-i", ini]
        cmd += ["-g", prog]
        try:
            proc = subprocess.run(cmd, cwd=tmp, stdin=subprocess.DEVNULL,
                                  capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired as exc:
            raise RS274Error(f"rs274 timed out after {timeout} s", program=text,
                             stdout=exc.stdout or "", stderr=exc.stderr or "") from exc
    stderr = "\n".join(l for l in proc.stderr.splitlines() if l.strip() != "executing")
    if proc.returncode != 0:
        raise RS274Error(f"rs274 exited with status {proc.returncode}: {stderr.strip()}",
                         stderr=proc.stderr, stdout=proc.stdout,
                         returncode=proc.returncode, program=text)
    return parse_canon(proc.stdout)


# --------------------------------------------------------------------------
# parsing rs274's canonical output

_CANON_LINE = re.compile(
    r"^\s*\d+\s+N(?:\.\.\.\.\.|(?P<n>\d*))\s*(?P<fn>[A-Z_][A-Z0-9_]*)\((?P<args>.*)\)\s*$")
_MOTION_UNSUPPORTED = {
    "STRAIGHT_PROBE", "RIGID_TAP", "NURBS_FEED", "NURBS_G5_FEED", "NURBS_G6_FEED",
    "SPLINE_FEED",
}


def _floats(args: str) -> list[float]:
    return [float(a) + 0.0 for a in args.split(",")]  # + 0.0 turns -0.0 into 0.0


def _mm(value: float, scale: float) -> float:
    # rs274 prints 4 decimals; rounding to 1e-9 mm only removes float noise of the inch scaling
    return round(value * scale, 9) + 0.0


def parse_canon(output: str) -> list[Move]:
    """Turn rs274's stdout into Moves (radius, mm, XZ), start point from the previous move.

    Tracks USE_LENGTH_UNITS (inch output is scaled by 25.4) and SELECT_PLANE
    (an ARC_FEED outside the XZ plane raises RS274Error).  The first move
    starts at x = z = 0 like rs274's dummy machine.
    """
    moves: list[Move] = []
    scale = 1.0
    plane = "XY"
    x = z = 0.0
    for raw in output.splitlines():
        m = _CANON_LINE.match(raw)
        if not m:
            continue
        fn, args = m.group("fn"), m.group("args")
        n = int(m.group("n")) if m.group("n") else None
        if fn == "USE_LENGTH_UNITS":
            if args == "CANON_UNITS_MM":
                scale = 1.0
            elif args == "CANON_UNITS_INCHES":
                scale = MM_PER_INCH
            else:
                raise RS274Error(f"unsupported length units in rs274 output: {raw.strip()}")
        elif fn == "SELECT_PLANE":
            plane = args.replace("CANON_PLANE_", "")
        elif fn in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED"):
            v = _floats(args)
            nx, nz = _mm(v[0], scale), _mm(v[2], scale)
            kind = "rapid" if fn == "STRAIGHT_TRAVERSE" else "line"
            moves.append(Move(kind, x, z, nx, nz, line=n))
            x, z = nx, nz
        elif fn == "ARC_FEED":
            v = _floats(args)
            if plane != "XZ":
                raise RS274Error(f"ARC_FEED in plane {plane}, only XZ (G18) is supported: "
                                 f"{raw.strip()}")
            z_end, x_end, z_c, x_c = (_mm(a, scale) for a in v[:4])
            rotation = int(v[4])
            if abs(rotation) != 1:
                raise RS274Error(f"multi-turn arc (rotation {rotation}) not representable: "
                                 f"{raw.strip()}")
            direction = "cw" if rotation < 0 else "ccw"
            moves.append(Move("arc", x, z, x_end, z_end, x_c, z_c, direction, line=n))
            x, z = x_end, z_end
        elif fn in _MOTION_UNSUPPORTED:
            raise RS274Error(f"unsupported motion in rs274 output: {raw.strip()}")
    return moves


def arc_sweep_deg(move: Move) -> float:
    """Signed theta sweep of an arc in degrees: + for 'cw' (theta increasing), - for 'ccw'.

    theta = atan2(z - zc, x - xc) (0 deg = +X, 90 deg = +Z); start == end is a full circle.
    """
    if move.kind != "arc":
        raise ValueError("not an arc")
    t0 = math.atan2(move.z_start - move.z_center, move.x_start - move.x_center)
    t1 = math.atan2(move.z_end - move.z_center, move.x_end - move.x_center)
    d = math.degrees(t1 - t0) % 360.0
    if move.direction == "cw":
        return d if d > 1e-9 else 360.0
    d = 360.0 - d if d > 1e-9 else 360.0
    return -d


# --------------------------------------------------------------------------
# FANUC lathe -> LinuxCNC

_WORD = re.compile(r"([A-Z])([+-]?(?:\d+\.?\d*|\.\d+))")
_LENGTH_ADDRESSES = set("XZUWIKR")
_DROPPED_G = {18, 40, 54, 80, 96, 97, 98, 99}   # no effect on the XZ path here
_DROPPED_M = {0, 1, 3, 4, 5, 8, 9, 41, 42, 43, 44}   # M41-M44: spindle gear range
_END_M = {2, 30}


def _fmt(d: Decimal) -> str:
    s = format(d, "f")
    if "." in s:
        s = s.rstrip("0").rstrip(".")
    if s in ("-0", ""):
        s = "0"
    return s


def _strip_comments(line: str, lineno: int) -> str:
    out, depth = [], 0
    for ch in line:
        if ch == "(":
            depth += 1
        elif ch == ")":
            if depth == 0:
                raise ValueError(f"line {lineno}: unbalanced ')': {line!r}")
            depth -= 1
        elif depth == 0:
            out.append(ch)
    if depth:
        raise ValueError(f"line {lineno}: unclosed comment: {line!r}")
    return "".join(out)


def to_linuxcnc(fanuc_program: str, *, units: str = "mm", gcode_system: str = "A",
                decimal_point: str = "fanuc", ignore_tool_words: bool = False) -> str:
    """Translate a FANUC lathe program of a small common subset to LinuxCNC G-code.

    Accepted: ``%`` lines (with any label after the ``%``) and O headers (dropped), comments (dropped), N words
    (replaced by the 1-based source line number so rs274's output names the
    source line), ``;`` as end of block (a line may hold several blocks),
    G00-G03, G04 (block dropped), G20/G21, X/Z absolute (X diameter), U/W
    incremental (U diameter) in G-code system A, G90/G91 absolute/incremental
    in systems B/C, I/K (incremental, radius) and R (negative = more than
    180 deg; R wins over I/K as on FANUC), F/S (dropped: a fixed F1000 is set
    so arcs never lack a feed), M00/M01/M03-M05/M08/M09 and the gear ranges
    M41-M44 (dropped), M02/M30
    (end; the rest is ignored), G18/G40/G54/G80/G96-G99 and G50 S.. (no path
    effect, dropped).
    T words raise unless ``ignore_tool_words`` (offsets are then taken as zero).

    Output: ``G18 G7 G90 G91.1 G40 G94 G21|G20 F1000``, one block per motion
    with the motion code and absolute X (diameter) and Z always written, and M2.
    All coordinates are made absolute here (LinuxCNC's U/W are axes, not
    increments); the start point is X0 Z0 like rs274's.

    ``decimal_point``: 'fanuc' (default) reads a length without a decimal point
    as least input increments, X10 = 0.010 mm (G21) or 0.0010 in (G20);
    'calculator' reads X10 as 10 mm/in.  ``units`` is the unit before any
    G20/G21 ('mm' or 'inch').  Anything else raises ValueError naming the line.
    """
    if units not in ("mm", "inch"):
        raise ValueError("units must be 'mm' or 'inch'")
    if gcode_system not in ("A", "B", "C"):
        raise ValueError("gcode_system must be 'A', 'B' or 'C'")
    if decimal_point not in ("fanuc", "calculator"):
        raise ValueError("decimal_point must be 'fanuc' or 'calculator'")

    inch = units == "inch"
    unit_word = "G20" if inch else "G21"
    out = [f"G18 G7 G90 G91.1 G40 G94 {unit_word} F1000"]
    motion: int | None = None
    incremental = False          # systems B/C: G91
    x = z = Decimal(0)           # current X (diameter) and Z in program units
    moved = False
    ended = False

    text = fanuc_program.replace("\r\n", "\n").replace("\r", "\n")
    for lineno, raw in enumerate(text.split("\n"), start=1):
        if ended:
            break
        stripped = raw.strip()
        if not stripped:
            continue
        if stripped.startswith("%"):  # a tape mark; what follows it on its line is a label the control skips
            continue
        body = _strip_comments(stripped, lineno)
        for block in body.split(";"):
            block = "".join(block.split()).upper()
            if not block:
                continue
            where = f"line {lineno}: {raw.strip()!r}"
            if re.fullmatch(r"O\d+", block):
                continue
            pos, words = 0, []
            for m in _WORD.finditer(block):
                if m.start() != pos:
                    break
                words.append((m.group(1), m.group(2)))
                pos = m.end()
            if pos != len(block):
                raise ValueError(f"{where}: outside the supported subset at {block[pos:]!r}")

            gs: list[int] = []
            ms: list[int] = []
            vals: dict[str, Decimal] = {}
            raw_vals: dict[str, str] = {}
            for letter, num in words:
                if letter in ("G", "M"):
                    try:
                        d = Decimal(num)
                    except InvalidOperation as exc:  # pragma: no cover - regex guards
                        raise ValueError(f"{where}: bad number {num!r}") from exc
                    if d != d.to_integral_value():
                        raise ValueError(f"{where}: {letter}{num} not supported")
                    (gs if letter == "G" else ms).append(int(d))
                    continue
                if letter in raw_vals:
                    raise ValueError(f"{where}: address {letter} twice in a block")
                raw_vals[letter] = num
                vals[letter] = Decimal(num)

            if 4 in gs:                      # dwell: X/U/P are times, no motion
                if len(gs) > 1 or ms:
                    raise ValueError(f"{where}: G04 combined with other codes")
                continue
            if 50 in gs:                     # G50 S..: spindle speed clamp only
                if len(gs) > 1 or ms or set(raw_vals) - {"N", "S"}:
                    raise ValueError(f"{where}: G50 is only supported as a speed clamp (G50 S..)")
                continue

            new_motion = None
            for g in gs:
                if g in (0, 1, 2, 3):
                    if new_motion is not None:
                        raise ValueError(f"{where}: two motion codes in a block")
                    new_motion = g
                elif g in (20, 21):
                    want_inch = g == 20
                    if want_inch != inch and moved:
                        raise ValueError(f"{where}: G20/G21 change after motion not supported")
                    inch = want_inch
                    out.append(f"N{lineno} G{g}")
                elif g in (90, 91) and gcode_system in ("B", "C"):
                    incremental = g == 91
                elif g in (90, 91):
                    raise ValueError(f"{where}: G{g} is a turning cycle in G-code system A "
                                     "(not supported); pass gcode_system='B' for G90/G91 "
                                     "absolute/incremental")
                elif g in _DROPPED_G:
                    pass
                else:
                    raise ValueError(f"{where}: G{g:02d} not supported")
            for mcode in ms:
                if mcode in _END_M:
                    ended = True
                elif mcode not in _DROPPED_M:
                    raise ValueError(f"{where}: M{mcode:02d} not supported")

            for letter in list(vals):
                if letter in ("N", "F", "S"):
                    del vals[letter]
                elif letter == "T":
                    if not ignore_tool_words:
                        raise ValueError(f"{where}: T word not supported "
                                         "(pass ignore_tool_words=True to drop it)")
                    del vals[letter]
                elif letter not in _LENGTH_ADDRESSES:
                    raise ValueError(f"{where}: address {letter} not supported")
                elif "." not in raw_vals[letter] and decimal_point == "fanuc":
                    vals[letter] = vals[letter] * (Decimal("0.0001") if inch
                                                   else Decimal("0.001"))
            if gcode_system != "A" and ("U" in vals or "W" in vals):
                raise ValueError(f"{where}: U/W are not increments in G-code system "
                                 f"{gcode_system}")
            if "X" in vals and "U" in vals or "Z" in vals and "W" in vals:
                raise ValueError(f"{where}: X with U or Z with W in one block")

            if new_motion is not None:
                motion = new_motion
            has_axis = any(k in vals for k in "XZUW")
            has_arc_words = any(k in vals for k in "IKR")
            if not has_axis and not has_arc_words:
                continue
            if motion is None:
                raise ValueError(f"{where}: axis words before any G00-G03")
            if has_arc_words and motion not in (2, 3):
                raise ValueError(f"{where}: I/K/R outside G02/G03")

            nx, nz = x, z
            if "X" in vals:
                nx = x + vals["X"] if incremental else vals["X"]
            if "U" in vals:
                nx = x + vals["U"]
            if "Z" in vals:
                nz = z + vals["Z"] if incremental else vals["Z"]
            if "W" in vals:
                nz = z + vals["W"]

            words_out = [f"N{lineno}", f"G{motion}", f"X{_fmt(nx)}", f"Z{_fmt(nz)}"]
            if motion in (2, 3):
                if "R" in vals:
                    if not has_axis:
                        raise ValueError(f"{where}: R arc without an end point")
                    words_out.append(f"R{_fmt(vals['R'])}")
                elif "I" in vals or "K" in vals:
                    words_out.append(f"I{_fmt(vals.get('I', Decimal(0)))}")
                    words_out.append(f"K{_fmt(vals.get('K', Decimal(0)))}")
                else:
                    raise ValueError(f"{where}: G0{motion} without I/K or R")
            out.append(" ".join(words_out))
            x, z = nx, nz
            moved = True
    out.append("M2")
    return "\n".join(out) + "\n"


# --------------------------------------------------------------------------
# self-test

def _selftest() -> int:
    if not rs274_available():
        print("rs274 not available (apt-get install linuxcnc-uspace); skipping")
        return 0
    r = 57.15
    cases = {
        "G03 I/K (pole -> equator)": (
            "%\nO0001 (HEMISHELL)\nN10 G21 G18 G00 X0. Z60. ;\n"
            "N20 G01 X0. Z57.15 F100 ;\nN30 G03 X114.3 Z0. I0. K-57.15 ;\nN40 M30 ;\n%\n",
            "ccw", -90.0, (0.0, 0.0)),
        "G03 R (pole -> equator)": (
            "G21 G18\nG0 X0 Z60.\nG1 X0 Z57.15 F100\nG3 X114.3 Z0 R57.15\nM30\n",
            "ccw", -90.0, (0.0, 0.0)),
        "G02 I/K (equator -> pole)": (
            "G21 G18\nG0 X114.3 Z5.\nG1 Z0. F100\nG2 X0 Z57.15 I-57.15 K0\nM30\n",
            "cw", 90.0, (0.0, 0.0)),
        "G02 R- (270 deg)": (
            "G21\nG0 X114.3 Z5.\nG1 Z0. F100\nG2 X0. Z57.15 R-57.15\nM30\n",
            "cw", 270.0, (r, r)),
        "G20 G03 I/K (inch)": (
            "G20\nG0 X0. Z2.5\nG1 Z2.25 F10.\nG3 X4.5 Z0. I0. K-2.25\nM30\n",
            "ccw", -90.0, (0.0, 0.0)),
    }
    failures = 0
    for name, (fanuc, direction, sweep, expect_c) in cases.items():
        lc = to_linuxcnc(fanuc)
        moves = run_rs274(lc)
        print(f"== {name}")
        print("   " + lc.strip().replace("\n", "\n   "))
        for mv in moves:
            print(f"   {mv}")
        arc = moves[-1]
        ok = (arc.kind == "arc" and arc.direction == direction
              and abs(arc.x_center - expect_c[0]) < 3e-3 and abs(arc.z_center - expect_c[1]) < 3e-3
              and abs(arc_sweep_deg(arc) - sweep) < 1e-3)
        print(f"   sweep {arc_sweep_deg(arc):+.3f} deg -> {'ok' if ok else 'FAIL'}")
        failures += not ok
    try:
        run_rs274(to_linuxcnc("G21\nG0 X10. Z0\nG2 X40. Z1. I5. K0\nM30\n"))
    except RS274Error as exc:
        print(f"== radius mismatch -> RS274Error: {exc}")
    else:
        print("== radius mismatch: expected RS274Error -> FAIL")
        failures += 1
    print("selftest:", "FAILED" if failures else "passed")
    return 1 if failures else 0


if __name__ == "__main__":
    raise SystemExit(_selftest())
