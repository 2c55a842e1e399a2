"""``--region``: what part of a program to compensate; everything else stays byte for byte.

A region is a range of sequence numbers (``N100-N200``: from the block labelled N100 to the
block labelled N200, in program order), a range of source lines (``L10-L50`` or ``10-50``),
or a tool (``T1``, ``T01``, ``T0101``: moves made while that tool is in the turret). One
number alone is the range of it alone: ``L10`` (or ``10``) is ``L10-L10``, ``N100`` is
``N100-N100``. Several ``--region`` options select the union of their blocks. Anything else,
and a range that can select nothing (line 0, a first line after the last, tool 0, which is no
tool), is refused (exit 3, a bad option value) naming the forms; so is a sequence number the
program lacks or carries twice, or a range of them that runs backwards. The blocks just outside
stay as they are: the region's first and last blocks meet them (the rewriter asks
:meth:`Region.contains` before it rewrites a neighbour).
"""

from __future__ import annotations

import re
from typing import NamedTuple

from ..diagnostics import OptionError
from ..interpret.motion import Move, Step

# The forms of a value, compiled when a value is parsed (re keeps them): every compensation
# imports this module, few give --region.
_LABELS = r"^[Nn](\d+)(?:-[Nn](\d+))?$"
_LINES = r"^[Ll]?(\d+)(?:-[Ll]?(\d+))?$"
_TOOL = r"^[Tt](\d{1,4})$"
FORMS = "N100-N200 or N100 (sequence numbers), L10-L50, L10, 10-50 or 10 (source lines), or a tool like T01"


class Range(NamedTuple):
    """One ``--region`` value. A named tuple rather than a frozen dataclass: every compensation
    defines the class, few make one, and a named tuple's class is made several times faster."""

    kind: str  #: "labels", "lines" or "tool"
    first: int
    last: int


def parse(text: str) -> Range:
    """One ``--region`` value; a malformed one, or one that can select nothing, is an OptionError."""
    spec = text.strip()
    if match := re.match(_LABELS, spec):
        first = int(match.group(1))
        return Range("labels", first, int(match.group(2) or first))
    if match := re.match(_LINES, spec):
        first = int(match.group(1))
        last = int(match.group(2) or first)
        if first == 0:
            raise OptionError(f"--region {text}: lines are counted from 1")
        if first > last:
            raise OptionError(f"--region {text}: the first line comes after the last (L{last}-L{first}?)")
        return Range("lines", first, last)
    if match := re.match(_TOOL, spec):
        digits = match.group(1)
        tool = int(digits[:-2]) if len(digits) > 2 else int(digits)  # T0101: tool 1, offset 01
        if tool == 0:
            raise OptionError(f"--region {text}: tool 0 is no tool (T0 cancels the offset); expected a tool like T01")
        return Range("tool", tool, tool)
    raise OptionError(f"--region {text}: expected {FORMS}")


def _as_lines(r: Range, spec: str, labels, file: str) -> Range:
    """A range of sequence numbers as the range of source lines between its blocks."""
    found = []
    for label in (r.first, r.last):
        count = labels.counts.get(label, 0)
        if count == 0:
            raise OptionError(f"--region {spec}: {file} has no block N{label}")
        if count > 1:
            first, second = labels.lines[label][:2]
            raise OptionError(f"--region {spec}: N{label} stands on {count} blocks of {file} (lines {first}, {second}"
                              f"...); give the lines instead, e.g. L{first}-L{first}")
        found.append(labels.lines[label][0])
    if found[0] > found[1]:
        raise OptionError(f"--region {spec}: N{r.last} (line {found[1]}) comes before N{r.first} (line {found[0]}) "
                          f"in {file}; did you mean N{r.last}-N{r.first}?")
    return Range("lines", found[0], found[1])


class Region:
    """Whether a step's moves may be compensated; asked, in program order, about the moves a
    compensation could change (so that ``matched`` says whether the region selected any)."""

    def __init__(self, specs: list[str], labels=None, file: str = "the program"):
        """``labels``: the program's :class:`~postproc.syntax.source.LabelIndex`. With it, a
        range of sequence numbers becomes the range of lines between its two blocks, found
        before anything is compensated: a block the compensation would not change (a rapid,
        a comment) still opens or closes it, and a label the program lacks, or holds twice,
        or whose range runs backwards is refused instead of selecting nothing or running on
        to the end."""
        self.ranges = [parse(spec) for spec in specs]
        if labels is not None:
            self.ranges = [_as_lines(r, spec, labels, file) if r.kind == "labels" else r
                           for r, spec in zip(self.ranges, specs)]
        self._open: set[int] = set()  # label ranges we are inside
        self._step: Step | None = None
        self._selected = False
        self.matched = False  #: whether any move asked about was selected

    def __call__(self, step: Step, move: Move) -> bool:
        chosen = self.contains(step, move)
        self.matched |= chosen
        return chosen

    def contains(self, step: Step, move: Move) -> bool:
        """Whether the region holds this move, without counting it as selected: the rewriter
        asks it of a block it would otherwise rewrite to meet a changed neighbour, and leaves
        a block outside the region as it is."""
        if not self.ranges:
            return True
        if step is not self._step:
            self._step = step
            self._selected = self._decide(step)
        return self._selected or any(r.kind == "tool" and move.tool == r.first for r in self.ranges)

    def _decide(self, step: Step) -> bool:
        label = step.block.label
        line = step.block.line
        inside = False
        for index, r in enumerate(self.ranges):
            if r.kind == "lines":
                inside |= r.first <= line <= r.last
            elif r.kind == "labels":
                if label == r.first:
                    self._open.add(index)
                if index in self._open:
                    inside = True
                    if label == r.last:
                        self._open.discard(index)
        return inside
