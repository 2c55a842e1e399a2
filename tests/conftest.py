"""Shared fixtures: where the corpus is, and a way to run the CLI in-process."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from click.testing import CliRunner

from postproc.cli import main

REPO = Path(__file__).resolve().parents[1]
SAMPLES = REPO / "samples"


def corpus_dir() -> Path:
    """``$POSTPROC_CORPUS``, or ``shared/corpus`` beside the repository (or beside a folder above it)."""
    configured = os.environ.get("POSTPROC_CORPUS")
    if configured:
        candidates = [Path(configured)]
    else:
        candidates = [parent / "shared" / "corpus" for parent in REPO.parents]
    for path in candidates:
        if path.is_dir():
            return path
    raise RuntimeError(f"the corpus of real programs is missing: {candidates[0]} (set POSTPROC_CORPUS)")


def corpus(folder: str) -> list[Path]:
    files = sorted((corpus_dir() / folder).glob("*.nc"))
    assert files, f"no programs in {folder}"
    return files


@pytest.fixture
def run():
    """Run ``postproc ARGS`` in-process; returns the click Result (stdout, stderr, exit code)."""

    def invoke(*args: str, input: bytes | str | None = None):
        runner = CliRunner()
        return runner.invoke(main, list(args), input=input, catch_exceptions=False)

    return invoke
