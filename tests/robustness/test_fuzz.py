"""Fuzzing: whatever a program, a measurement file or a model holds, postproc answers with a
clean result or one diagnostic.

Generated programs (from the grammar's constructs) and real programs of the corpus mutated
byte by byte (cut, duplicated and swapped bytes, inserted characters, stray macros) go through
``check`` and ``compensate``; the sample measurement files (ballbar traces, probe points, a
calibration) mutated the same way go through ``ballbar`` and ``compensate``; saved models are
mutated byte by byte and, re-signed so that their hash still matches, value by value (any key
replaced by any JSON value, or removed). Every outcome must be exit 0 with the program, or exit
2/3/4 with exactly one error line naming a position and no output at all: never a traceback
or an internal error, never a hang (each example has a deadline), never partial output.

The suite runs a size CI affords. A longer run, for a scheduled job::

    POSTPROC_FUZZ_EXAMPLES=20000 .venv/bin/pytest tests/robustness/test_fuzz.py
"""

from __future__ import annotations

import os
import re

import hashlib
import json

from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from postproc.cli.main import main
from postproc.compensate.models import _canonical

from support import SAMPLES
from support.corpus import corpus
from support.strategies import lathe_programs, lines

EXAMPLES = int(os.environ.get("POSTPROC_FUZZ_EXAMPLES", "150"))
FUZZ = settings(max_examples=EXAMPLES, deadline=10_000, suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                                             HealthCheck.too_slow])
PROGRAMS = [path.read_bytes() for path in corpus("fanuc") + corpus("fanuc-mill") + corpus("malformed")]
DIAGNOSTIC = re.compile(r"^(?:<stdin>|\S+?)(?::\d+){1,2}: error: \S")
NOISE = [b"(", b")", b"#", b"[", b"]", b";", b".", b"-", b"+", b"N", b"O", b"%", b"/", b",", b":", b"=", b" ",
         b"\t", b"\r", b"\n", b"\x00", b"\xff", b"\xc3\xa9", b"G", b"X", b"9", b"#1=", b"IF[", b"GOTO", b"WHILE[",
         b"END1", b"G71P", b"Q", b"R-", b",C", b"G02", b"M98P", b"(((", b"))"]


@st.composite
def mutated(draw, sources=PROGRAMS) -> bytes:
    data = bytearray(draw(st.sampled_from(sources)))
    for _ in range(draw(st.integers(1, 4))):
        if not data:
            break
        at = draw(st.integers(0, len(data) - 1))
        kind = draw(st.integers(0, 4))
        if kind == 0:  # cut
            data = data[: at] + data[at + draw(st.integers(1, 40)):]
        elif kind == 1:  # duplicate a run
            run = data[at : at + draw(st.integers(1, 40))]
            data[at:at] = run
        elif kind == 2:  # swap two bytes
            other = draw(st.integers(0, len(data) - 1))
            data[at], data[other] = data[other], data[at]
        else:  # insert a character or a stray macro
            data[at:at] = draw(st.sampled_from(NOISE))
    return bytes(data)


def _outcome(result, output_exists: bool = False) -> None:
    """Exit 0 with the program, or one error with a position and nothing written."""
    assert result.exit_code in (0, 2, 3, 4), (result.exit_code, result.stderr[-2000:])
    assert "Traceback" not in result.stderr
    if result.exit_code != 0:
        errors = [line for line in result.stderr.splitlines() if ": error: " in line]
        assert len(errors) == 1, result.stderr
        if result.exit_code == 3:
            assert DIAGNOSTIC.match(errors[0]) or ": error: " in errors[0], errors[0]
        assert result.stdout_bytes == b""
        assert not output_exists


