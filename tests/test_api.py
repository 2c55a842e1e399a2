"""The Python API (postproc/api.py): its arguments are checked as the command line's options
are, every failure is one of postproc's errors, and nothing is printed."""

from __future__ import annotations

from pathlib import Path

import pytest

import postproc
from postproc.diagnostics import OptionError, PostprocError
from postproc.machine import profile as profiles
from support import SAMPLES

HEMISHELL = SAMPLES / "programs" / "hemishell.nc"
CCW, CW = (str(SAMPLES / "ballbar" / f"v40r-100-{d}.csv") for d in ("ccw", "cw"))
PARAMETRIC = {"plugins": ["parametric"], "ballbar": [CCW, CW]}

#: argument -> values of the wrong type or outside its choices (each with a working rest)
WRONG = {
    "plugins": ["parametric", b"parametric", 7, [None], [Path("parametric")]],
    "ballbar": [CCW, Path(CCW), 3.0, [CCW, 7], [CCW, ""], [CCW, None], None],
    "probe": [str(SAMPLES / "probe" / "hemishell-pass1.csv"), [b"probe.csv"], [None]],
    "calibration": [7, ["cal.csv"], ""],
    "model": [1.5, ["model.json"]],
    "options": ["extrapolate=true", [("extrapolate", "true")]],
    "regions": ["L10-L12", 10, [10]],
    "mode": ["spline", "AUTO", None, 1],
    "macro_values": ["KEEP", None],
    "force": ["no", 0, None],
    "keep_unplannable": ["yes", 1],
    "machine": [12, b"m.toml", ["m.toml"]],
    "reporter": ["stderr", print],
    "tolerance": ["0.001", True, float("nan"), -1.0],
    "max_correction": ["0.1", float("inf"), 0.0],
}


@pytest.mark.parametrize("argument, value", [(name, value) for name, values in WRONG.items() for value in values],
                         ids=lambda item: repr(item)[:30])
def test_a_wrong_argument_is_an_option_error_naming_it_and_nothing_is_printed(argument, value, capsys):
    """One string where a list is expected would be read letter by letter ('--plugin p'), a
    PosixPath in a list of paths was a compensator's 'fit failed', a mode the command line has
    no choice for ran silently: each is refused by name, before anything is read."""
    arguments = {**PARAMETRIC, argument: value}
    with pytest.raises(OptionError) as caught:
        postproc.Pipeline(**arguments)
    spelled = {"tolerance": "tolerance", "max_correction": "max-correction"}.get(argument, argument)
    assert spelled in caught.value.message, caught.value.message
    assert capsys.readouterr() == ("", "")


def test_paths_may_be_path_objects_and_give_what_strings_give(tmp_path, capsys):
    text = HEMISHELL.read_text()
    as_strings = postproc.compensate_text(text, **PARAMETRIC, machine=str(SAMPLES / "machines" / "v40r-sim.toml"))
    pipeline = postproc.Pipeline(plugins=["parametric"], ballbar=[Path(CCW), Path(CW)],
                                 machine=SAMPLES / "machines" / "v40r-sim.toml")
    assert pipeline.compensate_text(text) == as_strings != text
    target = tmp_path / "out.nc"
    pipeline.compensate_file(HEMISHELL, target)
    assert target.read_text() == as_strings.replace("<text>", str(HEMISHELL))
    assert capsys.readouterr() == ("", "")


def test_a_machine_may_be_a_mapping_of_profile_keys_and_is_checked_as_a_file_is():
    assert postproc.Pipeline(machine={"max-correction": 0.05}).profile.max_correction == 0.05
    assert isinstance(postproc.Pipeline(machine=profiles.DEFAULT).profile, profiles.MachineProfile)
    with pytest.raises(OptionError, match="unknown key 'max_corection' in machine profile; did you mean 'max_correction'"):
        postproc.Pipeline(machine={"max_corection": 0.05})


@pytest.mark.parametrize("argument", ["path", "output"])
@pytest.mark.parametrize("value", [None, 7, b"out.nc", ""])
def test_a_file_to_compensate_or_write_that_is_not_a_path_is_refused_by_name(argument, value, tmp_path, capsys):
    """An output of None spooled the program and wrote it nowhere, with a Summary as if done; a
    path of None was a bare TypeError: every path argument is a str or os.PathLike, or an
    OptionError naming it, and nothing is written."""
    pipeline = postproc.Pipeline(plugins=["parametric"], ballbar=[CCW, CW])
    arguments = {"path": HEMISHELL, "output": tmp_path / "out.nc", argument: value}
    with pytest.raises(OptionError) as caught:
        pipeline.compensate_file(**arguments)
    assert caught.value.message.startswith(f"{argument}: ") and "is not a path" in caught.value.message
    assert list(tmp_path.iterdir()) == [] and capsys.readouterr() == ("", "")


@pytest.mark.parametrize("text", [None, 42, ["G01 X1."]])
def test_a_program_that_is_not_text_is_refused(text):
    with pytest.raises(PostprocError, match="expected the program as a str"):
        postproc.compensate_text(text)
