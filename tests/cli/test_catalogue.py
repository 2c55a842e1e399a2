"""A catalogue of bad inputs, each with the exact message it gets and no output program.

Programs (the text-level alarms of FANUC's list: format errors PS0003-PS0011, arc checks,
macro syntax, improper addresses), every measurement format (plus empty, binary, UTF-16 and
Latin-1 files, Windows line endings, a header of the wrong format) and options.
"""

from __future__ import annotations

import json

import pytest

from support import SAMPLES

HEMISHELL = str(SAMPLES / "programs" / "hemishell.nc")
CCW, CW = (str(SAMPLES / "ballbar" / f"v40r-100-{d}.csv") for d in ("ccw", "cw"))
PROBE = str(SAMPLES / "probe" / "hemishell-pass1.csv")
CALIBRATION = str(SAMPLES / "probe" / "artifact-calibration.csv")

PROGRAMS = [
    ("G00 X1. Z1.\nG01 X2..\n", "2:8: error: a second decimal point in one number (FANUC alarm PS0007)"),
    ("10 G01 X1.\n", "1:1: error: a number without an address letter (FANUC alarm PS0004)"),
    ("G00 X\n", "1:5: error: address X has no value (FANUC alarm PS0005)"),
    ("M-3\n", "1:1: error: M-3: address M takes no sign (FANUC alarm PS0006)"),
    ("M03.\n", "1:1: error: M03.: address M takes no decimal point (FANUC alarm PS0007)"),
    ("G00 X1234567890.\n", "1:5: error: X1234567890.: more than 9 digits (FANUC alarm PS0003)"),
    ("G00 X1. Y5.\n", "1:9: error: address Y: this lathe has no Y axis (axes X, Z; FANUC alarm PS0009)"),
    ("G00 X1. Z1.\nG01 X2. F0\n", "2:9: error: feed move with feed rate F0 (FANUC alarm PS0011)"),
    # every move that cuts at the F in force, or threads at it as its lead: F0 is the same alarm
    ("G00 X1. Z1.\nF0\nG01 X2.\n", "3:1: error: feed move with feed rate F0 (FANUC alarm PS0011)"),
    ("G00 X20. Z0.\nG02 X30. Z-5. R5. F0\n", "2:19: error: feed move with feed rate F0 (FANUC alarm PS0011)"),
    ("G00 X20. Z0. F0.\nG03 X30. Z-5. R5.\n", "2:1: error: feed move with feed rate F0 (FANUC alarm PS0011)"),
    ("G00 X0. Z0.2\nG32 X0. Z-0.4 F0.000\n", "2:15: error: G32: threading with lead F0 (FANUC alarm PS0011)"),
    ("G00 X0. Z0.2 F1.5\nG32 Z-10.\nG00 X5.\nF0\nG32 Z-20.\n",
     "5:1: error: G32: threading with lead F0 (FANUC alarm PS0011)"),
    ("G00 X0. Z0.2\nG34 Z-10. F0 K0.1\n", "2:11: error: G34: threading with lead F0 (FANUC alarm PS0011)"),
    ("G00 X30. Z2.\nG92 X20. Z-10. F0\n", "2:16: error: G92: threading with lead F0 (FANUC alarm PS0011)"),
    ("G00 X30. Z2.\nG76 P010060 Q100 R0.05\nG76 X20. Z-10. P1000 Q300 F0\n",
     "3:27: error: G76: threading with lead F0 (FANUC alarm PS0011)"),
    ("G00 X30. Z2.\nG90 X20. Z-10. F0\n", "2:16: error: G90: cycle with feed rate F0 (FANUC alarm PS0011)"),
    ("G00 X30. Z2.\nG94 X20. Z-1. F.2\nF0\nZ-2.\n", "4:1: error: G94: cycle with feed rate F0 (FANUC alarm PS0011)"),
    ("G00 X30. Z2.\nG75 R1.\nG75 X20. Z-10. P1000 Q2000 F0\n",
     "3:28: error: G75: cycle with feed rate F0 (FANUC alarm PS0011)"),
    ("G00 X30. Z2.\nG71 U1. R0.5\nG71 P10 Q20 U.2 W.1 F0\nN10 G00 X20.\nN20 G01 Z-10. F.1\n",
     "3:21: error: G71: cycle with feed rate F0 (FANUC alarm PS0011)"),
    ("G00 X30. Z2.\nG31 X20. F0\n", "2:10: error: feed move with feed rate F0 (FANUC alarm PS0011)"),
    ("G00 X20. Z0. F.1\nG02 X40. Z-10. I5. K0.\n",
     "2:16: error: arc end point is off the circle: radius 5.0000 mm at the start, 11.1803 mm at the end "
     "(limit 0.01 mm, FANUC alarm PS0020)"),
    ("G00 X20. Z0. F.1\nG02 X60. Z-10. R5.\n",
     "2:16: error: R arc too short: the chord 22.3607 mm exceeds twice the radius 5.0000 mm (FANUC alarm PS0020)"),
    ("G00 X20. Z0. F.1\nG02 X40. Z-10.\n", "2:1: error: G02/G03 without R or I/K (FANUC alarm PS0022)"),
    ("#1 = [2 + 3\n", "1:12: error: ']' missing: the bracket is not closed (FANUC alarm PS0118)"),
    ("IF [#1 EQ 1] GOTO\n", "1:14: error: GOTO at the end of the block: what it needs is missing (FANUC alarm PS0114)"),
    ("#1 = 5 X1.\n", "1:1: error: a macro statement must stand alone in its block (FANUC alarm PS0114)"),
    ("#1 = 1 / 0\n", "1:1: error: macro expression: division by zero (FANUC alarm PS0112)"),
    ("G00 X1. (open\n", "1:9: error: comment is not closed: '(' without its ')' on its line: close it with ')'"),
    ("G00 X1. %\n", "1:9: error: '%' inside a block: '%' is the end of the tape (end of record), where the control stops "
                    "reading, even in the middle of a block; it stands on a line of its own after the program's last "
                    "block: delete it here, or give it a line of its own where the tape ends"),
    ("G00 X1. Z1.\nG71 P10 Q20 U.1 W.1 F.2\nN10 G01 X2.\nM98 P1000\nN20 Z0.\n",
     "4:1: error: M98: a subprogram call in the contour N10..N20 of the G71 on line 2: a FANUC control takes no M98 "
     "between a multiple repetitive cycle's P and Q (it stops with an alarm), and what it would add to the contour "
     "cannot be seen here; write the subprogram's moves into the contour blocks, or call it before the cycle block or "
     "after the contour's last block"),
    ("G00 X1.)\n", "1:8: error: ')' without a '(' opening a comment"),
    ("G00 X1. Z1. F.1\nG01 X10. ,C1.\nG00 X20.\n",
     "2:10: error: corner ,C must be followed by a G01/G02/G03 move (FANUC alarm PS0051)"),
    ("G00 X1. Z1.\nG71 P10 Q20 U.1 W.1 F.2\nN10 G01 X2.\n",
     "2:9: error: G71 Q20: no block N20 in the program (FANUC alarm PS0060)"),
    ("G00 X1. Z1.\nG71 P10 Q20 U.1 W.1 F.2\nN10 G01 X2.\nN20 Z0.\nN10 X3.\n",
     "2:5: error: G71 P10: N10 stands on 2 blocks (lines 3, 5...); the contour is ambiguous"),
    ("G00 X1. U2.\n", "1:9: error: X and U both given for the X axis"),
    ("G00 X1. X2.\n", "1:9: error: address X appears twice in one block"),
    ("G00 X1. Z1.\nG04 X1. G28 U0.\n", "2:9: error: two G codes of group 00 in one block (G04 and G28)"),
    ("G00 X\x001.\n", "1:6: error: a character the control does not read (U+0000): is this a text program?"),
    ("G00 X\u0661\u0662.\n", "1:6: error: a character the control does not read (U+0661): is this a text program?"),
    ("G00 X1.; G01 Z1.\n", "1:10: error: only comments and ';' may follow ';', the end of the block: the rest goes on a "
                            "line of its own, a comment in parentheses (';' starts a comment on Siemens, HEIDENHAIN and "
                            "LinuxCNC controls, not on a FANUC)"),
    ("G01 X1. N10\n", "1:9: error: a sequence number N must begin the block"),
    ("END1.\n", "1:1: error: END1.: the loop number of DO and END is 1, 2 or 3 (FANUC alarm PS0126)"),
    ("WHILE [#1 LT 3] DO 4\n", "1:17: error: DO4: the loop number of DO and END is 1, 2 or 3 (FANUC alarm PS0126)"),
    ("#1=#1-#11:\n", "1:10: error: unexpected character ':'"),
    ("#1=[99999999.*99999999.*99999999.*99999999.*99999999.*99999999.]\n",
     "1:1: error: macro expression: calculated data overflow: 1e+48 is beyond +-1e47 (FANUC alarm PS0111)"),
    ("#1=[99999999.*99999999.*99999999.*99999999.*99999999.]\n#[#1*#1]=1\n",
     "2:1: error: macro expression: calculated data overflow: 1e+80 is beyond +-1e47 (FANUC alarm PS0111)"),
]


