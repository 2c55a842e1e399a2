"""The G-code table against FANUC's list for lathes (Series 0i-TF, 16i/18i-T), system by system:
every code the control knows in a system is known to the interpreter there, with its meaning."""

from __future__ import annotations

import pytest

from support.interpret import moves, steps
from postproc.interpret import gcodes as G
from postproc.diagnostics import Reporter

# (system A, system B, system C) spellings of each code in the control's list; None where a
# system has none. Written out from the manuals' table, not from postproc's.
FANUC = [
    ("G00", "G00", "G00"), ("G01", "G01", "G01"), ("G02", "G02", "G02"), ("G03", "G03", "G03"),
    ("G04", "G04", "G04"), ("G05", "G05", "G05"), ("G05.1", "G05.1", "G05.1"), ("G05.4", "G05.4", "G05.4"),
    ("G07.1", "G07.1", "G07.1"), ("G08", "G08", "G08"), ("G09", "G09", "G09"), ("G10", "G10", "G10"),
    ("G10.6", "G10.6", "G10.6"), ("G11", "G11", "G11"), ("G12.1", "G12.1", "G12.1"), ("G13.1", "G13.1", "G13.1"),
    ("G17", "G17", "G17"), ("G18", "G18", "G18"), ("G19", "G19", "G19"), ("G20", "G20", "G70"),
    ("G21", "G21", "G71"), ("G22", "G22", "G22"), ("G23", "G23", "G23"), ("G25", "G25", "G25"),
    ("G26", "G26", "G26"), ("G27", "G27", "G27"), ("G28", "G28", "G28"), ("G28.2", "G28.2", "G28.2"),
    ("G30", "G30", "G30"), ("G30.1", "G30.1", "G30.1"), ("G31", "G31", "G31"), ("G31.1", "G31.1", "G31.1"),
    ("G31.2", "G31.2", "G31.2"), ("G31.3", "G31.3", "G31.3"), ("G31.8", "G31.8", "G31.8"),
    ("G32", "G33", "G33"), ("G34", "G34", "G34"), ("G35", "G35", "G35"), ("G36", "G36", "G36"),
    ("G37", "G37", "G37"), ("G37.1", "G37.1", "G37.1"), ("G37.2", "G37.2", "G37.2"), ("G39", "G39", "G39"),
    ("G40", "G40", "G40"), ("G41", "G41", "G41"), ("G42", "G42", "G42"), ("G50", "G92", "G92"),
    ("G50.1", "G50.1", "G50.1"), ("G50.2", "G50.2", "G50.2"), ("G50.3", "G92.1", "G92.1"),
    ("G51.1", "G51.1", "G51.1"), ("G51.2", "G51.2", "G51.2"), ("G52", "G52", "G52"), ("G53", "G53", "G53"),
    ("G54", "G54", "G54"), ("G55", "G55", "G55"), ("G56", "G56", "G56"), ("G57", "G57", "G57"),
    ("G58", "G58", "G58"), ("G59", "G59", "G59"), ("G61", "G61", "G61"), ("G63", "G63", "G63"),
    ("G64", "G64", "G64"), ("G65", "G65", "G65"), ("G66", "G66", "G66"), ("G66.1", "G66.1", "G66.1"),
    ("G67", "G67", "G67"), ("G68", "G68", "G68"), ("G69", "G69", "G69"), ("G70", "G70", "G72"),
    ("G71", "G71", "G73"), ("G72", "G72", "G74"), ("G73", "G73", "G75"), ("G74", "G74", "G76"),
    ("G75", "G75", "G77"), ("G76", "G76", "G78"), ("G80", "G80", "G80"), ("G80.4", "G80.4", "G80.4"),
    ("G81", "G81", "G81"), ("G81.4", "G81.4", "G81.4"), ("G82", "G82", "G82"), ("G83", "G83", "G83"),
    ("G83.1", "G83.1", "G83.1"), ("G84", "G84", "G84"), ("G84.2", "G84.2", "G84.2"), ("G85", "G85", "G85"),
    ("G87", "G87", "G87"), ("G88", "G88", "G88"), ("G89", "G89", "G89"), ("G90", "G77", "G20"),
    ("G92", "G78", "G21"), ("G94", "G79", "G24"), (None, "G90", "G90"), (None, "G91", "G91"),
    ("G91.1", "G91.1", "G91.1"), ("G96", "G96", "G96"), ("G96.1", "G96.1", "G96.1"), ("G96.2", "G96.2", "G96.2"),
    ("G96.3", "G96.3", "G96.3"), ("G96.4", "G96.4", "G96.4"), ("G97", "G97", "G97"), ("G98", "G94", "G94"),
    ("G99", "G95", "G95"), (None, "G98", "G98"), (None, "G99", "G99"), ("G107", "G107", "G107"),
    ("G112", "G112", "G112"), ("G113", "G113", "G113"), ("G250", "G250", "G250"), ("G251", "G251", "G251"),
]
SYSTEMS = "ABC"


