"""``--region`` (postproc.compensate.region): every form the docs name, a single line or label as
its own range, and a malformed value refused naming the forms."""

from __future__ import annotations

import re

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from postproc.compensate.region import Range, parse
from postproc.diagnostics import OptionError
from support import SAMPLES

HEMISHELL = str(SAMPLES / "programs" / "hemishell.nc")
TRACES = ["--plugin", "parametric", "--ballbar", str(SAMPLES / "ballbar" / "v40r-100-ccw.csv"),
          "--ballbar", str(SAMPLES / "ballbar" / "v40r-100-cw.csv")]
GRAMMAR = re.compile(r"^([Nn]\d+(-[Nn]\d+)?|[Ll]?\d+(-[Ll]?\d+)?|[Tt]\d{1,4})$")


@given(st.integers(1, 10**6), st.integers(0, 10**6))
def test_every_documented_form_parses_and_one_number_is_its_own_range(first, more):
    last = first + more
    for text in (f"L{first}-L{last}", f"{first}-{last}", f"l{first}-{last}", f" L{first}-L{last} "):
        assert parse(text) == Range("lines", first, last), text
    for text in (f"L{first}", f"{first}", f"l{first}"):
        assert parse(text) == parse(f"L{first}-L{first}") == Range("lines", first, first), text
    assert parse(f"N{first}") == parse(f"N{first}-N{first}") == Range("labels", first, first)
    assert parse(f"N{first}-N{last}") == Range("labels", first, last)
    if more:
        with pytest.raises(OptionError, match="the first line comes after the last"):
            parse(f"L{last}-L{first}")


@pytest.mark.parametrize("text, tool", [("T1", 1), ("T01", 1), ("T0101", 1), ("t12", 12), ("T1203", 12)])
def test_a_tool_region_takes_the_tool_not_its_offset(text, tool):
    assert parse(text) == Range("tool", tool, tool)


@given(st.text(alphabet="LlNnTt0123456789-. ,:x", max_size=12))
def test_anything_else_is_refused_naming_the_forms(text):
    if GRAMMAR.match(text.strip()):
        return
    with pytest.raises(OptionError, match=r"expected N100-N200 or N100 .* L10-L50, L10, 10-50 or 10 .* T01"):
        parse(text)


@pytest.mark.parametrize("text, said", [("L0", "lines are counted from 1"), ("0-4", "lines are counted from 1"),
                                        ("T0", "tool 0 is no tool"), ("T00", "tool 0 is no tool"),
                                        ("T0001", "tool 0 is no tool")])
def test_a_region_that_can_select_nothing_is_refused(text, said):
    with pytest.raises(OptionError, match=said):
        parse(text)


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(line=st.sampled_from([9, 10, 11]), spelling=st.sampled_from(["L{0}", "{0}", "l{0}-L{0}"]))
def test_a_single_line_compensates_as_its_range_does(run, line, spelling):
    one = run("compensate", HEMISHELL, *TRACES, "--region", spelling.format(line))
    both = run("compensate", HEMISHELL, *TRACES, "--region", f"L{line}-L{line}")
    assert (one.exit_code, both.exit_code) == (0, 0), one.stderr
    strip = lambda out: [l for l in out.splitlines() if not l.startswith("(REGION ")]  # noqa: E731
    assert strip(one.stdout) == strip(both.stdout)
    assert one.stderr == both.stderr


def test_a_malformed_region_writes_nothing(run):
    result = run("compensate", HEMISHELL, *TRACES, "--region", "L10-")
    assert result.exit_code == 3
    assert result.stdout == ""
    assert result.stderr == ("postproc: error: --region L10-: expected N100-N200 or N100 (sequence numbers), "
                             "L10-L50, L10, 10-50 or 10 (source lines), or a tool like T01\n")


NUMBERED = ("%\nO5000\nG18 G21 G40 G99\nT0101\nG96 S200 M03\nN100 G00 X100. Z5.\nN110 G01 X20. F0.1\nN120 Z-10.\n"
            "N130 X40. Z-30.\nN140 Z-45.\nN150 G02 X80. Z-65. R20.\nN160 G01 Z-80.\nN170 G00 X200. Z150.\nM30\n%\n")