@pytest.mark.parametrize("text, message", PROGRAMS, ids=[m.split(": error: ")[1][:40] for _, m in PROGRAMS])
def test_bad_programs(run, tmp_path, text, message):
    program = tmp_path / "p.nc"
    program.write_bytes(text.encode("utf-8", "surrogateescape"))
    target = tmp_path / "out.nc"
    result = run("compensate", str(program), "-o", str(target))
    assert result.exit_code == 3
    assert result.stderr.splitlines()[0] == f"{program}:{message}"
    assert not target.exists() and result.stdout_bytes == b""


def test_an_unknown_g_code_is_a_warning_and_the_block_passes_through(run):
    result = run("compensate", input="G00 X1. Z1.\nG123 X1.\n")
    assert result.exit_code == 0 and result.stdout == "G00 X1. Z1.\nG123 X1.\n"
    assert result.stderr.splitlines()[0] == (
        "<stdin>:2:1: warning: block cannot be interpreted: G123 is not a G code this interpreter knows "
        "(G-code system A; FANUC alarm PS0010 on a control without it); it passes through unchanged")


HEAD = "# postproc ballbar 1\n# radius_mm = 100\n# direction = ccw\nangle_deg,deviation_mm\n"
ROWS = "".join(f"{a},0.001\n" for a in range(0, 360, 5))

