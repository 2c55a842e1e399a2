"""The corpus of real programs (``tests/corpus``) as test cases, with what each must answer."""

from __future__ import annotations

import os
import tomllib
from pathlib import Path

import pytest

from support import CORPUS


def corpus_dir() -> Path:
    """``tests/corpus`` (the project's own programs), or ``$POSTPROC_CORPUS`` when set."""
    configured = os.environ.get("POSTPROC_CORPUS")
    path = Path(configured) if configured else CORPUS
    if not path.is_dir():
        raise RuntimeError(f"the corpus of real programs is missing: {path} (POSTPROC_CORPUS names another one)")
    return path


def corpus(folder: str) -> list[Path]:
    files = sorted((corpus_dir() / folder).glob("*.nc"))
    assert files, f"no programs in {folder}"
    return files


def expectations(folder: str) -> dict:
    """What each program of a corpus folder needs and what postproc must answer: the folder's table
    in ``expectations.toml`` beside the programs (empty when the corpus has none)."""
    path = corpus_dir() / "expectations.toml"
    if not path.is_file():
        return {}
    return tomllib.loads(path.read_text(encoding="utf-8")).get(folder, {})


def machine_args(tmp_path: Path, keys: dict) -> list[str]:
    """``--machine FILE`` with the machine profile keys a corpus program needs (expectations.toml), or
    nothing: the program is then read as the default profile reads it."""
    if not keys:
        return []
    path = tmp_path / "machine.toml"
    path.write_text("".join(f"{key} = {str(value).lower() if isinstance(value, bool) else repr(value)}\n"
                            for key, value in keys.items()))
    return ["--machine", str(path)]


def known_defect(expected: dict, check: str):
    """pytest marks for one check of one corpus program: a strict xfail naming the engine defect that
    makes it fail today (``[folder."name".xfail] check = "reason"``), so its fix is proven when it lands."""
    reason = expected.get("xfail", {}).get(check)
    return [pytest.mark.xfail(strict=True, reason=reason)] if reason else []


def corpus_cases(folder: str, check: str) -> list:
    """The folder's programs as pytest params for one check, each with its expectations and marks."""
    table = expectations(folder)
    return [pytest.param(path, table.get(path.name, {}), id=path.name, marks=known_defect(table.get(path.name, {}), check))
            for path in corpus(folder)]
