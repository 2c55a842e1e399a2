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
from ...machine.bounds import MAX_CORRECTION
from .lengths import DIAMETERS, MAX_TRAVEL, RADII, WRITTEN, misreading, stylus_problem, travel_problem

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
#: mm; no datum vouching for a profile's touches lies further from all of them
DATUM_REACH_MM = 1000.0
#: A touch-trigger probe triggers after contact, so the touched artifact reads smaller than it is
#: by the pretravel: some micrometres, a few tens with a long stylus (mm)
MAX_PRETRAVEL_MM = 0.05
#: (what the file's stylus centres and stylus radius become, the likely cause), tried in order
#: when touches lie far off what was probed (the profile, the artifact)
MISREADINGS = (
    (lambda c, r: (c / 1000.0, r), "micrometres written as millimetres? (the coordinates divided by 1000 fit)"),
    (lambda c, r: (c * np.array([0.5, 1.0]), r), "x written as a diameter? (x is a radius, as in `postproc path`; "
                                                 "halved, it fits: a printout's D 1 where X was printed as a "
                                                 "diameter, D 2?)"),
    (lambda c, r: (c * np.array([2.0, 1.0]), r), "x halved twice? (doubled, it fits: a printout's D 2 where X was "
                                                 "printed as a radius, D 1?)"),
    (lambda c, r: (c / 25.4, r), "millimetres read as inches? (the coordinates divided by 25.4 fit: a printout "
                                 "headed G 20 whose numbers are millimetres?)"),
    (lambda c, r: (c * 25.4, r * 25.4), "inches written as millimetres? (every length times 25.4 fits)"),
    (lambda c, r: (c, r / 2.0), "stylus_radius_mm is the ball's diameter? (halved, it fits)"),
    (lambda c, r: (c, r * 2.0), "stylus_radius_mm is half the ball's radius? (doubled, it fits)"),
    (lambda c, r: (c, r * 25.4), "stylus_radius_mm in inches? (times 25.4, it fits)"),
)


def likely_cause(touches: "Touches", fits, otherwise: str) -> str:
    """Why touches lie far off what was probed: the first of :data:`MISREADINGS` under which
    ``fits(centres, stylus_radius)`` holds, else ``otherwise``. Asked only once touches are
    found off, so it costs nothing on a good file."""
    for misread, cause in MISREADINGS:
        if fits(*misread(touches.centres, touches.stylus_radius)):
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
    far = np.nonzero(np.abs(centres) > MAX_TRAVEL)
    if len(far[0]):
        row, column = int(far[0][0]), int(far[1][0])
        raise table.error(f"{COLUMNS[column]} = {centres[row, column]:g}: {travel_problem(centres[row, column])}",
                          lines[row])
    # A touch repeated at the same stylus centre is kept: at a printout's 1 um a repeatability
    # check gives that to the last digit, and a row copied twice only weighs its point twice.
    return centres, approach / lengths[:, None], lines


def _stylus(table: Table) -> float:
    stylus = table.number("stylus_radius_mm", positive=True, required=True)
    problem = stylus_problem(stylus)
    if problem:
        raise table.error(f"stylus_radius_mm = {stylus:g}: {problem}", table.header["stylus_radius_mm"][1])
    return stylus


def _datum(table: Table, repeatability: float | None, centres: np.ndarray) -> tuple[dict[str, float], dict[str, float]]:
    """The datum readings before and after the profile, axis -> mm, in pairs.

    A pair that is no drift of one datum (:func:`_misread_datum`: readings more than any
    correction apart) is no move of the machine
    a forced run could use (``--force`` covers a datum that moved by more than the
    repeatability), but a value misread: refused at its line, naming how."""
    keys = {(phase, axis): f"datum_{phase}_{axis}_mm" for phase in ("before", "after") for axis in "xz"}
    read = {place: table.coordinate(key) for place, key in keys.items()}
    given = {place: value for place, value in read.items() if value is not None}
    for (phase, axis) in given:
        other = "after" if phase == "before" else "before"
        if (other, axis) not in given:
            raise table.error(f"{keys[phase, axis]} without {keys[other, axis]}: the stability check needs the same "
                              "datum touched before and after the profile", table.header[keys[phase, axis]][1])
    stable = repeatability if repeatability is not None else MAX_REPEATABILITY
    for axis in "xz":
        if ("before", axis) in given:
            found = _misread_datum(given["before", axis], given["after", axis], stable, centres[:, "xz".index(axis)],
                                   WRITTEN + DIAMETERS if axis == "x" else WRITTEN)
            if found:
                phase, cause, how = found
                before, after = given["before", axis], given["after", axis]
                raise table.error(f"datum_before_{axis}_mm = {before:g} and datum_after_{axis}_mm = {after:g} differ "
                                  f"by {abs(after - before):.4f} mm, {how}, which no forced run can use: {cause}; "
                                  "correct the file, or probe again", table.header[keys[phase, axis]][1])
    return ({axis: value for (phase, axis), value in given.items() if phase == "before"},
            {axis: value for (phase, axis), value in given.items() if phase == "after"})


