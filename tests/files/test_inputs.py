"""Every input read exactly once, and bounded (postproc.files.inputs, postproc.syntax.source): pipes,
FIFOs, standard input and regular files alike; devices that never end get a clear error."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading

import pytest

from support import SAMPLES
from postproc.files import inputs
from postproc.diagnostics import MeasurementError

HEMISHELL = SAMPLES / "programs" / "hemishell.nc"
CCW, CW = (SAMPLES / "ballbar" / f"v40r-100-{d}.csv" for d in ("ccw", "cw"))
MACHINE = SAMPLES / "machines" / "v40r-sim.toml"
POSTPROC = f"{sys.executable} -c 'from postproc.cli.main import main; main()'"
COMMAND = [sys.executable, "-c", "from postproc.cli.main import main; main()"]


def _bash(script: str, folder) -> subprocess.CompletedProcess:
    return subprocess.run(["bash", "-c", script], capture_output=True, text=True, cwd=folder, timeout=120)


def _body(program: str) -> list[str]:
    """The program without the provenance lines that name a file (a pipe's name is /dev/fd/N); the
    hashes they give kept."""
    return [line.split(" SHA256 ")[-1] if line.startswith(("(INPUT", "(PROFILE")) else line
            for line in program.splitlines() if not line.startswith("(MODEL")]


def test_process_substitution_gives_the_same_program_as_the_files(tmp_path):
    """``<(cat file)`` for the program, both traces and the machine profile: each is read once."""
    files = f"--plugin parametric --ballbar {CCW} --ballbar {CW} --machine {MACHINE}"
    piped = (f"--plugin parametric --ballbar <(cat {CCW}) --ballbar <(cat {CW}) --machine <(cat {MACHINE})")
    direct = _bash(f"{POSTPROC} compensate {HEMISHELL} {files}", tmp_path)
    through = _bash(f"{POSTPROC} compensate <(cat {HEMISHELL}) {piped}", tmp_path)
    assert direct.returncode == through.returncode == 0, through.stderr
    assert "COMPENSATED" in through.stdout and _body(through.stdout) == _body(direct.stdout)


def test_a_model_and_its_fit_through_pipes(tmp_path):
    fitted = _bash(f"{POSTPROC} fit --plugin parametric --ballbar <(cat {CCW}) --ballbar <(cat {CW}) -o m.json",
                   tmp_path)
    assert fitted.returncode == 0, fitted.stderr
    model = json.loads((tmp_path / "m.json").read_text())
    assert [len(entry["sha256"]) for entry in model["inputs"]] == [64, 64]
    applied = _bash(f"{POSTPROC} compensate <(cat {HEMISHELL}) --model <(cat m.json)", tmp_path)
    assert applied.returncode == 0 and "(BLOCKS REPLACED 4 BY 6)" in applied.stdout, applied.stderr


def test_a_named_pipe_is_read_once_and_does_not_hang(tmp_path):
    fifo = tmp_path / "part.fifo"
    os.mkfifo(fifo)

    def feed():
        with open(fifo, "wb") as pipe:  # one writer, as a CAM system or a DNC link would be
            pipe.write(HEMISHELL.read_bytes())

    writer = threading.Thread(target=feed)
    writer.start()
    result = subprocess.run(COMMAND + ["compensate", str(fifo), "--plugin", "parametric", "--ballbar", str(CCW),
                                       "--ballbar", str(CW)], capture_output=True, timeout=60)
    writer.join(10)
    assert result.returncode == 0, result.stderr
    assert b"(BLOCKS REPLACED 4 BY 6)" in result.stdout


@pytest.mark.parametrize("device, message", [
    ("/dev/zero", "/dev/zero:1:1: error: a NUL byte: this is binary data, not a text program; nothing more was read"),
    ("/proc/self/mem", "/proc/self/mem: error: cannot read program: Input/output error"),
])
def test_a_device_as_program_is_a_clear_error(run, device, message):
    if not os.path.exists(device):
        pytest.skip(f"{device} is not on this system")
    for command in ("compensate", "check", "path"):
        result = run(command, device)
        assert (result.exit_code, result.stdout_bytes) == (3, b"")
        assert result.stderr.splitlines()[0] == message


def test_binary_data_on_stdin_is_stopped_at_its_first_nul(run):
    result = run("check", input=b"G00 X1. Z1.\nG01 X2" + b"\x00" * 5000 + b"Z3.\n")
    assert result.exit_code == 3
    assert result.stderr.splitlines()[:3] == [
        "<stdin>:2:7: error: a NUL byte: this is binary data, not a text program; nothing more was read",
        "    G01 X2", "          ^"]


@pytest.mark.parametrize("option", ["--ballbar", "--model", "--machine"])
def test_a_device_as_measurement_model_or_profile_is_bounded(run, option, monkeypatch):
    from postproc.compensate import models
    from postproc.machine import profile
    from postproc.measure.readers import csvfile

    for module in (csvfile, models, profile):
        monkeypatch.setattr(module, "MAX_BYTES", 4096)  # read /dev/zero to a small bound, quickly
    args = {"--ballbar": ["--plugin", "parametric", "--ballbar", "/dev/zero", "--ballbar", str(CW)],
            "--model": ["--model", "/dev/zero"], "--machine": ["--machine", "/dev/zero"]}[option]
    result = run("compensate", str(HEMISHELL), *args)
    assert (result.exit_code, result.stdout_bytes) == (3, b"")
    assert result.stderr.startswith("/dev/zero: error: more than 4096 bytes: too long for ")


def test_a_directory_as_input_is_named_as_such(run, tmp_path):
    assert run("check", str(tmp_path)).stderr == f"{tmp_path}: error: is a directory, not a program\n"
    result = run("compensate", str(HEMISHELL), "--model", str(tmp_path))
    assert (result.exit_code, result.stderr) == (3, f"{tmp_path}: error: is a directory, not a model\n")


def test_within_a_session_a_file_is_read_once(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text("first")
    with inputs.session():
        assert inputs.read(str(path), 100, MeasurementError, "a file").data == b"first"
        path.write_text("second")
        assert inputs.read(str(path), 100, MeasurementError, "a file").data == b"first"
    assert inputs.read(str(path), 100, MeasurementError, "a file").data == b"second"


def test_a_program_changed_while_it_is_compensated_does_not_matter(tmp_path):
    """The program is copied once; what is compensated is what was read."""
    from postproc.syntax.source import Source

    path = tmp_path / "p.nc"
    path.write_bytes(HEMISHELL.read_bytes())
    with Source(str(path)) as source:
        path.write_text("G00 X1.\n")
        assert source.read_bytes() == HEMISHELL.read_bytes()
        assert "".join(source.lines()).encode() == HEMISHELL.read_bytes()


@pytest.mark.parametrize("command, option, source", [
    (["profile", "show"], "--machine", MACHINE),
    (["budget"], None, SAMPLES / "budget" / "v40r-budget.toml"),
])
def test_a_toml_file_saved_with_a_byte_order_mark_reads_as_without_it(run, tmp_path, command, option, source):
    """Windows editors save UTF-8 with a byte order mark, which tomllib calls 'Invalid statement'
    at line 1: every TOML file postproc reads (profile, project file, budget) goes through one
    reader, which drops it."""
    marked = tmp_path / source.name
    marked.write_bytes(b"\xef\xbb\xbf" + source.read_bytes())
    plain = run(*command, *([option] if option else []), str(source))
    result = run(*command, *([option] if option else []), str(marked))
    assert (result.exit_code, result.stderr) == (0, ""), result.stderr
    assert result.stdout == plain.stdout.replace(str(source), str(marked))
    document, text = inputs.read_toml(str(marked), 1 << 20, MeasurementError, "a test file")
    assert not text.startswith("\ufeff") and document == inputs.read_toml(str(source), 1 << 20, MeasurementError, "")[0]


def test_a_project_file_saved_with_a_byte_order_mark_is_read(run, tmp_path, monkeypatch):
    (tmp_path / "postproc.toml").write_bytes(b"\xef\xbb\xbftolerance = 0.002\n")
    monkeypatch.chdir(tmp_path)
    result = run("compensate", str(HEMISHELL))
    assert result.exit_code == 0 and "project file: --tolerance from it" in result.stderr, result.stderr


@pytest.mark.parametrize("name, value, other", [("max_correction", "0.05", "0.08"), ("macro_values", '"keep"', '"refuse"')])
def test_a_project_key_in_both_its_spellings_is_refused(run, tmp_path, monkeypatch, name, value, other):
    (tmp_path / "postproc.toml").write_text(f"{name.replace('_', '-')} = {value}\n{name} = {other}\n")
    monkeypatch.chdir(tmp_path)
    result = run("check", str(HEMISHELL))
    assert (result.exit_code, result.stdout) == (3, "")
    assert f"postproc.toml:2:1: error: {name} is given twice" in result.stderr, result.stderr


PROBE = SAMPLES / "probe" / "hemishell-pass1.csv"
CALIBRATION = SAMPLES / "probe" / "artifact-calibration.csv"


def _model(tmp_path) -> str:
    model = tmp_path / "model.json"
    subprocess.run([*COMMAND, "fit", "--plugin", "parametric", "--ballbar", str(CCW), "--ballbar", str(CW), "-o",
                    str(model)], check=True, capture_output=True)
    return str(model)


#: (the command with {} where the file goes, the file piped): every kind of file a command reads
_PIPED = {
    "a trace to ballbar": (["ballbar", "{}", "--json"], CCW),
    "a trace to compensate": (["compensate", str(HEMISHELL), "--plugin", "parametric", "--ballbar", "{}",
                               "--ballbar", str(CW)], CCW),
    "probe points": (["compensate", str(HEMISHELL), "--plugin", "omp-feedback", "--probe", "{}"], PROBE),
    "a calibration": (["compensate", str(HEMISHELL), "--plugin", "omp-feedback", "--probe", str(PROBE),
                       "--calibration", "{}"], CALIBRATION),
    "a machine profile": (["profile", "show", "--machine", "{}"], MACHINE),
    "a model": (["compensate", str(HEMISHELL), "--model", "{}"], None),
}


@pytest.mark.parametrize("case", sorted(_PIPED))
def test_any_file_a_command_reads_may_be_piped_in_as_dash(tmp_path, case):
    """`--ballbar -` read a file named '-' ("-: cannot read the file: No such file or directory"):
    every file a command reads is standard input when given as -, and gives what the file gives."""
    arguments, source = _PIPED[case]
    source = source or _model(tmp_path)
    as_file = subprocess.run([*COMMAND, *(str(source) if a == "{}" else a for a in arguments)], capture_output=True)
    with open(source, "rb") as piped:
        as_pipe = subprocess.run([*COMMAND, *("-" if a == "{}" else a for a in arguments)], stdin=piped,
                                 capture_output=True)
    assert as_file.returncode == as_pipe.returncode == 0, as_pipe.stderr
    piped_name = as_pipe.stdout.decode().replace("<stdin>", "-").replace("_STDIN_", "-")  # how a record names stdin
    assert _body(piped_name) \
        == _body(as_file.stdout.decode().replace(str(source), "-").replace(os.path.basename(source).upper(), "-"))


@pytest.mark.parametrize("arguments", [
    ["compensate", "--plugin", "parametric", "--ballbar", "-", "--ballbar", str(CW)],  # the program is stdin too
    ["ballbar", "-", "-"],
    ["compensate", str(HEMISHELL), "--plugin", "omp-feedback", "--probe", "-", "--calibration", "-"],
])
def test_standard_input_named_twice_is_refused(arguments):
    with open(CCW, "rb") as piped:
        result = subprocess.run([*COMMAND, *arguments], stdin=piped, capture_output=True, text=True)
    assert (result.returncode, result.stdout) == (2, "")
    assert "standard input (-) is given 2 times" in result.stderr, result.stderr


def test_a_bad_file_piped_in_is_named_stdin():
    result = subprocess.run([*COMMAND, "ballbar", "-"], input="angle,deviation\n0,1\n", capture_output=True, text=True)
    assert result.returncode == 3
    assert result.stderr.startswith("<stdin>:1: error: the first line must be '# postproc ballbar 1'"), result.stderr
