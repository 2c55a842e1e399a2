"""postproc.report.citations: every page and section a report cites is the project's own, named
in the report's References."""

from __future__ import annotations

import html
import re

from click.testing import CliRunner

from support import REPO, SAMPLES
from postproc.compensate import registry
from postproc.cli.main import main
from postproc.report.citations import PAGES, TITLES, citations, source_numbers, title

HEADING = re.compile(r"^#{2,4}\s+(\d+(?:\.\d+)*)\.?\s+(.+?)\s*$")


def _headings(page: str) -> dict[str, str]:
    found = {}
    for line in (REPO / "docs" / page).read_text(encoding="utf-8").splitlines():
        match = HEADING.match(line)
        if match:
            found[match.group(1)] = match.group(2).replace("`", "")
    return found


def test_the_titles_are_the_pages_own_headings():
    for page in {page for page, _ in TITLES}:
        assert {number: name for (p, number), name in TITLES.items() if p == page} == _headings(page), page
    for page in PAGES:
        assert (REPO / "docs" / page).is_file(), page


def test_citations_are_read_as_written():
    assert citations("see docs/methods.md §7.2 and §9.8") == [("methods.md", "7.2"), ("methods.md", "9.8")]
    assert citations("formats.md §3-§6") == [("formats.md", str(n)) for n in range(3, 7)]
    assert citations("the guide (user-guide.md)") == [("user-guide.md", None)]
    assert source_numbers("eq. 6.12-6.13 and Table 6.7, section 6.3") == ["eq. 6.12-6.13", "Table 6.7", "section 6.3"]


def _cited_in_the_code():
    for path in sorted((REPO / "postproc").rglob("*.py")) + sorted((REPO / "plugins").rglob("*.py")):
        for page, number in citations(path.read_text(encoding="utf-8")):
            yield path.relative_to(REPO), page, number


def test_every_section_the_code_and_the_compensators_cite_exists():
    missing = [(str(path), page, number) for path, page, number in _cited_in_the_code()
               if page in ("methods.md", "formats.md") and number is not None and not title(page, number)]
    assert not missing
    for name, installed in registry.compensators().items():
        for page, number in citations(installed.cls.__doc__ or ""):
            assert page in PAGES and (number is None or title(page, number)), (name, page, number)


def test_a_report_lists_what_it_cites_with_the_titles(tmp_path):
    target = tmp_path / "r.html"
    result = CliRunner().invoke(main, ["report", str(SAMPLES / "programs" / "hemishell.nc"), "--plugin", "parametric",
                                       "--ballbar", str(SAMPLES / "ballbar" / "v40r-100-ccw.csv"),
                                       "--ballbar", str(SAMPLES / "ballbar" / "v40r-100-cw.csv"), "-o", str(target)])
    assert result.exit_code == 0, result.stderr
    text = target.read_text(encoding="utf-8")
    body = html.unescape(re.sub(r"<[^>]+>", " ", text.split('id="references"', 1)[0]))
    cited = set(citations(body))
    assert ("methods.md", "12") in cited and ("methods.md", "3.4") in cited
    table = re.search(r'<table id="references".*?</table>', text, re.S).group(0)
    rows = dict(re.findall(r"<tr><td>(.*?)</td><td>(.*?)</td></tr>", html.unescape(table)))
    for page, number in cited:
        key = f"docs/{page}" + (f" §{number}" if number else "")
        assert key in rows and rows[key] == title(page, number) != "", key
