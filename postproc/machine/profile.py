"""Machine profiles: what postproc must know about the control and the machine.

A profile is a TOML file (read with :mod:`tomllib`); the embedded default is a FANUC
18i-T-like two-axis lathe, metric, diameter programming, G-code system A, IS-B increments.
Everything the interpreter, the segmenter and the safety checks assume about a machine
comes from here, so a shop describes its lathe once.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
from dataclasses import dataclass, field
from typing import Any

from . import bounds
from .bounds import MAX_TOLERANCE
from .resolution import Grid
from ..diagnostics import Location, OptionError

INCREMENTS = {  # least input increment per system: (mm, inch)
    "IS-A": (0.01, 0.001),
    "IS-B": (0.001, 0.0001),
    "IS-C": (0.0001, 0.00001),
}


@dataclass(frozen=True, slots=True)
class MachineProfile:
    """A lathe and its control. Lengths in mm unless the name says otherwise."""

    name: str = "fanuc-18i-t"
    controller: str = "FANUC Series 18i-TB"
    gcode_system: str = "A"  #: FANUC lathe G-code system A, B or C
    diameter_x: bool = True  #: X (and U) are diameters
    input_increment: str = "IS-B"  #: least input increment system
    #: A length without a decimal point is in mm or inches (FANUC parameter 3401 bit 0, DPI), not
    #: in least input increments. None: not stated; read as the FANUC default (increments), and
    #: a program that mixes both spellings is refused by compensate.
    calculator_input: bool | None = None
    label_skip: bool = True  #: after the opening %, the control skips up to the first end of block
    axes: str = "XZ"  #: the axes this lathe has
    arc_radius_tolerance: float = 0.01  #: the control's arc check: start and end radii may differ by this
    max_arc_radius: float = 5000.0  #: an arc above this radius is emitted as lines
    min_block_time_s: float = 0.001  #: shortest block the look-ahead digests at full feed
    max_spindle_rpm: float = 4000.0  #: the spindle's top speed (bounds G96 near the axis)
    nose_radius_mm: float = 0.4  #: no block under G41/G42 shorter than this (the interference check)
    x_limits: tuple[float, float] | None = None  #: soft limits of x (radius mm, work coordinates); None: not set
    z_limits: tuple[float, float] | None = None  #: soft limits of z (mm, work coordinates)
    tolerance: float | None = None  #: default tolerance; None: the rule of docs/formats.md §8.1
    max_correction: float = 0.1  #: largest correction allowed anywhere
    model_max_age_days: float = 30.0  #: a saved model measured longer ago than this gets a warning
    plugin_time_limit_s: float = 60.0  #: a compensator call that runs longer is stopped and named
    output_decimals_mm: int = 3  #: decimals written for mm values
    output_decimals_inch: int = 4  #: decimals written for inch values
    spindle_speed_fluctuation: bool = False
    extra: dict[str, Any] = field(default_factory=dict, compare=False)
    #: the file the profile was read from and the SHA-256 of its bytes ("" for the embedded
    #: default): what identifies a profile, whose ``name`` may be left at the default's
    source: str = field(default="", compare=False)
    source_sha256: str = field(default="", compare=False)

    def increment(self, inch: bool) -> float:
        """Least input increment in program units."""
        return INCREMENTS[self.input_increment][1 if inch else 0]

    def grid(self, inch: bool) -> Grid:
        """The number grid of what this control is written: the decimals of the program's units,
        X as a diameter or a radius."""
        return Grid(self.output_decimals_inch if inch else self.output_decimals_mm, inch, self.diameter_x)

    def resolution_mm(self, inch: bool) -> float:
        """Output resolution in millimetres."""
        decimals = self.output_decimals_inch if inch else self.output_decimals_mm
        return 10.0**-decimals * (25.4 if inch else 1.0)

    def default_tolerance(self, inch: bool) -> float:
        """docs/formats.md §8.1: 0.001 mm, or twice the output resolution where that is larger.

        An inch program written to 0.0001 in (2.54 um) cannot be held to 1 um, so it gets
        0.00508 mm. A metric program written to 0.001 mm can: the segmenter picks, among the
        grid points around each vertex, the one nearest the path, so rounding spends only
        part of the tolerance, and 1 um is kept; coarser metric output gets twice its step.
        """
        if self.tolerance is not None:
            return self.tolerance
        step = self.resolution_mm(inch)
        return min(max(0.001, 2.0 * step) if (inch or step > 0.001) else 0.001, MAX_TOLERANCE)

    def finer_output(self, inch: bool, largest: float) -> str | None:
        """What to do when the default tolerance is the output grid's (twice its step, above
        1 um) and the largest correction (mm) lies within it: the fewest output decimals (by
        their profile key) whose default tolerance is below the correction, else the finest the
        control's least input increment allows with a finer ``--tolerance``. None when the
        default tolerance is not the grid's (a profile's ``tolerance``, or 1 um)."""
        if self.tolerance is not None or self.default_tolerance(inch) <= 0.001:
            return None
        unit = "inch" if inch else "mm"
        key = f"output_decimals_{unit}"
        now = getattr(self, key)
        said = f"the default tolerance is twice the output step of {10.0 ** -now:g} {unit}, {key} = {now} in the machine profile"
        rounding = self.resolution_mm(inch) / 2.0
        if rounding >= largest:
            said += f", and the blocks' rounding alone, up to {rounding * 1000:.2f} um, is as large as the correction"
        finest = round(-math.log10(self.increment(inch)))
        for decimals in range(now + 1, finest + 1):
            if dataclasses.replace(self, **{key: decimals}).default_tolerance(inch) < largest:
                return f"{said}: set {key} = {decimals}, or give a finer --tolerance"
        increment = f"the control's least input increment ({self.input_increment}, {self.increment(inch):g} {unit})"
        if now < finest:
            return (f"{said}: set {key} = {finest}, the finest {increment} allows, and give a --tolerance below the "
                    "correction, or leave the program uncompensated")
        return f"{said}, the finest {increment} allows: give a finer --tolerance, or leave the program uncompensated"


DEFAULT = MachineProfile()

MAX_BYTES = 1024 * 1024  #: a machine profile is a page of text

#: the fields that are not keys of a profile file: what it keeps aside, and where it was read from
NOT_KEYS = ("extra", "source", "source_sha256")
_FIELDS = {f.name: f for f in dataclasses.fields(MachineProfile) if f.name not in NOT_KEYS}


def load(path: str) -> MachineProfile:
    """Read a profile from TOML; unknown keys are refused (``x-`` keys are kept aside)."""
    from ..files import inputs

    data, text = inputs.read_toml(path, MAX_BYTES, OptionError, "a machine profile")
    profile = from_mapping(data, path, text)
    return dataclasses.replace(profile, source=path, source_sha256=hashlib.sha256(text.encode("utf-8")).hexdigest())


def from_mapping(data: dict[str, Any], origin: str = "<profile>", text: str | None = None) -> MachineProfile:
    """A profile from a TOML document; ``text``, the document as written, lets an error point at
    the key's line and column."""
    from ..files.inputs import did_you_mean, spellings, toml_key

    written = spellings(data, origin, text, OptionError)

    def at(name: str) -> Location:
        return toml_key(origin, text, written.get(name, name)) if text is not None else Location(origin)

    values: dict[str, Any] = {}
    extra: dict[str, Any] = {}
    for key, value in data.items():
        name = key.replace("-", "_")
        if key.startswith("x-") or key == "simulation":  # the virtual machine's own table
            extra[key] = value
            continue
        if name not in _FIELDS:
            raise OptionError(f"unknown key {key!r} in machine profile{did_you_mean(name, [*_FIELDS, 'simulation'])}",
                              at(name))
        values[name] = _checked(name, value, at(name))
    profile = MachineProfile(**values, extra=extra)
    bounds.max_correction(profile.max_correction, "max_correction =", at("max_correction"))
    if profile.tolerance is not None:
        bounds.tolerance(profile.tolerance, profile.max_correction, "tolerance =", at("tolerance"))
    if profile.gcode_system not in ("A", "B", "C"):
        raise OptionError("gcode_system must be A, B or C", at("gcode_system"))
    _known_axes(profile.axes, at("axes"))
    if profile.input_increment not in INCREMENTS:
        raise OptionError(f"input_increment must be one of {', '.join(INCREMENTS)}", at("input_increment"))
    for unit, inch in (("mm", False), ("inch", True)):
        _readable_decimals(profile, unit, inch, at(f"output_decimals_{unit}" if f"output_decimals_{unit}" in values
                                                   else "input_increment"))
    return profile


