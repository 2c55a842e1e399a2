"""The four figures every report, test and benchmark quotes (docs/methods.md §12).

Mean, mean absolute, RMS and standard deviation (population form, ddof = 0) of the
radial deviations from nominal, in micrometres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, slots=True)
class Figures:
    mean: float  #: um
    mean_abs: float  #: um
    rms: float  #: um
    std: float  #: um, ddof = 0
    count: int

    def __str__(self) -> str:
        return (f"mean {self.mean:+.2f} um, mean |e| {self.mean_abs:.2f} um, RMS {self.rms:.2f} um, "
                f"sigma {self.std:.2f} um ({self.count} points)")

    def as_dict(self) -> dict[str, float]:
        return {"mean_um": self.mean, "mean_abs_um": self.mean_abs, "rms_um": self.rms, "std_um": self.std,
                "count": self.count}


def figures(deviations_mm) -> Figures:
    """The four figures of deviations given in millimetres."""
    um = np.asarray(deviations_mm, dtype=float).ravel() * 1000.0
    if um.size == 0:
        raise ValueError("no deviations to summarise")
    return Figures(float(um.mean()), float(np.abs(um).mean()), float(np.sqrt(np.mean(um**2))), float(um.std()), int(um.size))
