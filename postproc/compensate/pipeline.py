"""One compensation run: compensators chosen, fitted and applied to programs.

The order is the user's: compensators run in the order of ``--plugin``; each computes its
correction on the nominal path, the corrections add, and the segmenter runs once on the
sum. A compensator that raises or returns something unusable is named in the error, and
no program is written. The output starts with a provenance comment block (FANUC-safe:
upper case, no nested parentheses, short lines); a program that already carries one is
refused unless forced, so nobody compensates twice by accident.

A compensator's opening blocks (a G10 offset setting, say) go right after the block by which
the program has set its units (G20/G21) and, when it sets it, its plane (G18), so that the
control reads them in the program's units, and before the program's first tool call or
move. A program that sets no units before those (or sets them only behind a block delete
``/``, which the control may skip) is refused for them: the blocks would be read in whatever
units the control was left in. The header says what was added where.
"""

from __future__ import annotations

import dataclasses
import os
import re
import signal
import sys
import tempfile
import threading
from contextlib import redirect_stdout
from typing import Any

import numpy as np

from .. import __version__
from ..machine import bounds
from ..files import inputs
from . import models, progress
from ..interpret import gcodes as G
from . import registry
from .lead import Lead
from .compensator import Compensator, Context, Measurements, check_options, parse_options
from ..diagnostics import (InternalError, Location, MeasurementError, ModelError, PluginError, PostprocError, Reporter, SafetyError,
                           UsageError)
from ..measure.readers.csvfile import snapshot as measurement_snapshot
from ..interpret.motion import ARC, LINE, Step
from ..files.output import Spool
from ..machine.profile import DEFAULT, MachineProfile, sha256 as profile_sha256
from ..interpret.program import interpret_source
from .region import Region
from .request import Request
from .rewrite import Piece, Rewriter
from ..syntax.source import Source, count_lines

HEADER_MARK = "POSTPROC"
_SAFE = re.compile(r"[^A-Z0-9 .,:/_=+-]")


