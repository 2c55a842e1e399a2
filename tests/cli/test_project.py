"""The project file (postproc.cli.project, docs/formats.md §19) and the starter profile
(``postproc profile init``): found from a subfolder, overridden by options, refused with its
line, column and a did-you-mean when wrong; TOML errors in a profile point at the key.

Each test builds a small shop folder (a ``.git`` at its root, a machine profile, a model fitted
from the sample traces) and runs the real command line from inside it.
"""

from __future__ import annotations

import pytest

from support import SAMPLES

HEMISHELL = str(SAMPLES / "programs/hemishell.nc")
CCW = str(SAMPLES / "ballbar/v40r-100-ccw.csv")
CW = str(SAMPLES / "ballbar/v40r-100-cw.csv")


@pytest.fixture
def shop(tmp_path, run, monkeypatch):
    """A repository with machines/lathe3.toml, models/lathe3.json and a job folder to work in."""
    root = tmp_path / "shop"
    (root / ".git").mkdir(parents=True)
    (root / "machines").mkdir()
    (root / "models").mkdir()
    (root / "jobs" / "1234").mkdir(parents=True)
    made = run("profile", "init", str(root / "machines" / "lathe3.toml"))
    assert made.exit_code == 0, made.stderr
    fitted = run("fit", "--plugin", "parametric", "--ballbar", CCW, "--ballbar", CW,
                 "-o", str(root / "models" / "lathe3.json"))
    assert fitted.exit_code == 0, fitted.stderr
    monkeypatch.chdir(root / "jobs" / "1234")
    return root


def _project(shop, text: str):
    path = shop / "postproc.toml"
    path.write_text(text)
    return path


def _provenance(program: str) -> list[str]:
    return [line for line in program.splitlines() if line.startswith("(") and line.isupper()]


def test_the_project_file_is_found_from_a_subfolder(shop, run):
    project = _project(shop, 'machine = "machines/lathe3.toml"\nmodel = "models/lathe3.json"\ntolerance = 0.002\n')
    shown = run("profile", "show")
    assert shown.exit_code == 0, shown.stderr
    lines = shown.stdout.splitlines()
    assert lines[0] == f"# project file: {project}"
    assert lines[1] == "# machine profile: ../../machines/lathe3.toml (from the project file)"
    assert 'name = "lathe3"' in lines
    result = run("compensate", HEMISHELL)
    assert result.exit_code == 0, result.stderr
    stamp = _provenance(result.stdout)
    assert "(MODEL LATHE3.JSON)" in stamp and "(TOLERANCE 0.002 MM MODE AUTO)" in stamp
    assert any(line.startswith("(MACHINE LATHE3 ") for line in stamp)
    assert "blocks replaced by" in result.stderr
    assert result.stderr.splitlines()[0] == (f"{project}: project file: --model, --machine, --tolerance from it "
                                             "(--no-project ignores it)")
    assert "project file" not in run("-q", "compensate", HEMISHELL).stderr


def test_options_on_the_command_line_override_the_project_file(shop, run):
    _project(shop, 'machine = "machines/lathe3.toml"\nmodel = "models/lathe3.json"\ntolerance = 0.002\n'
                   'plugins = ["iterative"]\n')
    result = run("compensate", HEMISHELL, "--tolerance", "0.004", "--machine", str(SAMPLES / "machines/v40r-sim.toml"))
    assert result.exit_code == 0, result.stderr
    stamp = _provenance(result.stdout)
    assert "(TOLERANCE 0.004 MM MODE AUTO)" in stamp and "(MODEL LATHE3.JSON)" in stamp
    assert any(line.startswith("(MACHINE OKUMA-HOWA-V40R-VIRTUAL ") for line in stamp)
    assert "(PLUGIN ITERATIVE" not in result.stdout  # from the project file alone, the model wins
    # a compensator on the command line sets the project's model (and plugins, options) aside
    own = run("compensate", HEMISHELL, "--plugin", "parametric", "--ballbar", CCW, "--ballbar", CW)
    assert own.exit_code == 0, own.stderr
    assert "(MODEL LATHE3.JSON)" not in own.stdout and any(line.startswith("(PLUGIN PARAMETRIC ")
                                                            for line in _provenance(own.stdout))
    # fit takes the project's plugins
    _project(shop, 'plugins = ["parametric"]\noptions = ["extrapolate=true"]\n')
    fitted = run("fit", "--ballbar", CCW, "--ballbar", CW)
    assert fitted.exit_code == 0, fitted.stderr
    assert '"parametric"' in fitted.stdout and "extrapolate" in fitted.stdout
    # and --no-project uses none of it
    bare = run("--no-project", "compensate", HEMISHELL)
    assert bare.exit_code == 0 and "nothing was applied" in bare.stderr
    assert bare.stdout == open(HEMISHELL).read()