BALLBAR = [
    ("empty", b"", "{f}: error: the file is empty"),
    ("binary", b"\x00\x01\x02binary", "{f}: error: this is a binary file, not a measurement table"),
    ("utf16", "# postproc ballbar 1\n".encode("utf-16"), "{f}: error: the file is UTF-16 text; save it as UTF-8 (or ASCII)"),
    ("latin1", b"# postproc ballbar 1\n# radius_mm = 100\n# direction = ccw\n# x-note = caf\xe9\nangle_deg,deviation_mm\n0,0\n",
     "{f}:4: error: a byte that is not UTF-8 (a Latin-1 file?); save the file as UTF-8"),
    ("probe-header", b"# postproc probe 1\n# stylus_radius_mm = 3\nx_mm,z_mm,approach_x,approach_z\n1,1,0,-1\n",
     "{f}:1: error: this is a postproc probe file, not a ballbar trace"),
    ("no-magic", b"angle,dev\n0,0\n", "{f}:1: error: the first line must be '# postproc ballbar 1', not 'angle,dev'"),
    ("no-radius", f"# postproc ballbar 1\n# direction = ccw\nangle_deg,deviation_mm\n{ROWS}".encode(),
     "{f}:3: error: the header key 'radius_mm' is required; the header lines end here without it"),
    ("radius-text", HEAD.replace("100", "abc").encode() + ROWS.encode(), "{f}:2: error: radius_mm = 'abc' is not a number"),
    ("radius-negative", HEAD.replace("100", "-5").encode() + ROWS.encode(), "{f}:2: error: radius_mm must be positive, not -5"),
    ("direction", HEAD.replace("ccw", "left").encode() + ROWS.encode(),
     "{f}:3: error: direction = 'left': expected ccw or cw (ccw: the G03 run, cw: the G02 run)"),
    ("direction-as-g-code", HEAD.replace("ccw", "G03").encode() + ROWS.encode(),
     "{f}:3: error: direction = 'G03': expected ccw or cw (ccw: the G03 run, cw: the G02 run)"),
    ("unknown-key", HEAD.replace("angle_deg", "# raduis_mm = 5\nangle_deg").encode() + ROWS.encode(),
     "{f}:4: error: unknown header key 'raduis_mm' (known: capture_arc_deg, center_x_mm, center_z_mm, centered, "
     "direction, feed_mm_min, measured, radius_mm, start_angle_deg; keys of your own start with x-)"),
    ("twice", HEAD.replace("# direction", "# radius_mm = 100\n# direction").encode() + ROWS.encode(),
     "{f}:3: error: header key 'radius_mm' given twice (first on line 2)"),
    ("bad-header-line", HEAD.replace("radius_mm = 100", "radius_mm 100").encode() + ROWS.encode(),
     "{f}:2: error: a header line must read '# key = value', not '# radius_mm 100'"),
    ("nan", (HEAD + "0,nan\n" + ROWS).encode(), "{f}:5: error: deviation_mm = 'nan' is not a finite number"),
    ("infinite", (HEAD + "0,inf\n" + ROWS).encode(), "{f}:5: error: deviation_mm = 'inf' is not a finite number"),
    ("text-value", (HEAD + "0,abc\n" + ROWS).encode(), "{f}:5: error: deviation_mm = 'abc' is not a finite number"),
    ("columns", (HEAD + "0,1,2\n" + ROWS).encode(), "{f}:5: error: 3 values where the header row has 2"),
    ("header-row", HEAD.replace("angle_deg,deviation_mm", "angle,deviation").encode() + ROWS.encode(),
     "{f}:4: error: the CSV header row must be angle_deg,deviation_mm or deviation_mm, not 'angle,deviation'; an instrument's export laid out otherwise (its own columns, semicolons, "
     "tabs, decimal commas, um) is converted by postproc import-trace"),
    ("semicolons", HEAD.replace("angle_deg,deviation_mm", "angle_deg;deviation_mm").encode() + ROWS.encode(),
     "{f}:4: error: the CSV header row must be angle_deg,deviation_mm or deviation_mm, not 'angle_deg;deviation_mm'; an instrument's export laid out otherwise (its own columns, semicolons, "
     "tabs, decimal commas, um) is converted by postproc import-trace"),
    ("decimal-comma-rows", (HEAD + "0;0,001\n" + ROWS).encode(),
     "{f}:5: error: angle_deg = '0;0' is not a finite number; an instrument's export laid out otherwise (its own columns, semicolons, "
     "tabs, decimal commas, um) is converted by postproc import-trace"),
    ("no-rows", HEAD.encode(), "{f}: error: the file has no data rows"),
    ("duplicate-angle", (HEAD + ROWS + "360,0.002\n").encode(), "{f}:77: error: angle 360 deg (0 deg) again (first on line 5): "
     "a second lap or run in one file? give each run of the test as a file of its own"),
    ("implausible", (HEAD + "2.5,1.5\n" + ROWS).encode(),
     "{f}:5: error: deviation 1.5 mm is beyond 1 mm: not a plausible ballbar reading (micrometres written as "
     "millimetres?)"),
    ("too-few", (HEAD + "0,0\n1,0\n").encode(),
     "{f}: error: 2 samples: a trace needs at least 36, over at least 90 deg of arc"),
    ("three-points", (HEAD + "0,0.001\n120,0.002\n240,0.001\n").encode(),
     "{f}: error: 3 samples: a trace needs at least 36, over at least 90 deg of arc"),
    ("35-samples", (HEAD + "".join(f"{a * 5},0.001\n" for a in range(35))).encode(),
     "{f}: error: 35 samples: a trace needs at least 36, over at least 90 deg of arc"),
    ("gap", (HEAD + "0,0\n10,0\n20,0\n30,0\n").encode(),
     "{f}: error: 4 samples: a trace needs at least 36, over at least 90 deg of arc"),
    ("short-arc", (HEAD + "".join(f"{a * 0.5},0.001\n" for a in range(170))).encode(),
     "{f}: error: the trace covers 84 deg from 0 to 84 deg: a trace needs at least 90 deg of arc (a lathe's test in "
     "XZ runs about 220 deg)"),
    ("raw-short-capture", (b"# postproc ballbar 1\n# radius_mm = 100\n# direction = cw\n# start_angle_deg = 0\n"
                           b"# capture_arc_deg = 80\ndeviation_mm\n" + b"0.001\n" * 960),
     "{f}: error: the trace covers 80 deg from 0 to 80 deg: a trace needs at least 90 deg of arc (a lathe's test in "
     "XZ runs about 220 deg)"),
    ("raw-few-readings", (b"# postproc ballbar 1\n# radius_mm = 100\n# direction = cw\n# start_angle_deg = 0\n"
                          b"deviation_mm\n" + b"0.001\n" * 210),
     "{f}: error: 35 samples (averaged from 210 readings, 6 each): a trace needs at least 36, over at least 90 deg "
     "of arc"),
    ("raw-key-in-processed", HEAD.replace("angle_deg,", "# start_angle_deg = 0\nangle_deg,").encode() + ROWS.encode(),
     "{f}:4: error: start_angle_deg belongs to the raw form (angles are given here)"),
    ("measured-without-zone", HEAD.replace("angle_deg", "# measured = 2026-11-20T14:05:00\nangle_deg").encode()
     + ROWS.encode(), "{f}:4: error: measured = '2026-11-20T14:05:00': expected an ISO 8601 time with a time zone, "
                      "such as 2026-11-20T14:05:00+01:00"),
    ("measured-not-a-time", HEAD.replace("angle_deg", "# measured = yesterday\nangle_deg").encode() + ROWS.encode(),
     "{f}:4: error: measured = 'yesterday': expected an ISO 8601 time with a time zone, such as "
     "2026-11-20T14:05:00+01:00"),
    ("raw-without-start", b"# postproc ballbar 1\n# radius_mm = 100\n# direction = ccw\ndeviation_mm\n0\n0\n0\n0\n0\n0\n",
     "{f}:4: error: the header key 'start_angle_deg' is required; the header lines end here without it"),
]


