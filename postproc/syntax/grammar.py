"""The grammar path: one line through ``grammars/fanuc.lark`` into a :class:`~postproc.syntax.blocks.Block`.

The Lark parser is built once per process, in memory, from the grammar shipped inside
the package (or, in a clone that was never installed, from the clone's ``grammars/``). No
Lark exception leaves this module: a line the grammar refuses becomes a
:class:`~postproc.diagnostics.ProgramSyntaxError` with the line, the column and, where
the mistake is a common one, the FANUC alarm it would raise.
"""

from __future__ import annotations

import functools
import importlib.resources
import re
from pathlib import Path

from lark import Lark, Token, Tree
from lark.exceptions import LarkError, UnexpectedCharacters, UnexpectedEOF, UnexpectedToken

from . import macro
from .blocks import BLANK, BLOCK, HEADER, NO_DETAIL, TAPE, Block, Comment, Detail, Word
from ..diagnostics import Location, ProgramSyntaxError


@functools.lru_cache(maxsize=1)
def parser() -> Lark:
    """The LALR parser of ``fanuc.lark``, built on first use."""
    return Lark(grammar_text(), parser="lalr", lexer="contextual", keep_all_tokens=True)


def grammar_text() -> str:
    """``fanuc.lark`` as installed (the package ``postproc.grammars``, which the build maps from
    the top-level ``grammars/``), or from ``grammars/`` beside the package when postproc is
    imported from a clone that was never installed: the same file either way."""
    try:
        grammar = importlib.resources.files("postproc.grammars")
    except ModuleNotFoundError:
        grammar = Path(__file__).resolve().parents[2] / "grammars"
    return grammar.joinpath("fanuc.lark").read_text("utf-8")


class _LineSyntaxError(Exception):
    def __init__(self, message: str, col: int):
        super().__init__(message)
        self.message = message
        self.col = col  # 0-based


def parse_block(text: str, line: int, eol: str, file: str) -> Block:
    """Parse one line (without its ending) into a block, or raise ProgramSyntaxError."""
    try:
        tree = parser().parse(text)
        return _block_from_tree(tree, text, line, eol)
    except _LineSyntaxError as exc:
        raise ProgramSyntaxError(exc.message + _other_control(text), Location(file, line, exc.col + 1, text)) from None
    except LarkError as exc:
        message, col = _explain(exc, text)
        raise ProgramSyntaxError(message + _other_control(text), Location(file, line, col + 1, text)) from None


def parse_detail(text: str) -> Detail:
    """Spellings and columns of a line that is known to parse."""
    tree = parser().parse(text)
    return _block_from_tree(tree, text, 0, "").detail


# ---------------------------------------------------------------- error messages

#: What another control's programs write that a FANUC control refuses, by control: a program
#: brought in by mistake is named as such, so that the error is not read as a typing mistake
#: to be mended block by block. Matched against a line that failed to parse (another control's
#: ``CYCLE95("K",1)`` reads to a FANUC control as a comment in parentheses).
_OTHER_CONTROLS = (
    ("a Siemens SINUMERIK", re.compile(
        r"(?i)\bCYCLE\d{2,3}\s*\(|\b(?:MSG|TRANS|ATRANS|AC|IC)\s*\(|\bDIAM(?:ON|OF|90)\b|\bR\d+\s*=|"
        r"\b(?:LIMS|CR|AR|RND|RNDM|CHR|CHF|ANG|SPOS|SF)\s*=|\bDEF\s+(?:REAL|INT|BOOL|STRING|AXIS|FRAME)\b|"
        r"\bGOTO[FBC]\s|\bT\s*=\s*\"|\bG5[0-9]{2}\b|\bSUPA\b|\bMCALL\b")),
    ("a HEIDENHAIN", re.compile(
        r"(?i)^\s*\d+\s+(?:BEGIN\s+PGM|END\s+PGM|TOOL\s+CALL|CYCL\s+DEF|LBL\s|CALL\s+LBL|[LC]\s+[XZ][+-]|"
        r"CC\s+[XZ]|RND\s+R|CHF\s)|\bFMAX\b")),
    ("a LinuxCNC", re.compile(
        r"(?i)#<[^>]*>|^\s*o\s*(?:<[^>]*>|\d+)\s*(?:sub|endsub|call|if|elseif|else|endif|while|endwhile|do|"
        r"repeat|endrepeat|return|break|continue)\b")),
    ("an Okuma OSP", re.compile(r"(?i)^\s*\$|\bNAT\d+|\bV[CS]\d+\s*=|^\s*N[A-Z]{2,}[A-Z0-9]*\s+G")),
)

