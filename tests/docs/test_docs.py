"""The project's own pages stay true and self-contained.

- Every hook has a heading in docs/hooks.md with its signature, and a test that uses it.
- Every citation of a page (``docs/methods.md §9.3`` in a help text, a docstring, a message, the
  report, a page) points at a page of the repository and a section that page has; every link of
  a page stays inside the repository and lands on a heading that exists.
- Every number of the source dissertation that code or pages cite (eq. 6.1, Table 6.7) is
  discussed in docs/methods.md, so a reader without the dissertation can look it up.
- docs/formats.md covers every command, compensator option, machine-profile key, measurement
  header key and exit code the code has.
"""

from __future__ import annotations

import dataclasses
import inspect
import os
import re
from pathlib import Path

import click
import pytest

from support import REPO
from postproc.compensate import hookspecs

DOCS = REPO / "docs"
PRUNED = {"__pycache__", "build", "out", "corpus"}  #: folders that hold no pages or code of the project
TEXT = {".py", ".md", ".toml", ".lark", ".txt", ".cfg", ".sh"}

PAGE = re.compile(r"(?<![\w/.-])((?:\.\.?/|[\w-]+/)*[\w-]+\.md)\b")
SECTION = re.compile(r"§\s*(\d+(?:\.\d+)*)")
#: what may stand between a page's name and its sections: separators, and the end and start of
#: links in a page (``[methods.md §3.1](methods.md#31-...), [§3.2](methods.md#32-...)``)
JOINED = re.compile(r"(?:#[\w-]*\))?[\s,;]*(?:(?:and|or|to|-)\s*)?\[?")
NUMBERED = re.compile(r"^#{1,6}\s+(\d+(?:\.\d+)*)\.?\s", re.M)
FENCE = re.compile(r"^```.*?^```[^\n]*$", re.M | re.S)
LINK = re.compile(r"\[(?:[^\]\\]|\\.)*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)|^\s*\[[^\]]+\]:\s*(\S+)|<([a-z][a-z0-9+.-]*:[^>\s]+)>",
                  re.M)
SCHEME = re.compile(r"^[a-z][a-z0-9+.-]*:", re.I)
SOURCE_REF = re.compile(r"\b(eqs?\.|equations?|tables?|figures?|fig\.|sections?|chapters?)\s+(\d+(?:\.\d+)*)"
                        r"((?:\s*(?:-|,|and|to)\s*\d+(?:\.\d+)*)*)", re.I)
KINDS = {"eq": "eq", "equation": "eq", "table": "table", "figure": "figure", "fig": "figure", "section": "section",
         "chapter": "chapter"}


def _files() -> list[Path]:
    """The project's own text files: code, scripts, pages and settings (not data, not environments;
    not this file, whose examples of wrong citations are wrong on purpose)."""
    found = []
    for folder, dirs, names in os.walk(REPO):
        dirs[:] = sorted(d for d in dirs if d not in PRUNED and not d.endswith(".egg-info")
                         and (not d.startswith(".") or d == ".ci"))
        here = Path(folder)
        for name in sorted(names):
            path = here / name
            if (path.suffix in TEXT or here.name in ("scripts", ".ci")) and path != Path(__file__).resolve():
                found.append(path)
    return found


def _pages() -> list[Path]:
    return [path for path in _files() if path.suffix == ".md"]


def _where(path: Path, text: str, index: int) -> str:
    return f"{path.relative_to(REPO)}:{text.count(chr(10), 0, index) + 1}"


def _resolve(page: str, citing: Path) -> Path | None:
    """The repository file a cited page name means: beside the citing file, from the root, in docs/,
    or among the corpus's own pages (tests/corpus/SOURCES.md, which the corpus tests name)."""
    for base in (citing.parent, REPO, DOCS, REPO / "tests" / "corpus"):
        candidate = (base / page).resolve()
        if candidate.is_relative_to(REPO) and candidate.is_file():
            return candidate
    return None


def _outline(page: Path) -> tuple[set[str], set[str]]:
    """The section numbers of a page's numbered headings, and the anchors of all its headings."""
    text = FENCE.sub("", page.read_text(encoding="utf-8"))
    numbers = set(NUMBERED.findall(text))
    anchors: set[str] = set()
    for heading in re.findall(r"^#{1,6}\s+(.+?)\s*#*$", text, re.M):
        anchor = re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")
        unique, count = anchor, 0
        while unique in anchors:
            count += 1
            unique = f"{anchor}-{count}"
        anchors.add(unique)
    return numbers, anchors


