"""postproc.report.docstring: a compensator's documentation shown in words, its markup read, never shown."""

from __future__ import annotations

import html
import re

import pytest
from click.testing import CliRunner

from support import SAMPLES
from postproc.compensate import registry
from postproc.cli.main import main
from postproc.report.docstring import inline, parts

MARKUP = re.compile(r"``|:[a-z]+:`|`_|(?<![\w`])`[^`\s][^`]*`(?!`)")


def _code(text):
    return [text.text[a:b] for a, b in text.code]


def test_inline_markup_becomes_code_spans_and_plain_text():
    text = inline("Fits ``a_x`` with :func:`~postproc.measure.ballbar_fit.fit`, see :mod:`postproc.compensate.models` and `iso`_ ::")
    assert text.text == "Fits a_x with fit, see postproc.compensate.models and iso"  # " ::" goes, as in reST
    assert _code(text) == ["a_x", "fit", "postproc.compensate.models", "iso"]
    assert inline(":class:`the model <postproc.compensate.models.Model>`").text == "the model"


def test_blocks_lists_and_verbatim():
    doc = """Summary line.

    A paragraph
    over two lines::

        e_x = a_x (x - xc)
          + s (z - zc)

    - first item
      continued
    - ``second`` item
    """
    found = parts(doc, skip_summary=True)
    assert [(p.kind, p.text) for p in found] == [
        ("p", "A paragraph over two lines:"), ("pre", "e_x = a_x (x - xc)\n  + s (z - zc)"),
        ("item", "first item continued"), ("item", "second item")]
    assert _code(found[3]) == ["second"]


@pytest.mark.parametrize("name", sorted(registry.compensators()))
def test_no_markup_of_any_installed_compensator_reaches_the_reader(name):
    cls = registry.compensators()[name].cls
    for part in [inline(cls.summary() or name), *parts(cls.__doc__ or "", skip_summary=True)]:
        if part.kind != "pre":
            assert not MARKUP.search(part.text), (name, part.text)


def test_no_markup_leaks_into_a_report(tmp_path):
    target = tmp_path / "r.html"
    result = CliRunner().invoke(main, ["report", str(SAMPLES / "programs" / "hemishell.nc"), "--plugin", "parametric",
                                       "--ballbar", str(SAMPLES / "ballbar" / "v40r-100-ccw.csv"),
                                       "--ballbar", str(SAMPLES / "ballbar" / "v40r-100-cw.csv"), "-o", str(target)])
    assert result.exit_code == 0, result.stderr
    text = target.read_text(encoding="utf-8")
    shown = re.sub(r"<pre>.*?</pre>", "", text.split("<main>", 1)[1], flags=re.S)
    words = html.unescape(re.sub(r"<[^>]+>", "", shown))
    assert not MARKUP.search(words), MARKUP.search(words)
    assert "<code>" in text  # the names it marked are set as code