def _key(spelling: str) -> int:
    return G.code_key(float(spelling[1:]))


@pytest.mark.parametrize("system", SYSTEMS)
def test_every_code_of_the_control_is_known_in_its_system(system):
    codes = [row[SYSTEMS.index(system)] for row in FANUC]
    unknown = [code for code in codes if code is not None and _key(code) not in G.SYSTEMS[system]]
    assert unknown == []


@pytest.mark.parametrize("system", SYSTEMS)
def test_each_code_means_the_same_as_its_counterpart_in_system_a(system):
    """G33 in B threads as G32 does in A; G77 turns as G90 does; G92 sets coordinates as G50 does."""
    for row in FANUC:
        here, in_a = row[SYSTEMS.index(system)], row[0]
        if here is None or in_a is None:
            continue
        assert G.SYSTEMS[system][_key(here)] == G.SYSTEMS["A"][_key(in_a)], (here, in_a)


@pytest.mark.parametrize("system, code", [("A", "G33"), ("B", "G32"), ("C", "G32"), ("B", "G50"), ("C", "G50.3"),
                                          ("A", "G95"), ("A", "G91"), ("B", "G50.3"), ("A", "G123")])
def test_a_code_of_another_system_is_unknown_and_the_warning_names_the_systems_that_have_it(system, code):
    """The control alarms on it (PS0010): the block passes through with a warning. A code the
    other systems have (G95 or G91 read as system A) most often means the control is set to one
    of them, and every G90 and G92 of the program then means something else: the warning names
    those systems, what the code is there, and the profile key that states the system."""
    assert _key(code) not in G.SYSTEMS[system]
    reporter = Reporter()
    moves("G18 G21 G99 F0.2\nG00 X40. Z5.\n" + f"{code} X30. Z-20. F1.5\n", reporter, gcode_system=system)
    (warning,) = [w.message for w in reporter.warnings if f"{code} is not a G code this interpreter knows" in w.message]
    assert f"(G-code system {system}; FANUC alarm PS0010 on a control without it)" in warning
    others = [name for name in "ABC" if name != system and _key(code) in G.SYSTEMS[name]]
    if others:
        assert f"in G-code system {' and '.join(others)} it is {code} (" in warning
        assert "state gcode_system in the machine profile" in warning
    else:
        assert "gcode_system" not in warning


@pytest.mark.parametrize("system, code", [("A", "G32"), ("B", "G33"), ("C", "G33"), ("A", "G34"), ("B", "G35")])
def test_threading_is_a_thread_with_its_end_known(system, code):
    feed = "G99" if system == "A" else "G95"
    absolute = "" if system == "A" else "G90 "
    program = f"G18 G21 {feed} F0.2\n{absolute}G00 X30. Z5.\n{code} Z-20. F1.5\nX29.4\nG00 X40.\n"
    reporter = Reporter()
    result = moves(program, reporter, gcode_system=system)
    threads = [(m.kind, m.x0, m.z0, m.x1, m.z1, m.exact) for m in result[1:3]]
    assert threads == [("thread", 15.0, 5.0, 15.0, -20.0, True), ("thread", 15.0, -20.0, 14.7, -20.0, True)]
    assert reporter.warnings == []


