"""Golden tests of the lathe interpreter, one feature at a time (radius mm throughout)."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings, strategies as st

from support.interpret import geometry, moves, steps
from postproc.diagnostics import InterpretationError, Reporter, format_message

START = "G18 G21 G99 F0.2\nG00 X100. Z10.\n"


def test_diameter_x_and_incremental_u_w():
    result = moves(START + "G01 X50. Z0.\nU-10. W-5.\nX30.\n")
    assert [geometry(m)[2:4] for m in result[1:]] == [
        ((50.0, 10.0), (25.0, 0.0)),
        ((25.0, 0.0), (20.0, -5.0)),
        ((20.0, -5.0), (15.0, -5.0)),
    ]


def test_radius_programming_when_the_profile_says_so():
    result = moves(START + "G01 X50.\n", diameter_x=False)
    assert geometry(result[-1])[3] == (50.0, 10.0)


def test_no_decimal_point_counts_least_input_increments():
    result = moves(START + "G01 X10 Z-5\n")
    assert geometry(result[-1])[3] == (0.005, -0.005)
    result = moves(START + "G01 X10 Z-5\n", calculator_input=True)
    assert geometry(result[-1])[3] == (5.0, -5.0)
    result = moves("G20 G99 F0.01\nG00 X1. Z1.\nG01 X10 Z-5\n")
    assert geometry(result[-1])[3] == pytest.approx((0.0005 * 25.4, -0.0005 * 25.4))


@pytest.mark.parametrize("increment, inch, expected", [
    ("IS-A", False, 1.18), ("IS-B", False, 0.118), ("IS-C", False, 0.0118),
    ("IS-A", True, 0.118 * 25.4), ("IS-B", True, 0.0118 * 25.4), ("IS-C", True, 0.00118 * 25.4),
])
def test_a_plain_number_is_in_least_input_increments_without_calculator_input(increment, inch, expected):
    units = "G20" if inch else "G21"
    for calculator in (False, None):  # stated false, or not stated: the FANUC default
        result = moves(f"G18 {units} G99 F0.01\nG00 X100. Z1.\nG01 X118 Z-1.\n", input_increment=increment,
                       calculator_input=calculator)
        assert result[-1].x1 == pytest.approx(expected / 2.0)


@pytest.mark.parametrize("inch", [False, True])
def test_calculator_input_reads_a_plain_number_in_mm_or_inches(inch):
    units, scale = ("G20", 25.4) if inch else ("G21", 1.0)
    program = f"G18 {units} G99 F0.01\nG00 X100. Z1.\nG01 X118 Z-1\nG02 X138 Z-11 R10\nG01 W-5 ,C1\nU4 W-4\n"
    result = moves(program, calculator_input=True)
    assert result[1].x1 == pytest.approx(59.0 * scale) and result[1].z1 == pytest.approx(-1.0 * scale)
    arc = result[2]
    assert math.hypot(arc.x1 - arc.xc, arc.z1 - arc.zc) == pytest.approx(10.0 * scale)
    chamfered = result[3]  # W-5 with a 1 (mm or in) chamfer before the diagonal move
    assert chamfered.z1 == pytest.approx(-15.0 * scale)


def test_inch_program_is_converted_to_mm():
    result = moves("G20 G99 F0.01\nG00 X2. Z0.1\nG01 Z-1.\n")
    assert geometry(result[-1])[2:4] == ((25.4, 2.54), (25.4, -25.4))


def test_g02_g03_with_i_k_are_radius_values_incremental_from_the_start():
    # The hemishell: from the pole down to the equator is a G03 (theta decreasing).
    result = moves("G18 G21 G99 F0.1\nG00 X0. Z60.\nG01 Z57.15\nG03 X114.3 Z0. I0. K-57.15\n")
    arc = result[-1]
    assert geometry(arc) == ("arc", 4, (0.0, 57.15), (57.15, 0.0), (0.0, 0.0), "ccw")


def test_r_arcs_short_and_long():
    # From (10, 0) to (20, -10): about (20, 0) theta runs 180 -> 270, a G02 quarter.
    short = moves(START + "G01 X20. Z0.\nG02 X40. Z-10. R10.\n")[-1]
    assert geometry(short)[4:] == ((20.0, 0.0), "cw")
    # Negative R takes the other centre and the 270 degree way round.
    long = moves(START + "G01 X20. Z0.\nG02 X40. Z-10. R-10.\n")[-1]
    assert geometry(long)[4] == (10.0, -10.0)
    assert math.hypot(long.x1 - long.xc, long.z1 - long.zc) == pytest.approx(10.0)


def test_arc_direction_convention_g02_is_theta_increasing():
    # A quarter from theta = 0 (+X) to theta = 90 (+Z) about (0, 0) is a G02.
    arc = moves("G18 G21 G99 F0.1\nG00 X20. Z0.\nG02 X0. Z10. R10.\n")[-1]
    assert geometry(arc)[4:] == ((0.0, 0.0), "cw")


def test_arc_radius_mismatch_is_the_controls_alarm():
    with pytest.raises(InterpretationError) as info:
        moves(START + "G01 X20. Z0.\nG02 X40. Z-10. I5. K0.\n")
    assert "PS0020" in info.value.message and info.value.location.line == 4


def test_r_arc_shorter_than_its_chord_is_refused():
    with pytest.raises(InterpretationError) as info:
        moves(START + "G01 X20. Z0.\nG02 X60. Z-10. R5.\n")
    assert "R arc too short" in info.value.message
    assert (info.value.location.line, info.value.location.col) == (4, 16)


def test_dwell_words_are_time_not_motion():
    result = moves(START + "G04 X1.5\nG04 U2.\nG04 P500\n")
    assert len(result) == 1


def test_reference_return_makes_the_position_unknown_until_an_absolute_move():
    result = moves(START + "G28 U0. W0.\nG01 W-5.\nG00 X20. Z5.\nG01 Z0.\n")
    kinds = [(m.kind, m.x1, m.z1) for m in result[1:]]
    assert kinds[0] == ("rapid", None, None)
    assert kinds[1][1:] == (None, None)  # incremental from an unknown point stays unknown
    assert kinds[2] == ("rapid", 10.0, 5.0)
    assert result[-1].known


def test_g50_sets_the_coordinates_and_with_s_only_clamps_the_spindle():
    result = moves("G18 G21 G99 F0.2\nG50 X200. Z100.\nG50 S2000\nG01 W-10.\n")
    assert geometry(result[-1])[2:4] == ((100.0, 100.0), (100.0, 90.0))


@settings(max_examples=60)
@given(words=st.lists(st.sampled_from(["X", "Z", "U", "W"]), unique=True, min_size=1, max_size=2),
       values=st.lists(st.integers(-2000, 2000), min_size=2, max_size=2), system=st.sampled_from("ABC"),
       incremental=st.booleans())
def test_coordinate_setting_gives_the_tool_the_coordinates_a_move_with_its_words_would_end_at(
        words, values, system, incremental):
    """G50 (G92 in systems B and C) leaves the tool where it is and names its coordinates: X and
    Z under G90, U and W added to the old ones (``G50 W-5.`` at Z-10 makes it Z-15). The next
    move starts there, exactly where a move with the same words would end. X or Z under G91
    (systems B and C), which controls read either as coordinates or as a shift, leaves that
    axis unknown: not guessed."""
    if {"X", "U"} <= set(words) or {"Z", "W"} <= set(words) or (system != "A" and ({"U", "W"} & set(words))):
        return  # one word per axis; U and W are X and Z incremental in system A only
    code = "G50" if system == "A" else "G92"
    mode = "" if system == "A" else ("G91 " if incremental else "G90 ")
    named = " ".join(f"{letter}{value / 10:.1f}" for letter, value in zip(words, values))
    start = "G18 G21 F0.2\nG00 X100. Z10.\n"
    after = moves(start + f"{mode}{code} {named}\nG01 W0. U0.\n" if system == "A"
                  else start + f"{mode}{code} {named}\nG91 G01 Z0.\n", gcode_system=system)[-1]
    moved = moves(start + f"{mode}G00 {named}\n", gcode_system=system)[-1]
    if system != "A" and incremental:
        assert (after.x0 is None, after.z0 is None) == ("X" in words, "Z" in words)
        return
    assert (after.x0, after.z0) == pytest.approx((moved.x1, moved.z1))


def test_work_offset_change_loses_the_position():
    result = moves("G54\n" + START + "G55\nG01 W-1.\n")
    assert result[-1].x0 is None


@pytest.mark.parametrize("change, lost", [
    ("G54.1 P2", "xz"),  # another additional system: P names it, the code alone does not
    ("G10 L2 P1 Z-300.", "z"),  # the offset of G54 rewritten: the tool stays, its coordinates change
    ("G10 L2 P0 U0.5", "x"),  # the external offset shifts every system; U adds to it
    ("G10 L20 P1 X1. Z5.", "xz"),  # G54.1 P1's offset
    ("G10 P0 W-50.", "z"),  # the lathe's workpiece coordinate shift (no L)
    ("G10 L#1 P1 Z0.", "z"),  # which data a computed L sets is known only when the program runs
])
def test_a_change_of_work_coordinates_loses_the_positions_it_moves(change, lost):
    """Whatever moves the frame the tool's coordinates are counted in, the position on that axis
    is unknown until an absolute move: a move after it is never joined to the old frame's end."""
    result = moves("G54.1 P1\n" + START + f"{change}\nG01 U-2. W-1.\n")
    last = result[-1]
    assert (last.x0 is None, last.z0 is None) == ("x" in lost, "z" in lost)


