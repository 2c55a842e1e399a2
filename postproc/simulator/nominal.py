"""What a program does to the virtual lathe besides the profile it cuts: the wear offsets its
G10 blocks set. The profile itself, and the moves the control runs, are
:mod:`postproc.measure.nominal` (the probing code measures against them too).
"""

from __future__ import annotations

from ..diagnostics import Reporter
from ..interpret.motion import Move
from ..measure.nominal import program_moves
from ..machine.profile import DEFAULT, MachineProfile


def run_program(path: str, profile: MachineProfile = DEFAULT,
                reporter: Reporter | None = None) -> tuple[str, list[Move], dict[int, tuple[float, float]]]:
    """The program's name, the moves the control runs (:func:`postproc.measure.nominal.read_program`), and
    what its G10 blocks do to the wear offsets (:func:`wear_added`)."""
    name, moves, settings = program_moves(path, profile, reporter)
    return name, moves, wear_added(settings, profile)


def wear_added(steps, profile: MachineProfile = DEFAULT) -> dict[int, tuple[float, float]]:
    """What a program's G10 blocks do to each tool wear offset (P1 and up), as (x, z) radius mm:
    U and W add to it, X and Z set it (X, U diameters on a diameter-programmed machine), in the
    units in force. The virtual lathe's wear offsets hold 0 before the program runs."""
    wear: dict[int, list[float]] = {}
    for step in steps:
        words = dict(step.block.codes)
        if ("G", "10") not in step.block.codes or "P" not in words:
            continue
        number = int(float(words["P"]))
        if not 0 < number < 10000:
            continue  # a work shift or a geometry offset: not modelled
        unit = 25.4 if step.modal.inch else 1.0
        scale = unit / (2.0 if profile.diameter_x else 1.0)
        held = wear.setdefault(number, [0.0, 0.0])
        for axis, (absolute, added, factor) in enumerate((("X", "U", scale), ("Z", "W", unit))):
            if absolute in words:
                held[axis] = float(words[absolute]) * factor
            if added in words:
                held[axis] += float(words[added]) * factor
    return {number: (x, z) for number, (x, z) in wear.items()}
