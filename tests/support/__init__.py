"""Test helpers, all in one place: ``support`` (where the repository, the samples and the corpus are),
``support.corpus`` (the corpus of real programs as test cases), ``support.interpret`` (a program given
as text, interpreted), ``support.strategies`` (hypothesis strategies), ``support.control`` (a FANUC
control that runs a probing program to its printout), ``support.artifact`` and ``support.closed_loop``
(virtual lathes and what several test modules measure on them), ``support.generate``,
``support.parts``, ``support.machines`` and ``support.linuxcnc``. No test module imports another."""

from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
SAMPLES = REPO / "samples"
CORPUS = REPO / "tests" / "corpus"

#: the sample hemishell (samples/programs/hemishell.nc) in inches: an inch program on its 0.0001 in grid
INCH_HEMISHELL = """%
O1003 (HEMISHELL IN INCHES)
G18 G20 G40 G99
T0101
G00 X0. Z2.441
G01 Z2.25 F0.003
G03 X4.5 Z0. I0. K-2.25
G01 X4.65
G00 Z2.441
M30
%
"""