def _citations(path: Path, text: str | None = None) -> list[tuple[str, Path | None, str | None, str]]:
    """(where, page cited or None, section or None, problem or "") for every page and section cited.

    A ``§N`` belongs to the page named just before it (``docs/methods.md §4, §6 and §13``); in a
    page, a ``§N`` with no page before it is a section of that page itself."""
    text = path.read_text(encoding="utf-8", errors="replace") if text is None else text
    found = []
    tokens = sorted([(m.start(), m.end(), "page", m) for m in PAGE.finditer(text)]
                    + [(m.start(), m.end(), "section", m) for m in SECTION.finditer(text)], key=lambda t: t[0])
    current, last_end = None, -1
    for start, end, kind, match in tokens:
        where = _where(path, text, start)
        if kind == "page":
            name = match.group(1)
            target = _resolve(name, path)
            problem = "" if target else f"{name}: no such page in the repository"
            after = text[end:end + 12]
            if re.match(r"\s*,?\s*(?:sections?\s+)?\d", after) or re.match(r"\s*,\s*\"", after):
                problem = problem or f"{name}{after.splitlines()[0]}: cite a section by its number, as {name} §N"
            found.append((where, target, None, problem))
            current, last_end = target, end
            continue
        joined = current is not None and JOINED.fullmatch(text[last_end:start])
        page = current if joined else (path if path.suffix == ".md" else None)
        problem = "" if page is not None else f"§{match.group(1)} names no page: cite it as docs/PAGE.md §N"
        found.append((where, page, match.group(1), problem))
        current, last_end = page, end
    return found


def _links(page: Path, text: str | None = None) -> list[tuple[str, str]]:
    text = page.read_text(encoding="utf-8") if text is None else text
    text = FENCE.sub(lambda m: "\n" * m.group(0).count("\n"), text)
    return [(_where(page, text, m.start()), next(g for g in m.groups() if g)) for m in LINK.finditer(text)]


# -- hooks ----------------------------------------------------------------------------------


def _hooks():
    return [name for name, value in vars(hookspecs).items() if name.startswith("postproc_") and inspect.isfunction(value)]


def test_every_hook_is_documented_with_its_signature():
    text = (REPO / "docs" / "hooks.md").read_text()
    for name in _hooks():
        returns = inspect.signature(getattr(hookspecs, name)).return_annotation.strip("'\"")
        assert f"## `{name}() -> {returns}`" in text, name


def test_every_hook_has_a_test():
    tests = "".join(path.read_text() for path in (REPO / "tests").rglob("test_*.py") if path.name != "test_docs.py")
    for name in _hooks():
        assert name in tests, f"no test uses {name}"


# -- citations and links ------------------------------------------------------------------------


def test_the_checker_finds_what_it_must():
    """The checks below can fail: a missing section, a page outside the repository, a section
    cited without its §, a bare § in code and every kind of link are found. (The texts are put
    together here so that this file does not cite them itself.)"""
    md = ".md"
    code = REPO / "postproc" / "probe.py"
    text = (f'"""docs/methods{md} §99.9; ../shared/docs/formats{md}; docs/formats{md} 7; §3."""\n'
            f'"""docs/methods{md} §9.3, §4 and §13."""\n')
    problems = [problem for *_, problem in _citations(code, text) if problem]
    assert len(problems) == 3, problems
    assert problems[0] == f"../shared/docs/formats{md}: no such page in the repository"
    assert problems[1] == f'docs/formats{md} 7; §3.""": cite a section by its number, as docs/formats{md} §N'
    assert problems[2] == "§3 names no page: cite it as docs/PAGE.md §N"
    cited = [(page, number) for _, page, number, problem in _citations(code, text) if number and not problem]
    assert cited == [(DOCS / f"methods{md}", n) for n in ("99.9", "9.3", "4", "13")]
    page = DOCS / f"probe{md}"
    text = ("# Probe\n\n## 1. One\n\nSee §2 and [methods](methods.md#no-such-heading), "
            "[up](../../elsewhere.md), [web](https://example.com), [here](#1-one).\n"
            "```\n[not a link](x)\n```\n")
    assert [(p, n) for _, p, n, _ in _citations(page, text) if n] == [(page, "2")]
    assert [target for _, target in _links(page, text)] == [
        "methods.md#no-such-heading", "../../elsewhere.md", "https://example.com", "#1-one"]


