"""The grammar: every construct issue 2 lists, and the messages for what it refuses."""

from __future__ import annotations

import pytest

from postproc.syntax import macro
from postproc.syntax.blocks import BLANK, BLOCK, HEADER, TAPE
from postproc.diagnostics import ProgramSyntaxError
from postproc.syntax.grammar import parse_block


def parse(text: str):
    return parse_block(text, 1, "\n", "t.nc")


def test_tape_mark_and_headers():
    assert parse("%").kind == TAPE
    assert parse("O1234 (PART)").kind == HEADER
    assert parse("o0001").kind == HEADER
    assert parse("<SHAFT-12>").kind == HEADER
    assert parse(":1234").kind == HEADER
    assert parse("   ").kind == BLANK


@pytest.mark.parametrize(
    "text, codes",
    [
        ("X10", (("X", "10"),)),
        ("X10.", (("X", "10."),)),
        ("X.5", (("X", ".5"),)),
        ("X+1.", (("X", "+1."),)),
        ("X -2.5", (("X", "-2.5"),)),
        ("x 1.5 z-2.", (("X", "1.5"), ("Z", "-2."))),
        ("T1 01", (("T", "101"),)),
        ("G01X0.42928932Z-0.03535534", (("G", "01"), ("X", "0.42928932"), ("Z", "-0.03535534"))),
        ("G01 X10. ,C1.", (("G", "01"), ("X", "10."), (",C", "1."))),
        ("G02 X10. Z-5. , R 2.", (("G", "02"), ("X", "10."), ("Z", "-5."), (",R", "2."))),
    ],
)
def test_words(text, codes):
    block = parse(text)
    assert block.kind == BLOCK
    assert block.codes == codes


def test_spelling_and_columns_are_kept():
    block = parse("N10 G01 X 10. (cut) z-2.;  (end)")
    assert block.label == 10
    assert [(w.letter, w.text, w.col) for w in block.words] == [("G", "G01", 4), ("X", "X 10.", 8), ("Z", "z-2.", 20)]
    assert [c.text for c in block.comments] == ["(cut)", "(end)"]
    assert block.has_eob


@pytest.mark.parametrize(
    "text, comments, eob_col",
    [
        ("N200 G01 Z.1 M09; (Retract, Collant Off);", ["(Retract, Collant Off)"], 16),
        ("G01 X1.;;", [], 7),
        ("G01 X1. ; ; (A) ;  ", ["(A)"], 8),
        ("G01 X1. (A); (B) (C);\t", ["(A)", "(B)", "(C)"], 11),
        (";", [], 0),
        (" ; (ONLY A COMMENT) ;", ["(ONLY A COMMENT)"], 1),
    ],
)
def test_semicolon_ends_the_block_wherever_a_printed_program_has_it(text, comments, eob_col):
    """``;`` is the end of block as the screen prints it: files carry it before and after a
    trailing comment, twice, with spaces after; the block's words are those before the first."""
    block = parse(text)
    assert [c.text for c in block.comments] == comments
    assert block.detail.eob_col == eob_col
    assert all(word.col < eob_col for word in block.words)


def test_semicolons_after_a_program_number():
    block = parse("O1200; (TOKARKA);")
    assert block.kind == HEADER
    assert [c.text for c in block.comments] == ["(TOKARKA)"]


def test_block_delete_levels():
    assert parse("/N10 G00 X1.").delete == 1
    assert parse("/3 G00 X1.").delete == 3


@pytest.mark.parametrize("text", ["(   #500 = TIPO de pieza (1-6, 0 = sin pieza)   )", "(a (b) c)",
                                  "G01 X10. (A (B (C) D) E)", "O1000 (A (B))", "#1 = 1 (A(B))", "M09; (A (B))"])
def test_nested_comments(text):
    """Real programs nest comments (a macro program's notes on its variables): read, kept."""
    block = parse(text)
    assert "".join(comment.text for comment in block.comments).startswith(text[text.index("("):][:6])


@pytest.mark.parametrize("text, col", [("G01 X10. %", 10), ("N10 %", 5), ("G01 X1. % (A)", 9), ("M30%", 4)])
def test_a_percent_inside_a_block_is_refused_as_the_end_of_the_tape(text, col):
    with pytest.raises(ProgramSyntaxError) as info:
        parse(text)
    assert info.value.location.col == col
    assert "'%' inside a block: '%' is the end of the tape" in info.value.message


def test_a_percent_inside_a_comment_is_text():
    assert parse("G01 X10. (50% FEED)").comments[0].text == "(50% FEED)"


