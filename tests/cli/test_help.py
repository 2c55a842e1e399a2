"""Help that teaches (postproc.cli.main, postproc.cli): every command's ``--help`` has an
Examples section whose commands parse, every option says what it does, the names and metavars
agree across commands, and the shell completes compensator names and their options.

The command tree is walked, so a new command or option cannot forget any of it.
"""

from __future__ import annotations

import re
import shlex

import click
import pytest

from support import REPO
from postproc.cli.main import main

GENERIC = re.compile(r"^(INTEGER|FLOAT|NUMBER|INTEGER RANGE|FLOAT RANGE|PATH|FILENAME|OUTPUT|L)$")


def _commands(command: click.Command = main, path: tuple[str, ...] = ("postproc",), parent=None):
    """(path, command, context) of the group and of every command and subcommand under it."""
    context = click.Context(command, info_name=path[-1], parent=parent)
    yield path, command, context
    if isinstance(command, click.Group):
        for name in command.list_commands(context):
            yield from _commands(command.get_command(context, name), path + (name,), context)


COMMANDS = [(" ".join(path), command, context) for path, command, context in _commands()]
IDS = [name for name, _, _ in COMMANDS]


def _examples(command: click.Command) -> list[str]:
    epilog = command.epilog or ""
    return [line.strip() for line in epilog.splitlines() if line.strip().startswith("postproc ")]


@pytest.mark.parametrize("name, command, context", COMMANDS, ids=IDS)
def test_every_command_help_has_examples(name, command, context):
    text = command.get_help(context)
    assert re.search(r"\n +Examples:\n", text), name
    assert _examples(command), f"{name}: no example runs postproc"


@pytest.mark.parametrize("name, command, context", COMMANDS, ids=IDS)
def test_every_option_is_described_with_a_meaningful_metavar(name, command, context):
    for param in command.params:
        if not isinstance(param, click.Option):
            continue
        assert param.help, f"{name} {param.opts[-1]}: no help"
        if not param.is_flag and not isinstance(param.type, click.Choice):
            assert param.metavar and not GENERIC.match(param.metavar), f"{name} {param.opts[-1]}: {param.metavar}"


def test_one_option_name_has_one_metavar_everywhere():
    """--output FILE, --jobs N, --from-line N, --machine FILE...: the same in every command."""
    seen: dict[str, set[str]] = {}
    for _, command, context in COMMANDS:
        for param in command.params:
            if isinstance(param, click.Option) and not param.is_flag and not isinstance(param.type, click.Choice):
                seen.setdefault(param.opts[-1], set()).add(param.make_metavar(context))
    # --overtravel is an arc past a ballbar capture (DEG) and a distance past a probe touch (MM): a unit each
    differing = {name: metavars for name, metavars in seen.items() if len(metavars) > 1 and name != "--overtravel"}
    assert not differing, sorted(differing.items())
    assert seen["--output"] == {"FILE"} and seen["--from-line"] == {"N"} and seen["--jobs"] == {"N"}


@pytest.mark.parametrize("example", [e for _, command, _ in COMMANDS for e in _examples(command)])
def test_every_example_in_help_parses(example):
    """The command line of each example is read by click as the user would type it: names,
    values and types (numbers, choices) all accepted."""
    args = shlex.split(example.replace("*.nc", "a.nc b.nc").split(" > ")[0])[1:]
    command, context, parent = main, None, None
    while True:
        context = command.make_context(command.name or "postproc", args, parent=parent, resilient_parsing=False)
        if not isinstance(command, click.Group):
            break
        name, command, args = command.resolve_command(context, [*context._protected_args, *context.args])
        assert command is not None, example
        parent = context
    assert context.params is not None