def test_g33_shows_as_thread_in_the_path_and_is_never_compensated(run, tmp_path):
    machine = tmp_path / "b.toml"
    machine.write_text('gcode_system = "B"\n')
    program = tmp_path / "thread.nc"
    program.write_text("%\nO0033\nG18 G21 G95\nT0303\nG97 S600 M03\nG90 G00 X30. Z5.\nG33 Z-20. F1.5\nG00 X40.\n"
                       "Z5.\nX29.4\nG33 Z-20. F1.5\nG00 X40.\nM30\n%\n")
    path = run("path", str(program), "--machine", str(machine))
    assert path.exit_code == 0 and path.stderr == ""
    rows = path.stdout.splitlines()
    assert rows[2] == "7,thread,15.000000,5.000000,15.000000,-20.000000,,,"
    assert rows[6] == "11,thread,14.700000,5.000000,14.700000,-20.000000,,,"


@pytest.mark.parametrize("start, cancel", [("G12.1", "G13.1"), ("G112", "G113"), ("G07.1 C30.", "G07.1 C0"),
                                           ("G68", "G69"), ("G51.2 P1 Q2", "G50.2"), ("G51.1 X0.", "G50.1 X0.")])
def test_a_mode_that_cannot_be_modelled_passes_through_up_to_its_cancel(start, cancel):
    reporter = Reporter()
    program = (f"G18 G21 G99 F0.2\nG00 X40. Z5.\n{start}\nG01 X20. C10.\nG01 X10. C-20.\nZ-3.\n{cancel}\n"
               "G00 X50. Z10.\nG01 X40. Z0.\n")
    result = steps(program, reporter)
    inside = [step for step in result if 4 <= step.block.line <= 6]
    assert all(not step.interpreted and step.moves == () for step in inside)
    after = [m for step in result if step.block.line >= 8 for m in step.moves]
    assert (after[0].x0, after[0].z0) == (None, None)  # where the mode left the tool is not known
    assert (after[1].x0, after[1].z0, after[1].x1, after[1].z1) == (25.0, 10.0, 20.0, 0.0)
    (warning,) = reporter.warnings
    assert "is not modelled: the blocks up to its cancel code pass through" in warning.message
    assert warning.location.line == 3


def test_g39_i_and_k_are_a_direction_not_a_full_circle():
    program = "G18 G21 G99 F0.2\nG00 X20. Z5.\nG42 G01 Z0.\nG02 X30. Z-5. R5.\nG39 I1. K0.\nG01 X40.\n"
    result = moves(program)
    assert [m.kind for m in result] == ["rapid", "line", "arc", "line"]


def test_workpiece_coordinate_preset_leaves_the_position_unknown():
    result = moves("G18 G21 G99 F0.2\nG00 X40. Z5.\nG50.3 X0. Z0.\nG01 Z-10.\n")
    assert result[-1].x0 is None and result[-1].z1 == -10.0


