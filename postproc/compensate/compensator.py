"""What a compensator is: the contract between the core and every compensator plugin.

A compensator is fitted from measurements (or loaded from a saved model), may survey the
whole program first, and is then asked, for each piece of each feed move, for the
displacement it wants along that piece: an (n, 2) array of (dx, dz) in radius mm at the
piece's sample points, or None for no change. That array is the edit, as data; the core
adds the edits of all selected compensators (each computed on the nominal path), plans
the sum with the segmenter and writes the blocks. A compensator never touches a block.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, ClassVar, Iterable, Sequence

import numpy as np

from ..diagnostics import Location, ModelError, OptionError, Reporter, SafetyError, out_of_range
from ..geometry import Arc, Line
from ..interpret.motion import Move
from ..machine.profile import DEFAULT, MachineProfile

__all__ = ["Compensator", "Option", "Context", "Measurements", "Piece", "parse_options"]


@dataclass(frozen=True)
class Piece:
    """The part of a move between axis reversals: what a compensator corrects.

    ``x_direction`` and ``z_direction`` say which way each axis travels over the piece
    (+1, -1). An axis that does not move in the piece keeps the direction it last
    travelled in, which is where its backlash leaves it; 0 when that is not known.
    """

    move: Move
    segment: Line | Arc
    t: np.ndarray  #: sample parameters on ``segment`` (read-only: shared between pieces)
    x_direction: int
    z_direction: int

    @cached_property
    def points(self) -> np.ndarray:
        """The nominal points at ``t``: sampled once, for every compensator and the target,
        so read-only."""
        points = self.segment.point_at(self.t)
        points.setflags(write=False)
        return points


#: The largest stock allowance of a measured pass a compensator takes (mm): a semi-finish pass
#: leaves a few tenths, a rough one a few mm; ``stock=20`` meant micrometres.
STOCK_MM = 5.0
#: The largest 3-sigma uncertainty of a fitted term a compensator can be told to accept (mm): ten
#: times the default (docs/methods.md §4); above it the fit would be held to nothing.
MAX_UNCERTAINTY_MM = 0.05


@dataclass(frozen=True)
class Option:
    """A setting a compensator declares: ``--option [PLUGIN.]KEY=VALUE``."""

    key: str
    kind: type  #: float, int, bool or str
    default: Any = None
    help: str = ""
    choices: tuple[str, ...] = ()
    positive: bool = False
    #: the largest size (mm) that makes sense for a length, or None: above it, most likely a
    #: length in micrometres (``residual=5`` meant 5 um), refused with that reading
    largest_mm: float | None = None

    def _too_large(self, value: float) -> str | None:
        if self.largest_mm is None or abs(value) <= self.largest_mm:
            return None
        hint = (f"; {value:g} um is {value / 1000:g} mm, if micrometres were meant"
                if abs(value) / 1000 <= self.largest_mm else "")
        return f"at most {self.largest_mm:g} mm (the option is in mm){hint}"

    def parse(self, text: str, plugin: str) -> Any:
        where = f"--option {plugin}.{self.key}={text}"
        if self.kind is bool:
            value = text.strip().lower()
            if value in ("true", "yes", "1", "on"):
                return True
            if value in ("false", "no", "0", "off"):
                return False
            raise OptionError(f"{where}: expected true or false")
        if self.kind in (float, int):  # refused as the command line's own numbers are (cli/common.py)
            whole = self.kind is int
            try:
                value = self.kind(text)
            except ValueError:
                raise OptionError(f"{where}: not a {'whole ' if whole else ''}number") from None
            if not math.isfinite(value):
                raise OptionError(f"{where}: not a finite number")
            problem = (out_of_range(value, whole, **({"at_least": 1} if whole else {"above": 0})) if self.positive
                       else None) or self._too_large(value)
            if problem:
                raise OptionError(f"{where}: {problem}")
            return value
        if self.choices and text not in self.choices:
            raise OptionError(f"{where}: expected one of {', '.join(self.choices)}")
        return text

    def check(self, value: Any, where: Location) -> Any:
        """A value saved in a model (JSON), held to the rules :meth:`parse` holds text to."""
        name = f"options.{self.key} = {json.dumps(value)}"
        if value is None:
            if self.default is None:
                return None
            raise ModelError(f"{name}: the option has a value when it is given", where)
        if self.kind is bool:
            if not isinstance(value, bool):
                raise ModelError(f"{name}: expected true or false", where)
            return value
        if self.kind in (float, int):
            number = isinstance(value, (int, float)) and not isinstance(value, bool)
            if not number or (self.kind is int and not isinstance(value, int)) or not math.isfinite(value) or (
                    self.positive and value <= 0):
                kind = "whole number" if self.kind is int else "number"
                raise ModelError(f"{name}: expected a {'positive ' if self.positive else ''}finite {kind}", where)
            problem = self._too_large(value)
            if problem:
                raise ModelError(f"{name}: {problem}", where)
            return self.kind(value)
        if not isinstance(value, str) or (self.choices and value not in self.choices):
            expected = f"one of {', '.join(self.choices)}" if self.choices else "a string"
            raise ModelError(f"{name}: expected {expected}", where)
        return value


@dataclass
class Measurements:
    """The measurement files given to one compensator, read, in the order given."""

    ballbar: list = field(default_factory=list)
    probe: list = field(default_factory=list)
    calibration: list = field(default_factory=list)

    def kinds(self) -> set[str]:
        return {kind for kind in ("ballbar", "probe", "calibration") if getattr(self, kind)}


@dataclass
class Context:
    """What a compensator may know of the run."""

    profile: MachineProfile = DEFAULT
    reporter: Reporter = field(default_factory=Reporter)
    tolerance: float = 0.001
    force: bool = False  #: explicit overrides (a failed datum check, an old model...)

    def refuse(self, text: str, remedy: str, where: Location | None = None) -> None:
        """A result a compensator does not trust: refused for safety (exit 4) with the remedy,
        or, under ``--force``, a warning that it was applied anyway."""
        if not self.force:
            raise SafetyError(f"{text} ({remedy}, or --force)", where)
        self.reporter.warn(f"{text}; applied anyway (--force)", where)


class Compensator:
    """Base class of compensators. The subclass docstring is its user documentation."""

    name: ClassVar[str] = ""
    takes: ClassVar[tuple[str, ...]] = ()  #: measurement kinds it uses
    needs: ClassVar[tuple[str, ...]] = ()  #: kinds it cannot work without
    options: ClassVar[tuple[Option, ...]] = ()
    needs_survey: ClassVar[bool] = False  #: whether it must see the whole program first

    def __init__(self, context: Context, settings: dict[str, Any] | None = None):
        self.context = context
        self.settings = {option.key: option.default for option in self.options}
        self.settings.update(settings or {})

    @classmethod
    def summary(cls) -> str:
        doc = (cls.__doc__ or "").strip()
        return doc.splitlines()[0] if doc else ""

    def fit(self, measurements: Measurements) -> None:
        """Build the model from measurements."""
        raise NotImplementedError

    def start(self) -> None:
        """A program begins (each program of a batch, each of a library's pipeline): forget what
        the last one left. The last one may have been refused half way, its :meth:`finish`
        never called, so whatever a compensator gathers per program (a prediction, a warning
        given once) is cleared here, not there."""

    def survey(self, moves: Iterable[Move]) -> None:
        """See every feed move of the program before any is corrected (when ``needs_survey``)."""

    def correct(self, piece: Piece) -> np.ndarray | None:
        """The displacement wanted at ``piece.points``: (n, 2) radius mm, or None."""
        raise NotImplementedError

    def correct_many(self, pieces: Sequence[Piece]) -> list[np.ndarray | None]:
        """The displacements of several pieces, in order: what the core calls, with the pieces
        of a run of moves at once. By default :meth:`correct` for each. A compensator whose
        correction depends on each point alone overrides it to work on all the points in one
        array pass: on a program of short moves, calling numpy per piece is most of its cost."""
        return [self.correct(piece) for piece in pieces]

    def prologue(self, inch: bool) -> list[str]:
        """Blocks (text, no line ending) to open the program with: a G10 offset setting, say.

        The core writes them right after the block by which the program has set its units
        (``inch``: G20) and plane, before its first tool call or move, so values are in the
        program's units; a program that sets no units there is refused. They must parse and
        interpret, and the provenance header names them."""
        return []

    def finish(self) -> None:
        """The program has been corrected: warn about what only the whole program shows (a
        prediction of the result, say), or raise to refuse it. Called once per program."""

    def model(self) -> dict[str, Any]:
        """The fitted model as JSON-able data (``postproc fit``)."""
        raise NotImplementedError(f"{self.name} cannot save its model")

    def load(self, model: dict[str, Any]) -> None:
        """Take a model saved by :meth:`model`."""
        raise NotImplementedError(f"{self.name} cannot load a saved model")

    def report(self) -> dict[str, Any]:
        """What was fitted and how well, for reports and for stderr."""
        return {}


def check_options(values: dict[str, Any], compensator: type["Compensator"], where: Location) -> dict[str, Any]:
    """The options saved in a model, checked against what its compensator declares: an unknown
    key or a wrong value is refused, as on the command line."""
    declared = {option.key: option for option in compensator.options}
    checked = {}
    for key, value in values.items():
        if key not in declared:
            known = ", ".join(sorted(declared)) or "none"
            raise ModelError(f"options.{key}: {compensator.name} declares no such option (it declares: {known})", where)
        checked[key] = declared[key].check(value, where)
    return checked


def parse_options(texts: Iterable[str], compensators: list[type[Compensator]]) -> dict[str, dict[str, Any]]:
    """``[PLUGIN.]KEY=VALUE`` texts scoped to the selected compensators (docs/formats.md §8.1)."""
    chosen: dict[str, dict[str, Any]] = {cls.name: {} for cls in compensators}
    given: dict[tuple[str, str], tuple[bool, Any, str]] = {}  # (plugin, key) -> (scoped, value, text)
    by_name = {cls.name: cls for cls in compensators}
    for text in texts:
        if "=" not in text:
            raise OptionError(f"--option {text}: expected [PLUGIN.]KEY=VALUE")
        key, value = text.split("=", 1)
        key = key.strip()
        targets = list(by_name.values())
        scoped = "." in key
        if scoped:
            plugin, key = key.split(".", 1)
            if plugin not in by_name:
                raise OptionError(f"--option {text}: {plugin!r} is not a selected compensator")
            targets = [by_name[plugin]]
        takers = [cls for cls in targets if any(option.key == key for option in cls.options)]
        if not takers:
            raise OptionError(f"--option {text}: no selected compensator declares {key!r}")
        for cls in takers:
            option = next(option for option in cls.options if option.key == key)
            parsed = option.parse(value.strip(), cls.name)
            earlier = given.get((cls.name, key))
            if earlier is not None and earlier[0] == scoped and earlier[1] != parsed:
                # two values of one setting: which was meant is a guess, whichever comes last
                raise OptionError(f"--option {text}: {cls.name}.{key} is set twice, to two values (--option "
                                  f"{earlier[2]} and --option {text}); give it once")
            if earlier is not None and earlier[0] and not scoped:
                continue  # PLUGIN.KEY=VALUE is that compensator's, whatever the order
            given[(cls.name, key)] = (scoped, parsed, text)
            chosen[cls.name][key] = parsed
    return chosen
