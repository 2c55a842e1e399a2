"""The virtual lathe's parameters: the ``[simulation]`` table of a machine profile.

Every key is optional; a profile without the table (or no profile) is a perfect machine
with an ideal probe. Unknown keys are refused (OptionError naming the file), as in every
postproc file. Lengths in mm, angles in degrees unless the name says otherwise, positions
in radius coordinates of the work coordinate system the part programs use.

``[simulation]``

- ``seed`` (int, 0): default seed of the noise generators (``--seed`` overrides).
- ``reference_x_mm``, ``reference_z_mm`` (0, 0): the machine's reference, the origin of the
  scaling, squareness and pitch terms (where the scales read true).
- ``pitch_mm`` (12): ballscrew pitch of the periodic term.
- ``squareness_rad`` (0): the X error per unit Z: ``e_x += s (z - z_ref)``.
- ``home_x_mm``, ``home_z_mm`` (unset): where the tool stands before a program, test or
  probing cycle starts; it sets the direction each axis last travelled (lost motion). Unset:
  each axis last moved in + (as after a reference return).
- ``rapid_mm_min`` (10000): rapid traverse rate (only the servo lag needs times).

``[[simulation.term]]``: general error terms, any number of them, each a table of its own:
a polynomial in the position about the reference, added to one axis's error,

    e_axis += value_mm (u / length_mm)^x_power (w / length_mm)^z_power,  u = x - x_ref, w = z - z_ref.

- ``axis`` (required): ``"x"`` or ``"z"``, the error the term adds to.
- ``value_mm`` (required): the term at u = w = ``length_mm`` (where it has both powers).
- ``x_power``, ``z_power`` (0, 0): whole numbers from 0 to 6.
- ``length_mm`` (100): the length the powers are taken over.

A bowed Z slide (X straightness along Z) is ``axis = "x"`` with ``z_power = 2``; a Z error
growing with X squared ``axis = "z"`` with ``x_power = 2``; a Z-carriage yaw carrying the
cross slide round (an error that grows with x times z) ``axis = "z"``, ``x_power = 1``,
``z_power = 1``. Unlike ``straightness_mm`` a term is not tied to a slide's span.

``[simulation.x]`` and ``[simulation.z]``: one axis each.

- ``scaling`` (0): actual minus nominal per unit length, about the reference.
- ``backlash_mm`` (0): lost motion b: the axis lags its command by b/2 in its direction of
  travel; after a reversal it stands still until the command has moved b.
- ``pitch_amplitude_mm`` (0): d in ``d sin(2 pi (z - z_ref) / pitch)``, for both axes a
  function of z (docs/methods.md §8).
- ``straightness_mm`` (0): the slide's straightness, a parabolic bow of this height at the
  middle of its span and zero at both ends: the X slide bows Z (a Z error over x), the Z slide
  bows X (an X error over z).
- ``straightness_span_mm`` ([low, high], the profile's soft limits of that axis).
- ``lag_s`` (0): servo time lag: the axis is where its command was ``lag_s`` earlier. A common
  lag only moves the tool along its path; a mismatch between the axes distorts it, by an
  amount that grows with the feed and flips with the direction of motion.

``[simulation.ballbar]``: the 720 deg test of docs/methods.md §3, or a partial arc.

- ``radius_mm`` (100), ``center_x_mm``, ``center_z_mm`` (0, 0): nominal test circle.
- ``feed_mm_min`` (1000).
- ``start_angle_deg`` (0): theta of the first captured sample.
- ``capture_arc_deg`` (360): the arc captured, from the start in the run's direction (a
  lathe's XZ test, ISO 13041-6: about 220, the turret stopping short of the spindle).
- ``overtravel_deg`` (180): the arc run before and after the capture (the full test's pre-
  and over-travel; a partial arc has room for a few degrees only).
- ``setup_offset_x_mm``, ``setup_offset_z_mm`` (0, 0): the pivot's position minus the
  nominal centre (the set-up error the reader removes; it reports the path's centre as seen
  from the pivot, i.e. minus this).
- ``noise_mm`` (0): standard deviation of each bar reading.
- ``spacing_deg`` (0.5): angle between processed samples.
- ``oversample`` (6): raw readings per processed sample.
- ``feed_in_mm`` (1.5): the radial feed-in and feed-out moves.

``[simulation.probe]``: the on-machine touch probe.

- ``stylus_radius_mm`` (3).
- ``pretravel_mm`` (0), ``lobing_mm`` (0), ``lobes`` (3), ``lobing_phase_deg`` (0): the
  probe triggers after the stylus centre has travelled on by
  ``d(theta) = pretravel + lobing cos(lobes (theta - phase))``, theta the angle of the
  outward surface normal (minus the approach direction), as the probe readers name it.
- ``noise_mm`` (0): standard deviation of each reported coordinate.
- ``standoff_mm`` (1): each approach starts this far from the nominal surface; a surface
  closer than that (or not met within as far again beyond nominal) is an error.
- ``points`` (36): touches along a profile.
- ``repeatability_mm`` (0.003): written to probe files for the stability check.
- ``datum_x_mm``, ``datum_z_mm`` (unset): a datum ring probed before and after the profile:
  its top face at z = ``datum_z_mm`` touched from +Z, its outside diameter (radius
  ``datum_x_mm``) touched from +X, both at (datum_x_mm, datum_z_mm). Each given axis is
  written as ``datum_before_*`` / ``datum_after_*`` (the reported stylus-centre coordinate).
- ``drift_x_mm``, ``drift_z_mm`` (0): thermal drift of the actual tool position over the
  probing session, growing linearly from the datum before to the datum after.

``[simulation.artifact]``: the calibration sphere.

- ``radius_mm`` (25.4), ``center_x_mm`` (80), ``center_z_mm`` (30): as given to postproc.
- ``y_offset_mm`` (0): how far the ball's centre really lies off the cutting plane (the probe
  then sees a circle of radius sqrt(R^2 - y^2)).
- ``step_deg`` (2.5): touches every step over the top 180 deg.

``[simulation.cut]``

- ``tool_offset_x_mm``, ``tool_offset_z_mm`` (0, 0): tool-setting error, added to the tool tip.
- ``deflection_x_mm``, ``deflection_z_mm`` (0, 0): the cutting force pushes the tool away from
  the material along the surface normal m by ``deflection_x m_x^2 + deflection_z m_z^2``.
- ``tool_y_mm`` (0): the tool tip's height off the Y = 0 plane; the tip cuts radius
  ``sqrt(x^2 + y^2)`` and never reaches the spindle axis.
- ``nub_height_mm`` (0): the stock the previous pass left; where the tool did not reach the
  axis, a nub this high remains (docs/methods.md §9).
- ``spindle_rpm`` (1000): converts feeds per revolution (G99) into mm/min; G96 is not modelled.
- ``step_mm`` (0.02): spacing of the surface polyline.

``[simulation.cmm]``: the virtual CMM of ``inspect``.

- ``noise_mm`` (0), ``points`` (36).
"""