def _other_control(text: str) -> str:
    """A note for a line written for another control, or ''."""
    for control, pattern in _OTHER_CONTROLS:
        if pattern.search(text):
            return (f" (this line is written for {control} control, not a FANUC one: postproc reads FANUC lathe "
                    "programs; post the part for a FANUC control)")
    return ""



#: Characters a text program picks up on its way to postproc, and where from: the remedy is
#: then the user's to take, not a guess at a binary file.
_KNOWN_CHARACTERS = {
    "\ufeff": "a byte order mark inside the program (files joined together, each with its mark?): delete it",
    "\u00a0": "a no-break space (copied from a document or a web page?): type a plain space",
    "\u200b": "a zero-width space (copied from a document or a web page?): delete it",
    "\x1a": "a DOS end-of-file mark (Ctrl-Z): end the program with '%' before it, or delete it",
    "\x0c": "a form feed (a page break from an editor): delete it",
    "\u2212": "a minus sign from a word processor: type '-'",
    "\u2013": "a dash from a word processor: type '-' for a minus",
}


def _explain(exc: LarkError, text: str) -> tuple[str, int]:
    """A message in the user's terms and the 0-based column of the mistake."""
    if isinstance(exc, UnexpectedCharacters):
        col = exc.column - 1
        char = text[col] if col < len(text) else ""
        before = text[:col].rstrip(" \t")
        if char == "(":
            rest = text[col:].split("\n", 1)[0]
            if rest.count("(") == rest.count(")"):
                return "comment nested more than three deep: take the innermost parentheses out", col
            return "comment is not closed: '(' without its ')' on its line: close it with ')'", col
        if char == "%":
            return _PERCENT_IN_BLOCK, col
        if char == ")":
            return "')' without a '(' opening a comment", col
        if char and (not char.isprintable() or ord(char) > 126):
            known = _KNOWN_CHARACTERS.get(char, "is this a text program?")
            return f"a character the control does not read (U+{ord(char):04X}): {known}", col
        if char == "." and before and (before[-1].isdigit() or before[-1] == "."):
            return "a second decimal point in one number (FANUC alarm PS0007)", col
        if char.isdigit() or char in "+-.":
            if not before or before.endswith(";"):
                return "a number without an address letter (FANUC alarm PS0004)", col
            return f"{char!r} cannot follow here: a number without an address letter? (FANUC alarm PS0004)", col
        if char == "#":
            return "'#' variable where the block cannot take one", col
        if char.isalpha() and before and before[-1].isalpha():
            return f"address {before[-1].upper()} has no value (FANUC alarm PS0005)", col - 1
        if char.isalpha() and char.upper() == "N":
            return "a sequence number N must begin the block", col
        return f"unexpected character {char!r}", col
    if isinstance(exc, UnexpectedToken):
        token = exc.token
        if token.type == "$END":
            return _explain_end(text, exc.expected)
        col = token.column - 1
        history = [t for t in (exc.token_history or ()) if t is not None]
        last = history[-1] if history else None
        if token.type == "SEQUENCE_NUMBER":
            return "a sequence number N must begin the block", col
        if token.type == "PERCENT":
            return _PERCENT_IN_BLOCK, col
        if last is not None and last.type == "EOB":
            return ("only comments and ';' may follow ';', the end of the block: the rest goes on a line of its own, a "
                    "comment in parentheses (';' starts a comment on Siemens, HEIDENHAIN and LinuxCNC controls, not on a "
                    "FANUC)"), col
        if last is not None and last.type == "ADDRESS":
            return f"address {last.upper()} has no value (FANUC alarm PS0005)", last.column - 1
        if last is not None and last.type == "SIGN":
            return "a sign without a number", last.column - 1
        if token.type == "NUMBER" and (last is None or last.type in ("SEQUENCE_NUMBER", "BLOCK_DELETE", "COMMENT")):
            return "a number without an address letter (FANUC alarm PS0004)", col
        if token.type == "EOB":
            return "';' where a value is still missing", col
        if token.type in ("ADDRESS", "PROGRAM_NUMBER", "VARIABLE", "IF", "GOTO", "WHILE"):
            return f"{token!s} cannot follow here: the block's statement or expression is not complete", col
        return f"unexpected {token!s}", col
    if isinstance(exc, UnexpectedEOF):
        return _explain_end(text, exc.expected)
    return f"cannot parse this block ({exc.__class__.__name__})", 0


