"""The plugin system: discovery, order, options, routing, faults, and a third-party plugin."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from support import REPO, SAMPLES
from postproc.compensate import hookspecs
from postproc.compensate import registry
from postproc.compensator import Compensator

HEMISHELL = str(SAMPLES / "programs" / "hemishell.nc")
CCW, CW = (str(SAMPLES / "ballbar" / f"v40r-100-{d}.csv") for d in ("ccw", "cw"))
BUILT_IN = {"ballbar-inverse", "iterative"}


def test_plugins_lists_name_version_and_summary(run):
    result = run("plugins")
    assert result.exit_code == 0 and result.stderr == ""
    lines = result.stdout.splitlines()
    names = [line.split()[0] for line in lines]
    assert BUILT_IN <= set(names) and names == sorted(names)
    for line in lines:
        assert re.match(r"^\S+ \d+\.\d+\.\d+ \S.+$", line), line


def test_built_in_compensators_come_through_entry_points():
    installed = registry.compensators()
    for name in BUILT_IN:
        assert installed[name].cls.__module__.startswith("postproc_plugins.")
        assert installed[name].distribution == "postproc"


def test_compensators_run_in_the_order_given(run):
    result = run("compensate", HEMISHELL, "--plugin", "iterative", "--plugin", "ballbar-inverse",
                 "--ballbar", CCW, "--ballbar", CW, "--option", "radius-mapping=relative")
    assert result.exit_code == 0, result.stderr
    plugins = [line for line in result.stdout.splitlines() if line.startswith("(PLUGIN")]
    assert plugins == ["(PLUGIN ITERATIVE 0.1.0)", "(PLUGIN BALLBAR-INVERSE 0.1.0)"]


class _Raises(Compensator):
    """Raises while correcting."""

    name = "test-raises"

    def fit(self, measurements):
        pass

    def correct(self, piece):
        raise ZeroDivisionError("oops")


class _Nonsense(_Raises):
    """Returns a correction of the wrong shape."""

    name = "test-nonsense"

    def correct(self, piece):
        return np.zeros((3, 3))


class _Mutates(_Raises):
    """Changes the shared sample points in place."""

    name = "test-mutates"

    def correct(self, piece):
        piece.points[:, 0] += 0.001
        return np.zeros((len(piece.t), 2))


class _Miscounts(_Raises):
    """Returns fewer corrections than it was given pieces."""

    name = "test-miscounts"

    def correct_many(self, pieces):
        return [None] * (len(pieces) - 1)


class _Infinite(_Raises):
    """Returns a correction that is not finite."""

    name = "test-infinite"

    def correct(self, piece):
        shift = np.zeros((len(piece.t), 2))
        shift[-1, 1] = np.inf
        return shift


class _Test:
    @hookspecs.hookimpl
    def postproc_compensators(self):
        return [_Raises, _Nonsense, _Mutates, _Miscounts, _Infinite]


@pytest.fixture
def faulty():
    manager = registry.manager()
    plugin = _Test()
    manager.register(plugin, name="faulty-test-plugin")
    yield
    manager.unregister(plugin)


@pytest.mark.parametrize("name, words", [("test-raises", "correct failed: ZeroDivisionError: oops"),
                                         ("test-nonsense", "returned a correction of shape (3, 3)"),
                                         ("test-mutates", "correct failed: ValueError: output array is read-only"),
                                         ("test-miscounts", "returned 2 corrections for 3 pieces"),
                                         ("test-infinite", "returned a correction with values that are not finite")])
def test_a_faulty_plugin_is_named_and_nothing_is_written(run, faulty, tmp_path, name, words):
    target = tmp_path / "out.nc"
    result = run("compensate", HEMISHELL, "--plugin", name, "-o", str(target))
    assert result.exit_code == 5
    assert f"plugin '{name}': {words}" in result.stderr
    assert not target.exists() and list(tmp_path.iterdir()) == []


@pytest.fixture(scope="module")
def shop_plugin(tmp_path_factory) -> Path:
    """The sample third-party plugin, installed by pip into a directory of its own."""
    target = tmp_path_factory.mktemp("site")
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
                    "--target", str(target), str(SAMPLES / "plugins" / "postproc-shop-example")], check=True)
    return target


def _postproc(site: Path, *args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(site)}
    return subprocess.run([sys.executable, "-c", "from postproc.cli.main import main; main()", *args],
                          capture_output=True, text=True, env=env, cwd=REPO)


def test_a_third_party_plugin_appears_and_runs(shop_plugin, tmp_path):
    listed = _postproc(shop_plugin, "plugins")
    assert listed.returncode == 0
    assert "radial-allowance 1.0.0 Leave a finishing allowance on every feed arc." in listed.stdout.splitlines()
    result = _postproc(shop_plugin, "compensate", HEMISHELL, "--plugin", "radial-allowance", "--option", "allowance=0.05")
    assert result.returncode == 0, result.stderr
    assert "G03 X114.4 Z0. I0. K-57.2" in result.stdout


def test_a_third_party_reader_reads_its_instrument_export(shop_plugin, tmp_path):
    export = tmp_path / "trace.shopbar"
    rows = "".join(f"{a};5\n" for a in range(0, 360, 2))
    export.write_text(f"SHOPBAR EXPORT;RADIUS=57.15;DIR=CCW\nANGLE;DEV_UM\n{rows}")
    result = _postproc(shop_plugin, "compensate", HEMISHELL, "--plugin", "ballbar-inverse", "--ballbar", str(export))
    assert result.returncode == 0, result.stderr
    assert "G03 X114.29 Z0. I0. K-57.145" in result.stdout


class _Reader:
    """A reader registered in-process through postproc_measurement_readers."""

    @hookspecs.hookimpl
    def postproc_measurement_readers(self):
        from postproc.measure.readers.ballbar import read_ballbar
        from postproc.measure.readers.registry import MeasurementReader

        def read(path, context):
            with open(path) as handle:
                text = handle.read().replace("# flipped ballbar", "# postproc ballbar 1", 1)
            flipped = Path(path).with_suffix(".converted.csv")
            flipped.write_text(text)
            return read_ballbar(str(flipped), context.reporter)

        return [MeasurementReader("ballbar", "flipped", lambda path: open(path).readline().startswith("# flipped"), read)]


def test_postproc_measurement_readers_come_before_the_built_in_ones(run, tmp_path):
    manager = registry.manager()
    plugin = _Reader()
    manager.register(plugin, name="reader-test-plugin")
    try:
        trace = tmp_path / "t.csv"
        rows = "".join(f"{a},0.005\n" for a in range(0, 360, 2))
        trace.write_text(f"# flipped ballbar\n# radius_mm = 57.15\n# direction = ccw\n# centered = true\nangle_deg,deviation_mm\n{rows}")
        assert [reader.name for reader in registry.readers()][0] == "flipped"
        result = run("compensate", HEMISHELL, "--plugin", "ballbar-inverse", "--ballbar", str(trace))
        assert result.exit_code == 0 and "G03 X114.29 Z0. I0. K-57.145" in result.stdout
    finally:
        manager.unregister(plugin)


def _named_reader(name: str, magic: str, **order):
    """A plugin object with one ballbar reader that accepts files whose first line is ``magic``
    and reads them as postproc traces, marked ``tryfirst``/``trylast`` as ``order`` says."""
    from postproc.measure.readers.ballbar import read_ballbar
    from postproc.measure.readers.csvfile import snapshot
    from postproc.measure.readers.registry import MeasurementReader, first_line

    def read(path, context):
        text = snapshot(path).data.decode().replace(magic, "# postproc ballbar 1", 1)
        converted = Path(path).with_suffix(f".{name}.csv")
        converted.write_text(text)
        return read_ballbar(str(converted), context.reporter)

    class Plugin:
        @hookspecs.hookimpl(**order)
        def postproc_measurement_readers(self):
            return [MeasurementReader("ballbar", name, lambda path: first_line(path) == magic, read)]

    return Plugin()


@pytest.fixture
def registered():
    """Register plugin objects for one test (in the order given), unregistered after it."""
    manager = registry.manager()
    added = []

    def register(*plugins):
        for index, plugin in enumerate(plugins):
            manager.register(plugin, name=f"reader-order-{len(added)}-{index}")
            added.append(plugin)

    yield register
    for plugin in added:
        manager.unregister(plugin)


def _ballbar_names():
    return [reader.name for reader in registry.readers() if reader.kind == "ballbar"]


def test_readers_come_in_pluggys_order_tryfirst_plain_then_the_built_in_trylast(registered):
    """An unmarked shop reader comes before the built-in one (trylast), the shop reader
    registered last first; a tryfirst one comes before every unmarked one, whenever it was
    registered. The order is pluggy's own: that of the hook's call."""
    registered(_named_reader("early-tryfirst", "# A", tryfirst=True), _named_reader("plain", "# B"),
               _named_reader("later", "# C"))
    names = _ballbar_names()
    assert names == ["early-tryfirst", "later", "plain", "postproc ballbar 1"]
    called = [reader.name for found in registry.manager().hook.postproc_measurement_readers() for reader in found]
    assert [reader.name for reader in registry.readers()] == called


def test_a_tryfirst_reader_takes_a_file_before_another_shops_reader(registered, run, tmp_path):
    """Two shop readers both accept the file: the tryfirst one reads it, though registered first."""
    registered(_named_reader("first", "# SHOP", tryfirst=True), _named_reader("second", "# SHOP"))
    trace = tmp_path / "shop.csv"
    rows = "".join(f"{a},0.005\n" for a in range(0, 360, 2))
    trace.write_text(f"# SHOP\n# radius_mm = 57.15\n# direction = ccw\n# centered = true\nangle_deg,deviation_mm\n{rows}")
    result = run("compensate", HEMISHELL, "--plugin", "ballbar-inverse", "--ballbar", str(trace))
    assert result.exit_code == 0, result.stderr
    assert (tmp_path / "shop.first.csv").exists() and not (tmp_path / "shop.second.csv").exists()


def test_a_file_no_shop_reader_accepts_falls_back_to_the_built_in_reader(registered, run, tmp_path):
    """A shop reader that declines a file leaves it to the built-in reader: a postproc trace is
    read as ever, and a file nobody reads gets the built-in reader's exact message."""
    registered(_named_reader("shop", "# SHOP", tryfirst=True))
    result = run("compensate", HEMISHELL, "--plugin", "ballbar-inverse", "--ballbar", CCW, "--ballbar", CW,
                 "--option", "radius-mapping=relative")
    assert result.exit_code == 0, result.stderr
    assert not list((SAMPLES / "ballbar").glob("*.shop.csv"))
    wrong = tmp_path / "wrong.csv"
    wrong.write_text("# some other format\n1,2\n")
    refused = run("compensate", HEMISHELL, "--plugin", "ballbar-inverse", "--ballbar", str(wrong))
    assert refused.exit_code == 3 and refused.stdout == ""
    assert refused.stderr.startswith(f"{wrong}:1: error: ") and "postproc ballbar 1" in refused.stderr