@pytest.mark.parametrize("data", ["G54.1 P1", "G10 P1 Z0.5", "G10 P10001 X0.1", "G10 L50", "G10 L3 P1"])
def test_the_same_work_coordinates_or_other_data_keep_the_position(data):
    result = moves("G54.1 P1\n" + START + f"{data}\nG01 U-2. W-1.\n")
    assert result[-1].known


def test_modal_states_follow_the_blocks():
    result = steps(START + "G98 G96 S200 G42\nG01 Z0. F100.\nG40 G00 X120.\nT0303\n")
    modal = result[-1].modal
    assert (modal.per_rev, modal.comp, modal.tool, modal.offset) == (False, 40, 3, 3)
    feed = [m for s in result for m in s.moves if m.kind == "line"][0]
    assert (feed.comp, feed.feed, feed.per_rev) == (42, 100.0, False)


@pytest.mark.parametrize("motion", ["G00 X50. Z-10.", "G01 X50. Z-10.", "G01 X50.", "G02 X40. Z-10. R10.",
                                    "G03 U20. W-10. I0. K-10.", "G90 X50. Z-10."])
@pytest.mark.parametrize("word, axis", [("A150.", "A"), ("C1.", "C"), ("H30.", "C")])
def test_a_word_that_changes_the_path_on_a_lathe_without_its_axis_is_not_read_as_nothing(motion, word, axis):
    """A (direct drawing's angle), C (a chamfer) and H (incremental C) mean something to the
    control even where the profile has no such axis: parameter 3405 bit 4 reads them as the
    angle, chamfer and corner of the drawing. Read as nothing, ``G01 X50. A150.`` would be a
    move along X alone. The block passes through uninterpreted, with a warning at the word, and
    the position after it is unknown; on a lathe with the axis it is a move like any other."""
    program = START + "G01 X30. Z0.\n" + f"{motion} {word}\nG01 W-5.\n"
    reporter = Reporter()
    result = moves(program, reporter)
    assert not result[-2].known and result[-1].x0 is None
    (warning,) = reporter.warnings
    assert f"{word[0]} in a motion block" in warning.message
    assert warning.location.col == len(motion) + 2
    result = moves(program, axes="XZ" + axis)
    assert result[-2].known and result[-1].known


