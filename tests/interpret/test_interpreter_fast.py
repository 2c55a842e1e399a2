"""The interpreter's fast path against its general path: the same steps for every program.

Ordinary blocks skip the general machinery; this is the proof that skipping it changes
nothing: on the corpus, the samples and generated programs, both paths give the same moves,
modal states, flags and warnings (or the same error). The tally, which keeps no step,
counts the same blocks and moves with the same warnings.
"""

from __future__ import annotations

import random

from dataclasses import replace

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from support import SAMPLES
from support.corpus import corpus
from postproc.diagnostics import PostprocError, Reporter
from postproc.interpret.interpreter import Interpreter
from postproc.machine.profile import DEFAULT
from postproc.syntax.reader import read_blocks
from postproc.syntax.source import Source
from support.strategies import lathe_programs
from support.generate import program


def _run(text: str, fast: bool, profile=DEFAULT):
    reporter = Reporter()
    with Source.from_text(text, "t.nc") as source:
        interpreter = Interpreter(profile, reporter, "t.nc", labels=lambda: source.labels, fast=fast)
        try:
            steps = [(s.block.line, s.moves, s.modal, s.interpreted, s.in_contour, s.shared)
                     for s in interpreter.run(read_blocks(source.lines(), source.name, reporter))]
        except PostprocError as exc:
            return ("error", str(exc), [str(w) for w in reporter.warnings])
    return (steps, [str(w) for w in reporter.warnings])


def _tally(text: str, profile=DEFAULT):
    reporter = Reporter()
    with Source.from_text(text, "t.nc") as source:
        interpreter = Interpreter(profile, reporter, "t.nc", labels=lambda: source.labels)
        try:
            counts = interpreter.tally(read_blocks(source.lines(), source.name, reporter, light=True))
        except PostprocError as exc:
            return ("error", str(exc), [str(w) for w in reporter.warnings])
    return (counts, [str(w) for w in reporter.warnings])


def _same(text: str, profile=DEFAULT) -> None:
    general = _run(text, False, profile)
    assert _run(text, True, profile) == general
    if general[0] == "error":
        assert _tally(text, profile) == general, "tally"
    else:
        steps, warnings = general
        assert _tally(text, profile) == ((len(steps), sum(len(s[1]) for s in steps)), warnings), "tally"


_LENGTH = st.one_of(st.floats(-999.0, 999.0).map(lambda v: f"{v:.3f}"),  # canonical: with the point
                    st.integers(-99999, 99999).map(str),  # plain: least input increments
                    st.sampled_from(["0", "-0.", ".5", "1.", "-.25", "0.0000", "123456789", "1.23456789", "12.34567"]))
_FEED = st.sampled_from(["0.2", ".15", "100", "0", "0.", "1.5", "12345"])
_G = st.sampled_from(["G00", "G01", "G02", "G03", "G0", "G1", "G2", "G3", "G001", "g01", "G04", "G20", "G21", "G90",
                      "G91", "G18", "G19", "G40", "G41", "G99", "G98", "G28"])


@st.composite
def _ordinary_blocks(draw) -> str:
    """A block of the kinds the fast path takes, and their near misses: G00-G03 (in every
    spelling), X Z U W I K R with and without their decimal point, F, S, M, labels and
    comments, in canonical order or any other, spaced or not."""
    words = []
    if draw(st.booleans()):
        words.append(draw(_G))
    for letter in draw(st.lists(st.sampled_from("XZUWIKR"), max_size=4)):
        words.append(letter + draw(_LENGTH))
    if draw(st.integers(0, 3)) == 0:
        words.append("F" + draw(_FEED))
    if draw(st.integers(0, 5)) == 0:
        words.append("S" + draw(st.sampled_from(["200", "1500", "0", "-5"])))
    if draw(st.integers(0, 5)) == 0:
        words.append("M" + draw(st.sampled_from(["08", "3", "05", "98", "30", "1.", "99"])))
    if draw(st.booleans()):
        words = draw(st.permutations(words))
    line = draw(st.sampled_from([" ", ""])).join(words)
    if draw(st.integers(0, 3)) == 0:
        line = f"N{draw(st.integers(1, 40))} {line}"
    if draw(st.integers(0, 5)) == 0:
        line += draw(st.sampled_from([" (CUT)", ";", " (A);"]))
    return line


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(start=st.sampled_from(["G00 X50. Z5. F0.2", "G00 X50. Z5.", "G20 G00 X2. Z.2 F.01", "G28 U0 W0", "G00 X50 Z5"]),
       body=st.lists(_ordinary_blocks(), max_size=12),
       profile=st.sampled_from([DEFAULT, replace(DEFAULT, diameter_x=False), replace(DEFAULT, calculator_input=True),
                                replace(DEFAULT, calculator_input=False), replace(DEFAULT, gcode_system="B")]))