class _Hangs(_Raises):
    """Never returns."""

    name = "test-hangs"

    def correct(self, piece):
        while True:
            pass


class _Slow:
    @hookspecs.hookimpl
    def postproc_compensators(self):
        return [_Hangs]


def test_a_plugin_that_hangs_is_stopped_and_named(run, tmp_path):
    manager = registry.manager()
    plugin = _Slow()
    manager.register(plugin, name="slow-test-plugin")
    try:
        machine = tmp_path / "m.toml"
        machine.write_text("plugin_time_limit_s = 0.5\n")
        target = tmp_path / "out.nc"
        result = run("compensate", HEMISHELL, "--plugin", "test-hangs", "--machine", str(machine), "-o", str(target))
        assert result.exit_code == 5
        assert "plugin 'test-hangs': correct took longer than 0.5 s" in result.stderr
        assert not target.exists()
    finally:
        manager.unregister(plugin)


# ---------------------------------------------------------------------- a shop reader that misbehaves

def _trace_made(path, context, change):
    """The built-in reader's trace of the sample, with ``change`` applied to it."""
    import dataclasses

    from postproc.measure.readers.ballbar import read_ballbar

    trace = read_ballbar(CCW, context.reporter)
    return dataclasses.replace(trace, **change(trace))


def _probe_made(path, context, change):
    import dataclasses

    from postproc.measure.readers.probe import read_probe

    points = read_probe(str(SAMPLES / "probe" / "hemishell-pass1.csv"))
    return dataclasses.replace(points, **change(points))