#: The axis addresses of a FANUC lathe (system A): X and Z, a C axis (spindle positioning or Cs
#: contouring), Y on a mill-turn, B for a second spindle or a tailstock, A for a tilting head.
#: U, W, H and V are the incremental addresses of X, Z, C and Y, not axes.
_AXIS_LETTERS = "XZCYBA"


def _known_axes(axes: str, where: Location) -> None:
    """Refuse an ``axes`` the lathe cannot have: a letter that is no axis address (``XZU``: U
    is X written incrementally, and every U word would be read as another axis's move), a
    lowercase one (``xzc`` would leave the C words read as chamfers), a letter twice, or no
    X or Z."""
    wrong = [letter for letter in axes if letter not in _AXIS_LETTERS]
    if wrong or len(set(axes)) != len(axes) or "X" not in axes or "Z" not in axes:
        raise OptionError(f"axes = {axes!r}: the lathe's axis letters, each once, X and Z among them, from "
                          f"{', '.join(_AXIS_LETTERS)} in capitals (U, W, H and V are the incremental addresses of X, "
                          "Z, C and Y, not axes): for example \"XZ\" or \"XZC\"", where)


def _readable_decimals(profile: MachineProfile, unit: str, inch: bool, where: Location) -> None:
    """Refuse output decimals finer than the control's least input increment: it would read a
    written ``X19.968`` under IS-A (0.01 mm) as another number or alarm, and the block read back
    here would not be the block the control runs."""
    increment = INCREMENTS[profile.input_increment][1 if inch else 0]
    finest = round(-math.log10(increment))
    decimals = profile.output_decimals_inch if inch else profile.output_decimals_mm
    if decimals > finest:
        raise OptionError(f"output_decimals_{unit} = {decimals} writes {10.0 ** -decimals:g} {unit}, finer than the "
                          f"least input increment of {profile.input_increment} ({increment:g} {unit}), which the "
                          f"control cannot read; set output_decimals_{unit} = {finest}, or the "
                          f"control's own increment system as input_increment", where)


