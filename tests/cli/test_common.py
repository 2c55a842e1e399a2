"""Every number any command takes, and every number a compensator's --option takes: a value that
is not a number, or outside the range where the option means something (zero or negative for a
length, a feed, a count), is a wrong option value: exit 3, one message that names the option,
the value and the range, nothing on stdout (docs/formats.md §7.3). Tested as data: one row per
option and bad value; and every numeric option the command line declares has its row."""

from __future__ import annotations

import click
import pytest

from support import SAMPLES
from postproc.cli.common import Number
from postproc.cli.main import main

HEMISHELL = str(SAMPLES / "programs" / "hemishell.nc")
CCW, CW = (str(SAMPLES / "ballbar" / f"v40r-100-{d}.csv") for d in ("ccw", "cw"))
PROBE = str(SAMPLES / "probe" / "hemishell-pass1.csv")
TRACES = ["--ballbar", CCW, "--ballbar", CW]

#: What each command needs besides the option under test (the option comes right after the command's name).
COMMANDS = {
    "compensate": [HEMISHELL, "--plugin", "parametric", *TRACES],
    "path": [HEMISHELL],
    "report": [HEMISHELL, "--plugin", "parametric", *TRACES, "-o", "r.html"],
    "ballbar": [CCW, CW],
    "inspect": [HEMISHELL, "--probe", PROBE, "--band", "0.01"],
    "probe-import": [PROBE],
    "probe-program": [HEMISHELL],
    "artifact-program": ["--center-x", "0", "--center-z", "0", "--artifact-radius", "10"],
    "artifact-find": ["round.csv", "--artifact-radius", "10"],
    "import-trace": ["trace.txt", "--radius", "100", "--direction", "ccw"],
    "simulate ballbar": [],
    "simulate probe": [HEMISHELL],
    "simulate cut": [HEMISHELL],
    "simulate calibrate": [],
    "simulate inspect": [HEMISHELL],
}

POSITIVE = "must be positive"
COUNT = "must be a whole number, 1 or more"

#: (command, option, value, exit code, the message after "postproc: error: OPTION VALUE: ").
TABLE = [
    ("compensate", "--tolerance", "0", 3, POSITIVE),
    ("compensate", "--tolerance", "-0.001", 3, POSITIVE),
    ("compensate", "--max-correction", "0", 3, POSITIVE),
    ("compensate", "--jobs", "0", 3, COUNT),
    ("compensate", "--jobs", "-2", 3, COUNT),
    ("compensate", "--jobs", "1.5", 3, "not a whole number"),
    ("compensate", "--jobs", "two", 3, "not a whole number"),
    ("path", "--tolerance", "0", 3, POSITIVE),
    ("path", "--tolerance", "-1", 3, POSITIVE),
    ("report", "--tolerance", "0", 3, POSITIVE),
    ("report", "--band", "0", 3, POSITIVE),
    ("ballbar", "--averaging", "0", 3, COUNT),
    ("ballbar", "--averaging", "-1", 3, COUNT),
    ("ballbar", "--averaging", "six", 3, "not a whole number"),
    ("ballbar", "--max-deviation", "0", 3, POSITIVE),
    ("ballbar", "--max-deviation", "-1", 3, POSITIVE),
    ("inspect", "--band", "0", 3, POSITIVE),
    ("inspect", "--from-line", "0", 3, COUNT),
    ("inspect", "--to-line", "-1", 3, COUNT),
    ("probe-import", "--stylus-radius", "0", 3, POSITIVE),
    ("probe-import", "--repeatability", "-0.003", 3, POSITIVE),
    ("probe-program", "--points", "0", 3, COUNT),
    ("probe-program", "--points", "x", 3, "not a whole number"),
    ("probe-program", "--per-feature", "0", 3, COUNT),
    ("probe-program", "--inset", "-1", 3, "must be 0 or more"),
    ("probe-program", "--stylus-radius", "0", 3, POSITIVE),
    ("probe-program", "--clearance", "0", 3, POSITIVE),
    ("probe-program", "--overtravel", "-1", 3, POSITIVE),
    ("probe-program", "--feed", "0", 3, POSITIVE),
    ("probe-program", "--travel-feed", "-100", 3, POSITIVE),
    ("probe-program", "--program-number", "0", 3, "a FANUC program number is 1 to 9999"),
    ("probe-program", "--program-number", "10000", 3, "a FANUC program number is 1 to 9999"),
    ("probe-program", "--from-line", "0", 3, COUNT),
    ("probe-program", "--to-line", "0", 3, COUNT),
    ("artifact-program", "--artifact-radius", "0", 3, POSITIVE),
    ("artifact-program", "--stylus-radius", "-1", 3, POSITIVE),
    ("artifact-program", "--clearance", "0", 3, POSITIVE),
    ("artifact-program", "--overtravel", "0", 3, POSITIVE),
    ("artifact-program", "--feed", "0", 3, POSITIVE),
    ("artifact-program", "--travel-feed", "0", 3, POSITIVE),
    ("artifact-program", "--program-number", "-1", 3, "a FANUC program number is 1 to 9999"),
    ("artifact-find", "--artifact-radius", "0", 3, POSITIVE),
    ("artifact-find", "--tolerance", "0", 3, POSITIVE),
    ("artifact-find", "--tolerance", "abc", 3, "not a number"),
    ("import-trace", "--radius", "0", 3, POSITIVE),
    ("import-trace", "--feed", "0", 3, POSITIVE),
    ("import-trace", "--feed", "-1", 3, POSITIVE),
    ("import-trace", "--capture-arc", "0", 3, "must be above 0 and at most 360"),
    ("import-trace", "--capture-arc", "400", 3, "must be above 0 and at most 360"),
    ("simulate ballbar", "--radius", "0", 3, POSITIVE),
    ("simulate ballbar", "--feed", "0", 3, POSITIVE),
    ("simulate ballbar", "--capture-arc", "-90", 3, "must be above 0 and at most 360"),
    ("simulate ballbar", "--overtravel", "-1", 3, "must be from 0 to 180"),
    ("simulate ballbar", "--seed", "-1", 3, "must be a whole number, 0 or more"),
    ("simulate ballbar", "--seed", "x", 3, "not a whole number"),
    ("simulate probe", "--points", "1", 3, "must be a whole number, 2 or more"),
    ("simulate probe", "--inset", "-1", 3, "must be 0 or more"),
    ("simulate probe", "--per-feature", "0", 3, COUNT),
    ("simulate probe", "--from-line", "0", 3, COUNT),
    ("simulate probe", "--to-line", "0", 3, COUNT),
    ("simulate probe", "--seed", "-1", 3, "must be a whole number, 0 or more"),
    ("simulate cut", "--from-line", "0", 3, COUNT),
    ("simulate cut", "--to-line", "-3", 3, COUNT),
    ("simulate calibrate", "--radius", "-1", 3, POSITIVE),
    ("simulate calibrate", "--step-deg", "0", 3, POSITIVE),
    ("simulate calibrate", "--seed", "-5", 3, "must be a whole number, 0 or more"),
    ("simulate inspect", "--points", "0", 3, "must be a whole number, 2 or more"),
    ("simulate inspect", "--inset", "-0.5", 3, "must be 0 or more"),
    ("simulate inspect", "--inset", "x", 3, "not a number"),
    ("simulate inspect", "--seed", "-1", 3, "must be a whole number, 0 or more"),
    ("simulate inspect", "--from-line", "-1", 3, COUNT),
    ("simulate inspect", "--to-line", "0", 3, COUNT),
]


