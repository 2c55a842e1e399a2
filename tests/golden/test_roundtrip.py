"""Round trips: what the corpus README asks of each folder, through the command line."""

from __future__ import annotations

import re

import pytest
from hypothesis import HealthCheck, given, settings

from support import SAMPLES
from support.corpus import corpus_cases, machine_args
from postproc.syntax.reader import read_blocks
from postproc.syntax.source import Source
from support.strategies import lathe_programs


def _programs():
    samples = [pytest.param(path, {}, id=path.name) for path in sorted(SAMPLES.glob("**/*.nc"))]
    return corpus_cases("fanuc", "roundtrip") + samples


@pytest.mark.parametrize("path, expected", _programs())
def test_lathe_programs_come_back_byte_for_byte(run, path, expected, tmp_path):
    data = path.read_bytes()
    machine = machine_args(tmp_path, expected.get("machine", {}))
    by_file = run("compensate", str(path), *machine)
    assert by_file.exit_code == 0, by_file.stderr
    assert by_file.stdout_bytes == data
    by_stdin = run("compensate", *machine, input=data)
    assert by_stdin.exit_code == 0, by_stdin.stderr
    assert by_stdin.stdout_bytes == data
    checked = run("check", str(path), *machine)
    assert checked.exit_code == 0, checked.stderr
    assert checked.stdout == ""


@pytest.mark.parametrize("path, expected", corpus_cases("fanuc-mill", "roundtrip"))
def test_mill_programs_parse_losslessly(path, expected):
    with Source(str(path)) as source:
        blocks = list(read_blocks(source.lines(), source.name))
        assert b"".join(b.raw.encode("utf-8", "surrogateescape") for b in blocks) == path.read_bytes()
        # every word's spelling is a piece of its line, at its column
        for block in blocks:
            for word in block.words:
                assert block.text[word.col : word.end] == word.text


@pytest.mark.parametrize("path, expected", corpus_cases("malformed", "refused"))
def test_malformed_programs_are_refused_with_a_position_and_no_output(run, path, expected, tmp_path):
    line, col, words = expected["line"], expected["column"], expected["words"]
    target = tmp_path / "out.nc"
    for args in (("compensate", str(path)), ("compensate", str(path), "-o", str(target)), ("check", str(path))):
        result = run(*args)
        assert result.exit_code == 3
        assert result.stdout_bytes == b""
        first = result.stderr.splitlines()[0]
        assert re.match(rf"^{re.escape(str(path))}:{line}:{col}: error: ", first), first
        assert words in first
    assert not target.exists()
    assert list(tmp_path.iterdir()) == []  # not even a temporary file is left


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(lathe_programs())
def test_generated_programs_come_back_byte_for_byte(run, text):
    data = text.encode()
    result = run("compensate", input=data)
    assert result.exit_code == 0, result.stderr
    assert result.stdout_bytes == data