def test_macro_assignment_and_expression_precedence():
    block = parse("#1 = #2 + 3 * [#4 - 1] / 2")
    statement = block.statement
    assert isinstance(statement, macro.Assignment)
    value = macro.evaluate(statement.value, {2: 1.0, 4: 5.0})
    assert value == pytest.approx(1 + 3 * 4 / 2)


@pytest.mark.parametrize(
    "text, expected",
    [
        ("#1=SIN[30]", 0.5),
        ("#1=COS[60.]", 0.5),
        ("#1=ATAN[1]/[-1]", 135.0),
        ("#1=SQRT[16]", 4.0),
        ("#1=ABS[-2.5]", 2.5),
        ("#1=ROUND[2.5]", 3.0),
        ("#1=ROUND[-2.5]", -3.0),
        ("#1=FIX[-1.7]", -1.0),
        ("#1=FUP[-1.2]", -2.0),
        ("#1=FUP[1.2]", 2.0),
        ("#1=7 MOD 4", 3.0),
        ("#1=6 AND 3", 2.0),
        ("#1=6 OR 3", 7.0),
        ("#1=6 XOR 3", 5.0),
        ("#1=-[2+3]", -5.0),
    ],
)
def test_functions_evaluate_as_the_control_does(text, expected):
    statement = parse(text).statement
    assert macro.evaluate(statement.value, {}) == pytest.approx(expected)


def test_control_flow_statements():
    assert isinstance(parse("IF [#500 EQ 0] GOTO 100").statement, macro.IfGoto)
    assert isinstance(parse("IF[#2LE#3]GOTO222").statement, macro.IfGoto)
    assert isinstance(parse("IF [#1 GT 2] THEN #3 = 4").statement, macro.IfThen)
    assert parse("WHILE [#1 LT 10] DO 1").statement == macro.WhileDo(
        macro.Comparison("LT", macro.Variable(1), macro.Number(10.0, "10")), 1
    )
    assert isinstance(parse("WH[[#1GE#2]OR[#1EQ#2]]DO1;").statement, macro.WhileDo)
    assert parse("END 1").statement == macro.EndLoop(1)
    assert parse("N5 GOTO 10").statement == macro.Goto(macro.Number(10.0, "10"))
    assert parse("N5 GOTO 10").label == 5
    assert isinstance(parse("DPRNT[X#5061[44]*Z#5062[44]]").statement, macro.Output)


def test_words_with_macro_values():
    block = parse("G65P3002X0.Y0.D#501R#2Z#3I#4C2.E42T200V300F#10;")
    letters = [letter for letter, _ in block.codes]
    assert letters == list("GPXYDRZICETVF")
    assert block.codes[4] == ("D", macro.Variable(501))
    block = parse("G91G#8X-#4Y0.F#20;")
    assert block.codes[1] == ("G", macro.Variable(8))
    assert block.codes[2] == ("X", macro.Negate("-", macro.Variable(4)))
    block = parse("X[#1+2.]")
    assert macro.evaluate(block.codes[0][1], {1: 1.0}) == 3.0


def test_m98_m99_g65():
    assert parse("M98 P1234").codes == (("M", "98"), ("P", "1234"))
    assert parse("M99").codes == (("M", "99"),)
    assert parse("G65 P9010 A1. B2.").codes[0] == ("G", "65")


@pytest.mark.parametrize(
    "text, col, words",
    [
        ("G2 X-9.5. Y0. R9.5 Z-0.5.;", 9, "second decimal point"),
        ("#1=#1-#11:", 10, "unexpected character ':'"),
        ("G01 X", 5, "address X has no value"),
        ("G01 X Z1.", 5, "address X has no value"),
        ("G01 X1. (open", 9, "comment is not closed"),
        ("G01 X1.)", 8, "')' without"),
        ("(a)b)", 5, "')' without a '('"),
        ("M09 (A (B) C", 5, "comment is not closed: '(' without its ')' on its line: close it with ')'"),
        ("G01 X1. (A (B (C (D))))", 9, "comment nested more than three deep: take the innermost parentheses out"),
        ("(unclosed", 1, "comment is not closed"),
        ("G01 X10. (unclosed", 10, "comment is not closed"),
        ("G01 X1. (A)(B", 12, "comment is not closed"),
        ("10 G01", 1, "number without an address"),
        ("#1 = [2 + 3", 12, "']' missing"),
        ("G01 X1. #1=2", 9, "stand alone"),
        ("G01 X1. N10", 9, "sequence number N must begin"),
        ("X1. ; G01", 7, "only comments and ';' may follow"),
        ("N200 G01 Z.1 M09; (C); X1.", 24, "only comments and ';' may follow"),
    ],
)
def test_refusals_name_the_column(text, col, words):
    with pytest.raises(ProgramSyntaxError) as info:
        parse(text)
    assert info.value.location.col == col, str(info.value)
    assert words in info.value.message
    assert str(info.value).startswith(f"t.nc:1:{col}: error: ")