@pytest.mark.parametrize("command, option, value, code, message", TABLE,
                         ids=[f"{c} {o} {v}" for c, o, v, _, _ in TABLE])
def test_a_number_outside_its_range_is_a_wrong_option_value(run, tmp_path, monkeypatch, command, option, value, code,
                                                             message):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "trace.txt").write_text("deviation\n" + "0.001\n" * 400)
    (tmp_path / "round.csv").write_text("")
    given = COMMANDS[command]
    if option in given:  # the command's own value for it goes: the bad one is the only one
        at = given.index(option)
        given = given[:at] + given[at + 2:]
    result = run(*command.split(), option, value, *given)
    assert (result.exit_code, result.stdout_bytes) == (code, b"")
    assert result.stderr.splitlines()[0] == f"postproc: error: {option} {value}: {message}"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["round.csv", "trace.txt"]  # nothing written


#: A compensator's numeric --option: (plugin, its measurements, KEY=VALUE, the message after it).
PLUGIN_OPTIONS = [
    ("iterative", TRACES, "selective=0", POSITIVE),
    ("iterative", TRACES, "selective=-0.001", POSITIVE),
    ("iterative", TRACES, "max-gap=0", POSITIVE),
    ("ballbar-inverse", TRACES, "max-gap=-5", POSITIVE),
    ("parametric", TRACES, "max-uncertainty=0", POSITIVE),
    ("error-map", TRACES, "max-uncertainty=-0.01", POSITIVE),
    ("error-map", TRACES, "residual=0", POSITIVE),
    ("tool-offset", ["--probe", PROBE], "offset=0", COUNT),
    ("tool-offset", ["--probe", PROBE], "offset=-3", COUNT),
    ("tool-offset", ["--probe", PROBE], "offset=1.5", "not a whole number"),
    ("tool-offset", ["--probe", PROBE], "residual=0", POSITIVE),
    ("tool-offset", ["--probe", PROBE], "residual=x", "not a number"),
]


@pytest.mark.parametrize("plugin, measurements, setting, message", PLUGIN_OPTIONS,
                         ids=[f"{p} {s}" for p, _, s, _ in PLUGIN_OPTIONS])
def test_a_compensators_number_outside_its_range_is_refused_as_the_command_lines_are(run, plugin, measurements,
                                                                                    setting, message):
    result = run("compensate", HEMISHELL, "--plugin", plugin, *measurements, "--option", setting)
    assert (result.exit_code, result.stdout_bytes) == (3, b"")
    assert result.stderr.splitlines()[0] == f"postproc: error: --option {plugin}.{setting}: {message}"


def _numeric_options(command: click.Command, path: str):
    if isinstance(command, click.Group):
        for name, sub in command.commands.items():
            yield from _numeric_options(sub, f"{path} {name}".strip())
        return
    for param in command.params:
        if isinstance(param, click.Option) and not param.is_flag and (
                isinstance(param.type, (Number, click.types._NumberParamTypeBase))):
            yield path, max(param.opts, key=len), param.type


def test_every_numeric_option_is_a_number_with_its_range_and_has_a_row():
    """A new numeric option declared with click's own int, float or IntRange would be refused
    with a usage error (exit 2), or not at all: each is a Number, and each is in the table."""
    context = click.Context(main)
    commands = {name: main.get_command(context, name) for name in main.list_commands(context)}
    found = [(path, option, kind) for name, command in commands.items()
             for path, option, kind in _numeric_options(command, name)]
    assert found
    assert [(path, option) for path, option, kind in found if not isinstance(kind, Number)] == []
    ranged = {(path, option) for path, option, kind in found if any(v is not None for v in kind.range.values())}
    tabled = {(command, option) for command, option, _, _, _ in TABLE}
    assert ranged - tabled == set()