from __future__ import annotations

import dataclasses
import math
import zlib
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..machine import profile as profiles
from ..diagnostics import Location, OptionError

ANY, NONNEGATIVE, POSITIVE, COUNT, PAIR, OPTIONAL = "any", "nonnegative", "positive", "count", "pair", "optional"
AXIS = "axis"
REQUIRED = object()  #: the default of a key every table must give
MAX_POWER = 6  #: highest power of a general error term


def _key(default: Any, rule: str = ANY, low: int = 0, high: int | None = None):
    """A configuration field: its default, the rule its value obeys, and a count's bounds."""
    return field(default=default, metadata={"rule": rule, "low": low, "high": high})


@dataclass(frozen=True, slots=True)
class Axis:
    scaling: float = _key(0.0)
    backlash_mm: float = _key(0.0, NONNEGATIVE)
    pitch_amplitude_mm: float = _key(0.0)
    straightness_mm: float = _key(0.0)
    straightness_span_mm: tuple[float, float] | None = _key(None, PAIR)
    lag_s: float = _key(0.0, NONNEGATIVE)


@dataclass(frozen=True, slots=True)
class Ballbar:
    radius_mm: float = _key(100.0, POSITIVE)
    center_x_mm: float = _key(0.0)
    center_z_mm: float = _key(0.0)
    feed_mm_min: float = _key(1000.0, POSITIVE)
    start_angle_deg: float = _key(0.0)
    capture_arc_deg: float = _key(360.0, POSITIVE)
    overtravel_deg: float = _key(180.0, NONNEGATIVE)
    setup_offset_x_mm: float = _key(0.0)
    setup_offset_z_mm: float = _key(0.0)
    noise_mm: float = _key(0.0, NONNEGATIVE)
    spacing_deg: float = _key(0.5, POSITIVE)
    oversample: int = _key(6, COUNT, 1)
    feed_in_mm: float = _key(1.5, POSITIVE)


