"""The report as one self-contained HTML file: the template and the escaping.

Everything the file needs is inside it: the style sheet inline, every image a ``data:`` URI,
no script, no link to anything outside but anchors within the page. Every string of the
document is escaped (``html.escape`` with quotes) on its way out, whoever supplied it, so
a file named ``<script>.csv`` or a plugin's report reads as text.
"""

from __future__ import annotations

import base64
import html

from .document import Document, Image, Part, Section, Table, Text, Verdict

STYLE = """
:root { color-scheme: light; }
* { box-sizing: border-box; }
body { font: 15px/1.45 system-ui, -apple-system, "Segoe UI", Roboto, "DejaVu Sans", sans-serif; color: #1d232a;
       margin: 0 auto; max-width: 1000px; padding: 1.2em 2em 4em; background: #fff; }
header { margin-bottom: .6em; }
h1 { font-size: 1.45em; margin: 0 0 .1em; overflow-wrap: anywhere; }
h2 { font-size: 1.3em; margin: 2em 0 .6em; border-bottom: 1px solid #c9d3dd; padding-bottom: .2em; }
h3 { font-size: 1.08em; margin: 1.5em 0 .5em; }
h4 { font-size: 1em; margin: 1.2em 0 .4em; color: #2b5d8a; }
p.subtitle { color: #4a5562; margin: 0; }
nav { border-top: 2px solid #2b5d8a; border-bottom: 1px solid #c9d3dd; margin: 1em 0; }
nav ol { columns: 2; margin: .5em 0; padding-left: 1.4em; }
nav a, a { color: #2b5d8a; }
#verdict h2 { display: none; }
.verdict { border-radius: 6px; padding: .6em 1em; margin: .6em 0 .5em; border: 2px solid; }
.verdict .headline { font-size: 1.6em; font-weight: 700; margin: 0 0 .15em; line-height: 1.2; }
.verdict p { margin: 0; }
.verdict .figures { font-size: 1.2em; font-weight: 600; margin-bottom: .2em; font-variant-numeric: tabular-nums; }
.verdict.pass { background: #e8f5e9; border-color: #2e7d32; }
.verdict.pass .headline { color: #1b5e20; }
.verdict.fail { background: #fdecea; border-color: #c62828; }
.verdict.fail .headline { color: #b71c1c; }
.verdict.none { background: #f1f3f5; border-color: #6b7682; }
.table { overflow-x: auto; margin: .5em 0 1em; max-width: 100%; }
table { border-collapse: collapse; font-size: .92em; }
caption { text-align: left; font-weight: 600; padding: .2em 0; }
th, td { border: 1px solid #d5dce3; padding: .25em .6em; vertical-align: top; }
th { background: #eef2f6; text-align: left; }
table.numeric td:not(:first-child) { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
td { overflow-wrap: break-word; white-space: pre-line; min-width: 3em; }
td:first-child { min-width: 7em; }
#inputs td:nth-child(3) { word-break: break-all; min-width: 12em; font: .85em ui-monospace, "DejaVu Sans Mono", monospace; }
code { font: .9em ui-monospace, "DejaVu Sans Mono", monospace; background: #f1f3f5; padding: 0 .2em;
       border-radius: 3px; overflow-wrap: anywhere; }
figure { margin: 1em 0; }
figure img { max-width: 100%; height: auto; border: 1px solid #e3e8ed; }
figcaption { font-size: .9em; color: #4a5562; }
p.note { color: #4a5562; font-size: .93em; }
p.item { margin: .3em 0 .3em 1.4em; text-indent: -.9em; }
p.item::before { content: "\\2022\\00a0\\00a0"; }
p.warning { background: #fff4e0; border-left: 4px solid #d98a00; padding: .4em .7em; overflow-wrap: anywhere; }
pre { background: #f5f7f9; border: 1px solid #e3e8ed; padding: .6em .8em; overflow-x: auto; font-size: .85em;
      white-space: pre; }
footer { margin-top: 3em; color: #6b7682; font-size: .85em; }
@media (max-width: 640px) {
  body { padding: .8em .8em 3em; font-size: 14px; }
  nav ol { columns: 1; }
  .verdict .headline { font-size: 1.3em; }
}
@media print {
  body { max-width: none; padding: 0; }
  nav { display: none; }
  figure, table { break-inside: avoid; }
}
"""


