"""The corpus of real programs: complete and licensed, and every lathe program compensated.

The corpus (tests/corpus, README.md there) is test data the project redistributes, so every
program must have its row in SOURCES.md with a licence that allows it, and every row its program.
Each lathe program is compensated with a model fitted from the bundled ballbar traces; the written
program must pass ``check``. What a program needs (a machine profile key) and the checks an engine
defect fails today are data in expectations.toml (strict xfails, so a fix shows the day it lands).
"""

from __future__ import annotations

import hashlib
import re

import pytest

from support import CORPUS, SAMPLES
from support.corpus import corpus_cases, corpus_dir, expectations, machine_args
from postproc.diagnostics import Reporter

FOLDERS = ("fanuc", "fanuc-mill", "malformed", "linuxcnc")
METADATA = {"README.md", "SOURCES.md", "expectations.toml", ".gitattributes"}
CHECKS = {"roundtrip", "compensate", "needs-machine", "needs-options", "refused", "arcs-placed"}
REDISTRIBUTABLE = {"MIT", "BSD-2-Clause", "BSD-3-Clause", "Apache-2.0", "ISC", "Unlicense", "CC0-1.0", "CC-BY-4.0",
                   "CC-BY-SA-4.0", "GPL-2.0-only", "GPL-2.0-or-later", "GPL-3.0-only", "GPL-3.0-or-later",
                   "LGPL-2.1-only", "LGPL-2.1-or-later", "LGPL-3.0-only", "LGPL-3.0-or-later"}


def _source_rows() -> dict[str, dict[str, str]]:
    """The rows of SOURCES.md's "Files" table, by file (path under tests/corpus)."""
    text = (CORPUS / "SOURCES.md").read_text(encoding="utf-8")
    table = text.split("## Files", 1)[1].split("\n## ", 1)[0]
    lines = [line for line in table.splitlines() if line.startswith("|")]
    header = [cell.strip() for cell in lines[0].strip("|").split("|")]
    rows = {}
    for line in lines[2:]:
        cells = dict(zip(header, (cell.strip() for cell in line.strip("|").split("|"))))
        assert cells["file"] not in rows, f"{cells['file']} has two rows in SOURCES.md"
        rows[cells["file"]] = cells
    return rows


def test_every_program_has_a_licensed_source_row_and_every_row_a_program():
    files = {path.relative_to(CORPUS).as_posix() for path in CORPUS.rglob("*") if path.is_file()}
    programs = files - METADATA
    assert all(name.split("/")[0] in FOLDERS and name.endswith(".nc") for name in programs), sorted(programs)
    rows = _source_rows()
    assert sorted(programs - rows.keys()) == [], "programs without a row in SOURCES.md"
    assert sorted(rows.keys() - programs) == [], "rows in SOURCES.md without their program"
    for name, row in rows.items():
        assert row["licence"] in REDISTRIBUTABLE, f"{name}: licence {row['licence']!r}"
        assert row["copyright"] and re.fullmatch(r"[0-9a-f]{40}", row["commit"]), name
        assert row["repository"] and row["path"] and row["what it exercises"], name
        assert _git_blob(CORPUS / name) == row["blob"], f"{name} is no longer byte for byte its source"


def _git_blob(path) -> str:
    """The file's git blob id (what ``git hash-object`` prints): proves the bytes are the source's."""
    data = path.read_bytes()
    return hashlib.sha1(b"blob %d\0" % len(data) + data).hexdigest()


def test_every_expectation_names_a_program_and_a_known_check():
    for folder in FOLDERS:
        names = {path.name for path in (CORPUS / folder).glob("*.nc")}
        for name, expected in expectations(folder).items():
            assert name in names, f"expectations.toml: {folder}/{name} is not in the corpus"
            assert set(expected.get("xfail", {})) <= CHECKS, (name, expected["xfail"])
            if folder == "malformed":
                assert {"line", "column", "words"} <= expected.keys(), name
    malformed = {path.name for path in (CORPUS / "malformed").glob("*.nc")}
    assert malformed == set(expectations("malformed")), "every malformed program needs its expected error"


