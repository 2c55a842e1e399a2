"""Hypothesis strategies that write FANUC programs the way people and CAM systems do.

``lines()`` writes any block the grammar accepts (every address, macro statements,
comments anywhere, odd spacing and case); ``lathe_programs()`` writes whole programs a
lathe interpreter runs without error, with every formatting habit of the corpus (CRLF,
tabs, ``;`` as a printed end of block, also twice and around a comment, leading-dot
numbers, a label after the opening ``%``, a last line without its newline).
"""

from __future__ import annotations

from hypothesis import strategies as st

SPACE = st.sampled_from(["", "", "", " ", "  ", "\t"])
EOL = st.sampled_from(["\n", "\n", "\r\n", "\r\n", "\r"])


@st.composite
def numbers(draw, signed: bool = True, digits: int = 5) -> str:
    """``10``, ``10.``, ``.5``, ``-0.42928932``, ``+1.``: every spelling FANUC reads (at most
    nine digits, the control's limit; at most ``digits`` before the point)."""
    sign = draw(st.sampled_from(["", "", "-", "+"])) if signed else ""
    whole = draw(st.text("0123456789", min_size=0, max_size=digits))
    point = draw(st.booleans())
    fraction = draw(st.text("0123456789", min_size=0, max_size=9 - len(whole))) if point else ""
    if not whole and not fraction:
        whole = draw(st.text("0123456789", min_size=1, max_size=3))
    return f"{sign}{whole}{'.' if point else ''}{fraction}"


def _case(draw, letter: str) -> str:
    return letter.lower() if draw(st.integers(0, 4)) == 0 else letter


@st.composite
def comments(draw) -> str:
    text = draw(st.text(st.characters(blacklist_characters="()\r\n\x00", blacklist_categories=("Cs",)), max_size=20))
    if draw(st.integers(0, 5)) == 0:
        inner = draw(st.text("ABC 123-", max_size=6))
        text = f"{text}({inner}){text[:3]}"
    return f"({text})"


@st.composite
def words(draw, letters: str = "ABCDEFGHIJKLMPQRSTUVWXYZ") -> str:
    letter = _case(draw, draw(st.sampled_from(letters)))
    return f"{letter}{draw(SPACE)}{draw(numbers())}"


@st.composite
def expressions(draw, depth: int = 0) -> str:
    atoms = [numbers(signed=False).map(str), st.integers(1, 999).map(lambda n: f"#{n}")]
    if depth < 2:
        atoms.append(expressions(depth + 1).map(lambda e: f"[{e}]"))
        atoms.append(
            st.tuples(st.sampled_from(["SIN", "COS", "ABS", "SQRT", "ROUND", "FIX", "FUP"]), expressions(depth + 1)).map(
                lambda t: f"{t[0]}[{t[1]}]"
            )
        )
    left = draw(st.one_of(*atoms))
    if draw(st.booleans()):
        op = draw(st.sampled_from(["+", "-", "*", "/", " AND ", " OR ", " MOD "]))
        return f"{left}{op}{draw(st.one_of(*atoms))}"
    return left


@st.composite
def macro_statements(draw) -> str:
    kind = draw(st.integers(0, 5))
    condition = f"[{draw(expressions())} {draw(st.sampled_from(['EQ', 'NE', 'GT', 'GE', 'LT', 'LE']))} {draw(expressions())}]"
    if kind == 0:
        return f"#{draw(st.integers(1, 999))}{draw(SPACE)}={draw(SPACE)}{draw(expressions())}"
    if kind == 1:
        return f"IF{draw(SPACE)}{condition}{draw(SPACE)}GOTO{draw(SPACE)}{draw(st.integers(1, 9999))}"
    if kind == 2:
        return f"IF {condition} THEN #{draw(st.integers(1, 999))}={draw(expressions())}"
    if kind == 3:
        return f"{draw(st.sampled_from(['WHILE', 'WH']))}{condition}DO{draw(st.integers(1, 3))}"
    if kind == 4:
        return f"END{draw(st.integers(1, 3))}"
    return f"GOTO{draw(SPACE)}{draw(st.integers(1, 9999))}"


@st.composite
def lines(draw) -> str:
    """One line the grammar accepts (no line ending)."""
    parts = [draw(SPACE)]
    if draw(st.integers(0, 9)) == 0:
        parts.append(draw(st.sampled_from(["/", "/1", "/9"])) + draw(SPACE))
    if draw(st.booleans()):
        parts.append(f"{_case(draw, 'N')}{draw(SPACE)}{draw(st.integers(0, 99999))}{draw(SPACE)}")
    if draw(st.integers(0, 6)) == 0:
        parts.append(draw(macro_statements()) + draw(SPACE))
    else:
        for _ in range(draw(st.integers(0, 6))):
            choice = draw(st.integers(0, 12))
            if choice == 0:
                parts.append(draw(comments()))
            elif choice == 1:
                parts.append(f",{draw(st.sampled_from('CRcr'))}{draw(numbers(signed=False))}")
            elif choice == 2:
                parts.append(f"{draw(st.sampled_from('XZxz'))}{draw(SPACE)}-#{draw(st.integers(1, 33))}")
            else:
                parts.append(draw(words()))
            parts.append(draw(SPACE) if parts[-1][-1].isalpha() is False else " ")
    if draw(st.booleans()):
        parts.append(draw(ends()))
    elif draw(st.integers(0, 3)) == 0:
        parts.append(draw(comments()) + draw(SPACE))
    return "".join(parts)


