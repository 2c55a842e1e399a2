"""A compensator's documentation (its class docstring, reStructuredText) as report parts.

The report shows what each compensator does in its own words; the words are written for
Python's help and Sphinx, so their markup is read here, never shown: paragraphs are
reflowed, ````literal````, ``:role:`target``` and ```interpreted``` text become code (a role's
``~`` keeps the last name, as Sphinx shows it), a paragraph's closing ``::`` becomes ``:``
and the indented block after it (an example, a formula) is kept verbatim, as is any indented
block; ``- item`` lines are a list. Anything else stays plain text, escaped on the way out
like every string of the report.
"""

from __future__ import annotations

import inspect
import re

from .document import Part, Text

INLINE = re.compile(r"``(?P<literal>.+?)``|:[\w:.-]+:`(?P<role>[^`]+)`|`(?P<interpreted>[^`]+)`_{0,2}")
BULLET = re.compile(r"^[-*+]\s+")


def parts(doc: str, skip_summary: bool = False) -> list[Part]:
    """The documentation as paragraphs, list items and verbatim blocks; without its first
    paragraph (the summary line, shown elsewhere) when ``skip_summary``."""
    blocks = _blocks(inspect.cleandoc(doc or ""))
    if skip_summary and blocks and not blocks[0][0]:
        blocks = blocks[1:]
    out: list[Part] = []
    for indented, lines in blocks:
        if indented:
            out.append(Text("\n".join(lines), "pre"))
            continue
        paragraph, items = [], []
        for line in lines:
            if BULLET.match(line):
                items.append([BULLET.sub("", line)])
            elif items:
                items[-1].append(line.strip())
            else:
                paragraph.append(line.strip())
        if paragraph:
            out.append(inline(" ".join(paragraph)))
        out += [inline(" ".join(item), "item") for item in items]
    return out


def inline(text: str, kind: str = "p") -> Text:
    """One paragraph with its inline markup read: the text plain, the code spans marked."""
    if text.endswith("::"):
        text = text[:-2].rstrip() + ("" if text[:-2].endswith((" ", ":")) else ":")
    plain, code, at = [], [], 0
    for match in INLINE.finditer(text):
        plain.append(text[at:match.start()])
        start = sum(map(len, plain))
        shown = match.group("literal") or match.group("interpreted") or _role(match.group("role"))
        plain.append(shown)
        code.append((start, start + len(shown)))
        at = match.end()
    plain.append(text[at:])
    return Text("".join(plain), kind, tuple(code))


def _role(target: str) -> str:
    """``~postproc.measure.ballbar_fit`` -> ``ballbar_fit``; ``title <target>`` -> ``title``."""
    target = re.sub(r"\s*<[^>]*>$", "", target)
    return target[1:].rsplit(".", 1)[-1] if target.startswith("~") else target


def _blocks(text: str) -> list[tuple[bool, list[str]]]:
    """(indented, lines) of each run of non-blank lines; indented runs in a row are one
    verbatim block (blank lines kept), dedented."""
    blocks: list[tuple[bool, list[str]]] = []
    run: list[str] = []
    for line in [*text.splitlines(), ""]:
        if line.strip():
            run.append(line)
            continue
        if run:
            indented = run[0].startswith((" ", "\t"))
            if indented and blocks and blocks[-1][0]:
                blocks[-1][1].extend(["", *run])
            else:
                blocks.append((indented, run))
        run = []
    return [(indented, _dedent(lines) if indented else lines) for indented, lines in blocks]


def _dedent(lines: list[str]) -> list[str]:
    margin = min(len(line) - len(line.lstrip()) for line in lines if line.strip())
    return [line[margin:] for line in lines]
