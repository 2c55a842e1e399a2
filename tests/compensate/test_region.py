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