@pytest.mark.parametrize("name, data, message", BALLBAR, ids=[case[0] for case in BALLBAR])
def test_bad_ballbar_traces(run, tmp_path, name, data, message):
    trace = tmp_path / f"{name}.csv"
    trace.write_bytes(data)
    result = run("compensate", HEMISHELL, "--plugin", "parametric", "--ballbar", str(trace), "--ballbar", CW)
    assert result.exit_code == 3 and result.stdout_bytes == b""
    assert result.stderr.splitlines()[0] == message.format(f=trace)


def test_windows_line_endings_are_read(run, tmp_path):
    trace = tmp_path / "crlf.csv"
    trace.write_bytes((HEAD + ROWS).replace("\n", "\r\n").encode())
    assert run("ballbar", str(trace)).exit_code == 0


def _probe(tmp_path, text: str):
    path = tmp_path / "p.csv"
    path.write_text(text)
    return str(path)


def test_bad_probe_files(run, tmp_path):
    nonunit = _probe(tmp_path, "# postproc probe 1\n# stylus_radius_mm = 3\nx_mm,z_mm,approach_x,approach_z\n1,60,0,-0.9\n")
    result = run("compensate", HEMISHELL, "--plugin", "omp-feedback", "--probe", nonunit)
    assert (result.exit_code, result.stderr.splitlines()[0]) == (
        3, f"{nonunit}:4: error: the approach vector has length 0.900000; it must be a unit vector (within 0.001)")
    text = open(PROBE).read()
    norepeat = _probe(tmp_path, "\n".join(line for line in text.splitlines() if "repeatability" not in line))
    result = run("compensate", HEMISHELL, "--plugin", "omp-feedback", "--probe", norepeat)
    assert (result.exit_code, result.stderr.splitlines()[0]) == (
        3, f"{norepeat}:3: error: datum readings without repeatability_mm: the stability check needs it")


