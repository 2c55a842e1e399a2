"""The architecture held by tools (docs/architecture.md): the import contracts of pyproject.toml
(import-linter) and no dead code (vulture at 80 % confidence)."""

from __future__ import annotations

import ast
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from support import REPO

BIN = Path(sys.executable).parent
CONTRACTS = 9  #: the contracts in pyproject.toml's [tool.importlinter]


def _tool(name: str) -> str:
    path = BIN / name
    if not path.exists():
        pytest.fail(f"{name} is not installed in this environment: pip install -e '.[test]'")
    return str(path)


def _run(*args: str, cwd: Path = REPO) -> subprocess.CompletedProcess:
    return subprocess.run(args, capture_output=True, text=True, cwd=cwd)


def test_the_import_contracts_are_kept():
    result = _run(_tool("lint-imports"), "--no-cache")
    assert result.returncode == 0, result.stdout + result.stderr
    assert f"Contracts: {CONTRACTS} kept, 0 broken." in result.stdout


def test_lint_imports_finds_a_broken_contract(tmp_path):
    """The check above can fail: a contract the code does not keep (the rewriter imports the
    segmenter) is reported broken, naming the import."""
    config = tmp_path / "contracts.toml"
    config.write_text('[tool.importlinter]\nroot_packages = ["postproc"]\n\n[[tool.importlinter.contracts]]\n'
                      'name = "made to break"\ntype = "forbidden"\nsource_modules = ["postproc.compensate.rewrite"]\n'
                      'forbidden_modules = ["postproc.compensate.segmenter"]\n')
    result = _run(_tool("lint-imports"), "--no-cache", "--config", str(config))
    assert result.returncode == 1
    assert "BROKEN" in result.stdout and "postproc.compensate.rewrite -> postproc.compensate.segmenter" in result.stdout


def test_no_dead_code():
    result = _run(_tool("vulture"), "postproc", "plugins", "--min-confidence", "80")
    assert result.returncode == 0, result.stdout + result.stderr


def test_vulture_finds_dead_code(tmp_path):
    """The check above can fail: an unused import and an unused parameter are found."""
    (tmp_path / "module.py").write_text("import os\n\n\ndef used(a, unused):\n    return a\n\n\nused(1, 2)\n")
    result = _run(_tool("vulture"), "module.py", "--min-confidence", "80", cwd=tmp_path)
    assert result.returncode == 3
    assert "unused import 'os'" in result.stdout and "unused variable 'unused'" in result.stdout


#: the modules that stay at the top of the package: the API, the errors, and the plugin
#: contract's documented paths (the map in docs/architecture.md)
TOP_LEVEL = {"__init__", "__main__", "api", "diagnostics", "compensator", "hookspecs"}


def _layers() -> list[str]:
    contracts = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["importlinter"]["contracts"]
    (layers,) = [c["layers"] for c in contracts if c["id"] == "engine-layers"]
    return [name.strip() for layer in layers for name in layer.split("|")]


def test_the_package_tree_is_the_map():
    """Every module is in a package of the map but the few public ones at the top; every package is
    a layer of the contract and a row of docs/architecture.md, so the map cannot go stale."""
    package = REPO / "postproc"
    modules = {path.stem for path in package.glob("*.py")}
    assert modules == TOP_LEVEL
    packages = {path.parent.name for path in package.glob("*/__init__.py")} - {"cam"}
    layered = {name.removeprefix("postproc.") for name in _layers()}
    assert packages <= layered, packages - layered
    page = (REPO / "docs" / "architecture.md").read_text()
    assert [name for name in sorted(packages) if f"| `{name}/` " not in page and f" · `{name}/` " not in page] == []



#: folders of tests/ that mirror no package: helpers, the corpus, and the tests of the whole
#: (closed loops on the virtual lathe, golden round trips, robustness, the pages, the project)
ACROSS = {"support", "corpus", "closed_loop", "golden", "robustness", "docs", "project"}


def _test_modules():
    return [path for path in (REPO / "tests").rglob("*.py") if "corpus" not in path.relative_to(REPO / "tests").parts]


def test_the_tests_mirror_the_packages():
    """A newcomer finds the test of ``postproc/<package>/<module>.py`` in
    ``tests/<package>/test_<module>*.py``. The command line's folder holds its end-to-end tests too."""
    folders = {path.name for path in (REPO / "tests").iterdir() if path.is_dir() and not path.name.startswith((".", "_"))}
    packages = {path.parent.name for path in (REPO / "postproc").glob("*/__init__.py")}
    assert folders - ACROSS <= packages, folders - ACROSS - packages
    strays = []
    for folder in sorted(folders & packages - {"cli"}):
        package = REPO / "postproc" / folder
        names = {folder} | {path.stem for path in package.glob("*.py")} | {path.parent.name for path in package.glob("*/__init__.py")}
        for test in (REPO / "tests" / folder).glob("test_*.py"):
            tested = test.stem.removeprefix("test_")
            if not any(tested == name or tested.startswith(name + "_") for name in names):
                strays.append(str(test.relative_to(REPO)))
    assert strays == []


def test_no_test_module_imports_another():
    """Shared helpers live in tests/support; a test module imports none of its peers (nor conftest)."""
    found = []
    for path in _test_modules():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = [alias.name for alias in node.names] if isinstance(node, ast.Import) else \
                [node.module or ""] if isinstance(node, ast.ImportFrom) and node.level == 0 else []
            found += [f"{path.relative_to(REPO)}: {name}" for name in names
                      if name.split(".")[0].startswith("test_") or name.split(".")[0] == "conftest"]
    assert found == []