class Pipeline:
    """Compensators ready to apply: built once, used for any number of programs."""

    def __init__(self, request: Request, profile: MachineProfile = DEFAULT, reporter: Reporter | None = None):
        self.request = request
        self.profile = profile
        self.reporter = reporter or Reporter()
        self.max_correction = bounds.in_force(request.tolerance, request.max_correction, profile)
        context = Context(profile=profile, reporter=self.reporter, force=request.force,
                          tolerance=request.tolerance or profile.default_tolerance(False))
        self.inputs: list[tuple[str, str]] = []  # (file, sha256) for the provenance
        self.measured: list = []  # when each measurement was taken (path, time or None), for a saved model
        with inputs.session():  # each file read once, whoever needs it
            if request.model:
                self._load(request.model, context)
                return
            installed = registry.select(request.plugins)
            self.installed = installed
            self.settings = parse_options(request.options, [item.cls for item in installed])
            self.compensators: list[Compensator] = [_built(item.cls, context, self.settings[item.cls.name])
                                                    for item in installed]
            self._fit()

    def _load(self, path: str, context: Context) -> None:
        """A saved model instead of measurements: the compensator it names, given its model."""
        request = self.request
        if request.plugins or request.ballbar or request.probe or request.calibration or request.options:
            raise UsageError("--model carries its compensator, measurements and options: give none of them with it")
        data = models.read(path)
        models.check_age(data, path, self.profile, self.reporter)
        installed = registry.select([data["plugin"]])
        item = installed[0]
        if data.get("plugin_version") != item.version:
            self.reporter.warn(f"the model was made by {item.cls.name} {data.get('plugin_version')}; "
                               f"{item.version} is installed", Location(path))
        options = check_options(data["options"], item.cls, Location(path))
        compensator = _built(item.cls, context, options)
        self._guarded(compensator, "load", compensator.load, data["model"], model=path)
        self.installed, self.compensators = installed, [compensator]
        self.settings = {item.cls.name: options}
        self.inputs = [(entry["file"], entry["sha256"]) for entry in data.get("inputs", [])]
        self.inputs.append((inputs.named(path), data["sha256"]))

    def saved_model(self, note: str | None = None) -> dict[str, Any]:
        """The fitted model of the one compensator, with its provenance, for ``postproc fit``."""
        if len(self.compensators) != 1:
            raise UsageError("a model is fitted for one compensator: give one --plugin")
        compensator, item = self.compensators[0], self.installed[0]
        model = self._guarded(compensator, "model", compensator.model)
        try:
            data = models.build(compensator.name, item.version, model, self.inputs, self.profile,
                                self.settings[compensator.name], note, models.measured_at(self.measured, self.reporter))
            saved = models.read_back(data)
        except (TypeError, ValueError, ModelError) as exc:
            raise PluginError(compensator.name, f"its model would not read back: {getattr(exc, 'message', exc)}") from None
        # and the compensator takes it back, as compensate --model will give it
        fresh = _built(item.cls, dataclasses.replace(compensator.context, reporter=Reporter()), self.settings[compensator.name])
        try:
            self._guarded(fresh, "load of its own model", fresh.load, saved["model"])
        except ModelError as exc:
            if compensator.context.force:  # what --force let the fit keep: no saved model may hold it
                raise MeasurementError(
                    f"{compensator.name}: --force kept what the measurements are refused for, and a saved model is held "
                    f"to it again ({exc.message}); give the measurements to compensate with --force to apply them to one "
                    "run, or measure again", Location(self.inputs[0][0] if self.inputs else None)) from None
            raise PluginError(compensator.name, f"its model would not load back: {exc.message}") from None
        except SafetyError:  # a refusal --force overrides: compensate --model says it again
            pass
        return data

    # ------------------------------------------------------------------ measurements

    def _fit(self) -> None:
        request = self.request
        given = {"ballbar": request.ballbar, "probe": request.probe,
                 "calibration": [request.calibration] if request.calibration else []}
        for kind, files in given.items():
            if files and not any(kind in c.takes for c in self.compensators):
                names = ", ".join(c.name for c in self.compensators)
                raise UsageError(f"--{kind} was given but no selected compensator ({names}) takes {kind} measurements")
        from ..measure.readers.registry import ReadContext, read as read_measurement  # not for a saved model's run

        readers = registry.readers()
        context = ReadContext(self.reporter)
        read = {kind: [read_measurement(path, kind, readers, context) for path in files] for kind, files in given.items()}
        paths = [path for files in given.values() for path in files]
        self.inputs += [(inputs.named(path), _digest(path)) for path in paths]
        self.measured = models.measurement_times(paths)
        with progress.bar(len(self.compensators), "fitting") as shown:
            for compensator in self.compensators:
                measurements = Measurements(**{kind: list(read[kind]) if kind in compensator.takes else []
                                               for kind in read})
                missing = [kind for kind in compensator.needs if not getattr(measurements, kind)]
                if missing:
                    raise UsageError(f"{compensator.name} needs {' and '.join('--' + kind for kind in missing)} "
                                     "measurements")
                shown.advance(0, compensator.name)
                self._guarded(compensator, "fit", compensator.fit, measurements)
                shown.advance(1, compensator.name)

    @staticmethod
    def _guarded(compensator: Compensator, what: str, function, *args, model: str | None = None):
        """Call a compensator; its failure is named. For a compensator given a saved ``model``, a
        failure on data (a missing key, a value of the wrong type), in loading it or in using it
        later, is the file's: a ModelError (exit 3), not the compensator's (exit 5)."""
        try:
            # what a plugin prints goes to stderr: stdout carries the program alone
            with _time_limit(compensator.context.profile.plugin_time_limit_s), redirect_stdout(sys.stderr):
                return function(*args)
        except SystemExit as exc:  # a plugin's sys.exit() would end the run "successfully", with nothing written
            raise PluginError(compensator.name, f"{what} called sys.exit({exc.code!r})") from None
        except PostprocError as exc:
            raise exc.at(Location(model)) if model is not None else exc
        except (KeyError, IndexError, TypeError, ValueError, AttributeError, OverflowError) as exc:
            if model is None:
                raise PluginError(compensator.name, f"{what} failed: {exc.__class__.__name__}: {exc}") from None
            raise ModelError(f"the model's content does not suit compensator {compensator.name} (is it another "
                             f"compensator's?): {what}: {exc.__class__.__name__}: {exc}", Location(model)) from None
        except _Overtime:
            raise PluginError(compensator.name, f"{what} took longer than {compensator.context.profile.plugin_time_limit_s:g} s "
                              "(the machine profile's plugin_time_limit_s): stopped") from None
        except Exception as exc:
            raise PluginError(compensator.name, f"{what} failed: {exc.__class__.__name__}: {exc}") from None

    # ------------------------------------------------------------------ programs

    def run(self, source: Source, spool: Spool) -> Rewriter:
        """Compensate one program into ``spool`` (the caller commits it). A warning that names
        no place while it runs is about this program."""
        self.reporter.about = Location(source.name)
        try:
            return self._run(source, spool)
        finally:
            self.reporter.about = None

    def _run(self, source: Source, spool: Spool) -> Rewriter:
        self._refuse_twice(source)
        for compensator in self.compensators:
            self._guarded(compensator, "start", compensator.start, model=self.request.model)
        if any(c.needs_survey for c in self.compensators):
            moves = [m for step in interpret_source(source, self.profile, Reporter())
                     for m in step.moves if m.kind in (LINE, ARC) and m.known]
            for compensator in self.compensators:
                if compensator.needs_survey:
                    self._guarded(compensator, "survey", compensator.survey, moves, model=self.request.model)
        opening, anchor = self._prologue(source)
        steps = interpret_source(source, self.profile, self.reporter, rewriting=True)
        region = Region(self.request.regions, source.labels if self.request.regions else None, source.name)
        rewriter = Rewriter(steps, self._corrector(source.name), self.profile, self.request, self.reporter, source.name,
                            selects=region, labels=source.labels)
        lead = Lead()  # the tape mark and program number go before the provenance block
        written = 0  # blocks written: one per source line up to the anchor, none of them replaced
        with tempfile.SpooledTemporaryFile(max_size=1 << 20) as body:
            total = progress.lines(source) if progress.shown() else 0  # counted only for a line on a terminal
            with progress.bar(total, os.path.basename(source.name), progress.MIN_BLOCKS) as shown:
                # each line encoded as it comes (an encoding error stops the run at its line), written a
                # chunk at a time; the lead lines are offered to ``lead`` until the first it does not take
                # (it takes none after that one)
                chunk: list[bytes] = []
                leading = True
                for text in rewriter.run():
                    written += 1
                    if not written % progress.EVERY:
                        shown.advance(progress.EVERY)
                        body.write(b"".join(chunk))
                        chunk.clear()
                    if leading:
                        if lead.takes(text):
                            continue
                        leading = False
                    chunk.append(text.encode("utf-8", "surrogateescape"))
                    if opening and written == anchor.block.line:
                        if text != anchor.block.raw:
                            raise InternalError(f"line {anchor.block.line} was not written as it was read: the opening "
                                                "blocks have no place")
                        chunk.append("".join(line + anchor.block.eol for _, line in opening).encode())
                body.write(b"".join(chunk))
            for compensator in self.compensators:
                self._guarded(compensator, "finish", compensator.finish, model=self.request.model)
            spool.write("".join(lead.lines).encode("utf-8", "surrogateescape"))
            if region.ranges and not region.matched and not opening:  # nothing done is said, and not marked as done
                self.reporter.warn(f"--region {' '.join(self.request.regions)} selects no block that could be "
                                   "compensated: the program is written back unchanged and not marked COMPENSATED",
                                   Location(source.name))
            else:
                self._say_what_changed(rewriter, source.name, bool(opening))
                eol = _eol(next(source.lines(), ""))
                added = [f"{name} ADDED {line} AFTER LINE {anchor.block.line}" for name, line in opening]
                spool.write(self._provenance(rewriter, eol, added).encode())
            body.seek(0)
            while chunk := body.read(1 << 20):
                spool.write(chunk)
        return rewriter

    def _say_what_changed(self, rewriter: Rewriter, name: str, added: bool) -> None:
        """A run that changed no feed move, or whose corrections all lie within the tolerance
        (so the written path may be as near the nominal as the compensated), says so: its
        header still reads COMPENSATED, and a shop must not take that for a corrected part."""
        if rewriter.replaced == 0:
            if added:  # a compensator's own blocks (tool-offset's G10) are the change
                return
            self.reporter.warn("no feed move was changed (the program has none the compensators reach): it is "
                               "written as it was, under a provenance header", Location(name))
            return
        inch = max(rewriter.inch_grids or (False,), key=self.profile.default_tolerance)  # the units of the coarser
        tolerance = self.request.tolerance or self.profile.default_tolerance(inch)
        if 0.0 < rewriter.largest <= tolerance:
            grid = None if self.request.tolerance else self.profile.finer_output(inch, rewriter.largest)
            self.reporter.warn(f"the largest correction, {rewriter.largest * 1000:.2f} um, is within the tolerance in "
                               f"force, {tolerance * 1000:.2f} um: the written path may be no nearer the compensated "
                               "path than the nominal one is " + (f"({grid})" if grid else "(a finer --tolerance, or "
                               "more output decimals in the machine profile, lets it follow)"), Location(name))

    def _prologue(self, source: Source) -> tuple[list[tuple[str, str]], Step | None]:
        """The compensators' own opening blocks, (compensator, text) each read back, and the
        step after which they go: the block by which the program has set its units and plane."""
        from ..interpret.interpreter import Interpreter
        from ..syntax.reader import read_blocks

        if all(type(c).prologue is Compensator.prologue for c in self.compensators):
            return [], None
        anchor, stop, skippable = _units_and_plane(interpret_source(source, self.profile, Reporter()),
                                                   self.profile.gcode_system)
        inch = anchor.modal.inch if anchor is not None else False
        blocks: list[tuple[str, str]] = []
        for compensator in self.compensators:
            given = self._guarded(compensator, "prologue", compensator.prologue, inch, model=self.request.model)
            if not isinstance(given, (list, tuple)) or not all(isinstance(text, str) for text in given):
                raise PluginError(compensator.name, f"prologue returned {given!r}, not a list of blocks (strings)")
            for text in given:
                try:
                    steps = list(Interpreter(self.profile, Reporter(), "<prologue>").run(
                        read_blocks([f"G{20 if inch else 21}\n", text + "\n"], "<prologue>")))
                except PostprocError as exc:
                    raise PluginError(compensator.name, f"its opening block {text!r} does not read: {exc.message}") from None
                refused = _not_an_opening_block(steps)
                if refused:
                    raise PluginError(compensator.name, f"its opening block {text!r} {refused}; an opening block sets a tool "
                                                        "offset (G10 P<n>) or is a comment, and changes nothing the program relies on")
                blocks.append((compensator.name, text))
        if blocks and anchor is None and skippable is not None:
            switch = "/" if skippable.block.delete == 1 else f"/{skippable.block.delete}"
            raise SafetyError(f"the program sets its units (G20/G21) only in a block behind the block delete "
                              f"'{switch}', which the control skips with the block delete switch on: "
                              f"{', '.join(t for _, t in blocks)} would then be read in whatever units the control was "
                              f"left in; set the units in a block without '{switch}' before the first tool call or move",
                              Location(source.name, skippable.block.line, 1, skippable.block.text))
        if blocks and anchor is None:
            where = Location(source.name, stop.block.line, 1, stop.block.text) if stop is not None else Location(source.name)
            what = "its first tool call or move" if stop is not None else "its end"
            if stop is not None and _sets_units(stop, self.profile.gcode_system):
                what += " (it sets them in that block: the opening blocks go before the tool moves or is called)"
            raise SafetyError(f"the program sets no units (G20/G21) before {what}: {', '.join(t for _, t in blocks)} "
                              "would be read in whatever units the control was left in; set the units in the "
                              "program's opening blocks", where)
        return blocks, anchor

    def _refuse_twice(self, source: Source) -> None:
        """A program that carries a provenance header anywhere (moved down by an editor, say) was
        compensated before: refused unless forced."""
        found = _compensated_before(source)
        if found is None:
            return
        where = Location(source.name, *found)
        if self.request.force:
            self.reporter.warn("this program was compensated before; compensating again (--force)", where)
            return
        raise SafetyError("this program was already compensated by postproc; give --force to compensate it again",
                          where)

    def _corrector(self, program: str):
        """The corrections of every compensator for a run of pieces, checked and added. A
        compensator's refusal that names no file (``the arc of line 10 ...``) is the program's."""
        compensators = self.compensators
        model = self.request.model

        def correct(pieces: list[Piece]) -> list[np.ndarray | None]:
            totals: list[np.ndarray | None] | None = None
            for compensator in compensators:
                try:
                    shifts = self._guarded(compensator, "correct", compensator.correct_many, pieces, model=model)
                except PostprocError as exc:
                    raise exc.at(Location(program)) from None
                checked = _checked(compensator.name, shifts, pieces)
                if totals is None:  # the first compensator's corrections are the sums so far
                    totals = checked
                    continue
                for index, shift in enumerate(checked):
                    if shift is not None:
                        total = totals[index]
                        totals[index] = shift if total is None else total + shift
            return totals if totals is not None else [None] * len(pieces)

        return correct

    def _provenance(self, rewriter: Rewriter, eol: str, added: list[str]) -> str:
        """The provenance comments: what was applied, from which files, every setting that
        changes the output (options, regions, tolerance, mode, the machine profile), the blocks
        compensators added and the blocks left uncompensated."""
        request = self.request
        lines = [f"POSTPROC {__version__} COMPENSATED"]
        for item, compensator in zip(self.installed, self.compensators):
            lines.append(f"PLUGIN {compensator.name} {item.version}")
        for name, values in self.settings.items():
            lines += [f"OPTION {name}.{key}={_option_text(value)}" for key, value in sorted(values.items())]
        for path, sha in self.inputs:
            lines.append(f"INPUT {path.rsplit('/', 1)[-1][:28]} SHA256 {sha[:12]}")
        if request.model:
            lines.append(f"MODEL {inputs.named(request.model).rsplit('/', 1)[-1][:28]}")
        lines += [f"REGION {region.strip()}" for region in request.regions]
        tolerance = request.tolerance
        lines.append(f"TOLERANCE {'DEFAULT' if tolerance is None else f'{tolerance:g} MM'} MODE {request.mode}")
        lines.append(f"MACHINE {self.profile.name[:40]} MAX CORRECTION {self.max_correction:g} MM")
        lines += _profile_lines(self.profile)
        if request.force:
            lines.append("FORCED: COMPENSATED AGAIN OR CHECK OVERRIDDEN")
        lines.append(f"LARGEST CORRECTION {rewriter.largest:.4f} MM")
        lines.append(f"BLOCKS REPLACED {rewriter.replaced} BY {rewriter.emitted}")
        lines += added
        if self.request.macro_values != "refuse":
            lines.append(f"MACRO VALUES {self.request.macro_values}")
        if self.request.macro_values == "numbers":
            lines += _numbered_lines(rewriter.macro_lines)
        lines += _unplannable_lines(rewriter.unplannable)
        return "".join(f"({_safe(line)}){eol}" for line in lines)

    def report(self) -> list[dict[str, Any]]:
        return [{"plugin": c.name, **c.report()} for c in self.compensators]


