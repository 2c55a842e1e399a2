"""Every hook has a heading in docs/hooks.md with its signature, and a test that uses it."""

from __future__ import annotations

import inspect

from conftest import REPO
from postproc import hookspecs


def _hooks():
    return [name for name, value in vars(hookspecs).items() if name.startswith("postproc_") and inspect.isfunction(value)]


def test_every_hook_is_documented_with_its_signature():
    text = (REPO / "docs" / "hooks.md").read_text()
    for name in _hooks():
        returns = inspect.signature(getattr(hookspecs, name)).return_annotation.strip("'\"")
        assert f"## `{name}() -> {returns}`" in text, name


def test_every_hook_has_a_test():
    tests = "".join(path.read_text() for path in (REPO / "tests").glob("test_*.py") if path.name != "test_docs.py")
    for name in _hooks():
        assert name in tests, f"no test uses {name}"
