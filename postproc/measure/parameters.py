"""A fitted machine parameter and what it is held to: :class:`Estimate` (a value and its 1-sigma),
the largest 3-sigma effect a fit may leave, the bounds no machine goes beyond, and the check of
a saved model's parameters against them.

A module of its own, apart from :mod:`postproc.measure.ballbar_fit` and
:mod:`postproc.measure.ballbar_analysis` (which use it and give its names too), because a run
that applies a saved model needs this and none of the fitting: a compensator loads its model
with these alone, and a small job does not pay for importing the fit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..diagnostics import Location, MeasurementError, ModelError

EFFECT_LIMIT_MM = 0.005  #: largest 3-sigma effect of a parameter that is reported or applied
MAX_SCALING = 500e-6  #: beyond this no machine scales: a wrong radius or unit
MAX_BACKLASH = 0.050  #: mm; beyond this, a unit (or a machine to repair before compensating)
MAX_NEGATIVE_BACKLASH = 0.010  #: mm; a control over-compensating its backlash by more is set wrong, or a unit
MAX_SQUARENESS = 500e-6  #: rad; as MAX_SCALING: 50 um over 100 mm of Z, an axis to realign, or a unit
MAX_SERVO_MISMATCH = 0.100  #: mm; 6 ms of lag between the axes at 1000 mm/min, a control to tune, or a unit


#: The lengths a telescoping ballbar measures at, mm: 50 mm (the small-circle set) to about 600 mm
#: (the longest bar with its extensions). A radius far above is a length in micrometres, refused
#: (a grid encoder's circle is smaller still); one below is said, since a grid encoder's circular
#: test runs at a few mm, but a ballbar's in inches reads 4 for 100 mm.
BAR_LENGTH_MM = (50.0, 1000.0)
TOO_LONG = "no circular test is that large (a ballbar: 50 to about 600 mm): a length in um written as mm?"


def bar_length_problem(radius: float) -> str | None:
    """What is wrong with a test radius no ballbar or grid encoder measures at, or None."""
    if radius > BAR_LENGTH_MM[1]:
        return f"above {BAR_LENGTH_MM[1]:g} mm: {TOO_LONG}"
    return None


@dataclass(frozen=True, slots=True)
class Estimate:
    """A fitted parameter and its 1-sigma uncertainty."""

    value: float
    sigma: float


#: name prefix -> (low, high, unit, scale to the unit, what a value beyond says): the bounds a fit
#: holds its traces to (:func:`postproc.measure.ballbar_analysis.plausibility`), which a saved
#: model is held to again (:func:`check_saved`)
BOUNDS = {
    "scaling": (-MAX_SCALING, MAX_SCALING, "ppm", 1e6, "no machine scales that much: a wrong radius or unit"),
    "backlash": (-MAX_NEGATIVE_BACKLASH, MAX_BACKLASH, "um", 1e3,
                 "a unit, a machine to repair, or a control whose backlash compensation is set far too high"),
    "squareness": (-MAX_SQUARENESS, MAX_SQUARENESS, "urad", 1e6, "an axis to realign, or a unit"),
    "servo_mismatch": (-MAX_SERVO_MISMATCH, MAX_SERVO_MISMATCH, "um", 1e3, "a control to tune, or a unit"),
}


def beyond_bounds(name: str, value: float) -> str | None:
    """Why a fitted parameter's value is beyond its :data:`BOUNDS`, or None (within, or unbounded)."""
    bound = next((b for prefix, b in BOUNDS.items() if name.startswith(prefix)), None)
    if bound is None or bound[0] <= value <= bound[1]:
        return None
    low, high, unit, scale, meaning = bound
    return (f"{name} {value * scale:+.1f} {unit} is beyond {low * scale:+.0f} .. {high * scale:+.0f} {unit}: "
            f"{meaning}")


def check_fitted(compensator: str, parameters: dict[str, Estimate], where: Location) -> None:
    """Hold the parameters a fit gives to the :data:`BOUNDS` a saved model is held to: a term
    the arcs hold only loosely (a sliver of one side, an ``--option max-uncertainty`` set wide)
    can come out far beyond what any machine has, and would be applied as it is."""
    for name, e in parameters.items():
        beyond = beyond_bounds(name, e.value)
        if beyond is not None:
            raise MeasurementError(f"{compensator}: the fit gives {beyond}; the arcs hold this term too loosely "
                                   "(measure a longer arc on that side, or keep --option max-uncertainty at its "
                                   "default) or the traces are in another unit", where)


def check_saved(compensator: str, parameters: dict[str, Estimate]) -> None:
    """Hold a saved model's parameters (``scaling_*``, ``backlash_*``, ``squareness``,
    ``servo_mismatch``: value and 1-sigma, mm and mm/mm) to what its traces were held to:
    finite, a 1-sigma not negative, each value within its :data:`BOUNDS`. A model edited by hand
    (its SHA-256 made again) or fitted from traces in another unit is refused (ModelError)
    naming the parameter and the bound."""
    for name, e in parameters.items():
        if not (math.isfinite(e.value) and math.isfinite(e.sigma) and e.sigma >= 0.0):
            raise ModelError(f"{compensator}: the saved model's {name} is {e.value:g} +- {e.sigma:g}: a value and a "
                             "1-sigma must be finite, the 1-sigma not negative; fit the model again from the traces")
        beyond = beyond_bounds(name, e.value)
        if beyond is not None:
            raise ModelError(f"{compensator}: the saved model's {beyond}; traces are refused beyond it, so the model "
                             "was edited, or made from traces in another unit: fit it again from the traces")