def test_ballbar_takes_its_traces_as_arguments_or_as_fit_takes_them(run):
    from support import SAMPLES

    ccw, cw = str(SAMPLES / "ballbar/v40r-100-ccw.csv"), str(SAMPLES / "ballbar/v40r-100-cw.csv")
    positional = run("ballbar", ccw, cw, "--json")
    as_options = run("ballbar", "--ballbar", ccw, "--ballbar", cw, "--json")
    mixed = run("ballbar", ccw, "--ballbar", cw, "--json")
    assert positional.exit_code == as_options.exit_code == mixed.exit_code == 0, positional.stderr
    assert positional.stdout == as_options.stdout == mixed.stdout
    none = run("ballbar")
    assert none.exit_code == 2 and "no trace was given" in none.stderr and none.stdout == ""


def _complete(args: str, incomplete: str) -> list[str]:
    from click.shell_completion import ShellComplete

    completer = ShellComplete(main, {}, "postproc", "_POSTPROC_COMPLETE")
    return [item.value for item in completer.get_completions(shlex.split(args), incomplete)]


@pytest.mark.parametrize("command", ["compensate", "fit", "path --plot p.png", "report"])
def test_plugin_names_are_completed(command):
    from postproc.compensate.registry import compensators

    installed = sorted(compensators())
    assert _complete(f"{command} --plugin", "") == installed
    assert _complete(f"{command} --plugin", "para") == ["parametric"]


def test_compensator_options_are_completed():
    found = _complete("compensate --plugin parametric --option", "parametric.")
    assert found and all(item.startswith("parametric.") and item.endswith("=") for item in found)
    assert "parametric.extrapolate=" in found


def test_the_shell_completion_script_is_generated(tmp_path):
    import os
    import subprocess
    import sys

    result = subprocess.run([sys.executable, "-m", "postproc"],
                            env={**os.environ, "_POSTPROC_COMPLETE": "bash_source"}, capture_output=True, text=True,
                            timeout=60)
    assert result.returncode == 0 and "_postproc_completion" in result.stdout
    words = subprocess.run([sys.executable, "-m", "postproc"],
                           env={**os.environ, "_POSTPROC_COMPLETE": "bash_complete",
                                "COMP_WORDS": "postproc compensate --plugin par", "COMP_CWORD": "3"},
                           capture_output=True, text=True, timeout=60)
    assert "plain,parametric" in words.stdout.splitlines()


def _runnable(example: str) -> bool:
    """An example that writes no file and reads only the repository's samples."""
    words = shlex.split(example)
    files = [word for word in words if "." in word and not word.startswith("-")]
    return " -o " not in example and ">" not in example and all((REPO / word).is_file() for word in files)


@pytest.mark.parametrize("example", [e for _, command, _ in COMMANDS for e in _examples(command) if _runnable(e)])
def test_the_examples_on_the_samples_run(example, run, monkeypatch):
    monkeypatch.chdir(REPO)
    result = run(*shlex.split(example)[1:])
    assert result.exit_code == 0, result.stderr
    assert result.stdout


@pytest.mark.parametrize("selected", [["parametric"], ["error-map"], ["iterative"], ["error-map", "parametric"],
                                      ["ballbar-inverse", "omp-feedback", "tool-offset"]])
def test_option_completion_offers_the_selected_compensators_keys_alone(selected):
    """After ``--plugin X`` only X's keys (qualified, and alone where no other selected one takes the key);
    before any ``--plugin``, every installed compensator's."""
    from postproc.compensate.registry import compensators

    found = compensators()
    plugins = " ".join(f"--plugin {name}" for name in selected)
    offered = _complete(f"compensate {plugins} --option", "")
    declared = {name: [option.key for option in found[name].cls.options] for name in selected}
    qualified = [f"{name}.{key}=" for name in selected for key in declared[name]]
    counts = {}
    for keys in declared.values():
        for key in keys:
            counts[key] = counts.get(key, 0) + 1
    assert offered == qualified + [f"{key}=" for key, count in counts.items() if count == 1]
    for other in set(found) - set(selected):
        assert not any(item.startswith(f"{other}.") for item in offered), other
    everything = _complete("compensate --option", "")
    assert everything == [f"{name}.{option.key}=" for name, item in sorted(found.items()) for option in item.cls.options]
