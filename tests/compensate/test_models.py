"""Fit once, apply many times: saved models, their checks and their warnings."""

from __future__ import annotations

import hashlib
import json
import uuid

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings, strategies as st

from postproc.cli.main import main
from postproc.compensate import models
from postproc.measure.ballbar_analysis import BOUNDS
from support import SAMPLES

HEMISHELL = str(SAMPLES / "programs" / "hemishell.nc")
CCW, CW = (str(SAMPLES / "ballbar" / f"v40r-100-{d}.csv") for d in ("ccw", "cw"))
FIT = ["fit", "--plugin", "ballbar-inverse", "--ballbar", CCW, "--ballbar", CW, "--option", "radius-mapping=relative"]


def _body(program: str) -> list[str]:
    """The program without its provenance comments (they name the inputs differently)."""
    return [line for line in program.splitlines() if not line.startswith(("(POSTPROC", "(PLUGIN", "(INPUT", "(MODEL",
                                                                          "(TOLERANCE", "(LARGEST", "(BLOCKS"))]


def test_a_saved_model_compensates_as_the_measurements_did(run, tmp_path):
    model = tmp_path / "model.json"
    fitted = run(*FIT, "--note", "warmed up 2 h", "-o", str(model))
    assert fitted.exit_code == 0 and fitted.stdout == "", fitted.stderr
    data = json.loads(model.read_text())
    assert (data["format"], data["version"], data["plugin"], data["note"]) == ("postproc model", 1, "ballbar-inverse", "warmed up 2 h")
    assert [entry["file"] for entry in data["inputs"]] == [CCW, CW] and len(data["inputs"][0]["sha256"]) == 64
    applied = run("compensate", HEMISHELL, "--model", str(model))
    direct = run("compensate", HEMISHELL, "--plugin", "ballbar-inverse", "--ballbar", CCW, "--ballbar", CW,
                 "--option", "radius-mapping=relative")
    assert applied.exit_code == direct.exit_code == 0
    assert _body(applied.stdout) == _body(direct.stdout)
    assert "(MODEL MODEL.JSON)" in applied.stdout


def test_a_changed_or_foreign_model_is_refused(run, tmp_path):
    model = tmp_path / "model.json"
    run(*FIT, "-o", str(model))
    data = json.loads(model.read_text())
    data["model"]["traces"]["ccw"]["deviations_mm"][0] += 0.01
    model.write_text(json.dumps(data))
    result = run("compensate", HEMISHELL, "--model", str(model))
    assert result.exit_code == 3 and result.stdout == ""
    assert result.stderr.startswith(f"{model}: error: the model's content does not match its SHA-256")
    data["version"] = 2
    model.write_text(json.dumps(data))
    assert "a model of version 2" in run("compensate", HEMISHELL, "--model", str(model)).stderr
    model.write_text("[1, 2")
    assert "not a postproc model (not JSON" in run("compensate", HEMISHELL, "--model", str(model)).stderr


@pytest.mark.parametrize("ending", ["\n", "\r\n"])
def test_a_model_saved_again_by_an_editor_with_a_byte_order_mark_reads_as_it_was(run, tmp_path, ending):
    """Opened and saved in a Windows editor, a model gains a BOM (and perhaps CR LF): its content,
    which the SHA-256 covers, is the same, and so is the compensation."""
    model = tmp_path / "model.json"
    run(*FIT, "-o", str(model))
    plain = run("compensate", HEMISHELL, "--model", str(model))
    model.write_bytes(b"\xef\xbb\xbf" + model.read_bytes().replace(b"\n", ending.encode()))
    again = run("compensate", HEMISHELL, "--model", str(model))
    assert again.exit_code == plain.exit_code == 0, again.stderr
    assert again.stdout == plain.stdout