def _raises(*args):
    raise KeyError("Deviation")


#: (kind, accepts, read, words of the message): every way a reader can fail but refusing the file
_FAULTY_READERS = {
    "accepts raises": ("ballbar", _raises, None, "reader 'faulty': accepts failed: KeyError: 'Deviation'"),
    "read raises": ("ballbar", None, _raises, "reader 'faulty': read failed: KeyError: 'Deviation'"),
    "nothing read": ("ballbar", None, lambda path, context: None, "read returned NoneType, not a BallbarTrace"),
    "another kind": ("ballbar", None, lambda p, c: _probe_made(p, c, lambda t: {}), "returned ProbeFile, not a BallbarTrace"),
    "a NaN deviation": ("ballbar", None, lambda p, c: _trace_made(p, c, lambda t: {
        "deviations": np.where(np.arange(len(t.angles)) == 3, np.nan, t.deviations)}), "deviations with values that are not finite"),
    "fewer deviations": ("ballbar", None, lambda p, c: _trace_made(p, c, lambda t: {"deviations": t.deviations[:-5]}),
                         "deviations of shape (715,)"),
    "a table of deviations": ("ballbar", None, lambda p, c: _trace_made(p, c, lambda t: {
        "deviations": np.column_stack([t.deviations, t.deviations])}), "deviations of shape (720, 2)"),
    "angles in degrees out of order": ("ballbar", None, lambda p, c: _trace_made(p, c, lambda t: {
        "angles": t.angles[::-1].copy(), "deviations": t.deviations[::-1].copy()}), "angles that are not increasing"),
    "angles in radians beyond 360": ("ballbar", None, lambda p, c: _trace_made(p, c, lambda t: {"angles": t.angles + 360.0}),
                                     "angles that are not increasing within [0, 360)"),
    "a radius of nan": ("ballbar", None, lambda p, c: _trace_made(p, c, lambda t: {"radius": float("nan")}),
                        "radius = nan, not a positive number"),
    "a direction of its own": ("ballbar", None, lambda p, c: _trace_made(p, c, lambda t: {"direction": "G03"}),
                               "direction 'G03', not 'ccw' or 'cw'"),
    "rows of another trace": ("ballbar", None, lambda p, c: _trace_made(p, c, lambda t: {"rows": t.rows[:10]}),
                              "read returned 10 rows for 720 samples"),
    "probe: a centre of three coordinates": ("probe", None, lambda p, c: _probe_made(p, c, lambda t: {
        "centres": np.column_stack([t.centres, t.centres[:, :1]])}), "centres of shape"),
    "probe: an infinite approach": ("probe", None, lambda p, c: _probe_made(p, c, lambda t: {
        "approach": np.where(np.arange(len(t.lines))[:, None] == 0, np.inf, t.approach)}), "approach with values that are not finite"),
    "probe: no stylus": ("probe", None, lambda p, c: _probe_made(p, c, lambda t: {"stylus_radius": None}),
                         "stylus_radius = None, not a positive number"),
    "probe: lines of fewer touches": ("probe", None, lambda p, c: _probe_made(p, c, lambda t: {"lines": t.lines[:-1]}),
                                      "lines for"),
}