def _profile_lines(profile: MachineProfile) -> list[str]:
    """What identifies the machine profile beyond its name, which a profile that sets none shares
    with the embedded default: its file and the SHA-256 of its bytes; a profile made in a library
    call, the SHA-256 of its settings as TOML; the embedded default, nothing."""
    if profile.source:
        return [f"PROFILE {profile.source.rsplit('/', 1)[-1][:28]} SHA256 {profile_sha256(profile)[:12]}"]
    if profile != DEFAULT:
        return [f"PROFILE SETTINGS SHA256 {profile_sha256(profile)[:12]}"]
    return []


def _digest(path: str) -> str:
    """The SHA-256 of a measurement file, from its one read (a shop reader may have read it itself)."""
    snapshot = inputs.recorded(path)
    return snapshot.sha256 if snapshot is not None else measurement_snapshot(path).sha256


class _Overtime(Exception):
    """A plugin call ran past its time limit."""


class _time_limit:
    """Stop a plugin call that runs too long (a timer signal; only in the main thread, on Unix)."""

    _installed = False

    def __init__(self, seconds: float):
        self.seconds = seconds
        self.armed = False

    def __enter__(self):
        if self.seconds > 0 and threading.current_thread() is threading.main_thread() and hasattr(signal, "setitimer"):
            if not _time_limit._installed:
                signal.signal(signal.SIGALRM, _time_limit._expire)
                _time_limit._installed = True
            signal.setitimer(signal.ITIMER_REAL, self.seconds)
            self.armed = True
        return self

    def __exit__(self, *exc) -> None:
        if self.armed:
            signal.setitimer(signal.ITIMER_REAL, 0)

    @staticmethod
    def _expire(signum, frame):
        raise _Overtime()