def _misread_datum(before: float, after: float, stable: float, touched: np.ndarray,
                   readings) -> tuple[str, str, str] | None:
    """(the reading misread, the likely cause, what gives it away) of a datum pair that is no
    drift of one datum, or None. Readings more than a correction apart: the one that, read
    otherwise, agrees best with the other; else both in um or inches when so read they drift by
    no more than ``stable`` and lie nearer the ``touched`` stretch of the axis; else two datums.
    A datum that drifts by less, far from every touch, is :func:`far_datum_cause`'s."""
    if abs(after - before) <= MAX_CORRECTION:
        return None
    how = f"more than any correction ({MAX_CORRECTION:g} mm)"
    agree = sorted((abs(value * factor - fixed), phase, explain(value))
                   for phase, fixed, value in (("after", before, after), ("before", after, before))
                   for factor, explain in readings if abs(value * factor - fixed) <= MAX_CORRECTION)
    if agree:
        return agree[0][1], agree[0][2], how
    both = _both_misread(before, after, stable, touched, _off(before, touched))
    return "before", (f"both readings {both}" if both else
                      "not one datum touched twice (another face or diameter, or a digit wrong)"), how


def far_datum_cause(before: float, after: float, stable: float, touched: np.ndarray) -> str | None:
    """For a datum pair that drifts by more than ``stable``: when the datum lies further than
    DATUM_REACH_MM from every touch and, both readings read in um (or inches), would be stable and
    within DATUM_REACH_MM of the touches, that misreading, said beside the move (a long part's datum
    may lie that far, so it is no refusal of its own: the move's, which --force may take)."""
    off = _off(before, touched)
    both = _both_misread(before, after, stable, touched, DATUM_REACH_MM) if off > DATUM_REACH_MM else None
    return f"as the datum lies {off:.0f} mm from every touch, both readings {both}" if both else None


def _off(value: float, touched: np.ndarray) -> float:
    """How far a datum reading lies from the stretch of its axis the touches cover (mm)."""
    return max(float(touched.min()) - value, value - float(touched.max()), 0.0)


def _both_misread(before: float, after: float, stable: float, touched: np.ndarray, near: float) -> str | None:
    """The misreading (um, inches) under which both readings drift by no more than ``stable`` and
    the datum lies nearer than ``near`` to the touches, or None."""
    return next((explain(after - before) for factor, explain in WRITTEN
                 if abs(after - before) * factor <= stable and _off(before * factor, touched) < near), None)


def read_probe(path: str) -> ProbeFile:
    table = read_table(path, PROBE_MAGIC, PROBE_KEYS, [COLUMNS])
    stylus = _stylus(table)
    repeatability = table.number("repeatability_mm", positive=True, at_most=(MAX_REPEATABILITY, (
        "no probe that repeats so poorly can measure a correction (at most 0.1 mm); micrometres written as "
        "millimetres?")))
    centres, approach, lines = _touches(table)
    before, after = _datum(table, repeatability, centres)
    if before and repeatability is None:
        first = min(table.header[key][1] for key in table.header if key.startswith("datum_"))
        raise table.error("datum readings without repeatability_mm: the stability check needs it", first)
    return ProbeFile(path, stylus, centres, approach, lines, table.extras, before, after, repeatability)


def read_calibration(path: str) -> CalibrationRun:
    table = read_table(path, CALIBRATION_MAGIC, CALIBRATION_KEYS, [COLUMNS])
    stylus = _stylus(table)
    radius = table.number("artifact_radius_mm", positive=True, required=True)
    centre = (table.coordinate("artifact_center_x_mm", required=True),
              table.coordinate("artifact_center_z_mm", required=True))
    centres, approach, lines = _touches(table)
    run = CalibrationRun(path, stylus, centres, approach, lines, table.extras, radius, centre)
    factors = run.factors()
    worst = int(np.argmax(np.abs(factors)))
    if abs(factors[worst]) > 0.5 * stylus:
        def fits(centres: np.ndarray, stylus: float) -> bool:  # read so, every k is a pretravel
            return bool(np.all(np.abs(CalibrationRun(path, stylus, centres, approach, lines, {}, radius, centre)
                                      .factors()) <= MAX_PRETRAVEL_MM))

        def artifact_fits(meant: float) -> bool:
            return bool(np.all(np.abs(factors + radius - meant) <= MAX_PRETRAVEL_MM))

        artifact = misreading(radius, artifact_fits, RADII)
        cause = likely_cause(run, fits, f"artifact_radius_mm = {radius:g}: {artifact}" if artifact else
                             "not a touch on the artifact (check artifact_radius_mm and its centre)")
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


