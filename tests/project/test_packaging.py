"""The package three ways: as a built wheel installed on its own, from a clone that was never
installed, and as ``python -m postproc``. Every subpackage is listed for the wheel, the grammar
ships inside it, and no top-level package is named ``plugins``."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
import tomllib
import zipfile
from pathlib import Path

import pytest

from support import REPO, SAMPLES

HEMISHELL = str(SAMPLES / "programs" / "hemishell.nc")
BALLBAR = [str(SAMPLES / "ballbar" / f"v40r-100-{direction}.csv") for direction in ("ccw", "cw")]
BUILT_IN = {"ballbar-inverse", "iterative", "parametric", "effective-angle", "omp-feedback", "tool-offset"}

# Python as if postproc were not installed: only the standard finders, so an editable install's
# finder cannot supply ``postproc.grammars`` (a plain install is shadowed by the working folder).
UNINSTALLED = ("import sys\n"
               "from importlib.machinery import BuiltinImporter, FrozenImporter, PathFinder\n"
               "sys.meta_path[:] = [f for f in sys.meta_path if f in (BuiltinImporter, FrozenImporter, PathFinder)]\n")


def test_every_subpackage_is_listed_for_the_wheel():
    listed = set(tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    found = {".".join(path.parent.relative_to(REPO).parts) for path in (REPO / "postproc").rglob("__init__.py")}
    assert found <= listed
    assert "plugins" not in listed and "postproc_plugins" in listed


def test_the_grammar_and_plugins_come_from_the_installed_package():
    import importlib.resources

    import postproc_plugins

    assert importlib.resources.files("postproc.grammars").joinpath("fanuc.lark").is_file()
    assert postproc_plugins.__name__ == "postproc_plugins"


def test_python_dash_m_postproc_is_the_command_line():
    result = subprocess.run([sys.executable, "-m", "postproc", "check", HEMISHELL], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert result.stdout == ""
    assert result.stderr == f"{HEMISHELL}: ok: 15 lines, 5 moves, 0 warnings\n"
    usage = subprocess.run([sys.executable, "-m", "postproc", "check", "--no-such-option"], capture_output=True, text=True)
    assert usage.returncode == 2 and usage.stdout == ""
    assert usage.stderr.startswith("Usage: postproc check")


def test_a_clone_that_was_never_installed_imports_and_finds_its_grammar():
    code = UNINSTALLED + (
        "import importlib.util, runpy\n"
        "assert importlib.util.find_spec('postproc.grammars') is None\n"
        "import postproc, postproc.syntax.grammar\n"
        "print(postproc.__file__)\n"
        "assert postproc.syntax.grammar.grammar_text() == open('grammars/fanuc.lark', encoding='utf-8').read()\n"
        "sys.argv = ['postproc', 'check', 'samples/programs/hemishell.nc']\n"
        "runpy.run_module('postproc', run_name='__main__')\n")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO)
    assert result.returncode == 0, result.stderr
    assert Path(result.stdout.strip()) == REPO / "postproc" / "__init__.py"
    assert result.stderr == "samples/programs/hemishell.nc: ok: 15 lines, 5 moves, 0 warnings\n"


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The wheel ``pip wheel`` builds (an isolated build, as ``pip install .`` does) from a copy of
    what the build reads, so that its build/ and egg-info land in the copy, not in the checkout."""
    source, folder = tmp_path_factory.mktemp("source"), tmp_path_factory.mktemp("wheel")
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(REPO / name, source / name)
    for name in ("postproc", "plugins", "grammars"):
        shutil.copytree(REPO / name, source / name, ignore=shutil.ignore_patterns("__pycache__"))
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "-w", str(folder), str(source)],
                   check=True)
    (built,) = folder.glob("postproc-*.whl")
    return built


def test_the_wheel_holds_the_grammar_the_plugins_and_their_entry_points(wheel):
    with zipfile.ZipFile(wheel) as archive:
        names = set(archive.namelist())
        assert archive.read("postproc/grammars/fanuc.lark") == (REPO / "grammars" / "fanuc.lark").read_bytes()
        entry_points = next(archive.read(name).decode() for name in names if name.endswith(".dist-info/entry_points.txt"))
    assert "postproc/__main__.py" in names
    assert {f"postproc_plugins/{path.name}" for path in (REPO / "plugins").glob("*.py")} <= names
    assert {name.split("/")[0] for name in names if ".dist-info/" not in name} == {"postproc", "postproc_plugins"}
    assert "postproc = postproc.cli.main:main" in entry_points
    for name in BUILT_IN:
        assert f"{name} = postproc_plugins." in entry_points


def test_the_installed_wheel_runs_from_anywhere(wheel, tmp_path, run):
    """pip installs the wheel into a fresh environment (its dependencies borrowed from this one,
    without this one's postproc); its console script checks and compensates a sample elsewhere."""
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    python = venv / "bin" / "python"
    site = Path(subprocess.run([python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                               capture_output=True, text=True, check=True).stdout.strip())
    subprocess.run([sys.executable, "-m", "pip", "--python", str(python), "install", "--quiet", "--no-deps",
                    "--no-index", "--ignore-installed", str(wheel)], check=True)
    # only now, so that pip cannot take this environment's postproc for the wheel's
    (site / "dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = {key: value for key, value in os.environ.items() if key not in ("PYTHONPATH", "POSTPROC_DEBUG")}

    def postproc(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([venv / "bin" / "postproc", *args], capture_output=True, text=True, cwd=elsewhere, env=env)

    where = subprocess.run([python, "-c", "import postproc.syntax.grammar as s; print(s.__file__); s.parser()"],
                           capture_output=True, text=True, cwd=elsewhere, env=env)
    assert where.returncode == 0, where.stderr
    assert Path(where.stdout.strip()).is_relative_to(site)
    checked = postproc("check", HEMISHELL)
    assert checked.returncode == 0 and checked.stdout == ""
    assert checked.stderr == f"{HEMISHELL}: ok: 15 lines, 5 moves, 0 warnings\n"
    listed = postproc("plugins")
    assert {line.split()[0] for line in listed.stdout.splitlines()} >= BUILT_IN
    arguments = ["compensate", HEMISHELL, "--plugin", "parametric", "--ballbar", BALLBAR[0], "--ballbar", BALLBAR[1]]
    compensated = postproc(*arguments)
    assert compensated.returncode == 0, compensated.stderr
    assert "(POSTPROC 0.1.0 COMPENSATED)" in compensated.stdout
    assert compensated.stdout == run(*arguments).stdout