def _built(cls: type[Compensator], context: Context, settings: dict[str, Any]) -> Compensator:
    """A compensator made: what its ``__init__`` prints goes to stderr, as in ``Pipeline._guarded``."""
    with redirect_stdout(sys.stderr):
        return cls(context, settings)


#: the words of a tool offset setting on a FANUC lathe, ``G10 P_ X(U)_ Y(V)_ Z(W)_ R(C)_ Q_``
_OFFSET_WORDS = frozenset("PXUYVZWRCQ")


def _offset_number(text: str) -> bool:
    """Whether a G10's P, as written, numbers a tool offset: P1-P9999 a wear offset, P10001-P19999
    a geometry offset (P0 is the work shift)."""
    return text.isascii() and text.isdigit() and int(text) % 10000 != 0 and int(text) < 20000


def _not_an_opening_block(steps: list[Step]) -> str:
    """Why a compensator's opening block (interpreted after a units block) may not open a
    program, or nothing. It goes in before the program's first tool call or move, so anything
    but setting a tool offset would change how the program runs: a move, a modal change (G91,
    units, spindle), a new coordinate system (G50, G54, G92), a tool call, a macro assignment
    the program may read. So a G10 is held to the one form a compensator has use for, a tool's
    wear or geometry offset (``G10 P<n>`` with X/U, Y/V, Z/W, R/C, Q), every word a number as
    written: an ``L`` selects other data (L2/L20 work offsets, L3 tool-life data and L50
    parameters, whose following blocks are read as data until G11), P0 rewrites the work shift,
    and a computed word (``L[50]``, ``P#1``) is whatever the control computes."""
    units, step = steps[0], steps[-1]
    block = step.block
    codes = [(address.upper(), value) for address, value in block.codes]
    if block.statement is not None:
        return "is a macro statement"
    g10 = [value for address, value in codes if address == "G"] == ["10"]
    if g10 and not any(address in "MSTFN" for address, _ in codes):
        refused = _not_a_tool_offset([(address, value) for address, value in codes if address != "G"])
        if refused:  # before the moves: a computed P may be the work shift, which the tool's position is then not known in
            return f"is not a G10 tool offset setting: {refused}"
    if step.moves:
        return "moves the machine"
    if step.modal != units.modal or not step.interpreted:
        return "changes the modal state"
    if codes and not g10 or any(address in "MSTFN" for address, _ in codes):
        return "is not a G10 data setting"
    return ""