def test_chamfer_and_corner_radius_are_rows_of_their_own():
    result = moves(START + "G01 X40. Z0.\nZ-20. ,C2.\nX80. ,R5.\nZ-40.\n")
    rows = [geometry(m) for m in result[2:]]
    assert rows[0][2:4] == ((20.0, 0.0), (20.0, -18.0))
    assert rows[1][:4] == ("line", 4, (20.0, -18.0), (22.0, -20.0))
    assert rows[2][2:4] == ((22.0, -20.0), (35.0, -20.0))
    fillet = rows[3]
    # Turning from +X to -Z about (35, -25): theta 90 -> 0, decreasing, a G03.
    assert fillet[:2] == ("arc", 5) and fillet[4] == (35.0, -25.0) and fillet[5] == "ccw"
    assert rows[4][2:4] == ((40.0, -25.0), (40.0, -40.0))


@pytest.mark.parametrize("before", ["", "M98 P1000\n", "G28 U0. W0.\n", "G65 P9010\n"])
@pytest.mark.parametrize("corner", [",C1.", ",R1."])
def test_a_corner_from_an_unknown_position_leaves_its_moves_unknown(before, corner):
    """A chamfer or rounding whose first move starts where the program does not say (the first
    move of the program, after a call or a reference return): the way into the corner is
    unknown, so are its points. The first move's end and the next one's start are unknown, never
    guessed (it raised a TypeError, exit 5); the next move's end is known again."""
    result = moves(f"G18 G21 G99 F0.1\n{before}G01 X140. Z-40. {corner}\nX170.\nZ-80.\n")
    chamfered, following, last = result[-3:]
    assert (chamfered.x1, chamfered.z1) == (None, None) and not chamfered.exact
    assert (following.x0, following.z0, following.x1, following.z1) == (None, None, 85.0, -40.0)
    assert last.known and (last.x0, last.z0, last.x1, last.z1) == (85.0, -40.0, 85.0, -80.0)