def test_every_cited_page_and_section_exists():
    outlines: dict[Path, set[str]] = {}
    problems = []
    for path in _files():
        for where, page, section, problem in _citations(path):
            if problem:
                problems.append(f"{where}: {problem}")
            elif section is not None:
                numbers = outlines.setdefault(page, _outline(page)[0])
                if section not in numbers:
                    problems.append(f"{where}: {page.relative_to(REPO)} has no section §{section}")
    assert not problems, "\n".join(problems)


def test_no_page_links_outside_the_repository_or_to_a_missing_heading():
    problems = []
    for page in _pages():
        for where, target in _links(page):
            if SCHEME.match(target):
                problems.append(f"{where}: {target} is outside the repository")
                continue
            name, _, anchor = target.partition("#")
            linked = (page.parent / name).resolve() if name else page
            if not linked.is_relative_to(REPO):
                problems.append(f"{where}: {target} is outside the repository")
            elif not linked.exists():
                problems.append(f"{where}: {target} does not exist")
            elif anchor and linked.suffix == ".md" and anchor not in _outline(linked)[1]:
                problems.append(f"{where}: {linked.relative_to(REPO)} has no heading #{anchor}")
    assert not problems, "\n".join(problems)


def _source_refs(text: str) -> set[tuple[str, str]]:
    """(kind, number) of every equation, table, figure, section and chapter of the source cited."""
    refs = set()
    for match in SOURCE_REF.finditer(text):
        kind = KINDS[match.group(1).lower().rstrip(".").rstrip("s")]
        numbers = [match.group(2)] + re.findall(r"\d+(?:\.\d+)*", match.group(3))
        separators = re.findall(r"-|,|and|to", match.group(3))
        between = []
        for first, separator, last in zip(numbers, separators, numbers[1:]):
            head, _, low = first.rpartition(".")
            same, _, high = last.rpartition(".")
            if separator in ("-", "to") and head == same:
                between += [f"{head}.{n}" if head else str(n) for n in range(int(low) + 1, int(high))]
        refs.update((kind, number) for number in numbers + between)
    return refs


def test_every_number_of_the_source_cited_is_discussed_in_methods_md():
    discussed = _source_refs((DOCS / "methods.md").read_text(encoding="utf-8"))
    assert ("eq", "6.8") in discussed  # eq. 6.7-6.10 and the index's lists are read as ranges
    problems = []
    for path in _files():
        text = path.read_text(encoding="utf-8", errors="replace")
        for match in SOURCE_REF.finditer(text):
            for kind, number in _source_refs(match.group(0)) - discussed:
                problems.append(f"{_where(path, text, match.start())}: {kind} {number} of the source is not in "
                                "docs/methods.md")
    assert not problems, "\n".join(problems)


# -- docs/formats.md covers what the code has ---------------------------------------------------


def _formats() -> str:
    return (DOCS / "formats.md").read_text(encoding="utf-8")


def _section(text: str, number: str) -> str:
    """The text of one numbered section of a page, up to the next heading of its level or above."""
    masked = FENCE.sub(lambda m: re.sub(r"[^\n]", " ", m.group(0)), text)  # a '# key' line in an example is no heading
    match = re.search(rf"^(#+)\s+{re.escape(number)}\.?\s.*?$", masked, re.M)
    assert match, f"no section {number}"
    level = len(match.group(1))
    end = re.compile(rf"^#{{1,{level}}}\s", re.M).search(masked, match.end())
    return text[match.start(): end.start() if end else len(text)]


def test_every_command_has_a_section_in_formats_md():
    from postproc.cli.main import main

    context = click.Context(main)
    text = _formats()
    for name in main.list_commands(context):
        command = main.get_command(context, name)
        subcommands = getattr(command, "commands", None)
        if subcommands:
            for sub in subcommands:
                assert f"`postproc {name} {sub}`" in text or f"`{name} {sub}" in text, f"{name} {sub}"
        else:
            assert re.search(rf"^### 8\.\d+ `postproc {name}`$", text, re.M), name