#: How far from the work origin a soft limit may lie, mm: further than the largest lathe reaches
#: (a 20 m shaft, a 25 m vertical lathe's table), so that a limit in um is refused
MAX_LIMIT_MM = 100_000.0


def _checked(name: str, value: Any, where: Location) -> Any:
    default = getattr(DEFAULT, name)
    if name in ("x_limits", "z_limits"):
        default = (0.0, 0.0)
    if name == "calculator_input":
        default = False
    if isinstance(default, tuple):
        if not (isinstance(value, list) and len(value) == 2 and all(_is_number(v) for v in value)):
            raise OptionError(f"{name} must be a list of two numbers", where)
        low, high = float(value[0]), float(value[1])
        if not (math.isfinite(low) and math.isfinite(high)):
            raise OptionError(f"{name}: the limits must be finite numbers", where)
        if not low < high:
            raise OptionError(f"{name}: the first limit must be below the second", where)
        if max(abs(low), abs(high)) > MAX_LIMIT_MM:
            raise OptionError(f"{name} = [{low:g}, {high:g}]: beyond {MAX_LIMIT_MM / 1000:g} m from the work origin, "
                              f"further than any lathe reaches: written in um? ([{low / 1000:g}, {high / 1000:g}] mm)",
                              where)
        return (low, high)
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise OptionError(f"{name} must be true or false", where)
        return value
    if isinstance(default, int) and not isinstance(default, bool):
        if not isinstance(value, int) or isinstance(value, bool) or value < 0:
            raise OptionError(f"{name} must be a whole number", where)
        _within(name, value, where)
        return value
    if isinstance(default, float) or name == "tolerance":
        if name in _ZERO_ALLOWED:
            if not _is_number(value) or not math.isfinite(value) or value < 0:
                raise OptionError(f"{name} must be a number, 0 or more ({_ZERO_ALLOWED[name]})", where)
        elif not _is_number(value) or not math.isfinite(value) or value <= 0:
            raise OptionError(f"{name} must be a positive number", where)
        _within(name, value, where)
        return float(value)
    if not isinstance(value, str):
        raise OptionError(f"{name} must be a string", where)
    return value


#: Numbers whose 0 is a setting of its own, and what it means.
_ZERO_ALLOWED = {"nose_radius_mm": "0: the control does not offset the tool by its nose radius under G41/G42"}

#: The sane range of each number a profile holds: beyond it, a typo or a unit slip (the
#: tolerance and the maximum correction: :mod:`postproc.machine.bounds`).
_RANGES = {
    "arc_radius_tolerance": (0.0, 1.0, "mm"),
    "max_arc_radius": (0.0, 100_000.0, "mm"),
    "min_block_time_s": (0.0, 1.0, "s"),
    "max_spindle_rpm": (0.0, 100_000.0, "rpm"),
    "nose_radius_mm": (0.0, 10.0, "mm"),
    "model_max_age_days": (0.0, 36_500.0, "days"),
    "plugin_time_limit_s": (0.0, 86_400.0, "s"),
    "output_decimals_mm": (2, 6, "decimals"),
    "output_decimals_inch": (3, 7, "decimals"),
}


def _within(name: str, value: float, where: Location) -> None:
    if name in _RANGES:
        low, high, unit = _RANGES[name]
        if not low <= value <= high:
            raise OptionError(f"{name} = {value:g}: out of range for a lathe (at most {high:g} {unit}"
                              f"{f', at least {low:g}' if low else ''})", where)


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def sha256(profile: MachineProfile) -> str:
    """What identifies a profile beyond its name (which a profile file that sets none shares with
    the embedded default): the SHA-256 of the file it was read from, as the provenance header's
    ``PROFILE`` line gives it; for a profile made otherwise (a library call, the embedded
    default), the SHA-256 of its settings as :func:`to_toml` writes them."""
    if profile.source:
        return profile.source_sha256
    return hashlib.sha256(to_toml(profile).encode("utf-8")).hexdigest()