def test_corner_without_a_following_move_is_refused():
    with pytest.raises(InterpretationError) as info:
        moves(START + "G01 X40. ,C2.\nG00 X100.\n")
    assert "PS0051" in info.value.message and info.value.location.line == 3


G71_PROGRAM = """G18 G21 G99
T0101
G00 X60. Z2.
G71 U1. R0.5
G71 P10 Q20 U0.4 W0.1 F0.3
N10 G00 X20.
G01 Z-10. F0.1
X40. Z-20.
N20 X62.
G00 X100. Z50.
T0202
G00 X60. Z2.
G70 P10 Q20
G00 X100.
"""


def test_g71_contour_is_not_run_in_sequence_and_g70_runs_it():
    result = moves(G71_PROGRAM)
    rows = [(m.line, m.kind, m.role) for m in result]
    assert rows[:2] == [(3, "rapid", "run"), (5, "cycle", "run")]
    assert rows[2] == (10, "rapid", "run")  # after G71 the tool is back at the start point
    assert geometry(result[2])[2] == (30.0, 2.0)
    g70 = [r for r in rows if r[2] == "replay"]
    assert [r[0] for r in g70] == [6, 7, 8, 9]
    assert geometry(result[-2])[1:4] == (13, (31.0, -20.0), (30.0, 2.0))  # G70 returns to its start
    assert geometry(result[-1])[2] == (30.0, 2.0)


def test_contour_blocks_are_marked_and_keep_their_geometry():
    result = steps(G71_PROGRAM)
    contour = [s for s in result if s.in_contour]
    assert [s.block.line for s in contour] == [6, 7, 8, 9]
    assert [m.role for s in contour for m in s.moves] == ["contour"] * 4
    assert geometry(contour[1].moves[0])[2:4] == ((10.0, 2.0), (10.0, -10.0))


def test_missing_or_repeated_p_q_labels_are_refused():
    with pytest.raises(InterpretationError) as info:
        moves(G71_PROGRAM.replace("Q20 U0.4", "Q30 U0.4"))
    assert "no block N30" in info.value.message and info.value.location.line == 5
    with pytest.raises(InterpretationError) as info:
        moves(G71_PROGRAM + "N10 G00 X1.\n")
    assert "N10 stands on 2 blocks" in info.value.message


def test_threading_and_single_pass_cycles_are_one_row_each():
    program = START + "G00 X30. Z5.\nG32 Z-20. F1.5\nG00 X40.\nG92 X29. Z-20. F1.5\nX28.5\nG90 X25. Z-30. F0.2\nG76 P010060 Q50 R0.02\nG76 X27. Z-20. P900 Q300 F1.5\nG75 X10. Z-10. P1000 Q2000 F0.1\n"
    result = moves(program)
    assert [(m.line, m.kind) for m in result[2:]] == [
        (4, "thread"), (5, "rapid"), (6, "thread"), (7, "thread"), (8, "cycle"), (10, "thread"), (11, "cycle"),
    ]
    assert result[4].x0 == result[4].x1 == 20.0  # a cycle ends where it began


def test_system_b_uses_g90_g91_and_g77():
    program = "G18 G21 G95 F0.2\nG90 G00 X100. Z10.\nG91 G01 X-20. Z-5.\nG90 G77 X50. Z-10.\n"
    result = moves(program, gcode_system="B")
    assert geometry(result[1])[3] == (40.0, 5.0)
    assert result[2].kind == "cycle"


