"""A FANUC control, emulated: a probing program run to the printout its DPRNT statements make."""

from __future__ import annotations

import re

import numpy as np

from postproc.interpret.program import interpret_source
from postproc.syntax.macro import Assignment, IfThen, Output, evaluate
from postproc.syntax.source import Source


class Alarm(Exception):
    pass


def fanuc_number(value: float, whole: int, decimals: int, padded: bool) -> str:
    """DPRNT's #n[ab]: the sign, the integer part in ``whole`` places (leading zeros as spaces when
    ``padded``, not printed otherwise), the fraction rounded to ``decimals`` places."""
    text = f"{abs(value):.{decimals}f}"
    integer, _, fraction = text.partition(".")
    sign = "-" if value < 0 and float(text) != 0 else ""
    if padded:
        integer = "" if integer == "0" and decimals else integer
        integer = integer.rjust(whole)
    body = integer + ("." + fraction if decimals else "")
    return sign + body if not padded else (sign + body.lstrip()).rjust(len(body) + len(sign))


def dprnt(text: str, variables: dict, padded: bool) -> str:
    body = text[text.index("[") + 1:-1]
    out = []
    for match in re.finditer(r"#(\d+)\[(\d)(\d)\]|(\*)|([^#*])", body):
        if match.group(1):
            out.append(fanuc_number(variables[int(match.group(1))], int(match.group(2)), int(match.group(3)), padded))
        else:
            out.append(" " if match.group(4) else match.group(5))
    return "".join(out)


def skips(text: str) -> list[tuple[np.ndarray, np.ndarray, str]]:
    """Each G31 of a program: its start and end (radius mm) and the record it prints."""
    found = []
    with Source.from_text(text, "probe.nc") as source:
        for step in interpret_source(source):
            codes = dict(step.block.codes)
            if codes.get("G") == "31":
                move = step.moves[0]
                found.append([np.array([move.x0, move.z0]), np.array([float(codes["X"]) / 2, float(codes["Z"])]), None])
            statement = step.block.statement
            if isinstance(statement, Output) and statement.text.startswith("DPRNT[") and found and found[-1][2] is None:
                found[-1][2] = statement.text.split("*")[0][6:] + ("" if "POINT" in statement.text else
                                                                   " " + statement.text.split("*")[1])
    return [tuple(item) for item in found]


def run_on_control(text: str, latched: list, padded: bool = True, eol: str = "\r\n") -> str:
    """The printout of a probing program whose skip moves latch at ``latched`` (radius mm; None: no touch)."""
    variables: dict[int, float] = {}
    lines: list[str] = []
    touch = 0
    with Source.from_text(text, "probe.nc") as source:
        for step in interpret_source(source):
            statement = step.block.statement
            if dict(step.block.codes).get("G") == "31":
                codes = dict(step.block.codes)
                where = latched[touch]
                x, z = (float(codes["X"]), float(codes["Z"])) if where is None else (2 * where[0], where[1])
                variables[5061], variables[5062] = round(x, 4), round(z, 4)
                touch += 1
            elif isinstance(statement, Assignment):
                variables[statement.target.index] = evaluate(statement.value, variables)
            elif isinstance(statement, IfThen):
                if evaluate(statement.condition, variables):
                    raise Alarm(step.block.text)
            elif isinstance(statement, Output):
                if statement.text == "POPEN":
                    lines.append("\x12%")
                elif statement.text == "PCLOS":
                    lines.append("\x14%")
                else:
                    lines.append(dprnt(statement.text, variables, padded))
    return eol.join(lines) + eol


_FLOW = re.compile(r"^(?:N(?P<label>\d+)\s*)?(?:"
                   r"#(?P<var>\d+)=(?P<value>.+)"
                   r"|IF\[#(?P<test>\d+)(?P<op>LT|GE)(?P<limit>\d+)\]GOTO(?P<branch>\d+)"
                   r"|GOTO(?P<goto>#?\d+)"
                   r"|M99P(?P<back>#?\d+)|P(?P<before>#?\d+)M99"
                   r"|WHILE\[#(?P<whiled>\d+)LT(?P<bound>\d+)\]DO(?P<do>\d)"
                   r"|END(?P<end>\d))$")


def executed(text: str, limit: int = 10000) -> str:
    """The blocks of a main program in the order a control runs them, its jumps taken: GOTO n,
    GOTO #v, IF [#v LT|GE n] GOTO n, M99 Pn / P#v, in either order (in a main program: a jump to block n), WHILE
    [#v LT n] DO m ... END m, and #v = #w + k or #v = k. Every other line is copied; the flow
    statements are left out, so the result is the straight program the machine cuts."""
    lines = text.splitlines()
    labels = {int(m.group(1)): i for i, line in enumerate(lines) if (m := re.match(r"N(\d+)", line))}
    variables: dict[int, float] = {}
    out: list[str] = []
    pc = 0

    def value(word: str) -> int:
        return int(variables[int(word[1:])]) if word.startswith("#") else int(word)

    while pc < len(lines):
        limit -= 1
        if limit < 0:
            raise Alarm("the program does not end")
        line = lines[pc]
        match = _FLOW.match(line.replace(" ", ""))
        pc += 1
        if match is None:
            out.append(line)
        elif match["var"]:
            target, _, step = match["value"].partition("+")
            variables[int(match["var"])] = (variables.get(int(target[1:]), 0.0) if target.startswith("#")
                                            else float(target)) + (float(step) if step else 0.0)
        elif match["test"]:
            current = variables.get(int(match["test"]), 0.0)
            if (current < int(match["limit"])) == (match["op"] == "LT"):
                pc = labels[int(match["branch"])]
        elif match["goto"] or match["back"] or match["before"]:
            pc = labels[value(match["goto"] or match["back"] or match["before"])]
        elif match["whiled"]:
            if not variables.get(int(match["whiled"]), 0.0) < int(match["bound"]):
                pc = next(i for i in range(pc, len(lines)) if lines[i].replace(" ", "") == f"END{match['do']}") + 1
        elif match["end"]:
            pc = next(i for i in range(pc - 1, -1, -1) if lines[i].replace(" ", "").endswith(f"DO{match['end']}"))
    return "\n".join(out) + "\n"
