"""tool-offset: the tool-setting error, found by registering the nominal profile to probe points."""

from __future__ import annotations

from typing import Any, Iterable

import numpy as np

from postproc.compensator import STOCK_MM, Option, Piece
from postproc.diagnostics import FitError, Location, MeasurementError, OptionError
from postproc.measure.features import MIN_TOUCHES
from postproc.measure.figures import figures
from postproc.geometry.fitting import register
from postproc.geometry import Profile
from postproc.hookspecs import hookimpl
from postproc.interpret.motion import REPLAY, Move
from postproc.corrections.probed import ProbeCompensator, ProbedChain, move_key, rows_text

APPLY = ("path", "wear-offset")
DEFAULT_RESIDUAL = 0.005  #: mm, when the probe file gives no repeatability_mm
RESIDUAL_FACTOR = 3.0  #: the default tolerance is this many times the probe file's repeatability_mm
GEOMETRY_OFFSETS = 10000  #: G10 P10000 + n sets geometry offset n; wear offsets are numbered below
INCH_MM = 25.4


class ToolOffset(ProbeCompensator):
    """Find the tool-setting error from the part and take it out (docs/methods.md §10, eq. 5.1-5.2).

    What it corrects: a tool set wrongly, which translates the whole profile it cuts. The
    nominal profile the touches lie on (one chain of connected feed moves, lines and arcs,
    from the first move touched to the last, its shape fixed) is registered to the touched
    points by least squares (Levenberg-Marquardt); the shift (dx, dz) that lays it on them is
    the tool-setting error, reported with its standard uncertainty and the four figures of
    the residuals. Then every feed move of the tool that cut the profile (a G70 contour's
    blocks when a G70 of that tool runs them) moves by (-dx, -dz).

    The touches are screened for the nub and stray touches per feature (a line or arc of the
    profile), each against the touches on its own feature, never across a corner. Minimum
    evidence: 3 touches per feature; a feature with fewer (1 or 2: they cannot be screened)
    is left out of the registration with a warning naming it and its rows.

    The registration is trusted only when the form is right: the largest residual (nub and
    outliers screened out) must be within ``residual``; beyond it a translation would not fix
    the part and the run is refused for safety (exit 4; ``--force`` applies the offset anyway,
    with a warning). Touches whose features' normals do not span both axes (a plain cylinder
    fixes only X, a face only Z) cannot give an offset: refused as bad input (exit 3).

    What it needs: ``--probe`` (one file, taken on a pass of this profile) and preferably
    ``--calibration``; the datum check as for ``omp-feedback``.

    Options:

    - ``residual=MM``: the largest residual allowed; default 3 x the probe file's
      ``repeatability_mm``, or 0.005 mm without one.
    - ``stock=MM`` (default 0): how far outside this program's profile the probed pass was cut.
    - ``apply=path|wear-offset``: ``path`` (default) moves the feed moves; ``wear-offset``
      leaves the path alone and adds the correction to the tool's wear offset with an
      incremental ``G10 P<n> U<diameter> W<z>`` (FANUC: P1-P64 a wear offset, U and W added to
      what it holds), so what the operator has set since the probed pass stays. The block goes
      right after the program sets its units and plane (G20/G21, G18), so its values are read
      in the program's units, and before its first tool call or move (a program that sets no
      units before those is refused); U is a diameter on a diameter-programmed machine (the
      control's offsets in diameter: parameter ODI). The wear offset adds to the tool position,
      so a part 4 um too big in radius gets U-0.008. It adds each time the program runs: run
      the compensated program once, for the part that was probed. The block is stated on
      stderr, in the report and in the program's header.
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

    or, with ``apply=wear-offset``, the program as it was with ``G10 P1 U-0.022 W-0.007``
    after its ``G18 G21 G40 G99`` line.
    """

    name = "tool-offset"
    minimum = MIN_TOUCHES
    options = (
        Option("residual", float, None, "largest registration residual that still counts as a right form, mm",
               positive=True, largest_mm=0.1),
        Option("stock", float, 0.0, "how far outside this program's profile the probed pass was cut, mm",
               largest_mm=STOCK_MM),
        Option("apply", str, "path", "move the path, or add the offset to the tool's wear with G10", APPLY),
        Option("offset", int, None, "wear offset number (default: the one the T word selected)", positive=True),
    )

    def survey(self, moves: Iterable[Move]) -> None:
        moves = list(moves)
        probed = self.probed_chains(moves)
        if len(probed) > 1:
            names = ", ".join(p.chain.lines for p in probed)
            raise MeasurementError(f"the touches lie on several profiles ({names}): a tool offset is registered to "
                                   "one", Location(self.probe.path))
        self.probed = probed
        self.left_out = self.thin(probed, self.minimum, "left out of the registration")
        self.fitted, self.used = self._register(probed[0])
        self.tool = probed[0].chain.tool
        self.tool_offset = probed[0].chain.moves[0].offset
        self._replayed = {move_key(m) for m in moves if m.role == REPLAY and m.tool == self.tool}

    def _register(self, probed: ProbedChain):
        enough = np.zeros(len(probed.index), dtype=bool)
        for evidence in probed.evidence():
            if evidence.count >= self.minimum:
                enough[evidence.members] = True
        used = probed.screening.kept & enough
        if not used.any():
            raise MeasurementError(f"no feature of {probed.chain.lines} has the {self.minimum} touches {self.name} "
                                   f"needs to screen them for the nub and outliers (rows {rows_text(probed.rows)}): "
                                   f"probe each feature at {self.minimum} points or more", Location(self.probe.path))
        outward = probed.deviations.outward[used]
        points = probed.touched[used] - self.settings["stock"] * outward
        # only the moves touched: a lead-in along the axis would claim the touches at the pole
        index = probed.deviations.nearest.index[used]
        probed_part = Profile(probed.chain.profile.segments[index.min():index.max() + 1])
        try:
            fitted = register(probed_part, points, outward)
        except FitError as exc:
            raise MeasurementError(f"{exc}: the touched features of {probed.chain.lines} do not fix both X and Z (a "
                                   "plain cylinder fixes only X, a face only Z), so no tool offset follows from them",
                                   Location(self.probe.path)) from None
        worst = float(np.max(np.abs(fitted.residuals)))
        if worst > self.residual_allowed:
            text = (f"after registering the profile of {probed.chain.lines} (offset {fitted.dx * 1000:+.2f} um in X, "
                    f"{fitted.dz * 1000:+.2f} um in Z) a residual of {worst * 1000:.2f} um is left, beyond the "
                    f"{self.residual_allowed * 1000:.2f} um allowed (--option residual): the form is not right, and a "
                    "tool offset would not make it right")
            self.context.refuse(text, "use omp-feedback", Location(self.probe.path))
        return fitted, used

    @property
    def residual_allowed(self) -> float:
        if self.settings["residual"] is not None:
            return self.settings["residual"]
        repeatability = self.probe.repeatability
        return RESIDUAL_FACTOR * repeatability if repeatability is not None else DEFAULT_RESIDUAL

    @property
    def offset_number(self) -> int:
        number = next((n for n in (self.settings["offset"], self.tool_offset, self.tool) if n is not None), None)
        if number is None or number == 0:
            why = "is cut by no numbered tool (no T word)" if number is None else "is cut with wear offset 0 (T..00)"
            raise OptionError(f"{self.name}: the profile {why}: give --option offset=N, the wear offset number "
                              "(G10 P0 would set the work shift)")
        if number >= GEOMETRY_OFFSETS:
            raise OptionError(f"{self.name}: wear offset {number}: G10 P{number} would set a geometry offset; wear "
                              f"offsets are numbered below {GEOMETRY_OFFSETS}")
        return number

    def correct(self, piece: Piece) -> np.ndarray | None:
        if self.settings["apply"] != "path":
            return None
        move = piece.move
        if move.tool != self.tool and move_key(move) not in self._replayed:
            return None
        return np.broadcast_to([-self.fitted.dx, -self.fitted.dz], (len(piece.t), 2)).copy()

    def prologue(self, inch: bool) -> list[str]:
        if self.settings["apply"] != "wear-offset":
            return []
        profile = self.context.profile
        decimals, unit, name = (profile.output_decimals_inch, INCH_MM, "in") if inch else \
            (profile.output_decimals_mm, 1.0, "mm")
        u, w = (_number(value / unit, decimals) for value in self.wear_change)
        number = self.offset_number
        self.g10 = f"G10 P{number} U{u} W{w}"
        self.context.reporter.warn(
            f"{self.name}: {self.g10} opens the program: it adds {u} {name} (a diameter) to the X wear and {w} {name} "
            f"to the Z wear of offset {number} each time the program runs (run it once, for the part that was probed)")
        return [self.g10]

    @property
    def wear_change(self) -> tuple[float, float]:
        """(U, W) in mm: minus the fitted offset, U as a diameter on a diameter-programmed machine."""
        scale = 2.0 if self.context.profile.diameter_x else 1.0
        return -scale * self.fitted.dx, -self.fitted.dz

    def report(self) -> dict[str, Any]:
        result = super().report()
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
            "points": len(probed.index), "points_used": int(self.used.sum()), "dropped": probed.dropped(),
            "minimum_touches_per_feature": self.minimum,
            "left_out": [{"feature": e.feature.describe(), "rows": list(e.rows)} for e in self.left_out],
            "apply": self.settings["apply"],
        })
        if self.settings["apply"] == "wear-offset" and hasattr(self, "g10"):
            u, w = self.wear_change
            result["g10"] = self.g10
            result["wear_offset"] = {"number": self.offset_number, "u_mm": u, "w_mm": w, "incremental": True}
        return result


def _number(value: float, decimals: int) -> str:
    """A FANUC value with a decimal point, no minus on zero."""
    text = f"{value:.{decimals}f}"
    return text[1:] if float(text) == 0.0 and text.startswith("-") else text


@hookimpl
def postproc_compensators():
    return [ToolOffset]
