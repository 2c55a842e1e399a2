"""The predicted profile of a program before and after compensation, on the virtual lathe.

The program's profile is its first continuous chain of feed moves (:mod:`postproc.measure.nominal`).
Deviations are read, as the virtual CMM reads them, where a surface crosses the nominal
normal at stations evenly spaced along the profile: positive = material left. Three things
can be predicted there:

- the **correction**, as the compensators ask for it on the nominal path, and as emitted:
  the compensated program (the very blocks ``compensate`` writes, segmented and rounded)
  cut on a perfect machine, against the nominal: the two differ by what the tolerance and
  the control's resolution allow;
- from a **ballbar test**, before and after: the machine the traces' parametric diagnosis
  describes (:func:`postproc.measure.ballbar_analysis.diagnose`: scaling, backlash, squareness and
  the servo mismatch as lags, about the test centre) is built as a virtual lathe, and the
  program and the compensated program are cut on it. Nothing else is on that machine (no
  tool setting, deflection or nub: what a ballbar cannot see);
- from **probe points**, before and after: the probed deviation (screened, minus the stock of
  the probed pass) is what the next pass repeats, the premise of the probe compensators, and
  the correction moves it: after = before + correction, at each probed point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..measure.ballbar_analysis import Diagnosis
from ..diagnostics import PostprocError, Reporter
from ..interpret.motion import CONTOUR, CYCLE, Move
from ..machine.profile import MachineProfile
from ..interpret.program import interpret_source
from ..simulator import Nominal, Simulation, cut, nominal
from ..simulator.config import Axis
from ..simulator.surface import Turned
from ..syntax.source import Source

STATION_SPACING = 0.25  #: mm between stations along the profile
STATIONS = (61, 401)  #: fewest and most stations
INSET = 0.05  #: mm: the first and last stations lie this far inside the profile's ends
REACH = 1.0  #: mm: a surface farther than this from the nominal is not this profile's surface


@dataclass(frozen=True)
class Program:
    """A program's moves as the control runs them, and its profile."""

    name: str
    moves: list[Move]
    nominal: Nominal | None  #: None when the program turns no surface
    note: str = ""  #: why there is no profile


def read_program(name: str, data: bytes, profile: MachineProfile, reporter: Reporter | None = None,
                 material: str = "axis") -> Program:
    """Interpret a program held in memory (its errors raise) and find its profile."""
    with Source.from_text(data, name) as source:
        moves = [move for step in interpret_source(source, profile, reporter or Reporter()) for move in step.moves]
    moves = [move for move in moves if move.role != CONTOUR and move.kind != CYCLE and move.known]
    try:
        return Program(name, moves, nominal(moves, material=material, program=name))
    except PostprocError as exc:
        return Program(name, moves, None, exc.message)


@dataclass(frozen=True)
class Stations:
    """Where the profile is read: points, outward normals, arc length."""

    points: np.ndarray
    normals: np.ndarray
    s: np.ndarray

    @classmethod
    def along(cls, nominal: Nominal) -> "Stations":
        """Evenly spaced, the ends held ``INSET`` inside the profile: an end on the spindle axis
        has no surface to cross along its normal when the tool path crosses the axis."""
        profile = nominal.profile
        count = int(np.clip(math.ceil(profile.length / STATION_SPACING) + 1, *STATIONS))
        inset = min(INSET, profile.length / (4 * count))
        s = np.linspace(inset, profile.length - inset, count)
        segment = np.clip(np.searchsorted(profile.offsets, s, side="right") - 1, 0, len(profile.segments) - 1)
        lengths = np.diff(profile.offsets)
        param = np.clip((s - profile.offsets[segment]) / lengths[segment], 0.0, 1.0)
        points = np.array([profile.segments[i].point_at(t) for i, t in zip(segment, param)])
        return cls(points, nominal.outward(segment, param), s)


@dataclass(frozen=True)
class Machine:
    """A virtual lathe built from a ballbar diagnosis, and what it leaves out."""

    simulation: Simulation
    notes: list[str]