def _not_a_tool_offset(words: list[tuple[str, Any]]) -> str:
    """Why a G10's words (but G) do not set a tool offset as written, or nothing."""
    other = next((address for address, _ in words if address not in _OFFSET_WORDS), None)
    if other is not None:
        return (f"it gives {other} (a tool offset is G10 P<n> with X/U, Y/V, Z/W, R/C, Q; an L selects other data: "
                "L2/L20 work offsets, L3 tool life, L50 parameters)")
    computed = next((address for address, value in words if type(value) is not str), None)
    if computed is not None:
        return f"its {computed} is computed (an opening block gives numbers as written)"
    number = [value for address, value in words if address == "P"]
    if len(number) != 1 or not _offset_number(number[0]):
        return "it needs one P, a wear offset P1-P9999 or a geometry offset P10001-P19999 (P0 sets the work shift)"
    return ""


def _checked(name: str, shifts, pieces: list[Piece]) -> list[np.ndarray | None]:
    """A compensator's corrections, one (n, 2) array of finite values (or None) per piece."""
    if not isinstance(shifts, (list, tuple)) or len(shifts) != len(pieces):
        count = len(shifts) if isinstance(shifts, (list, tuple)) else type(shifts).__name__
        raise PluginError(name, f"returned {count} corrections for {len(pieces)} pieces")
    checked = []
    for shift, piece in zip(shifts, pieces):
        if shift is not None:
            try:
                shift = np.asarray(shift, dtype=float)
            except (TypeError, ValueError) as exc:
                raise PluginError(name, f"returned a correction that is not numbers ({exc})") from None
            if shift.shape != (len(piece.t), 2):
                raise PluginError(name, f"returned a correction of shape {shift.shape} for {len(piece.t)} points")
        checked.append(shift)
    given = [shift for shift in checked if shift is not None]
    if given and not np.isfinite(np.concatenate(given)).all():
        raise PluginError(name, "returned a correction with values that are not finite")
    return checked


