"""One round of finding the calibration sphere as a FANUC probing program (docs/methods.md §9.2.1).

Three touches at the estimated centre (cx, cz) of a ball of radius R (:mod:`postproc.measure.artifact`):
straight down onto the pole at x = cx, then from +X and from -X at z = cz, each a skip move
(G31) from ``clearance`` outside the estimated ball to ``overtravel`` inside it, printed as
``postproc probe-program``'s are (:mod:`postproc.onmachine.probe_cycle`, :mod:`postproc.onmachine.probe_printout`:
``postproc probe-import`` reads the printout). The stylus travels over the ball: from the
pole's approach start across the top to above each side, then down to the side's start, all
at ``clearance`` outside the estimated ball's box. A first estimate by eye needs a clearance
and overtravel larger than its error; the later rounds start from a finding a few micrometres
off.

The ball must sit off the spindle axis (the -X touch starts at cx - R - R_stylus - clearance,
which must not cross it): the source mounted it on an arm beside the axis (Figure 4.16).
"""

from __future__ import annotations

import dataclasses

from ..diagnostics import Location, SafetyError
from .probe_cycle import Cycle, ProbingProgram, Touch, program_text, within_limits
from .probe_printout import POINT
from .probe_route import Envelope, Leg
from ..machine.profile import DEFAULT, MachineProfile

NAME = "ARTIFACT"  #: the program's name in its heading and messages


def plan_round(estimate: tuple[float, float], radius: float, cycle: Cycle,
               profile: MachineProfile = DEFAULT) -> ProbingProgram:
    """The probing program of one round at ``estimate`` (x radius, z; mm) on a ball of ``radius``.

    :raises OptionError: a setting the program cannot be written with (:meth:`Cycle.check`).
    :raises SafetyError: a touch that would start past the spindle axis, a move outside the
        soft limits.
    """
    cycle.check()
    cx, cz = estimate
    grid = profile.grid(False)
    grow = radius + cycle.stylus_radius + cycle.clearance
    if cx - grow < 0.0:
        raise SafetyError(f"the -X side touch would start at x {cx - grow:.3f} mm, past the spindle axis: a ball at "
                          f"x {cx:g} mm is too near the axis for a radius of {radius:g} mm (mount it on an arm "
                          "beside the axis)", Location(NAME))
    top = cz + grow
    inside = radius + cycle.stylus_radius - cycle.reach
    sides = [(POINT, 1, (cx, cz + radius), (0.0, 1.0), (cx, top), (cx, cz + inside), ()),
             (POINT, 2, (cx + radius, cz), (1.0, 0.0), (cx + grow, cz), (cx + inside, cz),
              (Leg(cx + grow, top, rapid=False),)),
             (POINT, 3, (cx - radius, cz), (-1.0, 0.0), (cx - grow, cz), (cx - inside, cz),
              (Leg(cx + grow, top, rapid=False), Leg(cx - grow, top, rapid=False)))]
    touches = []
    for record, index, target, outward, start, end, route in sides:
        start, end = grid.snap(*start), grid.snap(*end)
        touches.append(Touch(record, index, target, outward, start, end, (-outward[0], -outward[1]), route))
    home = Envelope.around([(cx - radius, cz - radius), (cx + radius, cz + radius)],
                           cycle.stylus_radius + cycle.clearance).corner
    leave = (Leg(cx - grow, top, rapid=False), Leg(*home, rapid=False))
    title = f"ARTIFACT R{radius:g} MM AT X {cx:.4f} Z {cz:.4f}, POLE +X -X"
    planned = ProbingProgram(NAME, cycle, tuple(touches), home, leave, (0, 0), title=title)
    within_limits(planned, profile)
    return dataclasses.replace(planned, text=program_text(planned, profile))
