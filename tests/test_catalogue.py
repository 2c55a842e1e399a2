"""A catalogue of bad inputs, each with the exact message it gets and no output program.

Programs (the text-level alarms of FANUC's list: format errors PS0003-PS0011, arc checks,
macro syntax, improper addresses), every measurement format (plus empty, binary, UTF-16 and
Latin-1 files, Windows line endings, a header of the wrong format) and options.
"""

from __future__ import annotations

import json

import pytest

from conftest import SAMPLES

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
    ("G00 X1. Z1.\nG01 X2. F0\n", "2:1: error: feed move with feed rate F0 (FANUC alarm PS0011)"),
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
    ("G00 X1. (open\n", "1:9: error: comment is not closed: '(' without its ')'"),
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
                            "line of its own"),
    ("G01 X1. N10\n", "1:9: error: a sequence number N must begin the block"),
    ("END1.\n", "1:1: error: END1.: the loop number of DO and END is 1, 2 or 3 (FANUC alarm PS0126)"),
    ("WHILE [#1 LT 3] DO 4\n", "1:17: error: DO4: the loop number of DO and END is 1, 2 or 3 (FANUC alarm PS0126)"),
    ("#1=#1-#11:\n", "1:10: error: unexpected character ':'"),
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
     "{f}: error: the header key 'radius_mm' is required"),
    ("radius-text", HEAD.replace("100", "abc").encode() + ROWS.encode(), "{f}:2: error: radius_mm = 'abc' is not a number"),
    ("radius-negative", HEAD.replace("100", "-5").encode() + ROWS.encode(), "{f}:2: error: radius_mm must be positive, not -5"),
    ("direction", HEAD.replace("ccw", "left").encode() + ROWS.encode(), "{f}:3: error: direction = 'left': expected ccw or cw"),
    ("unknown-key", HEAD.replace("angle_deg", "# raduis_mm = 5\nangle_deg").encode() + ROWS.encode(),
     "{f}:4: error: unknown header key 'raduis_mm' (known: capture_arc_deg, center_x_mm, center_z_mm, centered, "
     "direction, feed_mm_min, measured, radius_mm, start_angle_deg; keys of your own start with x-)"),
    ("measured-no-zone", HEAD.replace("angle_deg", "# measured = 2026-11-20T14:05:00\nangle_deg").encode() + ROWS.encode(),
     "{f}:4: error: measured = '2026-11-20T14:05:00' has no time zone; write it like 2026-11-20T14:05:00+01:00"),
    ("measured-text", HEAD.replace("angle_deg", "# measured = last tuesday\nangle_deg").encode() + ROWS.encode(),
     "{f}:4: error: measured = 'last tuesday' is not an ISO 8601 time; write it like 2026-11-20T14:05:00+01:00"),
    ("twice", HEAD.replace("# direction", "# radius_mm = 100\n# direction").encode() + ROWS.encode(),
     "{f}:3: error: header key 'radius_mm' given twice (first on line 2)"),
    ("bad-header-line", HEAD.replace("radius_mm = 100", "radius_mm 100").encode() + ROWS.encode(),
     "{f}:2: error: a header line must read '# key = value', not '# radius_mm 100'"),
    ("nan", (HEAD + "0,nan\n" + ROWS).encode(), "{f}:5: error: deviation_mm = 'nan' is not a finite number"),
    ("infinite", (HEAD + "0,inf\n" + ROWS).encode(), "{f}:5: error: deviation_mm = 'inf' is not a finite number"),
    ("text-value", (HEAD + "0,abc\n" + ROWS).encode(), "{f}:5: error: deviation_mm = 'abc' is not a finite number"),
    ("columns", (HEAD + "0,1,2\n" + ROWS).encode(), "{f}:5: error: 3 values where the header row has 2"),
    ("header-row", HEAD.replace("angle_deg,deviation_mm", "angle,deviation").encode() + ROWS.encode(),
     "{f}:4: error: the CSV header row must be angle_deg,deviation_mm or deviation_mm, not 'angle,deviation'"),
    ("no-rows", HEAD.encode(), "{f}: error: the file has no data rows"),
    ("duplicate-angle", (HEAD + ROWS + "360,0.002\n").encode(), "{f}:77: error: angle 360 deg (0 deg) again (first on line 5)"),
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
    ("raw-without-start", b"# postproc ballbar 1\n# radius_mm = 100\n# direction = ccw\ndeviation_mm\n0\n0\n0\n0\n0\n0\n",
     "{f}: error: the header key 'start_angle_deg' is required"),
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
        3, f"{norepeat}: error: datum readings without repeatability_mm: the stability check needs it")


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
    (["--tolerance", "0"], 3, "postproc: error: --tolerance 0.0: the tolerance must be positive"),
    (["--tolerance", "-0.001"], 3, "postproc: error: --tolerance -0.001: the tolerance must be positive"),
    (["--max-correction", "-1"], 3, "postproc: error: --max-correction -1.0: must be positive"),
    (["--plugin", "parametric", "--ballbar", CCW, "--ballbar", CW, "--option", "extrapolate=perhaps"], 3,
     "postproc: error: --option parametric.extrapolate=perhaps: expected true or false"),
    (["--plugin", "parametric", "--ballbar", CCW, "--ballbar", CW, "--region", "N10..N20"], 3, "postproc: error: --region N10..N20: expected N100-N200, L10-L50 (or 10-50) or a tool like T01"),
    (["--ballbar", CCW], 2, "postproc: error: measurements were given but no compensator (--plugin) to use them"),
]


@pytest.mark.parametrize("args, code, message", OPTIONS, ids=[" ".join(a[-2:]) for a, _, _ in OPTIONS])
def test_bad_options(run, args, code, message):
    result = run("compensate", HEMISHELL, *args)
    assert result.exit_code == code and result.stdout_bytes == b""
    assert result.stderr.splitlines()[0] == message


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
