"""Part programs several tests cut on the virtual lathe."""

import math
import random
from dataclasses import dataclass

# An outside profile of lines and arcs away from the spindle axis: a face-in, a cylinder,
# a fillet, a shoulder.
SHAFT = """%
O2000 (SHAFT)
G18 G21 G40 G98
T0101
G00 X90. Z10.
G01 X100. Z5. F200.
G01 Z-20.
G02 X140. Z-40. R20.
G01 X160.
G00 X200. Z50.
M30
%
"""


# -- turned profiles of many features, drawn from a seed --------------------------------------------------------------


MM_PER_INCH = 25.4


@dataclass(frozen=True)
class TurnedProfile:
    """An outside profile of a shaft, cut towards -Z with X never falling (a type I G71 contour),
    in radius millimetres: an end face from the spindle axis (or not), a chamfer, a diameter, a
    concave G02 fillet, a shoulder face, a convex G03 round, a long diameter, a taper and a face
    out to the stock. Every length is a whole number of the program's increments."""

    seed: int
    inch: bool
    end_face: bool  #: the profile starts on the spindle axis with an end face
    r0: float  #: first diameter's radius
    chamfer: float
    z1: float  #: first diameter's end
    fillet: float  #: concave G02 fillet radius (wider than the 3 mm stylus)
    r1: float  #: long diameter's radius
    round_: float  #: convex G03 round radius
    shoulder: float  #: length of the shoulder face between fillet and round
    z3: float  #: long diameter's end
    r2: float  #: taper's end radius
    z4: float  #: taper's end
    r3: float  #: end face's outer radius

    @classmethod
    def drawn(cls, seed: int, inch: bool = False) -> "TurnedProfile":
        rng = random.Random(seed)
        quantum = 0.0508 if inch else 0.05  # mm: a step every dimension is a multiple of (0.002 in)

        def pick(low: float, high: float) -> float:
            return round(rng.uniform(low, high) / quantum) * quantum

        r0, chamfer = pick(14.0, 22.0), pick(1.0, 2.5)
        z1 = -pick(8.0, 14.0)
        fillet = pick(4.0, 6.0)
        round_ = pick(3.0, 5.0)
        shoulder = pick(5.0, 9.0)
        r1 = r0 + fillet + shoulder + round_
        z3 = z1 - fillet - round_ - pick(18.0, 30.0)
        taper = rng.choice([20.0, 30.0, 45.0])  # degrees from the axis
        rise = pick(4.0, 7.0)
        r2 = r1 + rise
        z4 = z3 - round(rise / math.tan(math.radians(taper)) / quantum) * quantum
        r3 = r2 + pick(6.0, 9.0)
        return cls(seed, inch, rng.random() < 0.5, r0, chamfer, z1, fillet, r1, round_, shoulder, z3, r2, z4, r3)

    def program(self, cycle: bool = False) -> str:
        """The FANUC program: finishing the profile, or roughing it with G71 and finishing it with G70."""
        return "\n".join(self._lines(cycle)) + "\n"

    def profile_lines(self, cycle: bool = False) -> tuple[int, int]:
        """The source lines of the profile's first and last move (the moves that turn its surface)."""
        lines = self._lines(cycle)
        first = next(i for i, line in enumerate(lines, 1) if line.startswith(("G01 X", "N10 G01 X")))
        last = next(i for i, line in enumerate(lines, 1) if line.startswith(("G00", "G70")) and i > first)
        return first, last - 1

    def _lines(self, cycle: bool) -> list[str]:
        unit = MM_PER_INCH if self.inch else 1.0
        places = 4 if self.inch else 3

        def v(mm: float) -> str:
            text = f"{mm / unit:.{places}f}".rstrip("0")
            return "0." if text in ("0.", "-0.") else text

        def xz(x: float, z: float) -> str:
            return f"X{v(2.0 * x)} Z{v(z)}"

        feed = "F0.004" if self.inch else "F0.1"
        start = self.r0 - self.chamfer
        fillet_z = self.z1 - self.fillet
        round_x = self.r1 - self.round_
        if self.end_face:  # along the axis to the end face, which turns from the axis out
            approach = ["G00 X0.", f"G01 Z0. {feed}"]
            profile = [f"G01 X{v(2.0 * start)}"]
        else:
            approach = [f"G00 X{v(2.0 * start)}", f"G01 Z0. {feed}"]
            profile = []
        profile += [
            f"G01 {xz(self.r0, -self.chamfer)}",
            f"G01 Z{v(self.z1)}",
            f"G02 {xz(self.r0 + self.fillet, fillet_z)} I{v(self.fillet)} K0.",
            f"G01 X{v(2.0 * round_x)}",
            f"G03 {xz(self.r1, fillet_z - self.round_)} I0. K{v(-self.round_)}",
            f"G01 Z{v(self.z3)}",
            f"G01 {xz(self.r2, self.z4)}",
            f"G01 X{v(2.0 * self.r3)}",
        ]
        lines = ["%", f"O{2100 + self.seed % 100:04d} (TURNED PROFILE {self.seed})",
                 f"G18 {'G20' if self.inch else 'G21'} G40 G99", "T0101",
                 f"G00 X{v(2.0 * (self.r3 + 1.0))} Z{v(3.0)}"]
        contour = approach + profile
        if cycle:
            lines += [f"G71 U{v(1.0)} R{v(0.5)}", f"G71 P10 Q20 U{v(0.2)} W{v(0.1)} {feed}",
                      f"N10 {contour[0]}", *contour[1:-1], f"N20 {contour[-1]}", "G70 P10 Q20"]
        elif self.end_face:
            lines += contour
        else:  # straight to the chamfer's start
            lines += [f"G00 X{v(2.0 * start)} Z0.", profile[0] + f" {feed}", *profile[1:]]
        lines += [f"G00 X{v(2.0 * (self.r3 + 5.0))} Z{v(20.0)}", "M30", "%"]
        return lines