def test_lossless_tokens_rebuild_the_line():
    """Every character of a parsed line is in a token or in the white space between tokens."""
    text = "N10\tG01 X 10. (c (n) ) z-2.;  (end)"
    tokens = _tokens(text)
    rebuilt, last = [], 0
    for token in tokens:
        assert text[last : token.start_pos].strip(" \t") == ""
        rebuilt.append(text[last : token.start_pos] + token.value)
        last = token.end_pos
    rebuilt.append(text[last:])
    assert "".join(rebuilt) == text


def _tokens(text):
    from lark import Token

    from postproc.syntax.grammar import parser

    tree = parser().parse(text)
    return sorted(tree.scan_values(lambda v: isinstance(v, Token)), key=lambda t: t.start_pos)


OTHER_CONTROLS = [
    ("Siemens SINUMERIK", ["N60 G2 X50 Z-25 CR=5", "R1=10", "DEF REAL DIA", "N10 G18 G90 G95 DIAMON",
                           "LIMS=3000", 'MSG("ROUGHING")', 'CYCLE95("KONTUR",1.5,0.1,0.2,,0.2,0.1,0.1,9)',
                           "G1 X=IC(5) Z-10", 'T="ROUGH" D1']),
    ("HEIDENHAIN", ["0 BEGIN PGM TURN MM", "1 TOOL CALL 1 Z S2000", "2 L X+40 Z+2 R0 FMAX", "9 END PGM TURN MM"]),
    ("LinuxCNC", ["#<dia> = 40", "G1 X[#<dia>] Z-10", "o100 sub", "o100 call [1]", "O<turn> endsub"]),
    ("Okuma OSP", ["$O1234.MIN%", "NAT01 T010101 M42", "NLAP1 G81", "VC1=20"]),
]


@pytest.mark.parametrize("control, text", [(control, text) for control, lines in OTHER_CONTROLS for text in lines])
def test_a_line_of_another_controls_program_is_named_as_such(control, text):
    """A program posted for another control and brought in by mistake fails at its first line
    a FANUC control refuses; the error says whose line it is, so that nobody mends the program
    block by block into something that parses and means another thing."""
    with pytest.raises(ProgramSyntaxError) as info:
        parse(text)
    assert f"this line is written for a{'n' if control[0] in 'AEIOU' else ''} {control} control, not a FANUC one" \
        in info.value.message


def test_no_line_of_a_fanuc_program_is_taken_for_another_controls():
    """The names are given only to lines that fail; none of the lines of the FANUC corpus, nor the
    FANUC lines the catalogue refuses, looks like another control's."""
    from postproc.syntax.grammar import _other_control
    from support.corpus import corpus

    for path in corpus("fanuc") + corpus("fanuc-mill"):
        for line in path.read_bytes().decode("utf-8", "replace").splitlines():
            assert _other_control(line) == "", (path.name, line)
    for text in ["G00 X1.; G01 Z1.", "G01 X1. N10", "#1 = [2 + 3", "G00 X1. (open", "G01 X10. ,C1.", "10 G01 X1.",
                 "IF [#1 EQ 1] GOTO"]:
        assert _other_control(text) == "", text


@pytest.mark.parametrize("char, remedy", [
    ("\ufeff", "a byte order mark inside the program"), ("\u00a0", "a no-break space"),
    ("\u200b", "a zero-width space"), ("\x1a", "a DOS end-of-file mark (Ctrl-Z): end the program with '%' before it"),
    ("\x0c", "a form feed"), ("\u2212", "a minus sign from a word processor: type '-'"),
    ("\u2013", "a dash from a word processor"), ("\x00", "is this a text program?"), ("\u0661", "is this a text program?"),
])
@pytest.mark.parametrize("where", ["{}G01 X10.", "G01 X10.{}", "G01 {}X10. Z-5."])
def test_a_stray_character_a_text_program_picks_up_is_named_with_its_remedy(char, remedy, where):
    """A joined file's byte order mark, a space or a minus copied from a document, a DOS Ctrl-Z:
    the error names the character, where it comes from and what to do, wherever it stands; a
    character of no known origin asks whether the file is a text program at all."""
    text = where.format(char)
    with pytest.raises(ProgramSyntaxError) as info:
        parse(text)
    assert info.value.message == f"a character the control does not read (U+{ord(char):04X}): " + \
        info.value.message.split("): ", 1)[1]
    assert remedy in info.value.message and info.value.location.col == text.index(char) + 1
