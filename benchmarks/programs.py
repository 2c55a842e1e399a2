"""Programs for the benchmarks: long lathe programs of ordinary blocks, generated reproducibly."""

from __future__ import annotations

import math
import random


def lathe_program(blocks: int, seed: int = 1) -> str:
    """A FANUC lathe finishing program of about ``blocks`` blocks: feed lines and short arcs
    (G03 about a centre below the path, I/K incremental), N numbers on most blocks, a comment
    now and then, as CAM systems write them. Every number has a decimal point and digits
    after it, so that every parser compared can read it."""
    rng = random.Random(seed)
    lines = ["%", "O2000 (BENCHMARK)", "G18 G21 G40 G99", "T0101", "G96 S200 M03", "G50 S3000",
             "G00 X100.000 Z5.000", "G01 Z0.000 F0.200"]
    x, z = 50.0, 0.0
    while len(lines) < blocks - 2:
        if z < -100.0:  # the next pass: back to the face, as a finishing program of many parts does
            lines += [f"G00 X{2 * x + 4:.3f}", "G00 Z2.000", f"G01 X{2 * x:.3f} Z0.000"]
            z = 0.0
            continue
        kind = rng.random()
        if kind < 0.6:
            z = round(z - rng.uniform(0.01, 0.5), 3)
            x = round(min(60.0, max(5.0, x + rng.uniform(-0.3, 0.3))), 4)
            lines.append(f"N{(len(lines) * 5) % 99999} G01 X{2 * x:.3f} Z{z:.3f}")
        elif kind < 0.9:
            radius = rng.uniform(5.0, 40.0)
            xc, zc = x - radius, z
            sweep = math.radians(rng.uniform(2.0, 20.0))
            x1, z1 = round(xc + radius * math.cos(sweep), 4), round(zc - radius * math.sin(sweep), 3)
            lines.append(f"G03 X{2 * x1:.3f} Z{z1:.3f} I{xc - x:.3f} K{zc - z:.3f}")
            x, z = x1, z1
        else:
            z = round(z - 0.1, 3)
            lines.append(f"G01 X{2 * x:.3f} Z{z:.3f} F0.150 (FINISH)")
    return "\n".join(lines + ["M30", "%"]) + "\n"
