"""Security: plugins only from installed entry points, data parsed as data, sizes limited."""

from __future__ import annotations

import hashlib
import json

from support import SAMPLES
from postproc.compensate import models
from postproc.syntax import source
from postproc.measure.readers import csvfile

HEMISHELL = str(SAMPLES / "programs" / "hemishell.nc")


def _signed(data: dict) -> str:
    payload = {key: value for key, value in data.items() if key != "sha256"}
    return json.dumps({**payload, "sha256": hashlib.sha256(models._canonical(payload)).hexdigest()})


def test_a_model_cannot_name_code_to_load(run, tmp_path):
    """A model names its compensator; only an installed one is used, never a path or a module."""
    model = tmp_path / "m.json"
    run("fit", "--plugin", "parametric", "--ballbar", str(SAMPLES / "ballbar" / "v40r-100-ccw.csv"),
        "--ballbar", str(SAMPLES / "ballbar" / "v40r-100-cw.csv"), "-o", str(model))
    for evil in ("/tmp/evil.py", "os:system", "postproc_plugins.parametric"):
        data = json.loads(model.read_text())
        data["plugin"] = evil
        model.write_text(_signed(data))
        result = run("compensate", HEMISHELL, "--model", str(model))
        assert result.exit_code == 3 and "no compensator of that name is installed" in result.stderr


def test_model_and_measurement_files_are_never_executed(tmp_path):
    """JSON and CSV only: no pickle, no eval anywhere in the readers."""
    import inspect

    import postproc.measure.readers.ballbar as ballbar
    import postproc.measure.readers.probe as probe

    for module in (models, csvfile, ballbar, probe):
        text = inspect.getsource(module)
        assert "pickle" not in text and "eval(" not in text and "exec(" not in text


def test_size_limits(run, tmp_path, monkeypatch):
    monkeypatch.setattr(csvfile, "MAX_BYTES", 1000)
    trace = tmp_path / "big.csv"
    trace.write_text("# postproc ballbar 1\n" + "#" * 2000)
    result = run("ballbar", str(trace))
    assert result.exit_code == 3 and result.stderr.startswith(
        f"{trace}: error: the file is 2021 bytes; a measurement file is at most 1000")
    monkeypatch.setattr(models, "MAX_BYTES", 1000)
    model = tmp_path / "m.json"
    model.write_text("{" + " " * 2000 + "}")
    result = run("compensate", HEMISHELL, "--model", str(model))
    assert result.exit_code == 3
    assert result.stderr == f"{model}: error: the file is 2002 bytes; a model is at most 1000\n"
    monkeypatch.setattr(source, "MAX_PROGRAM_BYTES", 100)
    result = run("check", HEMISHELL)
    assert result.exit_code == 3 and result.stderr.startswith(f"{HEMISHELL}: error: program is ")