def test_the_search_stops_at_the_repositorys_root(tmp_path, run, monkeypatch):
    (tmp_path / "postproc.toml").write_text('tolerance = 0.002\n')  # above the repository: not this project's
    (tmp_path / "repo" / ".git").mkdir(parents=True)
    (tmp_path / "repo" / "sub").mkdir()
    monkeypatch.chdir(tmp_path / "repo" / "sub")
    shown = run("profile", "show")
    assert shown.exit_code == 0
    assert shown.stdout.splitlines()[0] == (f"# project file: none from {tmp_path / 'repo' / 'sub'} up to the "
                                            f"repository's root {tmp_path / 'repo'}")
    assert shown.stdout.splitlines()[1] == "# machine profile: the embedded default"


def test_project_given_explicitly(shop, run, tmp_path):
    other = tmp_path / "elsewhere.toml"
    other.write_text('machine = "shop/machines/lathe3.toml"\n')
    shown = run("--project", str(other), "profile", "show")
    assert shown.exit_code == 0, shown.stderr
    assert shown.stdout.splitlines()[0] == f"# project file: {other}" and 'name = "lathe3"' in shown.stdout


@pytest.mark.parametrize("text, message", [
    ('machine = "machines/lathe3.toml"\ntolerence = 0.002\n',
     ":2:1: error: unknown key 'tolerence' in the project file; did you mean 'tolerance'?"),
    ('machine = "machines/lathe3.toml"\n  x_limit = [0, 100]\n',
     ":2:3: error: unknown key 'x_limit' in the project file; did you mean 'x_limits' (a machine profile key"),
    ('machine = "machines/lathe4.toml"\n', ":1:1: error: machine = 'machines/lathe4.toml': no such file "),
    ('tolerance = 2\n', ":1:1: error: tolerance = 2: a tolerance of 2 mm (2000 um) is above 0.05 mm"),
    ('mode = "arcs"\n', ":1:1: error: mode must be one of auto, arc, line"),
    ('plugins = "parametric\n', ":1:22: error: not valid TOML: Illegal character"),
])
def test_a_bad_project_file_is_refused_at_its_line(shop, run, text, message):
    project = _project(shop, text)
    for args in (["compensate", HEMISHELL], ["check", HEMISHELL], ["plugins"]):
        result = run(*args)
        assert result.exit_code == 3, result.stderr
        assert result.stdout == ""
        assert result.stderr.startswith(f"{project}{message}"), result.stderr


def test_a_profile_error_points_at_the_key_with_a_did_you_mean(tmp_path, run):
    machine = tmp_path / "lathe.toml"
    machine.write_text('name = "lathe"\n\nx_limit = [0, 100]\n')
    result = run("check", HEMISHELL, "--machine", str(machine))
    assert result.exit_code == 3 and result.stdout == ""
    assert result.stderr.splitlines() == [
        f"{machine}:3:1: error: unknown key 'x_limit' in machine profile; did you mean 'x_limits'?",
        "    x_limit = [0, 100]", "    ^"]
    machine.write_text('name = "lathe"\ntolerance = [0.002\n')
    result = run("check", HEMISHELL, "--machine", str(machine))
    assert result.exit_code == 3 and result.stderr.startswith(f"{machine}:2:19: error: not valid TOML")


def test_profile_init_writes_a_commented_starter_that_reads_back_as_the_default(tmp_path, run):
    import dataclasses

    from postproc.machine import profile

    target = tmp_path / "lathe3.toml"
    made = run("profile", "init", str(target))
    assert made.exit_code == 0 and made.stdout == ""
    text = target.read_text()
    for field in dataclasses.fields(profile.MachineProfile):
        if field.name not in profile.NOT_KEYS:
            assert f"\n{field.name} = " in text or f"\n# {field.name} = " in text, field.name
    assert text.count("\n# ") > 25  # every key says what it means
    assert profile.load(str(target)) == dataclasses.replace(profile.DEFAULT, name="lathe3")
    assert run("profile", "init", "-", "--name", "x").stdout.startswith("# postproc machine profile")


def test_profile_init_never_overwrites(tmp_path, run):
    target = tmp_path / "lathe3.toml"
    target.write_text("# mine\n")
    refused = run("profile", "init", str(target))
    assert refused.exit_code == 2 and refused.stdout == ""
    assert f"{target} exists" in refused.stderr
    assert target.read_text() == "# mine\n"


def test_compensation_settings_without_a_compensator_are_not_a_usage_error(shop, run):
    """A project that sets how to compensate but names no compensator: compensate warns that
    nothing was applied, as with no project, instead of refusing options the user never typed."""
    _project(shop, 'macro_values = "keep"\noptions = ["extrapolate=true"]\nmode = "line"\n')
    result = run("compensate", HEMISHELL)
    assert result.exit_code == 0, result.stderr
    assert result.stdout == open(HEMISHELL).read() and "nothing was applied" in result.stderr
    typed = run("compensate", HEMISHELL, "--macro-values", "keep")
    assert typed.exit_code == 2 and "--macro-values was given but no compensator" in typed.stderr


def test_the_project_file_is_never_an_output(shop, run):
    project = _project(shop, 'tolerance = 0.002\n')
    refused = run("compensate", HEMISHELL, "-o", str(project))
    assert refused.exit_code == 2 and refused.stdout == ""
    assert f"is the input {project} (the project file): it would be destroyed" in refused.stderr
    assert project.read_text() == 'tolerance = 0.002\n'