def test_ordinary_and_canonical_blocks(start, body, profile):
    """Generated blocks, canonical and not, in every modal state they make (units, distance
    mode, feed, motion, plane, an unknown position): the fast path's steps, modal states,
    warnings and alarms are the general path's, and the tally counts as the run does."""
    _same("\n".join([start, *body, ""]), profile)


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
    # canonical blocks (N G X Z I K R F in order) in every state that must keep them off the shortest route
    "G20\nG00 X1. Z.1\nG01 Z-1. F.01\nG02 X1.5 Z-1.25 R.25\n",  # inch
    "G00 X10. Z1.\nN10 G01 X20. F.1\nN20 G01 Z-5.\n#1=1\nIF[#1EQ1]GOTO20\nG01 X30.\n",  # a jump target
    "G00 X10. Z1. F.1\nG01 X20. ,C1.\nG01 Z-5.\n",  # a corner waiting for its next move
    "G00 X40. Z2.\nG71 U1. R.5\nG71 P10 Q20 U.2 W.1 F.2\nN10 G00 X20.\nG01 Z-10. F.1\nN20 X40.\nG70 P10 Q20\n",
    "G00 X10. Z1. F.1\nG81 Z-5. R1.\nX20. Z1.\nG80\nG01 X5.\n",  # drilling in force
    "G00 X10. Z1. F.1\nG66 P9010 A1.\nX20. Z1.\nG67\nG01 X5.\n",  # a modal macro in force
    "G00 X10. Z1. F.1\nG18 G01 X20.\nG19\nG02 X30. Z0. R10.\n",  # an arc outside G18
    "G00 X10. Z1. F.1\nG91 G01 X2. Z-1.\n",  # incremental in system A is a G code the table refuses
    "G00 X10. Z1.\nG01 X20. F0\nX30.\n",  # F0 on a canonical block
    "N10 G00 X10. Z1. F.1 (PART) ;\nG01 X11.1234 Z-.5\nG03 X12. Z-1. K-.5 I.1\n",  # words out of order
    "G00 X10. Z1. F.1\nG01 X12345.6\nG01 X1.23456\n",  # more digits than the canonical form takes
    "G00 X10. Z1. F.1\nG12.1\nG01 X20. C5.\nG01 X10. Z-1.\nG13.1\nG00 X30. Z2.\nG01 X20. Z-1.\n",  # polar interpolation
    "G00 X10. Z1. F.1\nG32 Z-10. F1.5\nG00 X20.\nZ1.\nG01 X10. F.1\n",  # threading, then canonical blocks
    "%O1200(TOKARKA)\nG00 X10. Z1. F.1;\nG01 X20. Z-1.; (A);\nM30;\n%\n",  # a label, printed ends of block
    "G00 X10. Z1. F.1\nG01X118\nG00Z220\nG04 X1000\n",  # a plain axis word after decimal ones
    "G00 X10 Z1 F.1\nG01 X20. Z-1.\n",  # plain words first, a canonical block after
    "G00 X10 Z1 F.1\nG04 X15\nG28 U0 W0\nG01 X20. Z-1.\n",  # a dwell and zeros are no axis words
])
def test_edge_cases(text):
    _same(text)


def test_canonical_form_profiles():
    """Diameter or radius X, calculator input: the canonical route follows the profile."""
    text = "G00 X10. Z1.\nG01 X20. Z-1. F.1\nG02 X22. Z-2. R2.\nG00 X30.\n"
    for profile in (replace(DEFAULT, diameter_x=False), replace(DEFAULT, calculator_input=True)):
        results = []
        for fast in (True, False):
            with Source.from_text(text, "t.nc") as source:
                interpreter = Interpreter(profile, Reporter(), "t.nc", labels=lambda: source.labels, fast=fast)
                results.append([s.moves for s in interpreter.run(read_blocks(source.lines(), source.name))])
        assert results[0] == results[1]
