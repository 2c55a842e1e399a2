"""The one error hierarchy (postproc/diagnostics.py): every exception class lives there, and a
bug is an internal error (exit 5), never a refusal (exit 4) or bad input (exit 3)."""

from __future__ import annotations

import ast
import builtins

import pytest

from support import REPO, SAMPLES
from postproc import diagnostics
from postproc.interpret import interpreter
from postproc.compensate import self_check
from postproc.diagnostics import EXIT_INTERNAL, EXIT_REFUSED, InterpretationError, Location

HEMISHELL = str(SAMPLES / "programs" / "hemishell.nc")
TRACES = [str(SAMPLES / "ballbar" / f"v40r-100-{d}.csv") for d in ("ccw", "cw")]
#: Exception classes allowed outside diagnostics.py: click's usage errors of the command line,
#: and the FreeCAD post, which runs inside FreeCAD without postproc installed.
ELSEWHERE = {("postproc/cli/common.py", "BadValue"), ("postproc/cam/freecad/postproc_fanuc_lathe_post.py", "PostError")}


def _is_exception(value) -> bool:
    return isinstance(value, type) and issubclass(value, BaseException)


#: The names of the exception classes a class may derive from: Python's, postproc's, click's.
EXCEPTIONS = ({name for name, value in vars(builtins).items() if _is_exception(value)}
              | {name for name, value in vars(diagnostics).items() if _is_exception(value)} | {"ClickException"})


def _exception_classes(path) -> list[str]:
    """The classes a module defines that derive from an exception (by the names of their bases)."""
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ClassDef):
            bases = {base.attr if isinstance(base, ast.Attribute) else getattr(base, "id", "") for base in node.bases}
            if bases & EXCEPTIONS:
                found.append(node.name)
    return found


def test_every_exception_class_is_in_diagnostics():
    """Private control-flow signals (a leading underscore) never leave their module; every other
    exception class of postproc and its plugins is defined in diagnostics.py."""
    outside = []
    for folder in ("postproc", "plugins"):
        for path in sorted((REPO / folder).rglob("*.py")):
            relative = path.relative_to(REPO).as_posix()
            if relative == "postproc/diagnostics.py":
                continue
            outside += [(relative, name) for name in _exception_classes(path)
                        if not name.startswith("_") and (relative, name) not in ELSEWHERE]
    assert outside == []


def test_the_scan_finds_an_exception_class(tmp_path):
    """The check above can fail: a class deriving from ValueError or from a postproc error is found."""
    module = tmp_path / "module.py"
    module.write_text("class A(ValueError):\n    pass\n\nclass B(diagnostics.SafetyError):\n    pass\n\nclass C:\n    pass\n")
    assert _exception_classes(module) == ["A", "B"]


def _compensate(run, tmp_path):
    output = tmp_path / "out.nc"
    result = run("compensate", HEMISHELL, "--plugin", "ballbar-inverse", "--ballbar", *TRACES[:1], "--ballbar",
                 TRACES[1], "--option", "radius-mapping=relative", "-o", str(output))
    return result, output


def _fault_in(monkeypatch, where: str, fault: BaseException):
    """Make the interpreter raise ``fault`` on every block (``everywhere``) or only where it reads
    a replacement back (``self-check``), by its general path and its fast path alike."""
    for name in ("step", "canonical_motion"):
        real = getattr(interpreter.Interpreter, name)

        def faulty(self, block, *args, real=real):
            if where == "everywhere" or self.profile.name == "self-check":
                raise fault
            return real(self, block, *args)

        monkeypatch.setattr(interpreter.Interpreter, name, faulty)


@pytest.mark.parametrize("where", ["everywhere", "self-check"])
def test_a_bug_in_the_interpreter_is_an_internal_error(run, tmp_path, monkeypatch, where):
    """A ZeroDivisionError in the interpreter, wherever it is called, exits 5 naming it as an
    internal error; before the self-check caught every exception, it was a refusal (exit 4)."""
    _fault_in(monkeypatch, where, ZeroDivisionError("division by zero"))
    result, output = _compensate(run, tmp_path)
    assert result.exit_code == EXIT_INTERNAL
    assert result.stderr == ("postproc: internal error: ZeroDivisionError: division by zero "
                             "(set POSTPROC_DEBUG=1 to see where)\n")
    assert result.stdout == "" and not output.exists()


def test_a_bug_in_the_reader_of_the_self_check_is_an_internal_error(run, tmp_path, monkeypatch):
    def broken(lines, file, **options):
        raise IndexError("list index out of range")
        yield  # a generator, as read_blocks is

    monkeypatch.setattr(self_check, "read_blocks", broken)
    result, output = _compensate(run, tmp_path)
    assert result.exit_code == EXIT_INTERNAL and "internal error: IndexError" in result.stderr
    assert result.stdout == "" and not output.exists()


def test_a_replacement_the_interpreter_refuses_is_still_a_refusal(run, tmp_path, monkeypatch):
    """What the self-check is for: a replacement that does not interpret (postproc's own error)
    refuses the run, exit 4, naming the block."""
    _fault_in(monkeypatch, "self-check", InterpretationError("arc end point not on the arc", Location("<replacement>", 1)))
    result, output = _compensate(run, tmp_path)
    assert result.exit_code == EXIT_REFUSED
    assert "error: self-check: the replacement does not read back (arc end point not on the arc)" in result.stderr
    assert result.stdout == "" and not output.exists()


def test_repeated_warnings_are_counted_per_program_and_the_count_names_it():
    """A warning repeated more than 20 times is shown 20 times, then counted: per program, so
    that in a batch the 21st program with the habit is warned as the first was."""
    import io

    stream = io.StringIO()
    reporter = diagnostics.Reporter(stream)
    for program in ("a.nc", "b.nc"):
        reporter.about = Location(program)
        for _ in range(25):
            reporter.warn("the same habit")
    reporter.about = None
    reporter.warn("the same habit")
    reporter.close()
    lines = stream.getvalue().splitlines()
    assert [str(w) for w in reporter.warnings].count("a.nc: warning: the same habit") == 20
    assert [str(w) for w in reporter.warnings].count("b.nc: warning: the same habit") == 20
    assert "postproc: warning: the same habit" in lines
    assert lines[-2:] == ["a.nc: warning: 5 more like: the same habit", "b.nc: warning: 5 more like: the same habit"]