def test_what_a_shop_reader_prints_goes_to_stderr_never_into_the_output(run, registered, tmp_path):
    from postproc.measure.readers.ballbar import read_ballbar
    from postproc.measure.readers.registry import MeasurementReader

    def read(path, context):
        print("G00 X0. Z0. (read!)")
        return read_ballbar(CCW, context.reporter)

    class Plugin:
        @hookspecs.hookimpl
        def postproc_measurement_readers(self):
            return [MeasurementReader("ballbar", "chatty", lambda path: path.endswith(".shop"), read)]

    registered(Plugin())
    export = tmp_path / "export.shop"
    export.write_text("whatever\n")
    result = run("compensate", HEMISHELL, "--plugin", "parametric", "--ballbar", str(export), "--ballbar", CW)
    assert result.exit_code == 0, result.stderr
    assert "read!" not in result.stdout and "G00 X0. Z0. (read!)" in result.stderr


@pytest.mark.parametrize("fault", sorted(_FAULTY_READERS))
def test_a_shop_reader_that_fails_or_makes_nonsense_is_named_with_the_file(run, registered, tmp_path, fault):
    """Whatever a shop's reader does wrong (raises, returns nothing, another type, arrays of other
    lengths, values that are not finite, unsorted angles), the run stops naming its plugin, the
    reader and the file (exit 5): not a compensator's fault, not an internal error, and nothing
    written."""
    from postproc.measure.readers.registry import MeasurementReader

    kind, accepts, read, words = _FAULTY_READERS[fault]

    class Plugin:
        @hookspecs.hookimpl
        def postproc_measurement_readers(self):
            return [MeasurementReader(kind, "faulty", accepts or (lambda path: path.endswith(".shop")),
                                      read or (lambda path, context: None))]

    registered(Plugin())
    export = tmp_path / "export.shop"
    export.write_text("whatever the instrument writes\n")
    target = tmp_path / "out.nc"
    measurements = (["--plugin", "parametric", "--ballbar", str(export), "--ballbar", CW] if kind == "ballbar" else
                    ["--plugin", "omp-feedback", "--probe", str(export)])
    result = run("compensate", HEMISHELL, *measurements, "-o", str(target))
    assert result.exit_code == 5, result.stderr
    assert result.stderr.startswith(f"{export}: error: plugin 'reader-order-0-0': "), result.stderr
    assert words in result.stderr and "internal error" not in result.stderr
    assert not target.exists()


class _HookFails:
    @hookspecs.hookimpl
    def postproc_compensators(self):
        raise ImportError("no module named 'shoplib'")


