"""A compensator's ``report()`` dict as report parts: whatever it holds, shown as well as it can be.

The dict is the compensator's own (built-in or third-party), so nothing in it is assumed:

- ``parameters``: ``{name: {"value", "sigma", ...}}`` (or ``{name: number}``): a table of the
  fitted values with their 1-sigma uncertainty. A parameter's ``unit`` is used when given;
  otherwise its name and unit come from :mod:`.quantities` (scaling in ppm, squareness in
  urad, backlash, servo mismatch and any ``*_mm`` in um); other keys of a parameter
  (``applied: false``, say) are listed beside it;
- any dict with ``mean_um``, ``mean_abs_um``, ``rms_um`` and ``std_um`` (the four figures,
  ``Figures.as_dict()``), wherever it sits: a row of the four-figures table;
- PNG bytes, or an object with ``savefig`` (a matplotlib figure): an image;
- everything else: a table of name, value and unit, nested keys named as one
  (``chain 1, feature 2, s`` for ``chains[1].features[2].s_mm``), a list of strings one per
  line, long lists of numbers summarised.

No key is shown as it is: every name and unit is :mod:`.quantities`'s.
"""

from __future__ import annotations

import io
import math
from collections.abc import Mapping
from typing import Any

from ..measure.figures import Figures
from .charts import png_image
from .document import Image, Part, Table, Text
from .quantities import FOUR as FOUR_HEADINGS, Quantity, path_quantity, quantity, significant, with_sigma, words

FOUR = ("mean_um", "mean_abs_um", "rms_um", "std_um")
LIST_SHOWN = 8  #: a list longer than this is summarised


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


def _quantity(name: str, entry: Mapping) -> Quantity:
    if isinstance(entry.get("unit"), str):
        return Quantity(words(name), entry["unit"])
    return quantity(name, errors=True)


def _real(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def parameters_table(parameters: Mapping, caption: str, key: str = "") -> Table:
    """Fitted parameters with their uncertainty, named and in the units people read them in."""
    rows = []
    for name, entry in parameters.items():
        entry = entry if isinstance(entry, Mapping) else {"value": entry}
        found = _quantity(str(name), entry)
        value, sigma = entry.get("value"), entry.get("sigma")
        if _real(value):
            shown, spread = with_sigma(found.value(value), found.value(sigma) if _real(sigma) else None)
        else:
            shown, spread = number(value), ""
        extra = "; ".join(f"{words(key)}: {_plain(v)}" for key, v in entry.items()
                          if key not in ("value", "sigma", "unit"))
        rows.append((found.name, shown, spread or "not given", found.unit, extra))
    return Table(("parameter", "value", "1 sigma", "unit", "notes"), tuple(rows), caption, key=key)


def _plain(value: Any, factor: float = 1.0) -> str:
    """A value of any shape as text, numbers scaled to the unit shown."""
    if isinstance(value, (list, tuple)):
        if len(value) > LIST_SHOWN:
            numbers = [v * factor for v in value if _real(v)]
            span = f", {significant(min(numbers))} .. {significant(max(numbers))}" if numbers else ""
            return f"{len(value)} values{span}"
        return ", ".join(_plain(v, factor) for v in value)
    if value is None:
        return "none"
    if _real(value) and (isinstance(value, float) or factor != 1.0):
        return number(float(value) * factor)
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
    rows: list[tuple[str, str, str]] = []

    def walk(prefix: str, value: Any) -> None:
        named = path_quantity(prefix)
        if is_four_figures(value):
            figures.append((f"{plugin}: {named.name}", four_figures(value)))
            return
        image = _image(value, f"{plugin}: {named.name}")
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
            rows.append((named.name, "\n".join(value), ""))
            return
        numeric = _real(value) or (isinstance(value, (list, tuple)) and any(_real(v) for v in value))
        rows.append((named.name, _plain(value, named.factor), named.unit if numeric else ""))

    for key, item in report.items():
        walk(str(key), item)
    if rows:
        parts.append(Table(("item", "value", "unit"), tuple(rows), f"{plugin}: everything else it reports",
                           numeric=False))
    if not parts and not figures:
        parts.append(Text(f"{plugin} reports nothing about its fit.", "note"))
    if figures:
        parts.append(Table(("fit", *FOUR_HEADINGS, "points"),
                           tuple(figure_row(label, f) for label, f in figures), f"{plugin}: the four figures it reports"))
    return parts, figures


def figure_row(label: str, figures: Figures) -> tuple[str, ...]:
    return (label, f"{figures.mean:+.3f}", f"{figures.mean_abs:.3f}", f"{figures.rms:.3f}", f"{figures.std:.3f}",
            str(figures.count) if figures.count else "")
