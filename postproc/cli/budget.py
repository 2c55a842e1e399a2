"""``postproc budget FILE.toml [--json]``: combine an error budget (docs/methods.md §11).

Per axis: the PV sum, the RSS of the RMS values and their average, for each group of sources
and for all of them, as a table in micrometres on stdout, or with ``--json`` one JSON object in
millimetres (``total``, ``groups``, ``sources``, per axis ``pv_mm``, ``rms_mm``, ``estimate_mm``).
Errors are raised as PostprocError for the command line to report.
"""

from __future__ import annotations

import json

import click

from ..measure.budget import Budget, Total, read_budget
from .common import examples


@click.command("budget", epilog=examples(
    "postproc budget samples/budget/v40r-budget.toml",
    "postproc budget lathe3-budget.toml --json > budget.json"))
@click.argument("file", metavar="FILE.toml")
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object instead of the table.")
def command(file, as_json):
    """Combine an error budget: per axis PV sum, RSS of RMS and their average."""
    budget = read_budget(file)
    if as_json:
        click.echo(json.dumps(budget.as_dict(), indent=2, allow_nan=False))
    else:
        click.echo(report(budget))


def _cells(values: dict[str, float], axes) -> str:
    """Micrometres, one column per axis; a dash where a source does not act on the axis."""
    return "".join(f"{values[axis] * 1000:>9.3f}" if axis in values else f"{'-':>9}" for axis in axes)


def report(budget: Budget) -> str:
    """The table for people, in micrometres."""
    axes = budget.axes
    head = "".join(f"{axis:>9}" for axis in axes)
    width = max([len(s.name) for s in budget.sources] + [len(g) for g in budget.groups] + [12])
    lines = [f"error budget: {budget.name} ({budget.path})",
             f"Gaussian sources: PV = {budget.gaussian_sigmas:g} sigma; uniform RMS = PV/(2 sqrt 3); "
             "sinusoidal RMS = PV/(2 sqrt 2)",
             "",
             f"{'source':<{width}}  {'distribution':<12}{'PV (um)':>{9 * len(axes)}}{'RMS (um)':>{9 * len(axes)}}",
             f"{'':<{width}}  {'':<12}{head}{head}"]
    for group in budget.groups:
        for s in (s for s in budget.sources if s.group == group):
            lines.append(f"{s.name:<{width}}  {s.distribution:<12}{_cells(s.pv, axes)}{_cells(s.rms, axes)}")
    lines += ["",
              f"{'':<{width}}  {'PV sum (um)':>{9 * len(axes)}}{'RSS of RMS (um)':>{9 * len(axes)}}"
              f"{'(PV+RMS)/2 (um)':>{9 * len(axes)}}",
              f"{'':<{width}}  {head}{head}{head}"]
    rows: list[tuple[str, Total]] = [(group, budget.total(group)) for group in budget.groups]
    rows.append(("total", budget.total()))
    for name, total in rows:
        cells = _cells(total.pv, axes) + _cells(total.rms, axes) + _cells(total.estimate, axes)
        lines.append(f"{name:<{width}}  {cells}")
    return "\n".join(lines)