#: '%' after the start of a block: the end-of-record mark, which the control reads as the end of
#: the tape wherever it stands.
_PERCENT_IN_BLOCK = ("'%' inside a block: '%' is the end of the tape (end of record), where the control stops reading, "
                     "even in the middle of a block; it stands on a line of its own after the program's last block: "
                     "delete it here, or give it a line of its own where the tape ends")


_KEYWORD_AT_END = re.compile(r"(?i)(goto|then|do|end|while|wh|if)$")


def _explain_end(text: str, expected) -> tuple[str, int]:
    stripped = text.rstrip(" \t")
    col = len(stripped)
    keyword = _KEYWORD_AT_END.search(stripped)
    if keyword:
        word = keyword.group(1).upper()
        return f"{word} at the end of the block: what it needs is missing (FANUC alarm PS0114)", keyword.start()
    if stripped and stripped[-1].isalpha():
        return f"address {stripped[-1].upper()} has no value (FANUC alarm PS0005)", col - 1
    if "RSQB" in expected:
        return "']' missing: the bracket is not closed (FANUC alarm PS0118)", col
    if stripped.endswith(("+", "-")):
        return "a sign without a number", col - 1
    return "the block ends before its statement is complete (FANUC alarm PS0114)", col


# ---------------------------------------------------------------- tree to block


def _first_token(node) -> Token:
    while isinstance(node, Tree):
        node = node.children[0]
    return node


def _block_from_tree(tree: Tree, text: str, line: int, eol: str) -> Block:
    (top,) = tree.children
    kind = top.data
    items: list[tuple[int, object]] = []  # (start column, item)
    for child in top.children:
        items.append((_first_token(child).start_pos, child))
    if kind == "tape_mark":
        return Block(line, text, eol, TAPE, detail=_detail_of(items, text, ()))
    if kind == "program_header":
        return Block(line, text, eol, HEADER, detail=_detail_of(items, text, ()))
    if not items:
        return Block(line, text, eol, BLANK, detail=NO_DETAIL)

    label = delete = statement = None
    words: list[Word] = []
    codes: list[tuple[str, object]] = []
    bounds = [start for start, _ in items] + [len(text)]
    for index, (start, item) in enumerate(items):
        end = _end_before(text, start, bounds[index + 1])
        if isinstance(item, Token):
            if item.type == "BLOCK_DELETE":
                delete = int(item[1:]) if len(item) > 1 else 1
            elif item.type == "SEQUENCE_NUMBER":
                label = int(_digits(item[1:]))
            continue
        if item.data in ("word", "corner_word"):
            address = item.children[0]
            letter = address.upper() if item.data == "word" else "," + address[-1].upper()
            value = _word_value(item.children[1])
            words.append(Word(letter, text[start:end], start, value))
            codes.append((letter, value))
        else:
            if statement is not None:
                raise _LineSyntaxError("two macro statements in one block", start)
            statement = _statement(item)
    if statement is not None and words:
        col = next(start for start, item in items if isinstance(item, Tree) and item.data not in ("word", "corner_word"))
        raise _LineSyntaxError("a macro statement must stand alone in its block (FANUC alarm PS0114)", col)
    detail = _detail_of(items, text, tuple(words))
    return Block(line, text, eol, BLOCK, label, delete, tuple(codes), statement, detail=detail)