def test_macro_constants_are_evaluated_and_unknowns_pass_through_with_a_warning():
    reporter = Reporter()
    program = START + "#1 = 20.\n#2 = #1 * 2\nG01 X#2 Z[#1 - 25.]\nG01 X#500\nG01 Z-10.\nG00 X50.\n"
    result = moves(program, reporter)
    assert geometry(result[1])[3] == (20.0, -5.0)
    assert (result[2].x1, result[2].z1, result[2].exact) == (None, -5.0, False)
    assert result[3].x0 is None
    assert geometry(result[4])[3] == (25.0, -10.0)
    assert any("cannot be interpreted" in str(w) and ":6:" in str(w) for w in reporter.warnings)


@pytest.mark.parametrize("deleted", ["/#1 = 20.", "/2 #1 = 20.", "/IF [#3 EQ 0] THEN #1 = 20.", "/#[#1 - 9.] = 20."])
def test_a_variable_set_behind_a_block_delete_holds_either_value(deleted):
    """With the switch on the control skips the block and #1 stays 10; with it off #1 becomes 20.
    Neither is the program's one value: a move that reads it is not interpreted (as a word block
    behind '/' is not), never read with the value of the switch's one position."""
    result = moves(START + f"#1 = 10.\n#3 = 0\n{deleted}\nG01 X#1 Z0.\n")
    assert (result[-1].x1, result[-1].z1) == (None, 0.0)
    result = moves(START + f"#1 = 10.\n#3 = 0\n{deleted.lstrip('/2 ')}\nG01 X#1 Z0.\n")
    assert (result[-1].x1, result[-1].z1) == (10.0, 0.0)  # run without the '/', it sets #1 = 20.


def test_jump_targets_forget_what_only_one_path_knew():
    program = START + "#1 = 5.\nN100\nG01 X#1\n#1 = #1 + 1\nIF [#1 LT 10] GOTO 100\n"
    result = moves(program)
    assert result[1].x1 is None and result[1].x0 is None


@pytest.mark.parametrize("flow", ["M98 P2000", "M098 P2000", "M198 P2000", "M198 P2000 L3", "G65 P9000 A1.", "M99",
                                  "M99 P100"])
def test_after_a_call_or_a_return_the_motion_mode_is_not_assumed(flow):
    """The subprogram may leave G00 where the caller had G01 (and M99 in a main program loops back
    with whatever mode the last pass left): a block that relies on the mode is not interpreted.
    M198 calls a subprogram kept on an external device or the data server: a call like M98."""
    reporter = Reporter()
    result = steps("G18 G21 G99\nG00 X20. Z2.\nG01 Z0. F0.1\n" + flow + "\nX30. Z-5.\nG01 X40. Z-10.\nW-2.\n",
                   reporter)
    after, explicit, incremental = result[-3:]
    assert not after.interpreted and explicit.interpreted and explicit.moves[0].kind == "line"
    assert incremental.moves[0].known  # from the absolute end of the block before it
    result = steps("G18 G21 G99\nG00 X20. Z2.\nG01 Z0. F0.1\n" + flow + "\nG01 W-5.\n", reporter)
    assert result[-1].moves[0].z0 is None  # where the subprogram left the tool is not known
    assert any(":5:1: warning: block cannot be interpreted: the motion mode" in str(w) for w in reporter.warnings)


def test_subprogram_call_and_block_delete_warn():
    reporter = Reporter()
    result = moves(START + "M98 P1000\nG01 W-1.\n/G01 X10.\nG00 X50. Z5.\n", reporter)
    assert result[1].x0 is None
    text = "\n".join(str(w) for w in reporter.warnings)
    assert "M98" in text and "block delete" in text


@pytest.mark.parametrize("deleted", ["/M09", "/M01", "/M08 M05", "/2 M00", "/N50 M09 (COOLANT OFF)", "/G04 U1.",
                                     "/G04 P500", "/G01", "/G99", "/G18", "/S800", "/T0101", "/F0.2", "/G21 G40",
                                     "/ M09", "/G54"])
def test_a_block_delete_block_that_changes_nothing_keeps_the_position_known(deleted):
    """Run or skipped, a block that moves nothing and leaves every mode and modal value as it
    found them (the same tool, feed, speed, units...) leaves the tool where it was: the move
    after it starts from a known point, and only the '/' block itself is left as it is."""
    reporter = Reporter()
    program = "G18 G21 G40 G54 G99 T0101 F0.2 S800\nG00 X100. Z10.\nG01 X50. Z0.\n" + deleted + "\nX40. Z-5.\n"
    result = steps(program, reporter)
    after = result[-1].moves[0]
    assert (after.x0, after.z0) == (25.0, 0.0) and after.exact
    assert not any("block delete" in w.message for w in reporter.warnings)
    assert result[-1].modal == result[-3].modal


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 399).filter(lambda m: m not in (2, 30, 98, 99, 198)), st.sampled_from(["/", "/2 ", "/9"]),
       st.booleans())