def test_an_old_model_or_one_for_another_machine_warns(run, tmp_path):
    import datetime as dt
    import hashlib

    from postproc.compensate.models import _canonical

    model = tmp_path / "model.json"
    run(*FIT, "-o", str(model))
    data = json.loads(model.read_text())
    data.pop("sha256")
    data["measured"] = (dt.datetime.now(dt.timezone.utc) - dt.timedelta(days=90)).replace(microsecond=0).isoformat()
    data["machine_profile"] = "another-lathe"
    data["sha256"] = hashlib.sha256(_canonical(data)).hexdigest()
    model.write_text(json.dumps(data))
    result = run("compensate", HEMISHELL, "--model", str(model))
    assert result.exit_code == 0
    assert "was measured 90 days ago" in result.stderr and "made for machine profile 'another-lathe'" in result.stderr


def test_a_model_carries_its_own_compensator_and_options(run, tmp_path):
    model = tmp_path / "model.json"
    run(*FIT, "-o", str(model))
    result = run("compensate", HEMISHELL, "--model", str(model), "--plugin", "iterative")
    assert result.exit_code == 2 and "--model carries its compensator" in result.stderr


def test_a_model_is_dated_by_the_measured_key_of_its_files(run, tmp_path):
    """Every measurement format takes ``measured`` (ISO 8601 with a zone); a model is as old as its oldest measurement, in UTC."""
    stamped = []
    for path, moment in ((CCW, "2026-11-20T14:05:00+01:00"), (CW, "2026-11-20T14:35:00+01:00")):
        lines = open(path).read().splitlines(keepends=True)
        copy = tmp_path / path.rsplit("/", 1)[-1]
        copy.write_text(lines[0] + f"# measured = {moment}\n" + "".join(lines[1:]))
        stamped.append(str(copy))
    model = tmp_path / "model.json"
    fitted = run("fit", "--plugin", "parametric", "--ballbar", stamped[0], "--ballbar", stamped[1], "-o", str(model))
    assert fitted.exit_code == 0, fitted.stderr
    assert json.loads(model.read_text())["measured"] == "2026-11-20T13:05:00+00:00"
    for name in ("probe/hemishell-pass1.csv", "probe/artifact-calibration.csv"):
        lines = (SAMPLES / name).read_text().splitlines(keepends=True)
        probe = tmp_path / name.rsplit("/", 1)[-1]
        probe.write_text(lines[0] + "# measured = 2026-11-21T08:00:00Z\n" + "".join(lines[1:]))
    result = run("compensate", HEMISHELL, "--plugin", "tool-offset", "--probe", str(tmp_path / "hemishell-pass1.csv"),
                 "--calibration", str(tmp_path / "artifact-calibration.csv"))
    assert result.exit_code == 0, result.stderr


def test_a_parametric_model_beyond_what_traces_may_read_is_refused(run, tmp_path):
    """A model edited by hand (its SHA-256 made again) or fitted from traces in another unit is
    held to the bounds its traces are: 500 ppm of scaling, 50 um of backlash."""
    import hashlib

    from postproc.compensate.models import _canonical

    model = tmp_path / "model.json"
    assert run("fit", "--plugin", "parametric", "--ballbar", CCW, "--ballbar", CW, "-o", str(model)).exit_code == 0
    saved = json.loads(model.read_text())
    for name, value, said in (("backlash_x", 0.08, "backlash_x +80.0 um is beyond -10 .. +50 um"),
                              ("scaling_x_plus", -0.0009, "scaling_x_plus -900.0 ppm is beyond -500 .. +500 ppm")):
        data = json.loads(json.dumps(saved))
        data.pop("sha256")
        data["model"]["parameters"][name][0] = value
        data["sha256"] = hashlib.sha256(_canonical(data)).hexdigest()
        model.write_text(json.dumps(data))
        result = run("compensate", HEMISHELL, "--model", str(model))
        assert (result.exit_code, result.stdout) == (3, ""), result.stderr
        assert f"parametric: the saved model's {said}" in result.stderr