def _detail_of(items, text: str, words: tuple[Word, ...]) -> Detail:
    comments = []
    label_col = eob_col = None
    for start, item in items:
        if isinstance(item, Token):
            if item.type == "COMMENT":
                comments.append(Comment(str(item), start))
            elif item.type == "EOB" and eob_col is None:  # the block ends at its first ';'
                eob_col = start
            elif item.type == "SEQUENCE_NUMBER":
                label_col = start
    return Detail(words, tuple(comments), label_col, eob_col)


def _end_before(text: str, start: int, stop: int) -> int:
    end = stop
    while end > start and text[end - 1] in " \t":
        end -= 1
    return end


def _digits(token: str) -> str:
    return token.replace(" ", "").replace("\t", "")


def _word_value(node):
    """A plain number as its literal string, anything else as an expression."""
    if node.data == "number":
        return _digits(node.children[0])
    if node.data == "signed" and isinstance(node.children[1], Tree) and node.children[1].data == "number":
        return node.children[0] + _digits(node.children[1].children[0])
    return _expr(node)


def _expr(node):
    data = node.data
    children = node.children
    if data == "number":
        digits = _digits(children[0])
        return macro.Number(float(digits), digits)
    if data == "variable":
        token = children[0]
        if token.startswith("#_"):
            return macro.Variable(0, name=token[1:].upper())
        return macro.Variable(int(_digits(token[1:])))
    if data == "indirect_variable":
        return macro.Variable(_expr(children[2]))
    if data == "bracket":
        return _expr(children[1])
    if data in ("signed", "negate"):
        return macro.Negate(str(children[0]), _expr(children[1]))
    if data == "binary":
        op = children[1].upper()
        left, right = children[0], children[2]
        # FANUC writes the two-argument arctangent as ATAN[y]/[x].
        if op == "/" and _is_atan_call(left) and isinstance(right, Tree) and right.data == "bracket":
            return macro.Call("ATAN2", (_expr(left.children[2]), _expr(right.children[1])))
        return macro.Binary(op, _expr(left), _expr(right))
    if data == "comparison":
        return macro.Comparison(children[1].upper(), _expr(children[0]), _expr(children[2]))
    if data == "call":
        args = tuple(_expr(child) for child in children[2:-1] if isinstance(child, Tree))
        return macro.Call(children[0].upper(), args)
    raise AssertionError(f"unexpected expression node {data}")


def _is_atan_call(node) -> bool:
    return (
        isinstance(node, Tree)
        and node.data == "call"
        and node.children[0].upper() in ("ATAN", "ATN")
        and len([c for c in node.children[2:-1] if isinstance(c, Tree)]) == 1
    )


def _loop_number(keyword: Token, number: Token) -> int:
    """The identification number of DO or END: 1, 2 or 3, nothing else."""
    digits = _digits(number)
    if not digits.isdigit() or not 1 <= int(digits) <= 3:
        raise _LineSyntaxError(f"{keyword.upper()}{digits}: the loop number of DO and END is 1, 2 or 3 "
                               "(FANUC alarm PS0126)", keyword.start_pos)
    return int(digits)


def _statement(node):
    data = node.data
    children = [child for child in node.children if not (isinstance(child, Token) and child in "[]=")]
    if data == "assignment":
        return macro.Assignment(_expr(children[0]), _expr(children[1]))
    if data == "if_goto":
        return macro.IfGoto(_expr(children[1]), _expr(children[3]))
    if data == "if_then":
        return macro.IfThen(_expr(children[1]), _statement(children[3]))
    if data == "while_do":
        return macro.WhileDo(_expr(children[1]), _loop_number(children[2], children[3]))
    if data == "do_loop":
        return macro.DoLoop(_loop_number(children[0], children[1]))
    if data == "end_loop":
        return macro.EndLoop(_loop_number(children[0], children[1]))
    if data == "goto":
        return macro.Goto(_expr(children[1]))
    if data in ("print_statement", "popen", "pclos"):
        return macro.Output(str(children[0]))
    raise AssertionError(f"unexpected statement node {data}")
