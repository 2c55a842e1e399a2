"""A compensator's ``report()`` dict as report parts: whatever it holds, shown as well as it can be.

The dict is the compensator's own (built-in or third-party), so nothing in it is assumed:

- ``parameters``: ``{name: {"value", "sigma", ...}}`` (or ``{name: number}``): a table of the
  fitted values with their 1-sigma uncertainty. A parameter's ``unit`` is used when given;
  otherwise the units of the ballbar diagnosis are read from its name (scaling in ppm,
  squareness in urad, backlash, servo mismatch and ``*_mm`` in um); other keys of a
  parameter (``applied: false``, say) are listed beside it;
- any dict with ``mean_um``, ``mean_abs_um``, ``rms_um`` and ``std_um`` (the four figures,
  ``Figures.as_dict()``), wherever it sits: a row of the four-figures table;
- PNG bytes, or an object with ``savefig`` (a matplotlib figure): an image;
- everything else: a key/value table, nested keys joined with dots (``chains[1].tool`` for
  a list of dicts), a list of strings one per line, long lists of numbers summarised.
"""

from __future__ import annotations

import io
import math
from collections.abc import Mapping
from typing import Any

from ..figures import Figures
from .charts import png_image
from .document import Image, Part, Table, Text

FOUR = ("mean_um", "mean_abs_um", "rms_um", "std_um")
LIST_SHOWN = 8  #: a list longer than this is summarised
UNITS = (("scaling", 1e6, "ppm"), ("squareness", 1e6, "urad"), ("backlash", 1e3, "um"),
         ("servo_mismatch", 1e3, "um"), ("centre", 1e3, "um"), ("center", 1e3, "um"))


def is_four_figures(value: Any) -> bool:
    return isinstance(value, Mapping) and all(isinstance(value.get(key), (int, float)) for key in FOUR)


def four_figures(value: Mapping) -> Figures:
    return Figures(float(value["mean_um"]), float(value["mean_abs_um"]), float(value["rms_um"]),
                   float(value["std_um"]), int(value.get("count", 0) or 0))


def number(value: Any, digits: int = 6) -> str:
    """A number for people: significant digits, no float noise."""
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            return str(value)
        return f"{value:.{digits}g}"
    return str(value)


def _unit(name: str, entry: Mapping) -> tuple[float, str]:
    if isinstance(entry.get("unit"), str):
        return 1.0, entry["unit"]
    lowered = name.lower()
    if lowered.endswith("_rad"):
        return 1e6, "urad"
    if lowered.endswith("_mm"):
        return 1e3, "um"
    for word, scale, unit in UNITS:
        if word in lowered:
            return scale, unit
    return 1.0, ""


def parameters_table(parameters: Mapping, caption: str) -> Table:
    """Fitted parameters with their uncertainty, in readable units."""
    rows = []
    for name, entry in parameters.items():
        entry = entry if isinstance(entry, Mapping) else {"value": entry}
        scale, unit = _unit(str(name), entry)
        value, sigma = entry.get("value"), entry.get("sigma")
        shown = number(value * scale, 5) if isinstance(value, (int, float)) and not isinstance(value, bool) else number(value)
        spread = (number(sigma * scale, 3) if isinstance(sigma, (int, float)) and not isinstance(sigma, bool)
                  else "not given")
        extra = "; ".join(f"{key}: {_plain(v)}" for key, v in entry.items() if key not in ("value", "sigma", "unit"))
        rows.append((str(name), shown, spread, unit, extra))
    return Table(("parameter", "value", "1 sigma", "unit", "notes"), tuple(rows), caption)


def _plain(value: Any) -> str:
    if isinstance(value, (list, tuple)):
        if len(value) > LIST_SHOWN:
            numbers = [v for v in value if isinstance(v, (int, float)) and not isinstance(v, bool)]
            span = f", {number(min(numbers))} .. {number(max(numbers))}" if numbers else ""
            return f"{len(value)} values{span}"
        return ", ".join(_plain(v) for v in value)
    if value is None:
        return "none"
    return number(value)


def _image(value: Any, name: str) -> Image | None:
    if isinstance(value, (bytes, bytearray)) and bytes(value[:8]) == b"\x89PNG\r\n\x1a\n":
        return png_image(bytes(value), name, name)
    if hasattr(value, "savefig"):
        buffer = io.BytesIO()
        value.savefig(buffer, format="png")
        return png_image(buffer.getvalue(), name, name)
    return None


def render(plugin: str, report: Mapping) -> tuple[list[Part], list[tuple[str, Figures]]]:
    """Parts showing a report dict, and the four-figures entries found in it (label, figures)."""
    parts: list[Part] = []
    figures: list[tuple[str, Figures]] = []
    rows: list[tuple[str, str]] = []

    def walk(prefix: str, value: Any) -> None:
        if is_four_figures(value):
            figures.append((f"{plugin}: {prefix}", four_figures(value)))
            return
        image = _image(value, f"{plugin}: {prefix}")
        if image is not None:
            parts.append(image)
            return
        if prefix == "parameters" and isinstance(value, Mapping) and value:
            parts.append(parameters_table(value, f"{plugin}: fitted parameters (1 sigma)"))
            return
        if isinstance(value, Mapping) and value:
            for key, item in value.items():
                walk(f"{prefix}.{key}", item)
            return
        if isinstance(value, (list, tuple)) and value and all(isinstance(item, Mapping) for item in value):
            for index, item in enumerate(value, 1):
                walk(f"{prefix}[{index}]", item)
            return
        if isinstance(value, (list, tuple)) and value and all(isinstance(item, str) for item in value):
            rows.append((prefix, "\n".join(value)))
            return
        rows.append((prefix, _plain(value)))

    for key, item in report.items():
        walk(str(key), item)
    if rows:
        parts.append(Table(("item", "value"), tuple(rows), f"{plugin}: everything else it reports", numeric=False))
    if not parts and not figures:
        parts.append(Text(f"{plugin} reports nothing about its fit.", "note"))
    if figures:
        parts.append(Table(("fit", "mean (um)", "mean |e| (um)", "RMS (um)", "sigma (um)", "points"),
                           tuple(figure_row(label, f) for label, f in figures), f"{plugin}: the four figures it reports"))
    return parts, figures


def figure_row(label: str, figures: Figures) -> tuple[str, ...]:
    return (label, f"{figures.mean:+.3f}", f"{figures.mean_abs:.3f}", f"{figures.rms:.3f}", f"{figures.std:.3f}",
            str(figures.count) if figures.count else "")