def test_a_moved_datum_is_refused_for_safety(run, tmp_path):
    lines = [line if not line.startswith("# datum_after_z_mm") else "# datum_after_z_mm = 13.5"
             for line in open(PROBE).read().splitlines()]
    moved = _probe(tmp_path, "\n".join(lines) + "\n")
    result = run("compensate", HEMISHELL, "--plugin", "omp-feedback", "--probe", moved)
    assert result.exit_code == 4 and result.stdout_bytes == b""
    assert result.stderr.splitlines()[0].startswith(
        f"{moved}: error: the machine moved during the inspection: datum_before_z_mm = 12.9936 and "
        "datum_after_z_mm = 13.5 differ by 0.5064 mm, more than repeatability_mm = 0.003")


def test_bad_calibrations(run, tmp_path):
    text = open(CALIBRATION).read()
    off = _probe(tmp_path, text.replace("artifact_radius_mm = 25.4", "artifact_radius_mm = 20"))
    result = run("compensate", HEMISHELL, "--plugin", "omp-feedback", "--probe", PROBE, "--calibration", off)
    assert result.exit_code == 3
    assert result.stderr.splitlines()[0] == (
        f"{off}:41: error: this touch is +5.3994 mm off the artifact's surface: not a touch on the artifact "
        "(check artifact_radius_mm and its centre)")
    partial = _probe(tmp_path, "\n".join(text.splitlines()[:30]) + "\n")
    result = run("compensate", HEMISHELL, "--plugin", "omp-feedback", "--probe", PROBE, "--calibration", partial)
    assert result.exit_code == 3
    assert result.stderr.splitlines()[0].startswith(
        f"{PROBE}:13: error: this touch approaches at theta 90.0 deg, 40.0 deg outside the directions calibrated in")