def _sets_units(step: Step, system: str) -> bool:
    table = G.SYSTEMS[system]
    return any(letter == "G" and type(value) is str and table.get(G.code_key(float(value)), (None, None))[1]
               in (G.INCH, G.METRIC) for letter, value in step.block.codes)


def _units_and_plane(steps, system: str) -> tuple[Step | None, Step | None, Step | None]:
    """(anchor, stop, skippable): the step by which the program has set its units and, if it
    sets it before, its plane, looked for before ``stop``, its first tool call or move (None: the
    end); and the first step before ``stop`` that sets the units behind a block delete ``/``.
    Such a block sets nothing for certain: with the switch on, the control skips it, and the
    blocks added after it would be read in the units it was left in."""
    table = G.SYSTEMS[system]
    units = plane = stop = skippable = None
    for step in steps:
        codes = step.block.codes
        if step.moves or any(letter == "T" for letter, _ in codes):
            stop = step
            break
        if step.block.delete is not None:
            if skippable is None and _sets_units(step, system):
                skippable = step
            continue
        if units is None and _sets_units(step, system):
            units = step
        for letter, value in codes:
            entry = table.get(G.code_key(float(value))) if letter == "G" and type(value) is str else None
            if entry is not None and entry[1] == G.PLANE_ZX and plane is None:
                plane = step
    if units is not None and plane is not None and plane.block.line > units.block.line:
        return plane, stop, skippable
    return units, stop, skippable


