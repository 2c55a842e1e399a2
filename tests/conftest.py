"""Shared fixtures: a way to run the CLI in-process. Helpers live in ``tests/support``."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

pytest.register_assert_rewrite("support")

from postproc.cli.main import main  # noqa: E402


@pytest.fixture
def run():
    """Run ``postproc ARGS`` in-process; returns the click Result (stdout, stderr, exit code)."""

    def invoke(*args: str, input: bytes | str | None = None):
        runner = CliRunner()
        return runner.invoke(main, list(args), input=input, catch_exceptions=False)

    return invoke
