"""The interpreter's fast path against its general path: the same steps for every program.

Ordinary blocks skip the general machinery; this is the proof that skipping it changes
nothing: on the corpus, the samples and generated programs, both paths give the same moves,
modal states, flags and warnings (or the same error).
"""

from __future__ import annotations

import random

import pytest
from hypothesis import HealthCheck, given, settings

from conftest import SAMPLES, corpus
from postproc.diagnostics import PostprocError, Reporter
from postproc.interpreter import Interpreter
from postproc.reader import read_blocks
from postproc.source import Source
from strategies import lathe_programs
from support.generate import program


def _run(text: str, fast: bool):
    reporter = Reporter()
    with Source.from_text(text, "t.nc") as source:
        interpreter = Interpreter(reporter=reporter, file="t.nc", labels=lambda: source.labels, fast=fast)
        try:
            steps = [(s.block.line, s.moves, s.modal, s.interpreted, s.in_contour, s.shared)
                     for s in interpreter.run(read_blocks(source.lines(), source.name, reporter))]
        except PostprocError as exc:
            return ("error", str(exc), [str(w) for w in reporter.warnings])
    return (steps, [str(w) for w in reporter.warnings])


def _same(text: str) -> None:
    assert _run(text, fast=True) == _run(text, fast=False)


@pytest.mark.parametrize("path", corpus("fanuc") + sorted(SAMPLES.glob("**/*.nc")), ids=lambda p: p.name)
def test_corpus_and_samples(path):
    _same(path.read_bytes().decode("utf-8", "surrogateescape"))


def test_generated_lathe_programs():
    for seed in range(150):
        _same(program(random.Random(seed)))


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(lathe_programs())
def test_formatting_habits(text):
    _same(text)


@pytest.mark.parametrize("text", [
    "G00 X10. Z1.\nG01 Z0.\n",  # a feed move before any F: the general path warns
    "G00 X10. Z1. F0\nG01 Z0.\n",  # F0: the general path refuses
    "G00 X10. Z1. F.1\nG02 X20. Z-5. I5. K3.\n",  # an arc off its circle: refused
    "G00 X10. Z1. F.1\nG01 X20. X30.\n",  # an address twice
    "G00 X10. Z1. F.1\nG02 I-5.\n",  # a full circle
    "G28\nG02 X20. Z0. R5. F.1\n",  # an arc from an unknown position
    "G00 X10 Z1 F100\nG1 U-1 W-1\nG20\nG01 X1.\n",  # increments, inch
])
def test_edge_cases(text):
    _same(text)