def _profile(tmp_path, name: str, text: str) -> str:
    """A machine profile file that sets no name (it has the embedded default's) and ``text``."""
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def test_a_model_records_the_machine_profile_by_its_sha256(run, tmp_path):
    """The model names the profile and records the SHA-256 the provenance header gives it: the
    file's bytes with --machine, the default's settings without."""
    import hashlib

    from postproc.machine.profile import DEFAULT, sha256, to_toml

    lathe = _profile(tmp_path, "lathe.toml", "max_correction = 0.05\n")
    model = tmp_path / "model.json"
    assert run(*FIT, "--machine", lathe, "-o", str(model)).exit_code == 0
    data = json.loads(model.read_text())
    assert data["machine_profile"] == DEFAULT.name
    assert data["machine_profile_sha256"] == hashlib.sha256(b"max_correction = 0.05\n").hexdigest()
    applied = run("compensate", HEMISHELL, "--model", str(model), "--machine", lathe)
    assert applied.exit_code == 0, applied.stderr
    assert f"(PROFILE LATHE.TOML SHA256 {data['machine_profile_sha256'][:12].upper()})" in applied.stdout
    assert "machine profile" not in applied.stderr
    default = tmp_path / "default.json"
    assert run(*FIT, "-o", str(default)).exit_code == 0
    assert json.loads(default.read_text())["machine_profile_sha256"] == sha256(DEFAULT) == hashlib.sha256(
        to_toml(DEFAULT).encode()).hexdigest()


def test_a_model_applied_under_another_profile_of_the_same_name_warns(run, tmp_path):
    """Fitted under one profile file, applied under another with the same name (here both the
    default's, as neither sets one) or under the embedded default: the program is written, with
    one warning naming both SHA-256 and the remedy."""
    fitted_under = _profile(tmp_path, "a.toml", "max_correction = 0.05\n")
    other = _profile(tmp_path, "b.toml", "max_correction = 0.08\n")
    model = tmp_path / "model.json"
    run(*FIT, "--machine", fitted_under, "-o", str(model))
    sha = json.loads(model.read_text())["machine_profile_sha256"]
    for machine, this in (["--machine", other], other), ([], "its settings' SHA-256"):
        result = run("compensate", HEMISHELL, "--model", str(model), *machine)
        assert result.exit_code == 0
        assert result.stdout.startswith("%\nO1000") and "(POSTPROC" in result.stdout
        warnings = [line for line in result.stderr.splitlines() if "machine profile" in line]
        assert len(warnings) == 1
        assert warnings[0].startswith(f"{model}: warning: the model was made under a machine profile 'fanuc-18i-t' of "
                                      f"other content (SHA-256 {sha[:12]}) than this run's ({this}")
        assert warnings[0].endswith("make sure it is the same machine, or fit the model again with this --machine")


def test_a_model_saved_without_the_profile_sha256_is_compared_by_name(run, tmp_path):
    """A model saved before the SHA-256 was recorded still loads; only its profile's name is
    compared. A recorded SHA-256 that is not one is refused."""
    import hashlib

    from postproc.compensate.models import _canonical

    model = tmp_path / "model.json"
    run(*FIT, "-o", str(model))
    data = json.loads(model.read_text())
    data.pop("sha256")
    data.pop("machine_profile_sha256")
    model.write_text(json.dumps({**data, "sha256": hashlib.sha256(_canonical(data)).hexdigest()}))
    other = _profile(tmp_path, "b.toml", "max_correction = 0.08\n")
    result = run("compensate", HEMISHELL, "--model", str(model), "--machine", other)
    assert result.exit_code == 0 and "(POSTPROC" in result.stdout
    assert "machine profile" not in result.stderr
    data["machine_profile_sha256"] = "73AA"
    model.write_text(json.dumps({**data, "sha256": hashlib.sha256(_canonical(data)).hexdigest()}))
    result = run("compensate", HEMISHELL, "--model", str(model))
    assert result.exit_code == 3 and result.stdout == ""
    assert result.stderr == (f"{model}: error: 'machine_profile_sha256' must be 64 hex digits (lower case)\n")