class _Duplicate:
    @hookspecs.hookimpl
    def postproc_compensators(self):
        class Clash(_Raises):
            name = "ballbar-inverse"

        return [Clash]


class _NotAName:
    @hookspecs.hookimpl
    def postproc_compensators(self):
        class Numbered(_Raises):
            name = 42

        return [Numbered]


@pytest.mark.parametrize("plugin, words", [(_HookFails(), "postproc_compensators failed: ImportError: no module named 'shoplib'"),
                                           (_Duplicate(), "two plugins provide a compensator named 'ballbar-inverse' "
                                                          "(this one and 'ballbar-inverse')"),
                                           (_NotAName(), "not a named Compensator class")])
def test_a_plugin_whose_compensators_cannot_be_listed_is_named(run, registered, plugin, words):
    registered(plugin)
    result = run("compensate", HEMISHELL, "--plugin", "ballbar-inverse", "--ballbar", CCW,
                 "--option", "radius-mapping=relative")
    assert result.exit_code == 5 and result.stdout == ""
    assert result.stderr.startswith("postproc: error: plugin 'reader-order-0-0': ") and words in result.stderr


def _compensator(name: str = "test-shop", **members):
    """A plugin object providing one compensator built from ``members`` (fit does nothing)."""
    cls = type("Shop", (_Raises,), {"name": name, "correct": lambda self, piece: None, **members})

    class Plugin:
        @hookspecs.hookimpl
        def postproc_compensators(self):
            return [cls]

    return Plugin()


def _exits(self, measurements):
    raise SystemExit(0)


@pytest.mark.parametrize("members, words", [
    ({"fit": _exits}, "fit called sys.exit(0)"),
    ({"correct": lambda self, piece: np.array([["a", "b"]] * len(piece.t))}, "returned a correction that is not numbers"),
    ({"prologue": lambda self, inch: "G10 P1 U0.01 W0."}, "prologue returned 'G10 P1 U0.01 W0.', not a list of blocks"),
    ({"prologue": lambda self, inch: [None]}, "prologue returned [None], not a list of blocks"),
])
def test_a_compensator_that_exits_or_returns_what_no_compensator_returns_is_named(run, registered, tmp_path, members,
                                                                                   words):
    """sys.exit(0) in a plugin ended the run with exit 0 and nothing written; an array of text was
    an internal error; a string for the list of opening blocks was read letter by letter."""
    registered(_compensator(**members))
    target = tmp_path / "out.nc"
    result = run("compensate", HEMISHELL, "--plugin", "test-shop", "-o", str(target))
    assert result.exit_code == 5 and not target.exists()
    assert f"plugin 'test-shop': {words}" in result.stderr, result.stderr


def _refuses(kind):
    def correct(self, piece):
        from postproc import diagnostics

        raise getattr(diagnostics, kind)(f"test-shop: the move on line {piece.move.line} is beyond what was measured")

    return correct


@pytest.mark.parametrize("kind, code", [("OptionError", 3), ("SafetyError", 4), ("MeasurementError", 3)])
def test_a_compensators_refusal_of_a_move_names_the_program(run, registered, tmp_path, kind, code):
    """'postproc: error: ballbar-inverse: the arc of line 10 ...' named a line of no file: a
    compensator knows the move's line, the host the program's name, and puts them together."""
    registered(_compensator(correct=_refuses(kind)))
    program = tmp_path / "part.nc"
    program.write_text(open(HEMISHELL).read())
    result = run("compensate", str(program), "--plugin", "test-shop")
    assert result.exit_code == code
    assert result.stderr.startswith(f"{program}: error: test-shop: the move on line "), result.stderr


def test_a_compensators_warning_about_a_move_names_the_program_in_a_batch(run, registered, tmp_path):
    """'postproc: warning: parametric: the move on line 87 leaves the box...' said which line of
    which program? In a batch, none: a warning that names no place, while a program is being
    compensated, is about that program."""
    def correct(self, piece):
        self.context.reporter.warn(f"test-shop: the move on line {piece.move.line} is held")

    registered(_compensator(correct=correct))
    programs = []
    for name in ("a.nc", "b.nc"):
        programs.append(tmp_path / name)
        programs[-1].write_text(open(HEMISHELL).read())
    result = run("compensate", *map(str, programs), "--plugin", "test-shop", "--out-dir", str(tmp_path / "out"))
    assert result.exit_code == 0, result.stderr
    for program in programs:
        assert f"{program}: warning: test-shop: the move on line 9 is held" in result.stderr, result.stderr
    assert "postproc: warning: test-shop" not in result.stderr


