"""Probing a cut surface at points spread along the nominal profile of its program.

``points`` touches evenly spaced in arc length along the profile (:mod:`postproc.measure.nominal`), both ends
included, or, given an ``inset``, spread over the profile's features as ``postproc
probe-program`` spreads them (:meth:`.nominal.Nominal.spread`); each approaches along the
nominal normal into the material (:mod:`.touch`).
With a datum configured, it is probed before the first touch and after the last; the
thermal drift grows linearly over the session, so the two readings differ by it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..measure.features import MIN_TOUCHES
from ..measure.nominal import Nominal
from .config import Simulation
from .surface import Plane, Turned
from .touch import Touch, run


@dataclass(frozen=True)
class ProbeRun:
    """What a probe file holds: reported stylus centres, approaches and the datum readings."""

    stylus_radius: float
    centres: np.ndarray  #: (n, 2) reported stylus centres
    approach: np.ndarray  #: (n, 2) unit directions into the material
    datum_before: dict[str, float]  #: axis -> reported stylus-centre coordinate
    datum_after: dict[str, float]
    repeatability: float
    nominal: np.ndarray  #: (n, 2) the nominal points aimed at


def datum_touches(simulation: Simulation, when: float, label: str) -> list[tuple[str, Touch]]:
    """The datum ring's touches configured for one moment of the session."""
    probe = simulation.probe
    if probe.datum_x_mm is None and probe.datum_z_mm is None:
        return []
    x = probe.datum_x_mm if probe.datum_x_mm is not None else 0.0
    z = probe.datum_z_mm if probe.datum_z_mm is not None else 0.0
    corner = np.array([x, z])
    touches = []
    if probe.datum_z_mm is not None:
        face = Plane((x, z), (0.0, 1.0))
        touches.append(("z", Touch(face, corner, np.array([0.0, -1.0]), when, f"datum {label} (Z face)")))
    if probe.datum_x_mm is not None:
        diameter = Plane((x, z), (1.0, 0.0))
        touches.append(("x", Touch(diameter, corner, np.array([-1.0, 0.0]), when, f"datum {label} (X diameter)")))
    return touches


def probe_profile(surface: Turned, nominal: Nominal, simulation: Simulation, rng: np.random.Generator | None,
                  count: int | None = None, inset: float | None = None, per_feature: int = MIN_TOUCHES) -> ProbeRun:
    """Touch ``surface`` at ``count`` points (default: the configured number) along ``nominal``: evenly,
    or with an ``inset`` at least ``per_feature`` on every feature, clear of its ends."""
    count = count or simulation.probe.points
    if inset is None:
        targets, outward, _ = nominal.stations(count)
    else:
        probe = simulation.probe
        targets, outward = nominal.places(nominal.spread(count, inset, per_feature, probe.stylus_radius_mm,
                                                         probe.standoff_mm).s)
    before = datum_touches(simulation, 0.0, "before")
    after = datum_touches(simulation, 1.0, "after")
    points = [Touch(surface, targets[i], -outward[i], (i + 1) / (count + 1), f"point {i + 1}") for i in range(count)]
    session = [touch for _, touch in before] + points + [touch for _, touch in after]
    reported = run(session, simulation, rng, nominal.program)
    first, last = len(before), len(before) + count
    axis = {"x": 0, "z": 1}
    return ProbeRun(
        simulation.probe.stylus_radius_mm,
        reported[first:last],
        -outward,
        {name: float(reported[i, axis[name]]) for i, (name, _) in enumerate(before)},
        {name: float(reported[last + i, axis[name]]) for i, (name, _) in enumerate(after)},
        simulation.probe.repeatability_mm,
        targets,
    )
