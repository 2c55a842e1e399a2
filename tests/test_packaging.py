"""The package as pip installs it: every subpackage listed, no top-level package named plugins."""

from __future__ import annotations

import tomllib

from conftest import REPO


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