@FUZZ
@given(mutated())
def test_mutated_programs_get_a_result_or_one_diagnostic(run, tmp_path_factory, data):
    folder = tmp_path_factory.mktemp("fuzz")
    target = folder / "out.nc"
    result = run("compensate", "-o", str(target), input=data)
    _outcome(result, target.exists())
    if result.exit_code == 0:
        assert target.read_bytes() == data  # identity: byte for byte
    assert [p.name for p in folder.iterdir()] in ([], ["out.nc"])  # no temporary file left
    _outcome(run("check", input=data))


@FUZZ
@given(st.lists(lines(), min_size=1, max_size=12), st.sampled_from(["\n", "\r\n"]))
def test_generated_lines_get_a_result_or_one_diagnostic(run, text_lines, eol):
    data = eol.join(text_lines).encode("utf-8", "surrogateescape")
    result = run("compensate", input=data)
    _outcome(result)
    if result.exit_code == 0:
        assert result.stdout_bytes == data


@FUZZ
@given(lathe_programs())
def test_valid_programs_round_trip(run, text):
    result = run("compensate", input=text.encode())
    assert (result.exit_code, result.stdout_bytes) == (0, text.encode()), result.stderr


ZERO_TRACE = "".join(f"{a},0.0\n" for a in range(0, 360, 2))


@FUZZ
@given(st.integers(0, 10_000))
def test_a_zero_model_gives_the_nominal_path(run, tmp_path_factory, seed):
    """Compensation that corrects nothing leaves every move where it was (within tolerance)."""
    import random

    from support.interpret import moves
    from support.generate import program

    folder = tmp_path_factory.mktemp("zero")
    trace = folder / "zero.csv"
    trace.write_text(f"# postproc ballbar 1\n# radius_mm = 50\n# direction = ccw\n# centered = true\n"
                     f"angle_deg,deviation_mm\n{ZERO_TRACE}")
    text = program(random.Random(seed))
    result = run("compensate", "--plugin", "ballbar-inverse", "--ballbar", str(trace), "--option",
                 "radius-mapping=absolute", "--option", "max-gap=10", input=text.encode())
    assert result.exit_code == 0, result.stderr
    nominal = [m for m in moves(text)]
    compensated = [m for m in moves(result.stdout)]
    assert len(nominal) == len(compensated)
    for a, b in zip(nominal, compensated):
        assert (a.kind, a.x1, a.z1, a.xc, a.zc) == (b.kind, b.x1, b.z1, b.xc, b.zc)


def test_the_samples_are_valid_programs(run):
    for path in sorted((SAMPLES / "programs").glob("*.nc")):
        assert run("check", str(path)).exit_code == 0


HEMISHELL = str(SAMPLES / "programs" / "hemishell.nc")
CCW, CW = (str(SAMPLES / "ballbar" / f"v40r-100-{d}.csv") for d in ("ccw", "cw"))
PROBE = str(SAMPLES / "probe" / "hemishell-pass1.csv")
CALIBRATION = str(SAMPLES / "probe" / "artifact-calibration.csv")
MEASUREMENTS = {
    "ballbar": [(SAMPLES / "ballbar" / name).read_bytes() for name in ("v40r-100-ccw.csv", "v40r-100-ccw-raw.csv")],
    "probe": [(SAMPLES / "probe" / "hemishell-pass1.csv").read_bytes()],
    "calibration": [(SAMPLES / "probe" / "artifact-calibration.csv").read_bytes()],
}
MEASUREMENT_NOISE = [b",", b"#", b"=", b"-", b".", b"e", b"9", b"nan", b"inf", b"\n", b"\r", b"\x00", b"\xff",
                     b"# measured = 2026-01-01T00:00:00", b"# x-note = 1", b"1e308", b"0", b" "]