OPTIONS = [
    (["--plugin", "telepathy"], 3, "postproc: error: --plugin telepathy: no compensator of that name is installed "
                                   "(installed: ballbar-inverse, effective-angle, error-map, iterative, omp-feedback, parametric, tool-offset)"),
    (["--tolerance", "0"], 3, "postproc: error: --tolerance 0: must be positive"),
    (["--tolerance", "-0.001"], 3, "postproc: error: --tolerance -0.001: must be positive"),
    (["--max-correction", "-1"], 3, "postproc: error: --max-correction -1: must be positive"),
    (["--plugin", "parametric", "--ballbar", CCW, "--ballbar", CW, "--option", "extrapolate=perhaps"], 3,
     "postproc: error: --option parametric.extrapolate=perhaps: expected true or false"),
    (["--plugin", "parametric", "--ballbar", CCW, "--ballbar", CW, "--region", "N10..N20"], 3, "postproc: error: --region N10..N20: expected N100-N200 or N100 (sequence numbers), L10-L50, L10, 10-50 or 10 (source lines), or a tool like T01"),
    (["--ballbar", CCW], 2, "postproc: error: measurements were given but no compensator (--plugin) to use them"),
    (["--tolerance", "inf"], 3, "postproc: error: --tolerance inf: not a finite number"),
    (["--tolerance", "nan"], 3, "postproc: error: --tolerance nan: not a finite number"),
    (["--tolerance", "1e999"], 3, "postproc: error: --tolerance 1e999: not a finite number"),
    (["--tolerance", "abc"], 3, "postproc: error: --tolerance abc: not a number"),
    (["--tolerance", "20"], 3, "postproc: error: --tolerance 20: a tolerance of 20 mm (20000 um) is above 0.05 mm, "
                               "which would let the emitted path stray from the part; did you mean 20 um "
                               "(--tolerance 0.02)?"),
    (["--tolerance", "1e9"], 3, "postproc: error: --tolerance 1e+09: a tolerance of 1e+09 mm (1e+12 um) is above "
                                "0.05 mm, which would let the emitted path stray from the part; give at most 0.05 mm"),
    (["--tolerance", "0.05", "--max-correction", "0.01"], 3,
     "postproc: error: --tolerance 0.05: a tolerance above the maximum correction (0.01 mm) would let the emitted path "
     "stray further than any correction moves it; give at most 0.01 mm"),
    (["--max-correction", "5"], 3, "postproc: error: --max-correction 5: 5 mm (5000 um) is above 1 mm, beyond any "
                                   "error a compensation corrects; did you mean 5 um (--max-correction 0.005)?"),
    (["--max-correction", "inf"], 3, "postproc: error: --max-correction inf: not a finite number"),
    (["--out-dir", "out", "--jobs", "100000"], 3,
     "postproc: error: --jobs 100000: far more processes than a machine runs at once (at most 1024); give about the "
     "number of CPUs"),
    (["--macro-values", "numbers"], 2,
     "postproc: error: --macro-values was given but no compensator (--plugin) to compensate the blocks"),
    (["--plugin", "parametric", "--ballbar", CCW, "--macro-values", "some"], 2, None),
]


@pytest.mark.parametrize("args, code, message", OPTIONS, ids=[" ".join(a[-2:]) for a, _, _ in OPTIONS])
def test_bad_options(run, tmp_path, monkeypatch, args, code, message):
    monkeypatch.chdir(tmp_path)
    result = run("compensate", HEMISHELL, *args)
    assert result.exit_code == code and result.stdout_bytes == b""
    if message is None:  # click's own message for a value outside a choice
        assert "Invalid value for '--macro-values': 'some' is not one of 'refuse', 'keep', 'numbers'." in result.stderr
    else:
        assert result.stderr.splitlines()[0] == message
    assert list(tmp_path.iterdir()) == []


#: Every number any command takes is finite: (command line, message).
NUMBERS = [
    (["path", HEMISHELL, "--tolerance", "nan"], "--tolerance nan: not a finite number"),
    (["report", HEMISHELL, "--tolerance", "inf"], "--tolerance inf: not a finite number"),
    (["inspect", HEMISHELL, "--probe", PROBE, "--band", "nan"], "--band nan: not a finite number"),
    (["ballbar", CCW, "--max-deviation", "nan"], "--max-deviation nan: not a finite number"),
    (["ballbar", CCW, "--max-deviation", "0"], "--max-deviation 0: must be positive"),
    (["probe-import", PROBE, "--stylus-radius", "inf"], "--stylus-radius inf: not a finite number"),
    (["probe-program", HEMISHELL, "--datum-x", "nan", "--datum-z", "1"], "--datum-x nan: not a finite number"),
    (["probe-program", HEMISHELL, "--clearance", "inf"], "--clearance inf: not a finite number"),
    (["simulate", "ballbar", "--radius", "inf"], "--radius inf: not a finite number"),
    (["simulate", "ballbar", "--center-x", "-inf"], "--center-x -inf: not a finite number"),
    (["simulate", "calibrate", "--step-deg", "nan"], "--step-deg nan: not a finite number"),
]


@pytest.mark.parametrize("args, message", NUMBERS, ids=[" ".join(a[:1] + a[-2:]) for a, _ in NUMBERS])
def test_numbers_that_are_not_finite_are_refused_everywhere(run, args, message):
    result = run(*args)
    assert (result.exit_code, result.stdout_bytes) == (3, b"")
    assert result.stderr == f"postproc: error: {message}\n"