MODEL_INPUTS = ["--plugin", "parametric", "--ballbar", str(SAMPLES / "ballbar" / "v40r-100-ccw.csv"),
                "--ballbar", str(SAMPLES / "ballbar" / "v40r-100-cw.csv"), "--option", "extrapolate=true"]


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    """A parametric model fitted from the bundled ballbar traces (ccw and cw, 100 mm)."""
    from click.testing import CliRunner

    from postproc.cli.main import main

    path = tmp_path_factory.mktemp("model") / "m.json"
    result = CliRunner().invoke(main, ["fit", *MODEL_INPUTS, "-o", str(path)], catch_exceptions=False)
    assert result.exit_code == 0, result.stderr
    return path


@pytest.mark.parametrize("path, expected", corpus_cases("fanuc", "compensate"))
def test_lathe_programs_are_compensated_and_the_output_passes_check(run, model, tmp_path, path, expected):
    target = tmp_path / path.name
    machine = machine_args(tmp_path, expected.get("machine", {}))
    result = run("compensate", str(path), "--model", str(model), *machine, *expected.get("options", []),
                 "-o", str(target))
    assert result.exit_code == 0, result.stderr
    assert target.read_bytes() != path.read_bytes(), "the model changed nothing"
    checked = run("check", str(target), *machine)
    assert checked.exit_code == 0, checked.stderr
    assert ": error: " not in checked.stderr


@pytest.mark.parametrize("path, expected", [case for case in corpus_cases("fanuc", "needs-machine")
                                            if case.values[1].get("machine")])
def test_a_program_that_needs_a_profile_key_is_refused_without_it(run, model, tmp_path, path, expected):
    target = tmp_path / path.name
    result = run("compensate", str(path), "--model", str(model), "-o", str(target))
    # 4: refused for safety (a reading the profile must settle, calculator_input); 3: bad input for this
    # profile (a word of an axis the default lathe does not have)
    assert result.exit_code in (3, 4), result.stderr
    assert result.stdout_bytes == b"" and not target.exists()
    assert any(key in result.stderr for key in expected["machine"]), result.stderr


@pytest.mark.parametrize("path, expected", [case for case in corpus_cases("fanuc", "needs-options")
                                            if case.values[1].get("options")])
def test_a_program_that_needs_an_option_is_refused_without_it(run, model, tmp_path, path, expected):
    target = tmp_path / path.name
    machine = machine_args(tmp_path, expected.get("machine", {}))
    result = run("compensate", str(path), "--model", str(model), *machine, "-o", str(target))
    assert result.exit_code == 4, result.stderr
    assert result.stdout_bytes == b"" and not target.exists()
    assert expected["options"][0] in result.stderr.splitlines()[0]


@pytest.mark.parametrize("path, expected", corpus_cases("fanuc", "arcs-placed"))
def test_every_arc_block_is_placed_or_said(path, expected):
    """An arc block (G02/G03 in force, an end point, centre or radius) is a move, or a block that
    passes through uninterpreted (with its warning): never nothing at all."""
    import dataclasses

    from postproc.interpret.gcodes import G02, G03
    from postproc.machine.profile import DEFAULT
    from postproc.interpret.program import interpret_source
    from postproc.syntax.source import Source

    profile = dataclasses.replace(DEFAULT, **expected.get("machine", {}))
    reporter = Reporter()
    with Source(str(path)) as source:
        for step in interpret_source(source, profile, reporter):
            arc_words = {letter for letter, _ in step.block.codes} & set("XZUWCYHVIJKR")
            if step.modal.motion in (G02, G03) and arc_words and not step.block.statement:
                assert step.moves or not step.interpreted, f"line {step.block.line}: {step.block.text}"
                if not step.interpreted:
                    assert any(w.location.line <= step.block.line for w in reporter.warnings)


def test_the_corpus_is_the_repository_s_own_unless_overridden(monkeypatch, tmp_path):
    monkeypatch.delenv("POSTPROC_CORPUS", raising=False)
    assert corpus_dir() == CORPUS
    monkeypatch.setenv("POSTPROC_CORPUS", str(tmp_path))
    assert corpus_dir() == tmp_path
    monkeypatch.setenv("POSTPROC_CORPUS", str(tmp_path / "missing"))
    with pytest.raises(RuntimeError, match="missing"):
        corpus_dir()
