"""The compensator contract (postproc/compensate/compensator.py) and the public helpers plugins build on:
what a plugin sees, it can load without the engine."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from postproc.compensate.compensator import Compensator, Option, parse_options
from postproc.diagnostics import OptionError
from support import REPO

#: The engine: what reads, interprets, plans and writes programs. A plugin never needs it.
ENGINE = ("postproc.compensate.rewrite", "postproc.compensate.segmenter", "postproc.interpret.interpreter", "postproc.compensate.emitter", "postproc.syntax.reader",
          "postproc.syntax.fastpath", "postproc.compensate.pipeline", "postproc.syntax.grammar", "postproc.interpret.corners", "postproc.syntax.macro",
          "postproc.interpret.canonical", "postproc.interpret.statements", "postproc.interpret.convert",
          "postproc.interpret.arcs", "postproc.interpret.cycles", "postproc.interpret.state")

LOADED = """
import json, sys
from importlib.metadata import entry_points
import postproc.compensator
contract = sorted(name for name in sys.modules if name.startswith("postproc"))
plugins = [point.load() for point in entry_points(group="postproc") if point.value.startswith("postproc_plugins.")]
print(json.dumps({"contract": contract, "plugins": [p.__name__ for p in plugins],
                  "all": sorted(name for name in sys.modules if name.startswith("postproc"))}))
"""


def test_contract_and_every_built_in_plugin_load_without_the_engine():
    """A fresh interpreter, so that no other test's imports count: the contract and every
    built-in plugin (through their entry points, as postproc loads them) pull in no engine
    module."""
    done = subprocess.run([sys.executable, "-c", LOADED], capture_output=True, text=True, cwd=REPO, check=True)
    loaded = json.loads(done.stdout)
    assert len(loaded["plugins"]) >= 8  # the seven compensators and formats, error-map among them
    assert "postproc.compensator" in loaded["contract"]
    assert [name for name in loaded["all"] if name in ENGINE or name.startswith("postproc.simulator")] == []


def test_piece_is_the_contracts_own():
    """The engine takes the contract's Piece; it does not define one of its own."""
    from postproc.compensate import compensator, rewrite

    assert rewrite.Piece is compensator.Piece
    assert compensator.Piece.__module__ == "postproc.compensate.compensator"


# ---------------------------------------------------------------------- options: one value per setting


class _One(Compensator):
    name = "one"
    options = (Option("gain", float, 1.0), Option("mode", str, "a", choices=("a", "b")))


class _Two(Compensator):
    name = "two"
    options = (Option("gain", float, 1.0),)


@pytest.mark.parametrize("texts", [
    ["gain=1", "gain=2"], ["one.gain=1", "one.gain=2"], ["mode=a", "one.gain=2", "mode=b"], ["gain=1", "gain=1.5"],
])
def test_one_setting_given_two_values_is_refused_whatever_the_order(texts):
    """--option gain=1 --option gain=2 gave gain 2 without a word: which was meant is a guess."""
    for ordered in (texts, texts[::-1]):
        with pytest.raises(OptionError, match=r"is set twice, to two values"):
            parse_options(ordered, [_One, _Two])


@pytest.mark.parametrize("texts, expected", [
    (["gain=1", "gain=1.0"], {"one": {"gain": 1.0}, "two": {"gain": 1.0}}),
    (["gain=2", "one.gain=3"], {"one": {"gain": 3.0}, "two": {"gain": 2.0}}),
    (["one.gain=3", "gain=2"], {"one": {"gain": 3.0}, "two": {"gain": 2.0}}),
])
def test_one_value_given_twice_or_a_compensators_own_over_the_general_is_taken(texts, expected):
    """PLUGIN.KEY=VALUE is that compensator's whatever the order, as formats.md §8.1 scopes it."""
    assert parse_options(texts, [_One, _Two]) == expected


@pytest.mark.parametrize("key, text, meant", [("max-uncertainty", "5", "0.005 mm"), ("stock", "20", "0.02 mm"),
                                              ("residual", "5", "0.005 mm"), ("stock", "-30", "-0.03 mm")])
def test_a_length_option_far_too_large_is_refused_as_micrometres(key, text, meant):
    """Every length a compensator takes as an option is in mm: ``residual=5`` meant 5 um would
    turn a form check off, ``max-uncertainty=5`` hold a fit to nothing. Above the largest that
    makes sense it is refused, with the reading in micrometres; from a saved model too."""
    from postproc.compensate.compensator import MAX_UNCERTAINTY_MM, STOCK_MM
    from postproc.diagnostics import Location, ModelError

    option = Option(key, float, None, positive=not text.startswith("-"),
                    largest_mm={"max-uncertainty": MAX_UNCERTAINTY_MM, "stock": STOCK_MM, "residual": 0.1}[key])
    with pytest.raises(OptionError, match=rf"at most .* mm \(the option is in mm\); {text} um is {meant}"):
        option.parse(text, "p")
    with pytest.raises(ModelError, match="the option is in mm"):
        option.check(float(text), Location("m.json"))
    assert option.parse(str(float(text) / 1000), "p") == float(text) / 1000


def test_every_length_option_of_the_built_in_compensators_has_its_largest():
    """The class, not the three found: each float option whose help speaks of mm is bounded."""
    from postproc.compensate import registry

    for name, installed in registry.compensators().items():
        for option in installed.cls.options:
            if option.kind is float and ("mm" in option.help or option.key in ("stock", "residual")):
                assert option.largest_mm is not None, (name, option.key)
