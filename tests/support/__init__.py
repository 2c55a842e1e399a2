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