PROFILES = [
    ("nested", "x-deep = " + "[" * 3000 + "]" * 3000, ": error: nested too deeply to be a machine profile"),
    ("tolerance-inf", "tolerance = inf", ":1:1: error: tolerance must be a positive number"),
    ("tolerance-nan", "tolerance = nan", ":1:1: error: tolerance must be a positive number"),
    ("tolerance-um", "tolerance = 20", ":1:1: error: tolerance = 20: a tolerance of 20 mm (20000 um) is above 0.05 mm, which "
                                       "would let the emitted path stray from the part; did you mean 20 um "
                                       "(tolerance = 0.02)?"),
    ("tolerance-above-correction", "max_correction = 0.01\ntolerance = 0.02",
     ":2:1: error: tolerance = 0.02: a tolerance above the maximum correction (0.01 mm) would let the emitted path stray "
     "further than any correction moves it; give at most 0.01 mm"),
    ("correction-um", "max_correction = 5", ":1:1: error: max_correction = 5: 5 mm (5000 um) is above 1 mm, beyond any "
                                            "error a compensation corrects; did you mean 5 um (max_correction = 0.005)?"),
    ("time-limit", "plugin_time_limit_s = 1e300", ":1:1: error: plugin_time_limit_s = 1e+300: out of range for a lathe (at "
                                                  "most 86400 s)"),
    ("decimals", "output_decimals_mm = 40", ":1:1: error: output_decimals_mm = 40: out of range for a lathe (at most 6 "
                                            "decimals, at least 2)"),
    ("limits", "x_limits = [-inf, inf]", ":1:1: error: x_limits: the limits must be finite numbers"),
    ("binary", "\x00\x01", ":1:1: error: not valid TOML: Invalid statement"),
]


@pytest.mark.parametrize("name, text, message", PROFILES, ids=[case[0] for case in PROFILES])
def test_bad_machine_profiles(run, tmp_path, name, text, message):
    machine = tmp_path / "m.toml"
    machine.write_text(text + "\n")
    _refused(run, tmp_path, ["--machine", str(machine)], f"{machine}{message}")


def _refused(run, tmp_path, args: list[str], first_line: str) -> None:
    """compensate with these options: exit 3, this first line on stderr, nothing written."""
    target = tmp_path / "out.nc"
    result = run("compensate", HEMISHELL, *args, "-o", str(target))
    assert (result.exit_code, result.stdout_bytes) == (3, b"")
    assert result.stderr.splitlines()[0] == first_line
    assert not target.exists()


def test_models_from_another_version_or_tampered(run, tmp_path):
    model = tmp_path / "m.json"
    assert run("fit", "--plugin", "parametric", "--ballbar", CCW, "--ballbar", CW, "-o", str(model)).exit_code == 0
    data = json.loads(model.read_text())
    data["version"] = 7
    model.write_text(json.dumps(data))
    result = run("compensate", HEMISHELL, "--model", str(model))
    assert (result.exit_code, result.stderr.splitlines()[0]) == (
        3, f"{model}: error: a model of version 7; this postproc reads version 1")
    data["version"] = 1
    data["options"] = {"extrapolate": True}
    model.write_text(json.dumps(data))
    result = run("compensate", HEMISHELL, "--model", str(model))
    assert (result.exit_code, result.stderr.splitlines()[0]) == (
        3, f"{model}: error: the model's content does not match its SHA-256: it was changed after it was saved")


def _resigned(data: dict) -> str:
    """A model whose hash matches its (changed) content: what is checked is then the content."""
    import hashlib

    from postproc.compensate.models import _canonical

    payload = {key: value for key, value in data.items() if key != "sha256"}
    return json.dumps({**payload, "sha256": hashlib.sha256(_canonical(payload)).hexdigest()})


def _deep(levels: int):
    value: object = 1.0
    for _ in range(levels):
        value = [value]
    return value