def machine_of(diagnosis: Diagnosis, centre: tuple[float, float]) -> Machine:
    """The fitted errors as a virtual lathe: its reference at the test centre (where the
    fitted scaling and squareness are zero), the servo mismatch as a lag of one axis."""
    notes = []
    squareness = diagnosis.squareness
    if squareness is None:
        squareness = diagnosis.apparent_squareness
        notes.append("one trace only: its apparent squareness (squareness plus its share of the servo mismatch) "
                     "stands for the squareness, and no servo mismatch is modelled")
    backlash = {}
    for axis, estimate in (("x", diagnosis.backlash_x), ("z", diagnosis.backlash_z)):
        backlash[axis] = max(estimate.value, 0.0)
        if estimate.value < 0.0:
            notes.append(f"the fitted {axis.upper()} backlash is negative ({estimate.value * 1000:+.2f} um): "
                         "modelled as none")
    lags = {"x": 0.0, "z": 0.0}
    if diagnosis.servo_mismatch is not None:
        if diagnosis.feed:
            lag = diagnosis.servo_mismatch.value / (diagnosis.feed / 60.0)
            lags["x" if lag > 0 else "z"] = abs(lag)
            notes.append(f"the servo mismatch is modelled as a lag of {abs(lag) * 1000:.3f} ms of the "
                         f"{'X' if lag > 0 else 'Z'} axis; feeds per revolution are timed at "
                         f"{Simulation().cut.spindle_rpm:g} rpm, so its share is indicative")
        else:
            notes.append("the traces state no common feed: the servo mismatch is left out")
    simulation = Simulation(
        reference_x_mm=centre[0], reference_z_mm=centre[1], squareness_rad=squareness.value,
        x=Axis(scaling=diagnosis.scaling_x.value, backlash_mm=backlash["x"], lag_s=lags["x"]),
        z=Axis(scaling=diagnosis.scaling_z.value, backlash_mm=backlash["z"], lag_s=lags["z"]),
        origin="<ballbar diagnosis>")
    notes.append("the machine is the diagnosis only (scaling per axis, backlash, squareness, servo mismatch): "
                 "no pitch error, tool setting, cutting deflection or nub, which a ballbar does not see")
    return Machine(simulation, notes)


def surface(program: Program, simulation: Simulation | None = None) -> Turned:
    """What the program's profile leaves on a machine (a perfect one by default)."""
    return cut(program.moves, program.nominal, simulation or Simulation())


def read_surface(turned: Turned, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Deviation of a surface along each normal (mm, + = material left); NaN where it does not cross."""
    values = [turned.crossing(point, normal, REACH) for point, normal in zip(points, normals)]
    return np.array([np.nan if value is None else value for value in values], dtype=float)


def intended(program: Program, compensators: list, stations: Stations) -> np.ndarray:
    """The correction the compensators ask for on the nominal path, before the segmenter
    plans and rounds it: along the outward normal at the stations, mm.

    Asked piece by piece as the rewriter asks (split at axis reversals, each axis's last
    direction of travel carried from move to move), projected on the profile, interpolated.
    """
    from ..compensate.rewrite import pieces, travel_after

    nominal = program.nominal
    chosen = set(nominal.indexes)
    where, along = [], []
    last = (0, 0)
    for index, move in enumerate(program.moves):
        if index in chosen:
            for piece in pieces(move, last):
                points = piece.points
                total = np.zeros_like(points)
                for compensator in compensators:
                    shift = compensator.correct(piece)
                    if shift is not None:
                        total = total + np.asarray(shift, dtype=float)
                near = nominal.profile.closest(points)
                normals = nominal.outward(near.index, near.param)
                where.append(near.s)
                along.append(np.einsum("ij,ij->i", total, normals))
        last = travel_after(move, last)
    s, values = np.concatenate(where), np.concatenate(along)
    order = np.argsort(s, kind="stable")
    return np.interp(stations.s, s[order], values[order])


@dataclass
class Prediction:
    """Deviations along the profile at the stations; None where they cannot be predicted."""

    stations: Stations
    correction: np.ndarray | None = None  #: as emitted, along the outward normal, mm
    intended: np.ndarray | None = None  #: as the compensators ask for it on the nominal path, mm
    before: np.ndarray | None = None  #: the ballbar machine cutting the program
    after: np.ndarray | None = None  #: the ballbar machine cutting the compensated program
    notes: list[str] = field(default_factory=list)


def predict(program: Program, compensated: Program | None, machine: Machine | None,
            compensators: list | None = None) -> Prediction:
    """Correction (intended and emitted), before and after at the stations of ``program``'s profile."""
    stations = Stations.along(program.nominal)
    result = Prediction(stations)
    if compensators and compensated is not None:
        try:
            result.intended = intended(program, compensators, stations)
        except Exception as exc:  # a compensator's own failure: the emitted correction still stands
            result.notes.append(f"the intended correction could not be asked for: {exc.__class__.__name__}: {exc}")
    if compensated is not None:
        if compensated.nominal is None:
            result.notes.append(f"the compensated program turns no surface: {compensated.note}")
            compensated = None
        else:
            result.correction = read_surface(surface(compensated), stations.points, stations.normals)
            result.notes += _gaps(result.correction, "the compensated path")
    if machine is not None:
        result.before = read_surface(surface(program, machine.simulation), stations.points, stations.normals)
        result.notes += _gaps(result.before, "the program cut on the fitted machine")
        if compensated is not None:
            result.after = read_surface(surface(compensated, machine.simulation), stations.points, stations.normals)
            result.notes += _gaps(result.after, "the compensated program cut on the fitted machine")
    return result


def _gaps(values: np.ndarray, what: str) -> list[str]:
    missing = int(np.count_nonzero(~np.isfinite(values)))
    if not missing:
        return []
    return [f"{what} does not come within {REACH:g} mm of the nominal at {missing} of {len(values)} stations "
            "(left out)"]
