"""Shared fixtures: a way to run the CLI in-process; hypothesis's profiles. Helpers live in
``tests/support``.

The property tests run derandomized by default (the ``repeatable`` profile): the suite that
decides whether a change lands gives the same answer on every run, and a machine shared with
others cannot fail it on a time limit (no deadline). ``HYPOTHESIS_PROFILE=explore`` draws new
examples on every run, ten times as many, to hunt for what the fixed ones miss; a failure it
finds becomes an ``@example`` of its test."""

from __future__ import annotations

import os

import pytest
from click.testing import CliRunner
from hypothesis import settings

settings.register_profile("repeatable", derandomize=True, deadline=None)
settings.register_profile("explore", max_examples=1000, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "repeatable"))

pytest.register_assert_rewrite("support")

from postproc.cli.main import main  # noqa: E402


@pytest.fixture
def run():
    """Run ``postproc ARGS`` in-process; returns the click Result (stdout, stderr, exit code)."""

    def invoke(*args: str, input: bytes | str | None = None):
        runner = CliRunner()
        return runner.invoke(main, list(args), input=input, catch_exceptions=False)

    return invoke
