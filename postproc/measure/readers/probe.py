"""Probe files and probe calibrations on an artifact (docs/formats.md §5, §6).

Each row is the stylus-centre position C the control reported at the trigger and the unit
direction n in which the probe travelled (into the material). The touched point is
``P = C + (R_stylus + k(n)) n`` with ``k`` from a calibration (docs/methods.md §9.1).

Directions are named by ``theta``, the angle of the outward surface normal ``-n`` in the
project's convention (from +X towards +Z): a touch straight down on a pole has theta = 90,
a touch on the +X side moving in -X has theta = 0.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...diagnostics import Location
from .csvfile import Table, read_table

PROBE_MAGIC = "# postproc probe 1"
CALIBRATION_MAGIC = "# postproc probe-calibration 1"
COLUMNS = ["x_mm", "z_mm", "approach_x", "approach_z"]
PROBE_KEYS = {"stylus_radius_mm", "datum_before_x_mm", "datum_before_z_mm", "datum_after_x_mm", "datum_after_z_mm",
              "repeatability_mm"}
CALIBRATION_KEYS = {"stylus_radius_mm", "artifact_radius_mm", "artifact_center_x_mm", "artifact_center_z_mm"}
UNIT_TOLERANCE = 0.001
#: mm; a probe repeating worse than the largest correction cannot measure one (and as the floor of the
#: outlier screening, a repeatability this large would call no touch an outlier, not even the nub)
MAX_REPEATABILITY = 0.1
#: (what the file's centres become, the likely cause) tried when touches lie far off what was probed
MISREADINGS = (
    (lambda centres: centres / 1000.0, "micrometres written as millimetres? (the coordinates divided by 1000 fit)"),
    (lambda centres: centres * np.array([0.5, 1.0]), "x written as a diameter? (x is a radius, as in `postproc path`; "
                                                     "halved, it fits)"),
)


def likely_cause(centres: np.ndarray, fits, otherwise: str) -> str:
    """Why touches lie far off what was probed: the first of :data:`MISREADINGS` under which
    ``fits(centres)`` holds, else ``otherwise``. Asked only once touches are found off, so it
    costs nothing on a good file."""
    for misread, cause in MISREADINGS:
        if fits(misread(centres)):
            return cause
    return otherwise


def approach_theta(approach: np.ndarray) -> np.ndarray:
    """Theta (degrees, 0..360) of the outward normal of each approach direction."""
    return np.degrees(np.arctan2(-approach[:, 1], -approach[:, 0])) % 360.0


@dataclass(frozen=True)
class Touches:
    """Stylus centres and approach directions, as read."""

    path: str
    stylus_radius: float
    centres: np.ndarray  #: (n, 2) x, z in mm
    approach: np.ndarray  #: (n, 2) unit vectors into the material
    lines: tuple[int, ...]  #: the data row of each touch
    extras: dict[str, str] = field(default_factory=dict)

    @property
    def theta(self) -> np.ndarray:
        return approach_theta(self.approach)

    def where(self, index: int) -> Location:
        return Location(self.path, self.lines[index])

    def touched(self, k: np.ndarray | None = None) -> np.ndarray:
        """Touched points, with pretravel corrections ``k`` (mm, one per touch) if given."""
        reach = self.stylus_radius + (0.0 if k is None else np.asarray(k))
        return self.centres + np.asarray(reach)[..., None] * self.approach


@dataclass(frozen=True)
class ProbeFile(Touches):
    datum_before: dict[str, float] = field(default_factory=dict)  #: axis ("x", "z") -> mm
    datum_after: dict[str, float] = field(default_factory=dict)
    repeatability: float | None = None


@dataclass(frozen=True)
class CalibrationRun(Touches):
    artifact_radius: float = 0.0
    artifact_centre: tuple[float, float] = (0.0, 0.0)

    def factors(self) -> np.ndarray:
        """k at each touch: measured radius minus artifact radius (docs/methods.md §9.2, eq. 4.4-4.5)."""
        measured = np.hypot(self.centres[:, 0] - self.artifact_centre[0], self.centres[:, 1] - self.artifact_centre[1])
        return measured - self.stylus_radius - self.artifact_radius


def _touches(table: Table) -> tuple[np.ndarray, np.ndarray, tuple[int, ...]]:
    columns = {name: np.array(table.column(name)) for name in COLUMNS}
    centres = np.column_stack([columns["x_mm"], columns["z_mm"]])
    approach = np.column_stack([columns["approach_x"], columns["approach_z"]])
    lengths = np.hypot(approach[:, 0], approach[:, 1])
    lines = tuple(table.lines.tolist())
    for line, length in zip(lines, lengths):
        if abs(length - 1.0) > UNIT_TOLERANCE:
            raise table.error(f"the approach vector has length {length:.6f}; it must be a unit vector (within 0.001)", line)
    # A touch repeated at the same stylus centre is kept: at a printout's 1 um a repeatability
    # check gives that to the last digit, and a row copied twice only weighs its point twice.
    return centres, approach / lengths[:, None], lines


def read_probe(path: str) -> ProbeFile:
    table = read_table(path, PROBE_MAGIC, PROBE_KEYS, [COLUMNS])
    stylus = table.number("stylus_radius_mm", positive=True, required=True)
    before = {axis: table.number(f"datum_before_{axis}_mm") for axis in "xz"}
    after = {axis: table.number(f"datum_after_{axis}_mm") for axis in "xz"}
    before = {axis: value for axis, value in before.items() if value is not None}
    after = {axis: value for axis, value in after.items() if value is not None}
    if set(before) != set(after):
        missing = sorted(set(before) ^ set(after))
        raise table.error(f"the datum is given before and after for different axes ({', '.join(missing)} unmatched)")
    repeatability = table.number("repeatability_mm", positive=True, at_most=(MAX_REPEATABILITY, (
        "no probe that repeats so poorly can measure a correction (at most 0.1 mm); micrometres written as "
        "millimetres?")))
    if before and repeatability is None:
        raise table.error("datum readings without repeatability_mm: the stability check needs it")
    centres, approach, lines = _touches(table)
    return ProbeFile(path, stylus, centres, approach, lines, table.extras, before, after, repeatability)


def read_calibration(path: str) -> CalibrationRun:
    table = read_table(path, CALIBRATION_MAGIC, CALIBRATION_KEYS, [COLUMNS])
    stylus = table.number("stylus_radius_mm", positive=True, required=True)
    radius = table.number("artifact_radius_mm", positive=True, required=True)
    centre = (table.number("artifact_center_x_mm", required=True), table.number("artifact_center_z_mm", required=True))
    centres, approach, lines = _touches(table)
    run = CalibrationRun(path, stylus, centres, approach, lines, table.extras, radius, centre)
    factors = run.factors()
    worst = int(np.argmax(np.abs(factors)))
    if abs(factors[worst]) > 0.5 * stylus:
        def fits(centres: np.ndarray) -> bool:
            return bool(np.all(np.abs(CalibrationRun(path, stylus, centres, approach, lines, {}, radius, centre)
                                      .factors()) <= 0.5 * stylus))

        cause = likely_cause(centres, fits, "not a touch on the artifact (check artifact_radius_mm and its centre)")
        raise table.error(f"this touch is {factors[worst]:+.4f} mm off the artifact's surface: {cause}", lines[worst])
    return run


def angular_distance(a: np.ndarray, b: float) -> np.ndarray:
    """Smallest difference between angles in degrees."""
    return np.abs((np.asarray(a) - b + 180.0) % 360.0 - 180.0)


def outside_directions(theta: np.ndarray, calibrated: np.ndarray, limit: float = 5.0) -> np.ndarray:
    """Indexes of directions more than ``limit`` degrees from every calibrated direction's range."""
    low, high = float(np.min(calibrated)), float(np.max(calibrated))
    centre = (low + high) / 2.0
    half = (high - low) / 2.0 + limit
    return np.nonzero(angular_distance(theta, centre) > half + 1e-9)[0]


