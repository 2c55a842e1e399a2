"""Differential test: postproc's lathe interpreter against LinuxCNC's ``rs274``.

Two independent interpreters reading the same program must produce the same motions.
Each program goes through ``postproc path`` (in process, through click's CliRunner, to
keep the run short) and through ``to_linuxcnc`` + ``rs274 -g``; every motion is compared:
kind, source line, end point, arc centre and direction to 1e-4 mm, and every start point
but the first.

The first move's start is not compared, nor a coordinate of an axis no motion has commanded
yet: postproc does not know where the tool stands when a program begins (empty cells),
rs274's dummy machine starts at X0 Z0.

Zero-length moves are compared like any other, not filtered: postproc prints a row for
every motion block with axis words, even one that does not move, and so does rs274 for
the blocks ``to_linuxcnc`` writes.  The one place they would differ is a motion code
alone on a block (``G01``): rs274 prints a zero-length move for it, postproc nothing (a
FANUC control does not move); ``to_linuxcnc`` drops such blocks, so rs274 never sees them.
The generator writes such blocks on purpose.

rs274 comes from the Debian package linuxcnc-uspace.  Without it these tests fail rather
than skip: a skipped oracle would hide the whole check.
"""

from __future__ import annotations

import csv
import io
import random
import tempfile
from pathlib import Path

import pytest
from click.testing import CliRunner

from support.corpus import corpus, expectations
from postproc.cli.main import main
from support.generate import program
from support.linuxcnc import Move, RS274Error, rs274_available, run_rs274, to_linuxcnc

SEEDS = range(300)
TOLERANCE_MM = 1e-4
MIN_CORPUS_PROGRAMS = 2
RS274_REQUIRED = ("rs274 (Debian package linuxcnc-uspace) is required for the LinuxCNC differential "
                  "test: apt-get install -y --no-install-recommends linuxcnc-uspace")
COORDINATES = ("x_start", "z_start", "x_end", "z_end", "x_center", "z_center")


def _require_rs274() -> None:
    """Fail, never skip, when rs274 is missing: a skipped oracle would pass silently."""
    if not rs274_available():
        pytest.fail(RS274_REQUIRED, pytrace=False)


def _cell(text: str) -> float | None:
    """A CSV cell: empty where postproc does not know the position."""
    return float(text) if text else None


def _postproc_moves(source: bytes, machine: dict | None = None) -> list[Move]:
    """``postproc path - -o FILE`` on the program's bytes (with a machine profile of these keys), its CSV
    rows as Moves.

    The CSV goes to a file, not stdout: click before 8.2 mixes stderr (warnings) into
    the captured stdout.
    """
    with tempfile.TemporaryDirectory(prefix="postproc-path-") as tmp:
        csv_path = Path(tmp) / "path.csv"
        profile = []
        if machine:
            profile_path = Path(tmp) / "machine.toml"
            profile_path.write_text("".join(f"{key} = {str(value).lower()}\n" for key, value in machine.items()))
            profile = ["--machine", str(profile_path)]
        result = CliRunner().invoke(main, ["path", "-", "-o", str(csv_path), *profile], input=source)
        assert result.exit_code == 0, (
            f"postproc path exited with {result.exit_code}:\n{result.output}{result.exception or ''}")
        rows = list(csv.DictReader(io.StringIO(csv_path.read_text(encoding="utf-8"))))
    return [
        Move(row["kind"], *(_cell(row[c]) for c in COORDINATES), row["direction"] or None,
             line=int(row["line"]))
        for row in rows
    ]


def _linuxcnc_moves(translated: str) -> list[Move]:
    """rs274's moves; an rs274 error fails the test with the program it was given."""
    try:
        return run_rs274(translated)
    except RS274Error as exc:
        pytest.fail(f"{exc}\n--- LinuxCNC program ---\n{translated}", pytrace=False)


def _move_difference(expected: Move, actual: Move, compare_start: bool, unknown: set[str]) -> str | None:
    """What differs between rs274's move and postproc's, or None when they agree.

    ``unknown``: the axes ('x', 'z') no motion has commanded yet. postproc leaves their cells
    empty (it does not know where the tool stands), rs274 reports its dummy start 0; only
    there is an empty cell not a difference.
    """
    for name in ("kind", "line", "direction"):
        if getattr(expected, name) != getattr(actual, name):
            return f"{name}: rs274 {getattr(expected, name)!r}, postproc {getattr(actual, name)!r}"
    for name in COORDINATES if compare_start else COORDINATES[2:]:
        want, got = getattr(expected, name), getattr(actual, name)
        if got is None and want is not None and name[0] in unknown and not name.endswith("center"):
            continue
        if (want is None) != (got is None) or want is not None and abs(want - got) > TOLERANCE_MM:
            return f"{name}: rs274 {want}, postproc {got}"
    return None


def _first_difference(expected: list[Move], actual: list[Move]) -> str | None:
    """The first motion on which rs274 and postproc disagree, described, or None."""
    unknown = {"x", "z"}
    for index, (want, got) in enumerate(zip(expected, actual)):
        problem = _move_difference(want, got, compare_start=index > 0, unknown=unknown)
        unknown -= {axis for axis in ("x", "z") if getattr(got, f"{axis}_end") is not None}
        if problem:
            return (f"motion {index + 1} (source line {want.line}): {problem}\n"
                    f"  rs274:    {want}\n  postproc: {got}")
    if len(expected) != len(actual):
        longer = expected if len(expected) > len(actual) else actual
        return (f"rs274 has {len(expected)} motions, postproc {len(actual)}; "
                f"the first unmatched: {longer[min(len(expected), len(actual))]}")
    return None


def _compare(name: str, source: bytes, translated: str, machine: dict | None = None) -> None:
    """Compare both interpreters on one program; fail naming the program and the first difference."""
    expected = _linuxcnc_moves(translated)
    actual = _postproc_moves(source, machine)
    problem = _first_difference(expected, actual)
    assert problem is None, f"{name}: {problem}\n--- program ---\n{source.decode()}"


@pytest.mark.parametrize("seed", SEEDS)
def test_random_program_matches_linuxcnc(seed):
    _require_rs274()
    text = program(random.Random(seed))
    _compare(f"generated program, seed {seed} (support.generate.program(random.Random({seed})))",
             text.encode("ascii"), to_linuxcnc(text))


def _translate(text: str, machine: dict) -> str | None:
    """The LinuxCNC form of a corpus program, or None when it is outside the common subset.

    Tool words are dropped when that is all that stands in the way: postproc and the
    translator both take an unknown tool's offsets as zero. A program written for
    calculator-type input (its machine profile in expectations.toml says so) is translated so.
    """
    decimal_point = "calculator" if machine.get("calculator_input") else "fanuc"
    for ignore_tool_words in (False, True):
        try:
            return to_linuxcnc(text, ignore_tool_words=ignore_tool_words, decimal_point=decimal_point)
        except ValueError:
            continue
    return None


def test_corpus_programs_match_linuxcnc():
    _require_rs274()
    compared = []
    needs = expectations("fanuc")
    for path in corpus("fanuc"):
        source = path.read_bytes()     # bytes: postproc must see the CRLFs as they are
        machine = needs.get(path.name, {}).get("machine", {})
        translated = _translate(source.decode("utf-8"), machine)
        if translated is not None:
            _compare(str(path), source, translated, machine)
            compared.append(path.name)
    assert len(compared) >= MIN_CORPUS_PROGRAMS, (
        f"only {compared} of the corpus fit the common subset; expected at least {MIN_CORPUS_PROGRAMS}")
