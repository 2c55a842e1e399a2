"""What the user asked for: the options of ``postproc compensate``, as one value.

Kept apart from the pipeline so that a run with nothing to apply (a check, an identity
pass) does not import the compensation machinery and numpy."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(kw_only=True)
class Request:
    """What the user asked for (the options of ``postproc compensate``). Built by keyword only:
    thirteen fields, several of one type, are too many to fill in by position."""

    plugins: list[str] = field(default_factory=list)
    ballbar: list[str] = field(default_factory=list)
    probe: list[str] = field(default_factory=list)
    calibration: str | None = None
    model: str | None = None
    options: list[str] = field(default_factory=list)
    tolerance: float | None = None
    mode: str = "auto"
    max_correction: float | None = None
    force: bool = False
    regions: list[str] = field(default_factory=list)
    keep_unplannable: bool = False  #: leave blocks that cannot be held uncompensated instead of refusing
    macro_values: str = "refuse"  #: blocks whose geometry reads macro variables: refuse, keep or numbers
