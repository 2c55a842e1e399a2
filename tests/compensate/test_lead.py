"""Where the provenance block goes: after the opening tape mark and the program number, before
anything else, whatever of them a program has (formats.md §12)."""

from __future__ import annotations

import pytest

from postproc.compensate.lead import Lead

BODY = "G18 G21 G99\nG00 X20. Z2.\nG01 Z-10. F0.1\nG00 X100. Z50.\nM30\n"
#: longer than the lines written to the output a chunk at a time (compensate.progress.EVERY)
LONG = "G18 G21 G99\n" + "G00 X20. Z2.\nG01 Z-10. F0.1\n" * 1500 + "M30\n"

# (program, how many of its first lines come before the header)
SHAPES = [
    ("%\nO1234 (CAM FAILED)\n%\n", 2),  # an empty program: the closing % comes after the header
    ("%\n%\n", 1),  # only tape marks
    ("%\n" + BODY + "%\n", 1),  # no program number
    ("O1000\n" + BODY, 1),  # no tape mark
    (BODY, 0),  # neither
    ("%O1000(NAME)\nO1000\n" + BODY + "%\n", 2),  # a program number on the % line
    ("\ufeff%\n\nO1000 (PART)\n\n" + BODY + "%\n", 4),  # a byte order mark, blank lines
    ("%\nO1\n%\nO2\n" + BODY, 2),  # text after the closing %
    ("O1\nO2\n" + BODY, 1),  # a second program number starts another program
    ("<PART_1>\n(CAM NOTE)\n" + BODY, 1),  # a comment is no part of the lead
    ("%\nO1000\n" + LONG + "%\n", 2),  # a program of several chunks
]


@pytest.mark.parametrize("program, lead", SHAPES)
def test_the_lead_is_the_opening_tape_mark_and_program_number(program, lead):
    taker = Lead()
    lines = program.splitlines(keepends=True)
    taken = [line for line in lines if taker.takes(line)]
    assert taken == lines[:lead]


@pytest.mark.parametrize("program, lead", SHAPES)
def test_compensate_writes_the_header_after_the_lead_and_nothing_else(run, tmp_path, program, lead):
    trace = tmp_path / "ccw.csv"
    rows = "".join(f"{a},0.005\n" for a in range(0, 360, 2))
    trace.write_text("# postproc ballbar 1\n# radius_mm = 57.15\n# direction = ccw\n# centered = true\n"
                     f"angle_deg,deviation_mm\n{rows}")
    source = tmp_path / "in.nc"
    source.write_bytes(program.encode())
    result = run("compensate", str(source), "--plugin", "ballbar-inverse", "--ballbar", str(trace))
    assert result.exit_code == 0, result.stderr
    written, lines = result.stdout_bytes.decode().splitlines(keepends=True), program.splitlines(keepends=True)
    added = len(written) - len(lines)  # the provenance block, and nothing else, was added
    assert written[:lead] + written[lead + added:] == lines
    header = written[lead:lead + added]
    assert header[0].startswith("(POSTPROC ") and header[0].endswith(" COMPENSATED)\n")
    assert all(line.startswith("(") and line.endswith(")\n") for line in header)
