"""The shell scripts a new user and CI run: ``scripts/test`` (never prompts, says what it installs
and why) and ``.ci/run`` (the test command in a copy of the checkout with nothing beside it).

Each runs here on a copy of itself, with stand-ins for apt-get, sudo, id, python3 and pytest
first on PATH, so that nothing is installed and the suite does not run itself.
"""

from __future__ import annotations

import os
import shutil
import stat
import subprocess
from pathlib import Path

import pytest

from support import REPO

SYSTEM_COMMANDS = ("rs274", "chromium", "freecadcmd")


def _tool(folder: Path, name: str, body: str) -> None:
    path = folder / name
    path.write_text("#!/bin/bash\n" + body + "\n")
    path.chmod(path.stat().st_mode | stat.S_IXUSR)


@pytest.fixture
def sandbox(tmp_path):
    """A copy of scripts/test in a bare repository folder, and a PATH of stand-ins.

    Every stand-in appends what it was asked to ``calls``; ``bin`` holds only the real programs
    the script needs, none of the three system commands the tests drive.
    """
    repo = tmp_path / "repo"
    (repo / "scripts").mkdir(parents=True)
    shutil.copy2(REPO / "scripts" / "test", repo / "scripts" / "test")
    fake, real = tmp_path / "fake", tmp_path / "bin"
    fake.mkdir()
    real.mkdir()
    for name in ("bash", "env", "dirname"):
        (real / name).symlink_to(shutil.which(name))
    calls = tmp_path / "calls"
    log = f'echo "${{0##*/}} $*" >> {calls}'
    _tool(fake, "apt-get", log + '; echo "DEBIAN_FRONTEND=$DEBIAN_FRONTEND" >> ' + str(calls))
    _tool(fake, "python3", log)
    _tool(fake, "id", "echo 0")
    (repo / ".venv" / "bin").mkdir(parents=True)
    _tool(repo / ".venv" / "bin", "python", log)
    _tool(repo / ".venv" / "bin", "pytest", log)

    def run(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([str(repo / "scripts" / "test"), *args], capture_output=True, text=True,
                              stdin=subprocess.DEVNULL, env={"PATH": f"{fake}:{real}"}, timeout=60)

    def called() -> list[str]:
        return calls.read_text().splitlines() if calls.exists() else []

    return fake, run, called


def test_scripts_test_names_each_package_and_why_before_installing_without_a_question(sandbox):
    fake, run, called = sandbox
    result = run("-q", "-x")
    assert result.returncode == 0, result.stderr
    said = result.stderr.splitlines()
    assert said[0] == "scripts/test: installing 3 system package(s) with apt-get:"
    assert said[1].startswith("  linuxcnc-uspace: rs274, LinuxCNC's G-code interpreter") and "test_interpreter_linuxcnc.py" in said[1]
    assert said[2].startswith("  chromium: chromium, renders the HTML report") and "test_report.py" in said[2]
    assert said[3].startswith("  freecad: freecadcmd, runs the FreeCAD post-processor test")
    assert said[-1] == "scripts/test: installed linuxcnc-uspace chromium freecad"
    calls = called()
    apt = [call for call in calls if call.startswith("apt-get")]
    assert [call.split()[-1] for call in apt] == ["update", "freecad"]
    assert all(" -y " in call and "--force-confold" in call for call in apt)
    assert calls.count("DEBIAN_FRONTEND=noninteractive") == 2
    assert "apt-get" not in result.stdout
    assert calls[-1] == "pytest -q -x"


def test_scripts_test_installs_nothing_when_the_commands_are_there(sandbox):
    fake, run, called = sandbox
    for name in SYSTEM_COMMANDS:
        _tool(fake, name, "exit 0")
    result = run()
    assert result.returncode == 0 and result.stderr == ""
    assert not any(call.startswith("apt-get") for call in called())
    assert called()[-1] == "pytest "


def test_scripts_test_goes_through_sudo_n_when_not_root(sandbox):
    fake, run, called = sandbox
    _tool(fake, "id", "echo 1000")
    _tool(fake, "sudo", f'echo "sudo $*" >> {fake.parent / "calls"}; [ "$1" = -n ] || exit 9; shift; "$@"')
    _tool(fake, "rs274", "exit 0")
    result = run()
    assert result.returncode == 0, result.stderr
    sudo = [call for call in called() if call.startswith("sudo")]
    assert sudo[0] == "sudo -n true"
    assert all(call.startswith("sudo -n env DEBIAN_FRONTEND=noninteractive apt-get -y") for call in sudo[1:])
    assert [call.split()[-1] for call in called() if call.startswith("apt-get")] == ["update", "freecad"]


@pytest.mark.parametrize("sudo", ["password", "absent"])
def test_scripts_test_stops_with_the_remedy_when_it_cannot_become_root(sandbox, sudo):
    fake, run, called = sandbox
    _tool(fake, "id", "echo 1000")
    if sudo == "password":
        _tool(fake, "sudo", 'echo "sudo: a password is required" >&2; exit 1')
    result = run()
    assert result.returncode == 2
    assert result.stderr.splitlines()[-2:] == [
        "scripts/test: error: installing them needs root, and sudo cannot run here without a password.",
        "  Install them once (sudo apt-get install linuxcnc-uspace chromium freecad), or run scripts/test as root."]
    assert called() == []


def test_ci_run_tests_a_copy_of_the_tracked_files_with_nothing_beside_it(tmp_path):
    """``.ci/run`` in a small repository whose scripts/test reports where it ran and what it saw."""
    repo = tmp_path / "checkout"
    (repo / ".ci").mkdir(parents=True)
    (repo / "scripts").mkdir()
    shutil.copy2(REPO / ".ci" / "run", repo / ".ci" / "run")
    report = tmp_path / "seen"
    _tool(repo / "scripts", "test", f'{{ pwd; echo $(ls -A ..); echo $(ls -A); echo "corpus=${{POSTPROC_CORPUS-unset}}"; '
                                     f'echo "args=$*"; }} > {report}; exit 7')
    (repo / "tracked.txt").write_text("kept\n")
    git = ["git", "-C", str(repo), "-c", "user.name=ci", "-c", "user.email=ci@example.invalid"]
    subprocess.run([*git, "init", "-q"], check=True)
    subprocess.run([*git, "add", "."], check=True)
    subprocess.run([*git, "commit", "-q", "-m", "a checkout"], check=True)
    (repo / "untracked.txt").write_text("left out\n")
    (repo / ".venv").mkdir()
    (tmp_path / "shared").mkdir()  # what lay beside the checkout must not lie beside the copy
    result = subprocess.run([str(repo / ".ci" / "run"), "-k", "corpus"], capture_output=True, text=True,
                            env={**os.environ, "POSTPROC_CORPUS": str(tmp_path / "shared"), "TMPDIR": str(tmp_path)})
    assert result.returncode == 7  # scripts/test's own exit code
    where, beside, inside, corpus, args = report.read_text().splitlines()
    assert Path(where).name == "postproc" and Path(where).parent.parent == tmp_path
    assert beside == "postproc"
    assert inside.split() == [".ci", "scripts", "tracked.txt"]
    assert corpus == "corpus=unset" and args == "args=-k corpus"
    assert not Path(where).parent.exists()  # removed afterwards
    assert f"testing a copy of {repo} in {where}" in result.stderr