def test_the_built_in_radius_refusal_names_the_program(run):
    result = run("compensate", HEMISHELL, "--plugin", "ballbar-inverse", "--ballbar", CCW)
    assert result.exit_code == 3
    assert result.stderr.startswith(f"{HEMISHELL}: error: ballbar-inverse: the arc of line 10 has radius"), result.stderr


def test_what_a_compensator_prints_goes_to_stderr_never_into_the_program(run, registered):
    def fit(self, measurements):
        print("G00 X0. Z0. (fitted!)")

    registered(_compensator(fit=fit))
    result = run("compensate", HEMISHELL, "--plugin", "test-shop")
    assert result.exit_code == 0, result.stderr
    assert "fitted!" not in result.stdout and result.stdout.startswith("%\n")
    assert "G00 X0. Z0. (fitted!)" in result.stderr


@pytest.mark.parametrize("block, why", [
    ("G28 U0.", "moves the machine"), ("G00 X50. Z5.", "moves the machine"), ("G91", "changes the modal state"),
    ("G20", "changes the modal state"), ("M03 S500", "changes the modal state"), ("T0202", "changes the modal state"),
    ("G50 X100. Z50.", "is not a G10 data setting"), ("G54", "is not a G10 data setting"),
    ("G04 X1.", "is not a G10 data setting"), ("#500 = 1.", "is a macro statement"),
    ("G11", "is not a G10 data setting"),
    # a G10 other than a tool offset setting: parameters, tool-life data, work offsets, computed words
    ("G10 L50", "it gives L"), ("G10 L3", "it gives L"), ("G10 L[50]", "it gives L"), ("G10 L#1", "it gives L"),
    ("G10 L2 P1 X0. Z0.", "it gives L"), ("G10 L20 P1 X0.", "it gives L"), ("G10 L1 P1 U0.01", "it gives L"),
    ("G10 P1 U0.01 L50", "it gives L"), ("G10 P1 A5.", "it gives A"), ("G10 P1 U0.01 H1", "it gives H"),
    ("G10 P0 X0. Z0.", "it needs one P"), ("G10 P10000 X1.", "it needs one P"), ("G10 P20001 X1.", "it needs one P"),
    ("G10 P1.5 U0.01", "it needs one P"), ("G10 U0.01 W0.", "it needs one P"), ("G10", "it needs one P"),
    ("G10 P1 P2 U0.01", "address P appears twice"),
    ("G10 P#1 U0.01", "its P is computed"), ("G10 P[1] U0.01", "its P is computed"),
    ("G10 P1 U#5", "its U is computed"), ("G10 P1 U[0.01]", "its U is computed"),
])
def test_an_opening_block_that_would_change_how_the_program_runs_is_refused(run, registered, tmp_path, block, why):
    """A compensator's opening blocks go in before the program's first move: anything but a tool
    offset setting (a move, G91, other units, a new coordinate system, a tool call, a G10 of
    parameters, tool-life data or work offsets, a computed word, a macro variable the program
    may read) would change the whole program behind the user's back."""
    registered(_compensator(prologue=lambda self, inch: [block]))
    target = tmp_path / "out.nc"
    result = run("compensate", HEMISHELL, "--plugin", "test-shop", "-o", str(target))
    assert result.exit_code == 5 and not target.exists()
    assert f"plugin 'test-shop': its opening block {block!r} " in result.stderr and why in result.stderr, result.stderr


@pytest.mark.parametrize("blocks", [["G10 P1 U0.01 W-0.004"], ["(WEAR SET BY SHOP)", "G10 P2 U0. W0.002"],
                                    ["G10 P10001 X-210.5 Z-305.25 R0.4 Q3"], ["G10 P12 X0.01 Y0. Z0.002 C0.01"]])
def test_data_settings_and_comments_open_the_program(run, registered, blocks):
    registered(_compensator(prologue=lambda self, inch: blocks))
    result = run("compensate", HEMISHELL, "--plugin", "test-shop")
    assert result.exit_code == 0, result.stderr
    assert all(f"\n{block}\n" in result.stdout for block in blocks)


def _gain(key="gain"):
    from postproc.compensator import Option

    return Option(key, float, 1.0)