def _leaves(value, path=()):
    """Every number of a fitted model, by its path of keys and indices."""
    if isinstance(value, dict):
        for key, item in value.items():
            yield from _leaves(item, (*path, key))
    elif isinstance(value, list):
        for index, item in enumerate(value):
            yield from _leaves(item, (*path, index))
    elif isinstance(value, (int, float)) and not isinstance(value, bool):
        yield path


def _named(path) -> str:
    return "model" + "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in path)


@pytest.fixture(scope="module")
def parametric_model(tmp_path_factory):
    path = tmp_path_factory.mktemp("parametric") / "model.json"
    fitted = CliRunner().invoke(main, ["fit", "--plugin", "parametric", "--ballbar", CCW, "--ballbar", CW, "-o",
                                       str(path)], catch_exceptions=False)
    assert fitted.exit_code == 0, fitted.stderr
    return path


def _edited(model, path, value):
    """The model with one value replaced and its SHA-256 made again, as an editor by hand would."""
    data = json.loads(model.read_text())
    *parents, last = path
    holder = data["model"]
    for key in parents:
        holder = holder[key]
    holder[last] = value
    payload = {key: item for key, item in data.items() if key != "sha256"}
    data["sha256"] = hashlib.sha256(models._canonical(payload)).hexdigest()
    edited = model.parent / f"edited-{uuid.uuid4().hex}.json"
    edited.write_text(json.dumps(data))
    return edited


def _refused(edited):
    result = CliRunner().invoke(main, ["compensate", HEMISHELL, "--model", str(edited)], catch_exceptions=False)
    assert result.exit_code == 3 and result.stdout == "", result.stderr
    assert result.stderr.startswith(f"{edited}: error: ") and result.stderr.count("error:") == 1
    return result.stderr