#: (name, change to a fitted parametric model, message after "FILE: error: ")
MODELS = [
    ("nested-deeply", lambda d: d["model"].update(fit=_deep(40)), "not a postproc model (nested deeper than 32 levels)"),
    ("nested-beyond-the-parser", None, "not a postproc model (nested deeper than 32 levels)"),
    ("5000-digits", "5000", "not a postproc model (an integer of thousands of digits)"),
    ("4000-digits", lambda d: d["model"].update(radius_mm=10**3999), "model.radius_mm: an integer of 4000 digits is "
                                                                     "not a plausible value"),
    ("nan", "nan", "not a postproc model (NaN is not a number a model holds)"),
    ("infinity", "inf", "not a postproc model (Infinity is not a number a model holds)"),
    ("time-without-zone", lambda d: d.update(measured="2026-11-20T14:05:00"),
     "the model's measured time '2026-11-20T14:05:00' is not an ISO 8601 time with a time zone (such as "
     "2026-11-20T14:05:00+01:00)"),
    ("inputs-a-string", lambda d: d.update(inputs="ccw.csv"), "'inputs' must be a list, not a string"),
    ("inputs-entries", lambda d: d.update(inputs=[{"file": 1}]),
     'inputs[0] must be {"file": name, "sha256": 64 hex digits}'),
    ("options-a-list", lambda d: d.update(options=["extrapolate"]), "'options' must be an object, not a list"),
    ("plugin-a-number", lambda d: d.update(plugin=5), "'plugin' must be a string, not a whole number"),
    ("unknown-key", lambda d: d.update(colour="red"), "unknown key 'colour' in the model (known: created, format, "
                                                       "inputs, machine_profile, machine_profile_sha256, measured, model, "
                                                       "note, options, "
                                                       "plugin, plugin_version, postproc, sha256, version)"),
    ("unknown-option", lambda d: d.update(options={"colour": "red"}),
     "options.colour: parametric declares no such option (it declares: extrapolate, max-uncertainty)"),
    ("option-value", lambda d: d.update(options={"extrapolate": "perhaps"}),
     'options.extrapolate = "perhaps": expected true or false'),
    ("radius-zero", lambda d: d["model"].update(radius_mm=0), "model.radius_mm = 0: a radius must be positive"),
    ("radius-negative", lambda d: d["model"].update(radius_mm=-100.0),
     "model.radius_mm = -100.0: a radius must be positive"),
    ("another-plugins-model", lambda d: d.update(plugin="ballbar-inverse"),
     "the model's content does not suit compensator ballbar-inverse (is it another compensator's?): load: KeyError: "
     "'traces'"),
    ("model-incomplete", lambda d: d["model"].pop("parameters"),
     "parametric: the saved model is incomplete (KeyError: 'parameters')"),
]


@pytest.mark.parametrize("name, change, message", MODELS, ids=[case[0] for case in MODELS])
def test_bad_models(run, tmp_path, name, change, message):
    """Bad data in a model is bad input (exit 3), never an internal error."""
    model = tmp_path / "m.json"
    assert run("fit", "--plugin", "parametric", "--ballbar", CCW, "--ballbar", CW, "-o", str(model)).exit_code == 0
    data = json.loads(model.read_text())
    if callable(change):
        change(data)
        text = _resigned(data)
    elif change is None:
        text = "[" * 100_000 + "]" * 100_000
    else:
        literal = {"5000": "1" * 5000, "nan": "NaN", "inf": "Infinity"}[change]
        text = _resigned(data).replace('"radius_mm": 100.0', f'"radius_mm": {literal}')
    model.write_text(text)
    _refused(run, tmp_path, ["--model", str(model)], f"{model}: error: {message}")


def test_a_saved_trace_is_held_to_what_a_trace_file_is(run, tmp_path):
    model = tmp_path / "m.json"
    fit = ["fit", "--plugin", "ballbar-inverse", "--ballbar", CCW, "--ballbar", CW, "--option", "radius-mapping=relative"]
    assert run(*fit, "-o", str(model)).exit_code == 0
    changes = [
        (lambda t: t.update(radius_mm=0.0), "model.traces.ccw.radius_mm = 0.0: a radius must be positive"),
        (lambda t: t.update(angles_deg=t["angles_deg"][::-1]), "a saved ccw trace's angles must increase within 0 .. "
                                                               "360 deg"),
        (lambda t: t.update(deviations_mm=t["deviations_mm"][:2]), "a saved ccw trace needs at least 3 angles and as "
                                                                   "many deviations"),
        (lambda t: t["deviations_mm"].__setitem__(0, 1.5), "a saved ccw trace's deviation of 1.5 mm is beyond 1 mm: "
                                                           "not a plausible ballbar reading"),
        (lambda t: t.update(centre_mm=[0.0]), "a saved ccw trace's centre_mm must be two finite numbers"),
    ]
    for change, message in changes:
        data = json.loads(model.read_text())
        change(data["model"]["traces"]["ccw"])
        bad = tmp_path / "bad.json"
        bad.write_text(_resigned(data))
        result = run("compensate", HEMISHELL, "--model", str(bad))
        assert (result.exit_code, result.stderr.splitlines()[0]) == (3, f"{bad}: error: {message}")


INPUTS = [
    ("/dev/zero", "/dev/zero:1:1: error: a NUL byte: this is binary data, not a text program; nothing more was read"),
    ("/proc/self/mem", "/proc/self/mem: error: cannot read program: Input/output error"),
]


@pytest.mark.parametrize("path, message", INPUTS, ids=[case[0] for case in INPUTS])
def test_devices_as_programs(run, path, message):
    import os

    if not os.path.exists(path):
        pytest.skip(f"no {path} here")
    result = run("compensate", path)
    assert (result.exit_code, result.stdout_bytes, result.stderr.splitlines()[0]) == (3, b"", message)