@dataclass(frozen=True, slots=True)
class Probe:
    stylus_radius_mm: float = _key(3.0, POSITIVE)
    pretravel_mm: float = _key(0.0)
    lobing_mm: float = _key(0.0)
    lobes: int = _key(3, COUNT, 0)
    lobing_phase_deg: float = _key(0.0)
    noise_mm: float = _key(0.0, NONNEGATIVE)
    standoff_mm: float = _key(1.0, POSITIVE)
    points: int = _key(36, COUNT, 2)
    repeatability_mm: float = _key(0.003, POSITIVE)
    datum_x_mm: float | None = _key(None, OPTIONAL)
    datum_z_mm: float | None = _key(None, OPTIONAL)
    drift_x_mm: float = _key(0.0)
    drift_z_mm: float = _key(0.0)

    def pretravel(self, theta_deg) -> np.ndarray:
        """How far the stylus centre travels on past the touch before the probe triggers (mm)."""
        theta = np.radians(np.asarray(theta_deg, dtype=float) - self.lobing_phase_deg)
        return self.pretravel_mm + self.lobing_mm * np.cos(self.lobes * theta)


@dataclass(frozen=True, slots=True)
class Artifact:
    radius_mm: float = _key(25.4, POSITIVE)
    center_x_mm: float = _key(80.0)
    center_z_mm: float = _key(30.0)
    y_offset_mm: float = _key(0.0)
    step_deg: float = _key(2.5, POSITIVE)


@dataclass(frozen=True, slots=True)
class Cut:
    tool_offset_x_mm: float = _key(0.0)
    tool_offset_z_mm: float = _key(0.0)
    deflection_x_mm: float = _key(0.0)
    deflection_z_mm: float = _key(0.0)
    tool_y_mm: float = _key(0.0)
    nub_height_mm: float = _key(0.0, NONNEGATIVE)
    spindle_rpm: float = _key(1000.0, POSITIVE)
    step_mm: float = _key(0.02, POSITIVE)


@dataclass(frozen=True, slots=True)
class Cmm:
    noise_mm: float = _key(0.0, NONNEGATIVE)
    points: int = _key(36, COUNT, 2)


@dataclass(frozen=True, slots=True)
class Term:
    """A general error term: ``value_mm (u / length_mm)^x_power (w / length_mm)^z_power`` added to one axis."""

    axis: str = _key(REQUIRED, AXIS)
    value_mm: float = _key(REQUIRED)
    x_power: int = _key(0, COUNT, 0, MAX_POWER)
    z_power: int = _key(0, COUNT, 0, MAX_POWER)
    length_mm: float = _key(100.0, POSITIVE)

    def at(self, u, w) -> np.ndarray:
        """The term at offsets (u, w) from the reference, mm."""
        u = np.asarray(u, dtype=float) / self.length_mm
        w = np.asarray(w, dtype=float) / self.length_mm
        return self.value_mm * u**self.x_power * w**self.z_power


TABLES = {"x": Axis, "z": Axis, "ballbar": Ballbar, "probe": Probe, "artifact": Artifact, "cut": Cut, "cmm": Cmm}


@dataclass(frozen=True, slots=True)
class Simulation:
    """The whole virtual machine. ``Simulation()`` is a perfect one."""

    seed: int = _key(0, COUNT, 0)
    reference_x_mm: float = _key(0.0)
    reference_z_mm: float = _key(0.0)
    pitch_mm: float = _key(12.0, POSITIVE)
    squareness_rad: float = _key(0.0)
    home_x_mm: float | None = _key(None, OPTIONAL)
    home_z_mm: float | None = _key(None, OPTIONAL)
    rapid_mm_min: float = _key(10000.0, POSITIVE)
    x: Axis = field(default_factory=Axis)
    z: Axis = field(default_factory=Axis)
    ballbar: Ballbar = field(default_factory=Ballbar)
    probe: Probe = field(default_factory=Probe)
    artifact: Artifact = field(default_factory=Artifact)
    cut: Cut = field(default_factory=Cut)
    cmm: Cmm = field(default_factory=Cmm)
    term: tuple[Term, ...] = ()  #: the general error terms, in the order given
    origin: str = field(default="<perfect machine>", compare=False)  #: the profile it came from

    def axis(self, name: str) -> Axis:
        return self.x if name == "x" else self.z

    @property
    def home(self) -> tuple[float | None, float | None]:
        return (self.home_x_mm, self.home_z_mm)


def load(path: str | None) -> tuple[Simulation, profiles.MachineProfile]:
    """The simulation and the machine profile of a TOML file; no file: a perfect default lathe."""
    if path is None:
        return from_table({}, profiles.DEFAULT), profiles.DEFAULT
    profile = profiles.load(path)
    return from_table(profile.extra.get("simulation", {}), profile, path), profile