def test_every_compensator_and_option_is_in_formats_md():
    from postproc.compensate.registry import compensators

    text = _formats()
    for name, item in compensators().items():
        heading = re.search(rf"^### (9\.\d+) `{re.escape(name)}`$", text, re.M)
        assert heading, name
        body = _section(text, heading.group(1))
        for option in item.cls.options:
            assert f"`{option.key}" in body, f"{name}: option {option.key}"


def test_every_machine_profile_key_is_in_formats_md():
    from postproc.machine.profile import NOT_KEYS, MachineProfile

    body = _section(_formats(), "15")
    for field in dataclasses.fields(MachineProfile):
        if field.name not in NOT_KEYS:
            assert f"`{field.name}`" in body, field.name


@pytest.mark.parametrize("number, keys", [
    ("4", "postproc.measure.readers.ballbar:KEYS"),
    ("5", "postproc.measure.readers.probe:PROBE_KEYS"),
    ("6", "postproc.measure.readers.probe:CALIBRATION_KEYS"),
    ("3", "postproc.measure.readers.csvfile:COMMON_KEYS"),
])
def test_every_measurement_header_key_is_in_its_section(number, keys):
    import importlib

    module, _, name = keys.partition(":")
    body = _section(_formats(), number)
    for key in getattr(importlib.import_module(module), name):
        assert f"`{key}`" in body, key


def test_every_exit_code_is_in_formats_md():
    from postproc import diagnostics

    body = _section(_formats(), "7.3")
    for name, value in vars(diagnostics).items():
        if name.startswith("EXIT_"):
            assert f"\n| {value} |" in body, name


def test_the_reader_example_in_hooks_md_reads_its_export(tmp_path, run):
    """The documented vendor reader, registered as a plugin, reads a 220 deg export in every command."""
    import importlib.util
    import re

    from postproc.compensate import registry
    from postproc.simulator import ballbar_test, generator, load

    text = (REPO / "docs" / "hooks.md").read_text()
    section = text.split("## Example: a reader for a ballbar export", 1)[1]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    module_path = tmp_path / "vendor_reader.py"
    module_path.write_text(code)
    spec = importlib.util.spec_from_file_location("vendor_reader", module_path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)

    simulation, _ = load(str(REPO / "samples" / "machines" / "v40r-sim.toml"))
    exports = []
    for direction, start in (("ccw", 200.0), ("cw", -20.0)):
        test = ballbar_test(simulation, generator(3, direction), direction, start=start, capture=220.0, overtravel=2.0)
        rows = "".join(f"{a:.2f}  {d * 1000:.4f}\n" for a, d in zip(test.angles, test.deviations))
        export = tmp_path / f"{direction}.bbx"
        export.write_text(f"BALLBAR EXPORT v2\nRadius: 100.000 mm\nDirection: {direction.upper()}\n"
                          f"Feed: 1000 mm/min\nAngle[deg]  Error[um]\n{rows}")
        exports.append(str(export))
    manager = registry.manager()
    manager.register(module, name="vendor-reader-example")
    try:
        result = run("ballbar", *exports, "--json")
        assert result.exit_code == 0, result.stderr
        import json

        report = json.loads(result.stdout)
        assert abs(report["captured_arc_deg"]["cw"]["span"] - 220.0) < 0.6
        assert abs(report["scaling_x"] - 80e-6) < 4e-6 and abs(report["backlash_z_mm"] - 0.003) < 0.0006
        fitted = run("fit", "--plugin", "parametric", *(a for e in exports for a in ("--ballbar", e)),
                     "-o", str(tmp_path / "model.json"))
        assert fitted.exit_code == 0, fitted.stderr
        broken = tmp_path / "broken.bbx"
        broken.write_text(open(exports[0]).read().replace("\n12.00  ", "\n12.00 x "))
        refused = run("ballbar", str(broken))
        assert refused.exit_code == 3 and refused.stderr.startswith(f"{broken}:")
        assert "expected an angle and an error in um" in refused.stderr
    finally:
        manager.unregister(module)
