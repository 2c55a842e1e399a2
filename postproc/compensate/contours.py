"""``postproc check``'s look at each G71/G72 contour as written, against its cycle's one-way rule.

The interpreter gives it the steps of cycle contours only (``Step.in_contour``: the blocks it
reads by its general path anyway), so that the blocks outside them cost nothing. The rule
itself (:func:`.monotone.written_turn`, which ``compensate`` refuses by) is loaded at the first
G71/G72 contour's end: ``check`` on a program without one loads no numerical module.
"""

from __future__ import annotations

from ..diagnostics import Reporter
from ..interpret import gcodes as G
from ..interpret.motion import Step
from ..machine.profile import MachineProfile

class WrittenContours:
    """Fed each contour step of a program, it warns where a G71/G72 contour turns back as
    written in an axis its cycle's type needs run one way: the block, the axis, the alarm."""

    def __init__(self, file: str, profile: MachineProfile, reporter: Reporter):
        self.file, self.profile, self.reporter = file, profile, reporter
        self.steps: list[Step] = []

    def __call__(self, step: Step) -> None:
        if step.cycle not in G.ONE_WAY_CYCLES:
            return
        if step.contour_start:
            self.steps = []
        self.steps.append(step)
        if step.contour_end:
            from . import monotone

            steps, self.steps = self.steps, []
            grid = self.profile.grid(step.modal.inch)
            turn = monotone.written_turn(steps, min(grid.x_step, grid.z_step) / 2.0)  # the rewriter's noise
            if turn is not None:
                self.reporter.warn(turn.said() + "; compensate refuses the program",
                                   monotone.at_geometry(self.file, turn.step))