def test_a_system_b_program_with_g33_is_compensated_around_its_threads(run, tmp_path):
    from support import SAMPLES

    machine = tmp_path / "b.toml"
    machine.write_text('gcode_system = "B"\n')
    model = tmp_path / "model.json"
    assert run("fit", "--plugin", "parametric", "--ballbar", str(SAMPLES / "ballbar/v40r-100-ccw.csv"),
               "--ballbar", str(SAMPLES / "ballbar/v40r-100-cw.csv"), "--option", "extrapolate=true",
               "-o", str(model)).exit_code == 0
    program = tmp_path / "part.nc"
    program.write_text("%\nO0033\nG18 G21 G95\nT0101\nG90 G00 X30. Z5.\nG01 Z-20. F0.1\nG02 X40. Z-25. R5.\n"
                       "G00 X50.\nT0303\nG00 X30. Z5.\nG33 Z-20. F1.5\nG00 X40.\nM30\n%\n")
    result = run("compensate", str(program), "--model", str(model), "--machine", str(machine))
    assert result.exit_code == 0, result.stderr
    out = result.stdout.splitlines()
    assert "G33 Z-20. F1.5" in out  # the thread is written as it was
    assert "G01 Z-20. F0.1" not in out  # the turning pass is compensated
    assert run("check", "-", "--machine", str(machine), input=result.stdout_bytes).exit_code == 0


# The block that makes each cutting code cut (arcs with an R; cycles in their two-block form where
# they have one), with {F} for its feed or lead.
_CUTS = {G.G01: "{g} X20. Z-10. {F}", G.G02: "{g} X30. Z-5. R5. {F}", G.G03: "{g} X30. Z-5. R5. {F}",
         G.G32: "{g} Z-10. {F}", G.VARIABLE_LEAD: "{g} Z-10. {F} K0.1", G.CIRCULAR_THREAD: "{g} X30. Z-5. R5. {F}",
         G.TURN_CYCLE: "{g} X20. Z-10. {F}", G.THREAD_CYCLE: "{g} X20. Z-10. {F}", G.FACE_CYCLE: "{g} X20. Z-1. {F}",
         G.ROUGH_TURN: "{g} U1. R.5\n{g} P10 Q20 U.2 W.1 {F}\nN10 G00 X20.\nN20 G01 Z-10. F.1",
         G.ROUGH_FACE: "{g} W1. R.5\n{g} P10 Q20 U.2 W.1 {F}\nN10 G00 Z-2.\nN20 G01 X10. F.1",
         G.PATTERN: "{g} U1. W1. R2\n{g} P10 Q20 U.2 W.1 {F}\nN10 G00 X20.\nN20 G01 Z-10. F.1",
         G.FACE_PECK: "{g} R1.\n{g} X20. Z-10. P1000 Q2000 {F}", G.GROOVE: "{g} R1.\n{g} X20. Z-10. P1000 Q2000 {F}",
         G.THREAD_MULTI: "{g} P010060 Q100 R.05\n{g} X20. Z-10. P1000 Q300 {F}", G.SKIP: "{g} X20. {F}"}


def _cutting_codes():
    """Every code of every system that cuts or threads at the F in force: from the table itself,
    so that a code added to it is checked too."""
    cases = []
    for system, table in G.SYSTEMS.items():
        for key, (kind, meaning) in sorted(table.items()):
            if meaning in _CUTS and (kind == G.MOTION or meaning in G.CONTOUR_CYCLES or kind == G.ONE_SHOT):
                cases.append(pytest.param(system, G.code_name(key), meaning, id=f"{system}-{G.code_name(key)}"))
    return cases


@pytest.mark.parametrize("system, code, meaning", _cutting_codes())
def test_every_code_that_cuts_refuses_a_zero_feed_or_lead(system, code, meaning):
    """A FANUC control alarms (PS0011) on a cut or a thread at F0: the same in the block or modal."""
    from postproc.diagnostics import InterpretationError

    head = f"G18 {'G21 G99' if system == 'A' else ('G21 G95 G90' if system == 'B' else 'G71 G95 G90')}\nG00 X30. Z2.\n"
    body = _CUTS[meaning].replace("{g}", code)
    moves(head + body.replace("{F}", "F1.5") + "\n", gcode_system=system)  # a feed: no alarm
    for program in (head + body.replace("{F}", "F0.000") + "\n", head + "F0\n" + body.replace("{F}", "") + "\n"):
        with pytest.raises(InterpretationError, match=r"F0 \(FANUC alarm PS0011\)"):
            moves(program, gcode_system=system)