@pytest.mark.parametrize("name, options, words", [
    ("shop bad", lambda: (), "a compensator named 'shop bad': a name is lower-case letters"),
    ("shop.bad", lambda: (), "a compensator named 'shop.bad'"),
    ("Shop", lambda: (), "a compensator named 'Shop'"),
    ("test-shop", lambda: (object(),), "declares an option None"),
    ("test-shop", lambda: (_gain("gain=1"),), "declares an option 'gain=1'"),
    ("test-shop", lambda: (_gain(), _gain()), "declares the option 'gain' twice"),
])
def test_a_compensator_the_command_line_cannot_name_is_refused(run, registered, name, options, words):
    """A name with a space or a dot, or two options of one key, cannot be spelt in --plugin NAME and
    --option NAME.KEY=VALUE: refused when the compensators are listed, naming the plugin."""
    registered(_compensator(name, options=options()))
    result = run("compensate", HEMISHELL, "--plugin", "parametric", "--ballbar", CCW, "--ballbar", CW)
    assert result.exit_code == 5 and result.stdout == ""
    assert "plugin 'reader-order-0-0': " in result.stderr and words in result.stderr, result.stderr


# ---------------------------------------------------------------------- loading only what a run selects


def _fresh(code: str, site: Path | None = None, *args: str) -> subprocess.CompletedProcess:
    """Python started anew (nothing imported yet), with ``site`` on its path if given."""
    env = {**os.environ, "PYTHONPATH": str(site)} if site is not None else None
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, env=env, cwd=REPO)


def test_each_built_in_entry_point_is_named_after_the_compensator_it_provides():
    """What lets a run load only the compensators it names: an unloaded built-in entry point's
    name is the name of its compensator (or it provides none, as the readers' does)."""
    manager = registry.manager()
    for plugin, dist in manager.list_plugin_distinfo():
        if dist.project_name != registry.OWN:
            continue
        name = manager.get_name(plugin)
        provided = [cls.name for impl in manager.hook.postproc_compensators.get_hookimpls()
                    if impl.plugin is plugin for cls in impl.function() or ()]
        assert provided in ([], [name]), (name, provided)


def test_a_run_loads_only_the_built_in_compensators_it_selects():
    result = _fresh("import sys; from postproc.compensate import registry as plugins; "
                    "print([item.cls.name for item in plugins.select(['tool-offset', 'parametric'])]); "
                    "print(sorted(m for m in sys.modules if m.startswith('postproc_plugins.')))")
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines() == ["['tool-offset', 'parametric']",
                                          "['postproc_plugins.parametric', 'postproc_plugins.tool_offset']"]


def _clashing_distribution(site: Path, provides: str) -> None:
    """A distribution installed as pip leaves one (a dist-info beside its module) whose entry
    point is named otherwise than the compensator it provides."""
    (site / "clash_plugin.py").write_text(
        "from postproc.compensator import Compensator\nfrom postproc.hookspecs import hookimpl\n\n\n"
        f"class Clash(Compensator):\n    name = {provides!r}\n\n\n"
        "@hookimpl\ndef postproc_compensators():\n    return [Clash]\n")
    info = site / "clash_plugin-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: clash-plugin\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text("[postproc]\nclash = clash_plugin\n")


def _undated(model: dict) -> dict:
    return {key: value for key, value in model.items() if key not in ("created", "measured", "sha256")}


def test_what_a_plugin_prints_on_import_in_a_hook_or_when_made_goes_to_stderr(tmp_path):
    """Plugin code runs when its module is imported, when its hook is called and when its
    compensator is made, not only in the calls the pipeline guards: stdout carries the program
    (or the model) alone, whatever the plugin prints on the way."""
    (tmp_path / "chatty_plugin.py").write_text(
        "from postproc.compensator import Compensator\nfrom postproc.hookspecs import hookimpl\n"
        "print('G00 X0. (IMPORTED)')\n\n\n"
        "class Chatty(Compensator):\n    name = 'chatty'\n\n"
        "    def __init__(self, context, settings=None):\n        print('G00 X0. (MADE)')\n"
        "        super().__init__(context, settings)\n\n"
        "    def fit(self, measurements):\n        print('G00 X0. (FITTED)')\n\n"
        "    def correct(self, piece):\n        return None\n\n"
        "    def model(self):\n        return {}\n\n"
        "    def load(self, model):\n        print('G00 X0. (LOADED)')\n\n\n"
        "@hookimpl\ndef postproc_compensators():\n    print('G00 X0. (LISTED)')\n    return [Chatty]\n")
    info = tmp_path / "chatty_plugin-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: chatty-plugin\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text("[postproc]\nchatty = chatty_plugin\n")
    main = "from postproc.cli.main import main; main()"
    written, model = tmp_path / "written.nc", tmp_path / "model.json"
    for args, target in [(("compensate", HEMISHELL, "--plugin", "chatty"), written),
                         (("fit", "--plugin", "chatty"), model)]:
        to_file = _fresh(main, tmp_path, *args, "-o", str(target))
        assert to_file.returncode == 0, to_file.stderr
        to_stdout = _fresh(main, tmp_path, *args, "-o", "-")
        assert to_stdout.returncode == 0, to_stdout.stderr
        if target is written:
            assert to_stdout.stdout == target.read_text()
        else:  # the model alone, as written to a file but for when it was made
            assert _undated(json.loads(to_stdout.stdout)) == _undated(json.loads(target.read_text()))
        for word in ("IMPORTED", "LISTED", "MADE"):
            assert f"G00 X0. ({word})" in to_stdout.stderr
    loaded = _fresh(main, tmp_path, "compensate", HEMISHELL, "--model", str(model), "-o", "-")
    assert loaded.returncode == 0, loaded.stderr
    assert loaded.stdout.startswith("%\n") and "(LOADED)" not in loaded.stdout and "(MADE)" not in loaded.stdout
    assert "G00 X0. (LOADED)" in loaded.stderr


