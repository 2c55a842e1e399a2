"""tool-offset: the tool-setting error, found by registering the nominal profile to probe points."""

from __future__ import annotations

from typing import Any, Iterable

import numpy as np

from postproc.compensator import Option, Piece
from postproc.diagnostics import Location, MeasurementError, OptionError, SafetyError
from postproc.figures import figures
from postproc.fitting import FitError, register
from postproc.geometry import Profile
from postproc.hookspecs import hookimpl
from postproc.motion import REPLAY, Move
from postproc_plugins.omp_feedback import OmpFeedback, ProbedChain, move_key

APPLY = ("path", "wear-offset")
DEFAULT_RESIDUAL = 0.005  #: mm, when the probe file gives no repeatability_mm
RESIDUAL_FACTOR = 3.0  #: the default tolerance is this many times the probe file's repeatability_mm


class ToolOffset(OmpFeedback):
    """Find the tool-setting error from the part and take it out (docs/methods.md §10, eq. 5.1-5.2).

    What it corrects: a tool set wrongly, which translates the whole profile it cuts. The
    nominal profile the touches lie on (one chain of connected feed moves, lines and arcs,
    from the first move touched to the last, its shape fixed) is registered to the touched
    points by least squares (Levenberg-Marquardt); the shift (dx, dz) that lays it on them is
    the tool-setting error, reported with its standard uncertainty and the four figures of
    the residuals. Then every feed move of the tool that cut the profile (a G70 contour's
    blocks when a G70 of that tool runs them) moves by (-dx, -dz).

    The registration is trusted only when the form is right: the largest residual (nub and
    outliers screened out, as for ``omp-feedback``) must be within ``residual``; beyond it a
    translation would not fix the part and the run is refused for safety (exit 4; ``--force``
    applies the offset anyway, with a warning). A profile whose normals do not span both
    axes (a plain cylinder fixes only X, a face only Z) cannot give an offset: refused as
    bad input (exit 3).

    What it needs: ``--probe`` (one file, taken on a pass of this profile) and preferably
    ``--calibration``; the datum check as for ``omp-feedback``.

    Options:

    - ``residual=MM``: the largest residual allowed; default 3 x the probe file's
      ``repeatability_mm``, or 0.005 mm without one.
    - ``stock=MM`` (default 0): how far outside this program's profile the probed pass was cut.
    - ``apply=path|wear-offset``: ``path`` (default) moves the feed moves; ``wear-offset``
      leaves the path alone and opens the program with a ``G10 P<n> X<diameter> Z..`` block
      that sets the tool's wear offset (the wear offset adds to the tool position, so a part
      4 um too big in radius gets X-0.008). The values are absolute (X/Z, not U/W): the program
      runs for every part, and an incremental U/W would add the correction again at each run;
      an absolute value sets the same register every time. It replaces what the register
      held, so give ``wear-x``/``wear-z`` (mm, X as a diameter) when it did not hold 0 while the
      probed pass was cut: the block then writes that plus the correction. Values are in mm
      (metric input must be in force at the program start), X as a diameter on a diameter-
      programmed machine. The new wear takes effect at the program's T word for the tool.
    - ``offset=N``: the wear offset number; default the offset the profile's T word selected
      (T0312 -> 12), or the tool number where the T word named none.

    Example: the sample files (``samples/probe/``) give an offset of +11.2 um in X and +6.9 um
    in Z (each +-0.15 um) for T0101 of ``samples/programs/hemishell.nc``::

        G00 X0. Z62.                          G00 X0. Z62.
        G01 Z57.15 F0.08                      G01 X-0.022 Z61.993 F0.08
        G03 X114.3 Z0. I0. K-57.15      ->    X-0.022 Z57.143
        G01 X118.                             G03 X114.278 Z-0.007 I0. K-57.151
        G00 Z62.                              G01 X117.978 Z-0.007
                                              G00 X118. Z62.

    or, with ``apply=wear-offset``, the program as it was after ``G10 P1 X-0.022 Z-0.007``.
    """

    name = "tool-offset"
    options = (
        Option("residual", float, None, "largest registration residual that still counts as a right form, mm",
               positive=True),
        Option("stock", float, 0.0, "how far outside this program's profile the probed pass was cut, mm"),
        Option("apply", str, "path", "move the path, or write a G10 wear offset", APPLY),
        Option("offset", int, None, "wear offset number (default: the one the T word selected)", positive=True),
        Option("wear-x", float, 0.0, "the wear offset's X (diameter) when the probed pass was cut, mm"),
        Option("wear-z", float, 0.0, "the wear offset's Z when the probed pass was cut, mm"),
    )

    def survey(self, moves: Iterable[Move]) -> None:
        moves = list(moves)
        probed = self.probed_chains(moves)
        if len(probed) > 1:
            names = ", ".join(p.chain.lines for p in probed)
            raise MeasurementError(f"the touches lie on several profiles ({names}): a tool offset is registered to "
                                   "one", Location(self.probe.path))
        self.probed = probed
        self.fitted = self._register(probed[0])
        self.tool = probed[0].chain.tool
        self.tool_offset = probed[0].chain.moves[0].offset
        self._replayed = {move_key(m) for m in moves if m.role == REPLAY and m.tool == self.tool}

    def _register(self, probed: ProbedChain):
        kept = probed.screening.kept
        outward = probed.deviations.outward[kept]
        points = probed.touched[kept] - self.settings["stock"] * outward
        # only the moves touched: a lead-in along the axis would claim the touches at the pole
        index = probed.deviations.nearest.index
        probed_part = Profile(probed.chain.profile.segments[index.min():index.max() + 1])
        try:
            fitted = register(probed_part, points, outward)
        except FitError as exc:
            raise MeasurementError(f"{exc}: the feed moves of {probed.chain.lines} do not fix both X and Z (a plain "
                                   "cylinder fixes only X, a face only Z), so no tool offset follows from them",
                                   Location(self.probe.path)) from None
        worst = float(np.max(np.abs(fitted.residuals)))
        if worst > self.residual_allowed:
            text = (f"after registering the profile of {probed.chain.lines} (offset {fitted.dx * 1000:+.2f} um in X, "
                    f"{fitted.dz * 1000:+.2f} um in Z) a residual of {worst * 1000:.2f} um is left, beyond the "
                    f"{self.residual_allowed * 1000:.2f} um allowed (--option residual): the form is not right, and a "
                    "tool offset would not make it right")
            if not self.context.force:
                raise SafetyError(f"{text} (use omp-feedback, or --force to apply the offset anyway)",
                                  Location(self.probe.path))
            self.context.reporter.warn(f"{text}; applied anyway (--force)", Location(self.probe.path))
        return fitted

    @property
    def residual_allowed(self) -> float:
        if self.settings["residual"] is not None:
            return self.settings["residual"]
        repeatability = self.probe.repeatability
        return RESIDUAL_FACTOR * repeatability if repeatability is not None else DEFAULT_RESIDUAL

    @property
    def offset_number(self) -> int:
        number = next((n for n in (self.settings["offset"], self.tool_offset, self.tool) if n is not None), None)
        if number is None:
            raise OptionError(f"{self.name}: the profile is cut by no numbered tool (no T word): give "
                              "--option offset=N, the wear offset number")
        return number

    def correct(self, piece: Piece) -> np.ndarray | None:
        if self.settings["apply"] != "path":
            return None
        move = piece.move
        if move.tool != self.tool and move_key(move) not in self._replayed:
            return None
        return np.broadcast_to([-self.fitted.dx, -self.fitted.dz], (len(piece.t), 2)).copy()

    def prologue(self) -> list[str]:
        if self.settings["apply"] != "wear-offset":
            return []
        return [self._g10()]

    def _g10(self) -> str:
        profile = self.context.profile
        decimals = profile.output_decimals_mm
        scale = 2.0 if profile.diameter_x else 1.0
        x = self.settings["wear-x"] - scale * self.fitted.dx
        z = self.settings["wear-z"] - self.fitted.dz
        return f"G10 P{self.offset_number} X{_number(x, decimals)} Z{_number(z, decimals)}"

    def report(self) -> dict[str, Any]:
        result: dict[str, Any] = {"probe": self.probe.path, "notes": list(self.notes)}
        if not self.probed:
            return result
        probed, fitted = self.probed[0], self.fitted
        sigma = np.sqrt(np.diag(fitted.covariance))
        result.update({
            "moves": probed.chain.lines, "tool": self.tool, "stock_mm": self.settings["stock"],
            "offset_mm": {"x": fitted.dx, "z": fitted.dz},
            "offset_sigma_mm": {"x": float(sigma[0]), "z": float(sigma[1])},
            "residual_um": figures(fitted.residuals).as_dict(),
            "largest_residual_mm": float(np.max(np.abs(fitted.residuals))),
            "residual_allowed_mm": self.residual_allowed,
            "points": len(probed.index), "dropped": probed.dropped(), "apply": self.settings["apply"],
        })
        if self.settings["apply"] == "wear-offset" and any(
                n is not None for n in (self.settings["offset"], self.tool_offset, self.tool)):
            result["g10"] = self._g10()
        return result


def _number(value: float, decimals: int) -> str:
    """A FANUC value with a decimal point, no minus on zero."""
    text = f"{value:.{decimals}f}"
    return text[1:] if float(text) == 0.0 and text.startswith("-") else text


@hookimpl
def postproc_compensators():
    return [ToolOffset]