def test_any_machine_m_code_behind_block_delete_keeps_the_position_known(number, switch, dwell):
    """The class: an M code of the machine (coolant, stops, spindle, chuck...) alone or with a
    dwell behind any block delete switch moves nothing and changes no mode."""
    reporter = Reporter()
    block = f"{switch}M{number:02d}" + (" G04 U0.5" if dwell else "")
    result = steps("G18 G21 G99 F0.2\nG00 X100. Z10.\nG01 X50. Z0.\n" + block + "\nX40. Z-5.\n", reporter)
    assert (result[-1].moves[0].x0, result[-1].moves[0].z0) == (25.0, 0.0)
    assert not any("block delete" in w.message for w in reporter.warnings)


@pytest.mark.parametrize("deleted, mode_unknown", [
    ("/G01 X80.", False), ("/U-2.", False), ("/G00", True), ("/G02 X50. Z-5. R5.", True), ("/G98", False),
    ("/G20", False), ("/T0202", False), ("/F0.1", False), ("/S500", False), ("/G55", False),
    ("/M98 P1000", False), ("/M99", False), ("/G50 X100. Z0.", False), ("/G28 U0.", False), ("/G10 P0 Z1.", False),
    ("/G65 P9010 A1.", False), ("/G41", False), ("/G#1", True), ("/M30", False),
])
def test_a_block_delete_block_that_moves_or_changes_a_mode_makes_the_position_depend_on_the_switch(deleted,
                                                                                                   mode_unknown):
    """What follows depends on the operator's switch: the block passes through with a warning,
    the position unknown after it; after a motion code behind '/' the motion mode is unknown too,
    so that no block written later relies on one the switch decides."""
    reporter = Reporter()
    program = "G18 G21 G40 G54 G99 T0101 F0.2 S800\nG01 X100. Z10.\nG01 X50. Z0.\n" + deleted + "\nG01 X40. Z-5.\n"
    result = steps(program, reporter)
    assert result[-1].moves[0].x0 is None or result[-1].moves[0].z0 is None
    assert any("block delete" in w.message and w.location.line == 4 for w in reporter.warnings)
    assert (result[-2].modal.motion is None) is mode_unknown
    assert result[-2].modal.tool == 1 and result[-2].modal.feed == 0.2  # the state as if skipped, never guessed


@pytest.mark.parametrize("call", ["G65 P9010 A1. B2", "G66 P9010 A1.\nX20. Z1.\nG67"])
def test_macro_calls_with_number_arguments_warn_and_lose_the_position(call):
    """Arguments are any numbers (no format alarm); what the macro does is not interpreted."""
    reporter = Reporter()
    result = moves(START + call + "\nG01 W-1.\nG00 X50. Z5.\n", reporter)
    assert any(m.x0 is None for m in result)
    assert (result[-1].x1, result[-1].z1) == (25.0, 5.0)
    assert "macro" in str(reporter.warnings[0])


def test_unknown_g_code_and_unsupported_codes_pass_through_with_a_warning():
    reporter = Reporter()
    result = moves(START + "G187 P1\nG01 X50.\nG00 X20. Z5.\n", reporter)
    assert (result[1].x0, result[1].z0, result[1].x1) == (None, None, 25.0)
    assert (result[-1].x1, result[-1].z1) == (10.0, 5.0)
    assert "G187" in str(reporter.warnings[0])


def test_address_for_an_axis_the_lathe_lacks_is_refused():
    with pytest.raises(InterpretationError) as info:
        moves(START + "G01 X10. Y5.\n")
    assert "PS0009" in info.value.message and info.value.location.col == 10


def test_feed_move_without_feed_warns_once_and_f0_is_refused():
    reporter = Reporter()
    moves("G00 X10. Z1.\nG01 Z0.\nG01 Z-1.\n", reporter)
    assert len([w for w in reporter.warnings if "F word" in w.message]) == 1
    with pytest.raises(InterpretationError):
        moves("G00 X10. Z1.\nG01 Z0. F0\n")