def _changed_lines(original: str, written: str) -> set[int]:
    """The lines of ``original`` (1-based) that do not come out as they were, in order."""
    import difflib

    old = original.splitlines()
    new = [line for line in written.splitlines() if not line.startswith("(") or line in old]
    kept = set()
    for block in difflib.SequenceMatcher(None, old, new, autojunk=False).get_matching_blocks():
        kept.update(range(block.a + 1, block.a + block.size + 1))
    return set(range(1, len(old) + 1)) - kept


@pytest.mark.parametrize("region, lines", [
    ("N120", {8}), ("N110-N140", {7, 8, 9, 10}), ("N100-N160", set(range(6, 13))), ("N150", {11}),
    ("L8-L9", {8, 9}), ("N130-N130", {9}), ("N100", {6}),
])
def test_blocks_outside_the_region_come_out_as_they_were(run, tmp_path, region, lines):
    """The region's first and last blocks meet their neighbours' nominal ends themselves: the
    block before and the block after stay byte for byte, as everything outside does; a
    sequence number on a block the compensation does not change (a rapid) still opens and
    closes its range."""
    program = tmp_path / "p.nc"
    program.write_text(NUMBERED)
    result = run("compensate", str(program), *TRACES, "--region", region)
    assert result.exit_code == 0, result.stderr
    changed = _changed_lines(NUMBERED, result.stdout)
    assert changed <= lines, (region, sorted(changed - lines))
    if lines & {8, 9, 10, 11, 12}:  # a feed move inside: something is compensated
        assert changed, result.stderr


@pytest.mark.parametrize("region, said", [
    ("N110-N999", "has no block N999"),
    ("N140-N110", "N110 (line 7) comes before N140 (line 10)"),
    ("N990", "has no block N990"),
])
def test_a_sequence_number_range_the_program_cannot_hold_is_refused(run, tmp_path, region, said):
    """A range whose label is missing or that runs backwards would select nothing or run on to
    the end of the program: refused (exit 3), nothing written."""
    program = tmp_path / "p.nc"
    program.write_text(NUMBERED)
    result = run("compensate", str(program), *TRACES, "--region", region)
    assert result.exit_code == 3 and result.stdout == ""
    assert said in result.stderr


def test_a_sequence_number_on_two_blocks_is_refused_as_a_region(run, tmp_path):
    program = tmp_path / "p.nc"
    program.write_text(NUMBERED.replace("N160 G01", "N120 G01"))
    result = run("compensate", str(program), *TRACES, "--region", "N120")
    assert result.exit_code == 3 and result.stdout == ""
    assert "N120 stands on 2 blocks" in result.stderr and "give the lines instead, e.g. L8-L8" in result.stderr


MODAL_ARCS = ("%\nO8000\nG18 G21 G40 G99\nT0101\nG96 S200 M03\nG00 X20. Z5.\nG01 Z0. F0.1\nX60. Z-20.\n"
              "G02 X100. Z-40. R20.\nX120. Z-50. R10.\nG01 Z-60.\nG00 X150. Z50.\nM30\n%\n")


@pytest.mark.parametrize("region", ["L9", "L8-L9"])
def test_a_block_after_the_region_that_relies_on_its_mode_is_named_not_changed(run, tmp_path, region):
    """The region's last block (a G02 arc) ends at a join, a G01, and the block after it,
    outside the region, relies on modal G02: writing G02 in front of it would change a block the
    region leaves alone, so the run is refused naming that block, and nothing is written."""
    program = tmp_path / "p.nc"
    program.write_text(MODAL_ARCS)
    out = tmp_path / "out.nc"
    result = run("compensate", str(program), *TRACES, "--region", region, "-o", str(out))
    assert result.exit_code == 4 and result.stdout == "" and not out.exists()
    assert f"{program}:10:1: error: this block, outside --region, relies on modal G02" in result.stderr
    assert "widen --region" in result.stderr
    wider = run("compensate", str(program), *TRACES, "--region", region.split("-")[0] + "-L10")
    assert wider.exit_code == 0, wider.stderr