def escape(text: object) -> str:
    """Any value as HTML text, quotes included, so it is safe in content and attributes alike."""
    return html.escape(str(text), quote=True)


def render(document: Document, footer: str = "") -> str:
    """The whole file."""
    out = ['<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n',
           '<meta name="viewport" content="width=device-width, initial-scale=1">\n',
           f"<title>{escape(document.title)}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n",
           f"<header>\n<h1>{escape(document.title)}</h1>\n<p class=\"subtitle\">{escape(document.subtitle)}</p>\n",
           "</header>\n<main>\n"]
    if document.lead is not None:
        out.append(_section(document.lead, 2))
    out.append(_contents(document.sections))
    out += [_section(section, 2) for section in document.sections]
    out.append("</main>\n")
    if footer:
        out.append(f"<footer>{escape(footer)}</footer>\n")
    out.append("</body>\n</html>\n")
    return "".join(out)


def _contents(sections: list[Section]) -> str:
    items = "".join(f'<li><a href="#{escape(s.key)}">{escape(s.title)}</a></li>\n' for s in sections)
    return f"<nav>\n<ol>\n{items}</ol>\n</nav>\n"


def _section(section: Section, level: int) -> str:
    heading = min(level, 4)
    out = [f'<section id="{escape(section.key)}">\n<h{heading}>{escape(section.title)}</h{heading}>\n']
    out += [_part(part) for part in section.parts]
    out += [_section(sub, level + 1) for sub in section.subsections]
    out.append("</section>\n")
    return "".join(out)


def _part(part: Part) -> str:
    if isinstance(part, Text):
        return _text(part)
    if isinstance(part, Table):
        return _table(part)
    if isinstance(part, Image):
        return _image(part)
    if isinstance(part, Verdict):
        return (f'<div class="verdict {escape(part.state)}" id="verdict-{escape(part.state)}">'
                f'<p class="headline">{escape(part.headline)}</p>'
                + (f'<p class="figures">{escape(part.figures)}</p>' if part.figures else "")
                + f'<p>{escape(part.sentence)}</p></div>\n')
    raise TypeError(f"not a part of a report: {part!r}")


def _text(text: Text) -> str:
    if text.kind == "pre":
        return f"<pre>{escape(text.text)}</pre>\n"
    css = "" if text.kind == "p" else f' class="{escape(text.kind)}"'
    return f"<p{css}>{_spans(text)}</p>\n"


def _spans(text: Text) -> str:
    """The text escaped, its code ranges (plain text too) set in ``<code>``."""
    out, at = [], 0
    for start, end in sorted(text.code):
        if start < at or end <= start:
            continue
        out += [escape(text.text[at:start]), f"<code>{escape(text.text[start:end])}</code>"]
        at = end
    out.append(escape(text.text[at:]))
    return "".join(out)


def _table(table: Table) -> str:
    attributes = f' id="{escape(table.key)}"' if table.key else ""
    if table.numeric:
        attributes += ' class="numeric"'
    out = [f'<div class="table"><table{attributes}>\n']
    if table.caption:
        out.append(f"<caption>{escape(table.caption)}</caption>\n")
    out.append("<thead><tr>" + "".join(f"<th>{escape(cell)}</th>" for cell in table.header) + "</tr></thead>\n<tbody>\n")
    for row in table.rows:
        out.append("<tr>" + "".join(f"<td>{escape(cell)}</td>" for cell in row) + "</tr>\n")
    out.append("</tbody>\n</table></div>\n")
    return "".join(out)


def _image(image: Image) -> str:
    data = base64.b64encode(image.png).decode("ascii")
    caption = f"<figcaption>{escape(image.caption)}</figcaption>" if image.caption else ""
    return (f'<figure><img src="data:image/png;base64,{data}" width="{int(image.width)}" height="{int(image.height)}" '
            f'alt="{escape(image.alt)}">{caption}</figure>\n')