def test_g53_and_g28_alone():
    result = moves(START + "G53 G00 X0.\nG28\n")
    assert (result[1].x1, result[1].z1) == (None, 10.0)
    assert (result[2].x1, result[2].z1) == (None, None)


def test_full_circle_with_i_k():
    arc = moves(START + "G01 X20. Z0.\nG02 X20. Z0. I-5. K0.\n")[-1]
    assert geometry(arc)[2:6] == ((10.0, 0.0), (10.0, 0.0), (5.0, 0.0), "cw")


def test_full_circle_without_end_point():
    arc = moves(START + "G01 X20. Z0.\nG03 I0. K5.\n")[-1]
    assert geometry(arc)[2:6] == ((10.0, 0.0), (10.0, 0.0), (10.0, 5.0), "ccw")


@pytest.mark.parametrize("plane, arc", [("G17", "G02 C15.257 R30.578"), ("G17", "G03 H30. R20."),
                                         ("G19", "G02 Y5. R10."), ("G17", "G02 J5.")])
def test_an_arc_in_another_plane_is_said_and_leaves_the_position_unknown(plane, arc):
    """Whatever words it has (a C or Y end point, only a radius or a centre), an arc off the ZX
    plane moves X or Z on its way: it passes through with a warning and nothing after it is
    placed until an absolute move."""
    reporter = Reporter()
    result = steps(f"G18 G21 G99 F0.2\nG00 X100. Z10.\n{plane}\n{arc}\nG01 W-5.\nG18\nG00 X20. Z5.\n", reporter,
                   axes="XZCY")
    (warning,) = reporter.warnings
    assert warning.location.line == 4 and f"an arc in plane {plane}" in warning.message
    assert not result[3].interpreted
    after = result[4].moves[0]
    assert (after.x0, after.z0, after.x1, after.z1) == (None, None, None, None)
    assert (result[-1].moves[0].x1, result[-1].moves[0].z1) == (10.0, 5.0)


def test_a_rotary_move_alone_leaves_x_and_z_where_they_are():
    reporter = Reporter()
    result = steps(START + "G01 C90.\nG01 Z0.\n", reporter, axes="XZC")
    assert reporter.warnings == [] and result[2].moves == ()
    assert (result[3].moves[0].x0, result[3].moves[0].z0) == (50.0, 10.0)


def test_the_plain_number_warning_names_the_literal_when_the_address_is_also_an_expression():
    """Z-#1 Z1: the warning about the plain Z1 quotes Z1, not the expression given first (which made
    an internal error of it)."""
    reporter = Reporter()
    moves(START + "Z-#1 Z1\n", reporter=reporter)
    warned = [w for w in reporter.warnings if "has no decimal point" in w.message]
    assert len(warned) == 1 and warned[0].message.startswith("Z1 has no decimal point")


@pytest.mark.parametrize("program, where", [
    ("G00 X20. Z5.\nG01 Z0. F0.1\nG02 X40. Z-10. R10.\nZ-20.\n", (4, 1)),  # G02 in force, no R or I/K
    ("G00 X20. Z5.\nG01 Z0. F0.1\nG03 X40. Z-10.\n", (3, 1)),  # at the motion word the alarm is about
    ("G00 X20. Z5.\nG01 Z0. F0.1\n  G02 Z0. K0.\n", (3, 3)),  # I and K both zero, no I written
    ("G00 X20. Z5.\nG01 Z0. F0.1\nF0.\nX30.\n", (4, 1)),  # F0 in force
    ("G00 X20. Z5.\nG70 P10\n", (2, 1)),  # G70 without Q
    ("G00 X20. Z5.\nG01 X30. ,C1. F0.1\nG00 X40.\n", (2, None)),  # a corner with no feed move after it
    ("G00 X20. Z5.\n#1=[1/0]\n", (2, 1)),  # a macro expression the control refuses
])
def test_every_interpretation_error_has_a_column_and_a_caret(program, where):
    with pytest.raises(InterpretationError) as caught:
        steps("G18 G21 G99\n" + program)
    location, (line, col) = caught.value.location, where
    assert location.line == line + 1 and location.col is not None and col in (None, location.col)
    shown = format_message("error", caught.value.message, location).splitlines()
    assert shown[0].startswith(f"t.nc:{line + 1}:{location.col}: error: ")
    assert shown[1] == "    " + program.splitlines()[line - 1] and shown[2] == "    " + " " * (location.col - 1) + "^"