@settings(max_examples=40, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_every_number_of_a_saved_model_must_be_a_json_number(parametric_model, data):
    path = data.draw(st.sampled_from(sorted(_leaves(json.loads(parametric_model.read_text())["model"]), key=str)))
    original = json.loads(parametric_model.read_text())["model"]
    for key in path:
        original = original[key]
    wrong = data.draw(st.sampled_from([True, False, str(original), f" {original!r} ", "nan", "1e400"]))
    stderr = _refused(_edited(parametric_model, path, wrong))
    assert f"{_named(path)} = {json.dumps(wrong)}" in stderr and "fit it again" in stderr


@settings(max_examples=40, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(name=st.sampled_from(["scaling_x_plus", "scaling_x_minus", "scaling_z_plus", "scaling_z_minus", "backlash_x",
                             "backlash_z", "squareness", "servo_mismatch"]),
       beyond=st.floats(1.001, 1e6), sign=st.sampled_from([1.0, -1.0]))
def test_a_saved_parameter_beyond_its_bound_is_refused(parametric_model, name, beyond, sign):
    low, high = BOUNDS[next(prefix for prefix in BOUNDS if name.startswith(prefix))][:2]
    value = (high if sign > 0 else low) * beyond
    stderr = _refused(_edited(parametric_model, ("parameters", name, 0), value))
    assert f"the saved model's {name} " in stderr and "is beyond" in stderr and "fit it again" in stderr


@pytest.mark.parametrize("name, value", [("scaling_x_plus", 499e-6), ("backlash_x", -0.0099), ("backlash_z", 0.0499),
                                         ("squareness", -499e-6), ("servo_mismatch", 0.099)])
def test_a_saved_parameter_within_its_bound_is_applied(parametric_model, name, value):
    edited = _edited(parametric_model, ("parameters", name, 0), value)
    result = CliRunner().invoke(main, ["compensate", HEMISHELL, "--model", str(edited), "--max-correction", "1"],
                                catch_exceptions=False)
    assert result.exit_code in (0, 4), result.stderr  # 4: a correction the run refuses, not the model
    assert "the saved model" not in result.stderr


# ---------------------------------------------------------------------- what fit writes reads back

def _saves(made, loads):
    """A plugin object whose compensator's model() returns ``made()`` and whose load() is ``loads``."""
    from postproc.compensate.hookspecs import hookimpl
    from postproc.compensator import Compensator

    cls = type("Saves", (Compensator,), {"name": "test-saves", "takes": ("ballbar",),
                                         "fit": lambda self, measurements: None, "correct": lambda self, piece: None,
                                         "model": lambda self: made(), "load": loads})

    class Plugin:
        @hookimpl
        def postproc_compensators(self):
            return [cls]

    return Plugin()


def _strict_load(self, model):
    self.gain = float(model["gain"])  # a model of another shape: KeyError


@pytest.mark.parametrize("made, loads, words", [
    (lambda: {"gain": float("nan")}, None, "would not read back: Out of range float values are not JSON compliant"),
    (lambda: {"gain": __import__("numpy").arange(3)}, None, "would not read back: Object of type ndarray"),
    (lambda: {"gain": object()}, None, "would not read back: Object of type object"),
    (lambda: [1.0, 2.0], None, "would not read back: 'model' must be an object, not a list"),
    (lambda: {"gain": [1.0, float("inf")]}, None, "would not read back"),
    (lambda: {"gain": "0.5"}, None, "a number written as a string"),
    (lambda: {"inner_radius": -1.0}, None, "a radius must be positive"),
    (lambda: {"scale": 2.0}, _strict_load, "load of its own model failed: KeyError: 'gain'"),
])
def test_fit_never_writes_a_model_that_compensate_would_refuse(run, tmp_path, made, loads, words):
    """fit wrote a model whose content compensate --model refuses (a list for the model), or
    failed with an internal error on what JSON cannot hold (NaN, an array): what fit writes is
    read back and loaded back first, and a compensator whose model does not is named."""
    from postproc.compensate import registry

    plugin = _saves(made, loads or (lambda self, model: None))
    registry.manager().register(plugin, name="saves-test-plugin")
    try:
        target = tmp_path / "model.json"
        result = run("fit", "--plugin", "test-saves", "--ballbar", CCW, "-o", str(target))
        assert result.exit_code == 5 and not target.exists(), result.stderr
        assert result.stderr.startswith("postproc: error: plugin 'test-saves': ") and words in result.stderr, \
            result.stderr
    finally:
        registry.manager().unregister(plugin)


@pytest.mark.parametrize("radius", [1001.0, 100000.0])
def test_a_saved_model_whose_test_radius_no_ballbar_has_is_refused(parametric_model, radius):
    """radius_mm in um, its SHA-256 made again: refused as the trace it came from would be."""
    stderr = _refused(_edited(parametric_model, ("radius_mm",), radius))
    assert f"radius_mm {radius:g} is above 1000 mm" in stderr and "in um" in stderr


def test_a_model_too_large_to_read_back_is_refused_before_it_is_written(run, tmp_path, monkeypatch):
    """A model keeps the traces it applies: one of millions of samples would be a file over the
    64 MiB compensate --model reads. Refused with the size, the limit and the remedy; nothing written."""
    model = tmp_path / "model.json"
    monkeypatch.setattr(models, "MAX_BYTES", 16 * 1024)
    result = run(*FIT, "-o", str(model))
    assert result.exit_code == 3 and result.stdout == ""
    assert result.stderr.startswith(f"{CCW}: error: the model would be ")
    assert "over the 0.015625 MiB a model file may be" in result.stderr and "--plugin NAME --ballbar" in result.stderr
    assert not model.exists()