@st.composite
def mutated_measurement(draw) -> tuple[str, bytes]:
    kind = draw(st.sampled_from(sorted(MEASUREMENTS)))
    data = bytearray(draw(st.sampled_from(MEASUREMENTS[kind])))
    for _ in range(draw(st.integers(1, 4))):
        if not data:
            break
        at = draw(st.integers(0, len(data) - 1))
        kind_of_change = draw(st.integers(0, 3))
        if kind_of_change == 0:
            data = data[:at] + data[at + draw(st.integers(1, 40)):]
        elif kind_of_change == 1:
            data[at:at] = data[at : at + draw(st.integers(1, 40))]
        else:
            data[at:at] = draw(st.sampled_from(MEASUREMENT_NOISE))
    return kind, bytes(data)


@FUZZ
@given(mutated_measurement())
def test_mutated_measurement_files_get_a_result_or_one_diagnostic(run, tmp_path_factory, case):
    kind, data = case
    folder = tmp_path_factory.mktemp("measurement")
    path = folder / f"{kind}.csv"
    path.write_bytes(data)
    target = folder / "out.nc"
    arguments = {"ballbar": ["--plugin", "parametric", "--option", "extrapolate=true", "--ballbar", str(path),
                             "--ballbar", CW],
                 "probe": ["--plugin", "omp-feedback", "--probe", str(path)],
                 "calibration": ["--plugin", "omp-feedback", "--probe", PROBE, "--calibration", str(path)]}[kind]
    result = run("compensate", HEMISHELL, *arguments, "-o", str(target))
    _outcome(result, target.exists() and result.exit_code != 0)
    if kind == "ballbar":
        _outcome(run("ballbar", str(path)))


def _fitted(plugin: str, *arguments: str) -> dict:
    folder = SAMPLES.parent / ".pytest-fuzz-models"  # a fitted model, made once per session in memory
    result = CliRunner().invoke(main, ["fit", "--plugin", plugin, *arguments], catch_exceptions=False)
    assert result.exit_code == 0, (folder, result.stderr)
    return json.loads(result.stdout)


MODELS = {
    "parametric": _fitted("parametric", "--ballbar", CCW, "--ballbar", CW),
    "ballbar-inverse": _fitted("ballbar-inverse", "--ballbar", CCW, "--ballbar", CW, "--option",
                               "radius-mapping=relative"),
    "omp-feedback": _fitted("omp-feedback", "--probe", PROBE),
}
JSON_VALUES = st.recursive(
    st.none() | st.booleans() | st.integers(-10**20, 10**20) | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(max_size=8),
    lambda children: st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=8), children, max_size=4),
    max_leaves=8)


def _places(value, path=()):
    """Every place in a JSON value: the key paths of its objects' members and lists' items."""
    items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list) else ()
    for key, item in items:
        yield path + (key,)
        if len(path) < 6 and not (isinstance(item, list) and len(item) > 8):
            yield from _places(item, path + (key,))
        elif isinstance(item, list) and item:
            yield path + (key, 0)


@st.composite
def changed_models(draw) -> bytes:
    plugin = draw(st.sampled_from(sorted(MODELS)))
    data = json.loads(json.dumps(MODELS[plugin]))
    data.pop("sha256")
    for _ in range(draw(st.integers(1, 3))):
        place = draw(st.sampled_from(list(_places(data))))
        parent = data
        for key in place[:-1]:
            parent = parent[key]
        if isinstance(parent, dict) and draw(st.booleans()) and draw(st.booleans()):
            parent.pop(place[-1], None)
        else:
            parent[place[-1]] = draw(JSON_VALUES)
    data["sha256"] = hashlib.sha256(_canonical(data)).hexdigest()
    return json.dumps(data).encode()


@FUZZ
@given(st.one_of(changed_models(), mutated([json.dumps(model).encode() for model in MODELS.values()])))
def test_changed_models_get_a_result_or_one_diagnostic(run, tmp_path_factory, data):
    folder = tmp_path_factory.mktemp("model")
    model = folder / "m.json"
    model.write_bytes(data)
    target = folder / "out.nc"
    result = run("compensate", HEMISHELL, "--model", str(model), "-o", str(target))
    _outcome(result, target.exists() and result.exit_code != 0)