def to_toml(profile: MachineProfile) -> str:
    """The profile as TOML that :func:`load` reads back (unset limits are left out)."""
    lines = [f"# machine profile {toml_string(profile.name)}"]
    for name in _FIELDS:
        value = getattr(profile, name)
        if value is not None:
            lines.append(f"{name} = {_toml_value(value)}")
    return "\n".join(lines) + "\n"


_ESCAPES = {'"': '\\"', "\\": "\\\\", "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f", "\r": "\\r"}


def toml_string(text: str) -> str:
    """``text`` as a TOML basic string that reads back as ``text``: the quote, the backslash and
    every control character (U+0000 to U+001F, U+007F, which TOML forbids as they are) escaped.

    :raises ValueError: ``text`` holds a lone surrogate (an undecodable byte of a command line),
        which no TOML (UTF-8) file can hold.
    """
    parts = []
    for char in text:
        code = ord(char)
        if 0xD800 <= code <= 0xDFFF:
            raise ValueError(f"{text!r} holds a byte that is not UTF-8 text")
        parts.append(_ESCAPES.get(char) or (f"\\u{code:04X}" if code < 0x20 or code == 0x7F else char))
    return '"' + "".join(parts) + '"'


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return toml_string(value)
    if isinstance(value, tuple):
        return f"[{value[0]!r}, {value[1]!r}]"
    return repr(value)


#: What each key means, for the starter profile (docs/formats.md §15 says it in full).
MEANINGS = {
    "name": "The profile's name: saved models record it.",
    "controller": "The control, for people.",
    "gcode_system": "FANUC lathe G-code system: A, B or C.",
    "diameter_x": "X and U are diameters (false: radius programming).",
    "input_increment": "Least input increment: IS-A (0.01 mm), IS-B (0.001 mm), IS-C (0.0001 mm).",
    "calculator_input": "true: a length without a decimal point is in mm or inches (parameter 3401 DPI); false: in "
                        "increments. Unset: compensate refuses a program that mixes both spellings.",
    "label_skip": "The control skips from the opening % to the first end of block.",
    "axes": "The axes the lathe has (X Z C Y B A, X and Z among them); any other axis address is refused.",
    "arc_radius_tolerance": "The control's arc check: start and end radius may differ by this (mm).",
    "max_arc_radius": "An arc above this radius is written as lines (mm).",
    "min_block_time_s": "No block shorter than the feed covers in this time (s).",
    "max_spindle_rpm": "The spindle's top speed (bounds G96 near the axis).",
    "nose_radius_mm": "No block under G41/G42 shorter than this (mm); 0 if the control does not offset the tool.",
    "x_limits": "Soft limits of x [low, high], radius mm, work coordinates: a compensated move beyond is refused.",
    "z_limits": "Soft limits of z [low, high], mm, work coordinates.",
    "tolerance": "Default --tolerance, mm (0.002 is 2 um). Unset: 0.001 mm, or twice the output resolution.",
    "max_correction": "Default --max-correction, mm: a larger correction is refused.",
    "model_max_age_days": "A saved model measured longer ago than this gets a warning.",
    "plugin_time_limit_s": "A compensator call running longer is stopped and named (s).",
    "output_decimals_mm": "Decimals written in metric programs.",
    "output_decimals_inch": "Decimals written in inch programs.",
    "spindle_speed_fluctuation": "Read and shown; no effect yet.",
}
#: A value to uncomment for each key that is unset by default.
_UNSET_EXAMPLES = {"calculator_input": "true", "x_limits": "[-5.0, 265.0]", "z_limits": "[-450.0, 450.0]",
                   "tolerance": "0.002"}


def starter(name: str) -> str:
    """A commented machine profile to edit: every key with what it means and its default
    (the keys unset by default commented out, with a value to start from). Read back as it
    is, it is the embedded default under another name."""
    import textwrap

    lines = ["# postproc machine profile (docs/formats.md §15). Every key is shown with its default;",
             "# change what differs on your lathe and control, delete the rest if you like.",
             "# Check it with: postproc profile show --machine THIS-FILE", ""]
    for key in _FIELDS:
        lines += textwrap.wrap(MEANINGS[key], 96, initial_indent="# ", subsequent_indent="# ")
        value = name if key == "name" else getattr(DEFAULT, key)
        lines.append(f"{key} = {_toml_value(value)}" if value is not None else f"# {key} = {_UNSET_EXAMPLES[key]}")
        lines.append("")
    return "\n".join(lines)