@pytest.mark.parametrize("provides", ["iterative", "parametric"])
def test_a_compensator_name_taken_twice_is_caught_though_only_one_is_selected(tmp_path, provides):
    """A third-party compensator named like a built-in one: an error whether the built-in one is
    selected (both load) or not (its entry point's name gives it away, and everything loads)."""
    _clashing_distribution(tmp_path, provides)
    result = _fresh("from postproc.cli.main import main; main()", tmp_path, "compensate", HEMISHELL, "--plugin",
                    "parametric", "--ballbar", CCW, "--ballbar", CW)
    assert result.returncode == 5 and result.stdout == ""
    assert f"two plugins provide a compensator named {provides!r}" in result.stderr


# ---------------------------------------------------------------------- finding the entry points without importlib.metadata

_SELECTED = ("import sys; from postproc.compensate import registry as plugins; "
             "[item] = plugins.select(['parametric']); print(item.version, item.distribution); "
             "print('importlib.metadata' in sys.modules)")


def test_the_built_in_entry_points_are_found_without_reading_every_distribution():
    """The version and distribution a saved model is checked against are those importlib.metadata
    gives; the module that reads every installed distribution is not imported to find them."""
    from importlib.metadata import version

    result = _fresh(_SELECTED)
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines() == [f"{version('postproc')} postproc", "False"]


def test_another_distribution_without_postproc_entry_points_changes_nothing(tmp_path):
    info = tmp_path / "other_tool-2.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: other-tool\nVersion: 2.0\n")
    (info / "entry_points.txt").write_text("[console_scripts]\nother = other_tool:main\n")
    result = _fresh(_SELECTED, tmp_path)
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines()[1] == "False"


@pytest.mark.parametrize("entry_points", ["[postproc]\nshop = shop_plugin\n", "[console_scripts]\nbroken line\n"])
def test_another_distributions_postproc_entry_point_or_a_broken_file_is_read_by_importlib_metadata(tmp_path,
                                                                                                   entry_points):
    """What the direct way cannot vouch for goes the way it always went: a third-party plugin is
    loaded (its compensator's name checked against the built-in ones), a broken entry_points.txt
    fails as importlib.metadata fails on it."""
    info = tmp_path / "shop_plugin-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: shop-plugin\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text(entry_points)
    (tmp_path / "shop_plugin.py").write_text("")
    result = _fresh(_SELECTED, tmp_path)
    if "broken" in entry_points:
        assert result.returncode == 1 and "TypeError" in result.stderr
    else:
        assert result.returncode == 0, result.stderr
        assert result.stdout.splitlines()[1] == "True"


_LINES = st.sampled_from(["[postproc]", "[ postproc ]", "[[postproc]]", "[console_scripts]", "[postproc.x]",
                          "# [postproc]", "; note", "", "   ", "a = m:f", "a=m", " b =  m.n:f.g [x] ", "c = ",
                          "= m", "d = a = b", "no equals sign", "parametric = postproc_plugins.parametric"])


@given(st.lists(_LINES, max_size=12))
def test_entry_points_are_read_as_importlib_metadata_reads_them(tmp_path_factory, lines):
    """Any entry_points.txt: the same entry points of the group (the first of each name, the
    one that loads), or None where importlib.metadata refuses the file."""
    from importlib.metadata import PathDistribution

    info = tmp_path_factory.mktemp("site") / "any-1.0.dist-info"
    info.mkdir()
    text = "\n".join(lines) + "\n"
    (info / "entry_points.txt").write_text(text)
    try:
        points = PathDistribution(info).entry_points.select(group="postproc")
    except (TypeError, ValueError):
        assert registry._group(text) is None
        return
    expected: dict[str, str] = {}
    for point in points:
        expected.setdefault(point.name, point.value)
    assert registry._group(text) == expected