def _unplannable_lines(unplannable: list[tuple[int, str]], shown: int = 10) -> list[str]:
    """The provenance of ``--keep-unplannable``: each block left uncompensated, by line."""
    lines = [f"UNCOMPENSATED LINE {line}: {limit}" for line, limit in unplannable[:shown]]
    if len(unplannable) > shown:
        lines.append(f"UNCOMPENSATED {len(unplannable) - shown} MORE BLOCKS")
    return lines


def _option_text(value: Any) -> str:
    return ("TRUE" if value else "FALSE") if isinstance(value, bool) else (f"{value:g}" if isinstance(value, float)
                                                                        else str(value))


_MARK = re.compile(rb"\(\s*postproc\s+\S+\s+compensated")


def _compensated_before(source: Source) -> tuple[int, int, str] | None:
    """Where a provenance header stands (line, column, the line's text) anywhere in the program, or None: a scan of
    the bytes for the mark, lower-cased a chunk at a time."""
    line = 1
    for chunk in source.chunks():
        lowered = chunk.lower()
        at = lowered.find(b"postproc")
        while at >= 0:
            start = lowered.rfind(b"(", 0, at)
            match = _MARK.match(lowered, start) if start >= 0 else None
            if match is not None:
                before = max(chunk.rfind(b"\n", 0, match.start()), chunk.rfind(b"\r", 0, match.start()))
                ends = [i for i in (chunk.find(b"\n", match.end()), chunk.find(b"\r", match.end())) if i >= 0]
                text = chunk[before + 1 : min(ends) if ends else len(chunk)].decode("utf-8", "surrogateescape")
                col = len(chunk[before + 1 : match.start()].decode("utf-8", "surrogateescape")) + 1
                return line + count_lines(chunk, 0, before + 1), col, text
            at = lowered.find(b"postproc", at + 1)
        line += count_lines(chunk, 0, len(chunk))
    return None


def _numbered_lines(numbered: list[int], shown: int = 10) -> list[str]:
    """The provenance of ``--macro-values numbers``: each block whose macro values were written
    as numbers, by line (an operator who edits a variable must know they no longer follow it)."""
    lines = [f"MACRO VALUES AS NUMBERS LINE {line}" for line in numbered[:shown]]
    if len(numbered) > shown:
        lines.append(f"MACRO VALUES AS NUMBERS IN {len(numbered) - shown} MORE BLOCKS")
    return lines


def _safe(text: str) -> str:
    return _SAFE.sub("_", text.upper())[:60]


def _eol(text: str) -> str:
    """The program's own line ending (CRLF, a lone CR or LF), from its first line."""
    return "\r\n" if text.endswith("\r\n") else ("\r" if text.endswith("\r") else "\n")