@st.composite
def ends(draw) -> str:
    """A printed end of block: ``;``, then perhaps comments and more ``;`` (``M09; (OFF);``)."""
    parts = [";" + draw(SPACE)]
    for _ in range(draw(st.integers(0, 3))):
        parts.append(draw(st.one_of(comments(), st.just(";"))) + draw(SPACE))
    return "".join(parts)


@st.composite
def canonical_lines(draw) -> str:
    """A block in the canonical form a CAM system writes (see postproc.syntax.fastpath): N, G00-G03,
    X Z I K R with a decimal point, F, a simple comment, ``;``, each optional, in that order,
    one space or none between."""

    def length() -> str:
        sign = draw(st.sampled_from(["", "", "-", "+"]))
        whole = draw(st.text("0123456789", min_size=0, max_size=4))
        fraction = draw(st.text("0123456789", min_size=0 if whole else 1, max_size=4))
        return f"{sign}{whole}.{fraction}"

    gap = st.sampled_from(["", " "])
    parts = []
    if draw(st.booleans()):
        parts.append(f"N{draw(st.integers(0, 99999))}{draw(gap)}")
    if draw(st.booleans()):
        parts.append(f"G{draw(st.sampled_from(['0', '00', '1', '01', '2', '02', '3', '03']))}{draw(gap)}")
    geometry = draw(st.integers(0, 3)) > 0  # or none at all: an F or a G alone
    for letter in "XZIKR":
        if geometry and draw(st.integers(0, 2)) > 0:
            parts.append(f"{letter}{length()}{draw(gap)}")
    if draw(st.booleans()):
        parts.append(f"F{draw(st.sampled_from(['0.2', '.15', '100', '0.150', '12.']))}{draw(gap)}")
    if draw(st.integers(0, 3)) == 0:
        parts.append(f"({draw(st.text('ABC 12;-', max_size=8))}){draw(gap)}")
    if draw(st.booleans()):
        parts.append(";")
    return "".join(parts)


@st.composite
def lathe_blocks(draw) -> str:
    """A block a lathe interpreter runs: rapids, lines, dwell and the usual modal codes."""
    parts = [draw(SPACE)]
    if draw(st.booleans()):
        parts.append(f"N{draw(st.integers(1, 9999))} ")
    kind = draw(st.integers(0, 5))
    if kind == 0:
        parts.append(draw(st.sampled_from(["G00", "G0", "g00", "G01", "G1"])) + draw(SPACE))
        axes = draw(st.sampled_from(["X", "Z", "XZ", "U", "W", "UW", "XW", "UZ"]))
        for axis in axes:  # within a lathe's travel (machine.bounds.MAX_TRAVEL), 25 increments too
            number = numbers(digits=3 if axis in "XZ" else 2)
            parts.append(f"{_case(draw, axis)}{draw(SPACE)}{draw(number)}{draw(SPACE)}")
        if draw(st.booleans()):
            parts.append(f"F{draw(st.sampled_from(['0.2', '.15', '100', '0.008']))}")
    elif kind == 1:
        parts.append(draw(st.sampled_from(["G96 S200 M03", "G97 S1500", "G50 S2000", "M08", "M05", "G99", "G98",
                                           "G40", "G18 G21 G40", "G54", "T0101", "G04 X1.5", "G04 P500", "M01"])))
    elif kind == 2:
        parts.append(draw(comments()))
    elif kind == 3:
        parts.append(f"F{draw(st.sampled_from(['0.25', '.1', '0.008']))}")
    elif kind == 4:
        parts.append("")
    else:
        parts.append(f"G01 X{draw(numbers(signed=False, digits=3))} Z{draw(numbers(digits=3))} F0.2")
    if draw(st.integers(0, 3)) == 0:
        parts.append(draw(ends()))
    elif draw(st.integers(0, 3)) == 0:
        parts.append(draw(SPACE) + draw(comments()))
    parts.append(draw(st.sampled_from(["", "", " ", "\t"])))
    return "".join(parts)


@st.composite
def lathe_programs(draw) -> str:
    """A whole program a lathe interpreter runs without error, formatted in every habit."""
    eol = draw(EOL)
    mixed = draw(st.integers(0, 4)) == 0
    body = [draw(lathe_blocks()) for _ in range(draw(st.integers(0, 25)))]
    head = draw(st.sampled_from([[], ["%"], ["%", "O1234"], ["o0001 (PART)"], ["%", "<PART-7>"], ["%O1200(TOKARKA)"],
                                 ["% O0042 (SHAFT);"], ["%;", "O1234;"]]))
    tail = draw(st.sampled_from([[], ["M30"], ["M30", "%"], ["M30;", "%"]]))
    lines_ = head + ["G00 X50. Z5. F0.2"] + body + tail
    text = "".join(line + (draw(EOL) if mixed else eol) for line in lines_)
    if draw(st.booleans()):
        text = text.rstrip("\r\n")
    return text