def test_each_program_of_a_file_numbers_its_own_contour_blocks():
    """A main program and its local subprogram each number their blocks from N10: the control
    looks for a cycle's P and Q in the program that runs it, so neither contour is ambiguous, and
    a G70 finishes its own program's contour. Two N10s in one program still are ambiguous."""
    main = ("O0001\nG18 G21 G99\nG00 X52. Z2.\nG71 U2. R1.\nG71 P10 Q20 U0.4 W0.1 F0.25\nN10 G00 X20.\n"
            "G01 Z0. F0.1\nN20 G01 X52.\nG70 P10 Q20\nM98 P0002\nM30\n")
    sub = "O0002\nN10 G00 X40.\nG01 Z-22. F0.1\nN20 G01 X52.\nG00 Z-20.\nG70 P10 Q20\nM99\n"
    result = moves(main + sub)
    finish = [m for m in result if m.line in (13, 14, 15)]  # the subprogram's contour, run by its G70
    assert [(m.line, m.x1, m.z1) for m in finish][-3:] == [(13, 20.0, -20.0), (14, 20.0, -22.0), (15, 26.0, -22.0)]
    with pytest.raises(InterpretationError, match="N10 stands on 2 blocks"):
        moves(main.replace("M98 P0002\n", "N10 M08\n"))


_MAIN = "O0001\nG18 G21 G99\nG00 X52. Z2.\nG71 U2. R1.\nG71 P10 Q20 U0.4 W0.1 F0.25\n"
_CONTOUR = "N10 G00 X20.\nG01 Z0. F0.1\nN20 G01 X52.\n"


@pytest.mark.parametrize("text, program, span, elsewhere", [
    # the contour only in the subprogram: once in the file, but not in the program that runs the cycle
    (_MAIN + "G00 Z2.\nM98 P0002\nM30\nO0002\n" + _CONTOUR + "M99\n", "O0001", "lines 1 to 8", "line 10"),
    # in two other programs: not found, not ambiguous
    (_MAIN + "M30\nO0002\n" + _CONTOUR + "M99\nO0003\n" + _CONTOUR + "M99\n", "O0001", "lines 1 to 6",
     "line 8, ..."),
    # after the program's M30, with no O number of its own: past the program's end
    (_MAIN + "G00 Z2.\nM30\n" + _CONTOUR, "O0001", "lines 1 to 7", "line 8"),
    # a cycle in the subprogram whose contour is in the main program
    ("O0001\nG18 G21 G99\n" + _CONTOUR + "M98 P0002\nM30\nO0002\nG00 X52. Z2.\nG71 U2. R1.\n"
     "G71 P10 Q20 U0.4 W0.1 F0.25\nM99\n", "O0002", "lines 8 to 12", "line 3"),
])
def test_a_cycle_finds_its_contour_only_in_the_program_that_runs_it(text, program, span, elsewhere):
    """The control looks for a cycle's P and Q in the program that runs it, from its O number
    to its M30, M02 or M99, and alarms PS0060 when they stand only elsewhere: a label that
    stood once in the file was used from another program, and one that stood in two other
    programs was called ambiguous."""
    with pytest.raises(InterpretationError) as caught:
        moves(text)
    message = caught.value.message
    assert message.startswith(f"G71 P10: no block N10 in {program} ({span}), the program that runs the cycle; "
                               f"N10 stands only outside it ({elsewhere})"), message
    assert "(FANUC alarm PS0060)" in message and "ambiguous" not in message
    assert caught.value.location.line == text.splitlines().index("G71 P10 Q20 U0.4 W0.1 F0.25") + 1


def test_a_return_before_the_cycle_or_behind_a_block_delete_does_not_end_its_program():
    """An M99 before the cycle (a conditional return) or behind '/' (skippable) is no end of the
    program for the cycle's P and Q: the contour before and after them is found."""
    text = ("O0001\nG18 G21 G99\nM98 P0002\nM30\nO0002\nIF [#1 EQ 1] GOTO 5\nM99\nN5\n" + _CONTOUR
            + "/M99\nG00 X52. Z2.\nG70 P10 Q20\nM99\n")
    finish = [m for m in moves(text) if m.line in (9, 10, 11)]
    assert [(m.line, m.x1, m.z1) for m in finish][-3:] == [(9, 10.0, 2.0), (10, 10.0, 0.0), (11, 26.0, 0.0)]  # radii