def from_table(table: Any, profile: profiles.MachineProfile = profiles.DEFAULT, origin: str = "<profile>") -> Simulation:
    """Check a ``[simulation]`` table and fill in the defaults (straightness spans: soft limits).
    An error names the key's line and column in the profile it was read from."""
    text = None
    if profile.source is not None and profile.source == origin:
        from ..files import inputs

        text = inputs.read_toml(origin, profiles.MAX_BYTES, OptionError, "a machine profile")[1]  # read once a session
    if not isinstance(table, dict):
        raise OptionError("'simulation' must be a table", _at(origin, text, "simulation"))
    values = _fields(Simulation, table, "simulation", origin, tables=TABLES, lists={"term": Term}, text=text)
    # Without soft limits in the profile, the V40R's travel (docs/methods.md §1) spans the bow.
    spans = {"x": profile.x_limits or (-5.0, 265.0), "z": profile.z_limits or (-450.0, 450.0)}
    for name in ("x", "z"):
        axis = values.get(name, Axis())
        if axis.straightness_span_mm is None:
            axis = dataclasses.replace(axis, straightness_span_mm=tuple(spans[name]))
        values[name] = axis
    return Simulation(**values, origin=origin)


def _at(origin: str, text: str | None, name: str) -> Location:
    """Where a key of the ``[simulation]`` table is written: ``simulation.x.backlash_mm``, or
    ``simulation.term[2].axis`` in the second ``[[simulation.term]]``."""
    if text is None:
        return Location(origin)
    from ..files.inputs import toml_key

    *tables, key = name.split(".")
    occurrence = 1
    if key.endswith("]"):  # an item of an array of tables: its header
        key = key.partition("[")[0]
    elif tables and tables[-1].endswith("]"):  # a key of such an item: term[2]
        tables[-1], _, index = tables[-1][:-1].partition("[")
        occurrence = int(index)
    return toml_key(origin, text, key, ".".join(tables) or None, occurrence)


def _fields(cls, table: dict, where: str, origin: str, tables: dict | None = None,
            lists: dict | None = None, text: str | None = None) -> dict[str, Any]:
    known = {f.name: f for f in dataclasses.fields(cls) if f.name != "origin"}
    tables, lists = tables or {}, lists or {}
    values: dict[str, Any] = {}
    for key, value in table.items():
        name = f"{where}.{key}"
        if key in tables:
            if not isinstance(value, dict):
                raise OptionError(f"'{name}' must be a table", _at(origin, text, name))
            values[key] = tables[key](**_fields(tables[key], value, name, origin, text=text))
        elif key in lists:
            if not (isinstance(value, list) and all(isinstance(item, dict) for item in value)):
                raise OptionError(f"'{name}' must be an array of tables ([[{name}]])", _at(origin, text, name))
            values[key] = tuple(lists[key](**_fields(lists[key], item, f"{name}[{index + 1}]", origin, text=text))
                                for index, item in enumerate(value))
        elif key in known and known[key].metadata:
            values[key] = _checked(name, value, known[key].metadata, _at(origin, text, name))
        else:
            from ..files.inputs import did_you_mean

            choices = sorted(k for k in known if k not in tables and k not in lists)
            raise OptionError(f"unknown key '{name}' in the machine profile{did_you_mean(key, choices)} "
                              f"(known here: {', '.join(choices)})", _at(origin, text, name))
    missing = [f.name for f in known.values() if f.metadata and f.metadata["rule"] != OPTIONAL
               and f.default is REQUIRED and f.name not in values]
    if missing:
        raise OptionError(f"'{where}' needs {', '.join(repr(m) for m in missing)}", _at(origin, text, where))
    return values


def _checked(name: str, value: Any, rule: dict, where: Location) -> Any:
    kind = rule["rule"]
    if kind == COUNT:
        high = rule["high"]
        if not isinstance(value, int) or isinstance(value, bool) or value < rule["low"] or (high is not None and value > high):
            bounds = f"from {rule['low']} to {high}" if high is not None else f"of at least {rule['low']}"
            raise OptionError(f"'{name}' must be a whole number {bounds}", where)
        return value
    if kind == AXIS:
        if value not in ("x", "z"):
            raise OptionError(f"'{name}' must be \"x\" or \"z\"", where)
        return value
    if kind == PAIR:
        if not (isinstance(value, list) and len(value) == 2 and all(_number(v) for v in value)) or not value[0] < value[1]:
            raise OptionError(f"'{name}' must be a list of two numbers, the lower first", where)
        return (float(value[0]), float(value[1]))
    if not _number(value):
        raise OptionError(f"'{name}' must be a number", where)
    value = float(value)
    if kind == POSITIVE and not value > 0:
        raise OptionError(f"'{name}' must be positive", where)
    if kind == NONNEGATIVE and value < 0:
        raise OptionError(f"'{name}' cannot be negative", where)
    return value


def _number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def generator(seed: int, stream: str) -> np.random.Generator:
    """The noise of one kind of run: the same seed and stream give the same numbers everywhere."""
    return np.random.default_rng([seed, zlib.crc32(stream.encode())])
