"""Every compensator case in ``tests/compensate/cases/``, run through the command line.

A case is a file: a program, its measurements (files, or made on the virtual lathe by ``postproc
simulate``), the options of ``postproc compensate``, and what must come of them. Adding a case is
adding a file; its name is the test's id. The reading of the files is ``support.cases``."""

from __future__ import annotations

import json

import pytest

from support import REPO
from support.cases import SUMMARY, CaseError, files, load, report_value, toml_text, within


@pytest.mark.parametrize("path", files(), ids=[path.stem for path in files()])
def test_case(run, tmp_path, path):
    try:
        case, problem = load(path), None
    except CaseError as exc:
        case, problem = None, str(exc)
    if problem is not None:  # outside the except clause: the message alone, not a chain of tracebacks
        pytest.fail(problem, pytrace=False)
    program = _program(case, tmp_path)
    machine = _machine(case, tmp_path)
    args = ["compensate", program, *_measurements(case, run, tmp_path, program, machine), *_options(case, machine)]
    report = tmp_path / "report.json"
    if "report" in case.expect:
        args += ["--report", str(report)]
    output = tmp_path / "out.nc"
    result = run(*args, "-o", str(output))
    expect = case.expect
    assert result.exit_code == expect["exit"], f"{case.about}\n{result.stderr}"
    assert result.stdout_bytes == b""
    if "error" in expect:
        assert expect["error"] in result.stderr, result.stderr
    for warning in expect.get("warning", []):
        assert warning in result.stderr, result.stderr
    if expect["exit"] != 0:
        assert not output.exists(), "a refused run wrote a program"
        return
    written = output.read_bytes()
    if "unchanged" in expect:
        assert (written == open(program, "rb").read()) is expect["unchanged"]
    text = written.decode("utf-8", "surrogateescape")
    for line in expect.get("contains", []):
        assert line in text.splitlines(), f"{line!r} not in the output:\n{text}"
    for fragment in expect.get("absent", []):
        assert fragment not in text, f"{fragment!r} in the output"
    figures = {"replaced", "emitted", "largest_correction_um", "largest_deviation_um"} & set(expect)
    if figures:
        found = SUMMARY.search(result.stderr)
        assert found, f"no summary line on stderr:\n{result.stderr}"
        measured = dict(zip(["replaced", "emitted", "largest_correction_um", "largest_deviation_um"],
                            map(float, found.groups())))
        for name in sorted(figures):
            assert within(measured[name], expect[name]), f"{name}: {measured[name]:g}, expected {expect[name]}"
    if "report" in expect:
        document = json.loads(report.read_text())
        for key, wanted in expect["report"].items():
            value = report_value(document, key)
            assert within(value, wanted), f"report {key}: {value:g}, expected {wanted}"


def _program(case, tmp_path) -> str:
    if "path" in case.program:
        return str(REPO / case.program["path"])
    path = tmp_path / f"{case.name}.nc"
    path.write_bytes(case.program["text"].encode("utf-8", "surrogateescape"))
    return str(path)


def _machine(case, tmp_path) -> str | None:
    if case.machine is not None:
        path = tmp_path / "machine.toml"
        path.write_text(toml_text(case.machine))
        return str(path)
    return str(REPO / case.options["machine"]) if "machine" in case.options else None


def _measurements(case, run, tmp_path, program: str, machine: str | None) -> list[str]:
    args = []
    for kind, paths in case.measurements.items():
        for path in paths if isinstance(paths, list) else [paths]:
            args += [f"--{kind}", str(REPO / path)]
    simulate = case.simulate
    made = []
    for direction in simulate.get("ballbar", []):
        made.append(("ballbar", ["ballbar", "--direction", direction], tmp_path / f"{direction}.csv"))
    if "probe" in simulate:
        extra = [item for key, value in simulate["probe"].items() for item in (f"--{key}", str(value))]
        made.append(("probe", ["probe", program, *extra], tmp_path / "probe.csv"))
    if simulate.get("calibration"):
        made.append(("calibration", ["calibrate"], tmp_path / "calibration.csv"))
    for kind, command, path in made:
        result = run("simulate", *command, "--machine", machine, "-o", str(path))
        assert result.exit_code == 0, result.stderr
        args += [f"--{kind}", str(path)]
    return args


def _options(case, machine: str | None) -> list[str]:
    args = ["--machine", machine] if machine is not None else []
    for key, value in case.options.items():
        if key == "machine":
            continue
        if key == "model":
            value = str(REPO / value)
        if isinstance(value, bool):
            args += [f"--{key}"] if value else []
        else:
            args += [item for single in (value if isinstance(value, list) else [value]) for item in (f"--{key}", str(single))]
    return args


MALFORMED = [
    ("not-toml.toml", "about = \n", "not a TOML case file"),
    ("misspelt.toml", 'about = "x"\n[program]\npath = "samples/programs/hemishell.nc"\n[expect]\nexit = 0\nreplacd = 4\n',
     "unknown key 'expect.replacd'"),
    ("no-program.toml", 'about = "x"\n[expect]\nexit = 0\n', "'program' is required"),
    ("outside.toml", 'about = "x"\n[program]\npath = "/etc/passwd"\n[expect]\nexit = 0\n',
     "program.path = '/etc/passwd': give a path under samples/ or tests/"),
    ("missing.toml", 'about = "x"\n[program]\npath = "samples/nothing.nc"\n[expect]\nexit = 0\n',
     "program.path = 'samples/nothing.nc': no such file"),
    ("range.toml", 'about = "x"\n[program]\ntext = "M30\\n"\n[expect]\nexit = 0\nlargest_correction_um = [5, 1]\n',
     "expect.largest_correction_um = [5, 1]: expected a number or [low, high]"),
    ("type.toml", 'about = "x"\n[program]\ntext = "M30\\n"\n[options]\ntolerance = "fine"\n[expect]\nexit = 0\n',
     "options.tolerance = 'fine': expected float"),
    ("no-exit.toml", 'about = "x"\n[program]\ntext = "M30\\n"\n[expect]\nreplaced = 1\n', "expect.exit is required"),
]


@pytest.mark.parametrize("name, text, message", MALFORMED, ids=[case[0] for case in MALFORMED])
def test_a_malformed_case_file_is_named_with_what_is_wrong(tmp_path, name, text, message):
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(CaseError) as info:
        load(path)
    assert str(info.value).startswith(f"{path}: ") and message in str(info.value)


def test_every_built_in_compensator_has_cases():
    from postproc.compensate import registry

    built_in = {name for name, item in registry.compensators().items() if item.distribution == "postproc"}
    covered = {plugin for path in files() for plugin in load(path).options.get("plugin", [])}
    assert built_in - covered == set()
