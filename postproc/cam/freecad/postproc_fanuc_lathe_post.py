"""FreeCAD Path post-processor: a FANUC lathe program, compensated by postproc on the way out.

Installation: copy this one file into FreeCAD's macro folder (typically
``~/.local/share/FreeCAD/Macro/``) or into Path's default file path, where FreeCAD looks for
``*_post.py`` files, then choose ``postproc_fanuc_lathe`` as the Job's post processor. The
file imports only FreeCAD's modules and the standard library; postproc itself runs as a
separate program (FreeCAD's embedded Python is not postproc's environment), found as
``postproc`` on PATH or given with ``--postproc-exe``.

What it writes (FANUC lathe, G-code system A, the control's default)::

    %
    O0001 (JOB)
    (EXPORTED BY FREECAD)
    (POST PROCESSOR POSTPROC_FANUC_LATHE)
    (OUTPUT TIME 2024-05-02 14.31)
    G18 G21 G40 G99
    (TC DEFAULT TOOL)
    T0101
    G97 S1000 M03
    M08
    (FINISH)
    G00 X0.000 Z60.000
    G01 Z57.150 F0.1000
    G03 X114.300 Z0.000 I0.000 K-57.150
    ...
    M09
    M05
    M30
    %

- The toolpath lies in FreeCAD's XZ plane: FreeCAD's X is the radius, Z the spindle axis.
  X is written as a diameter (2x); I and K stay radius values, incremental from the arc's
  start (FreeCAD's G90.1 absolute centres are converted). A move off the XZ plane (a Y
  other than 0, a J other than 0, an arc outside G18) is refused.
- G02/G03: FreeCAD turns a G2 in G18 about -Y (its segment walker, which draws and bounds
  every toolpath, rotates about -Y for G2 and +Y for G3): clockwise seen from +Y, from +X
  towards +Z, theta increasing. That is the FANUC lathe G02 of postproc's convention, so G2
  is written G02 and G3 G03 unchanged.
- Feeds: G99, feed per revolution, as turning is programmed. FreeCAD's feeds are per minute;
  F = feed / spindle speed, with the spindle at constant speed (G97) from the tool
  controller's speed. A feed move without a running spindle is refused. ``--feed-per-minute``
  writes G98 and the feeds as they are.
- Units: G21 millimetres, or G20 inches (lengths and feeds converted) with ``--inches`` or
  when FreeCAD's unit schema is an inch one; ``--metric`` forces G21.
- Tools: a tool controller's ``M6 T3`` becomes ``T0303`` (tool 3, offset 3); its ``M3 S1000``
  ``G97 S1000 M03``. Coolant (Flood: M08, Mist: M07) is turned on before each operation
  that asks for it and off (M09) after it.
- No mill preamble (no G17, G54, G49, G80 or G90, which in system A is a turning cycle) and
  no file name as a block. The Job's fixtures (G54 and a mill clearance move in Z) are
  skipped: the lathe's work shift and the T offset set the work coordinates.
- Comments in upper case, limited to ``A-Z 0-9 space . , = _ -``; nested parentheses and
  every other character become spaces.
- G4 dwells become ``G04 P`` in milliseconds; G40/G41/G42 pass (the nose radius comes with
  the T offset, so no D word); G90/G91 and G90.1/G91.1 are followed, never written.
- Path commands a two-axis lathe cannot run (drilling cycles, G54-G59, tool length offsets,
  helices...) are refused with the operation's name, rather than written wrong.

Arguments (the Job's PostProcessorArgs, one line, shell quoting):

Posting: ``--no-header``, ``--no-comments``, ``--line-numbers``, ``--no-show-editor``,
``--precision N`` (decimals of lengths; default 3, 4 in inches), ``--inches``, ``--metric``,
``--feed-per-minute``, ``--program-number N`` (default 1), ``--preamble "G50 S2000;G28 U0."``
(blocks after the start block, ``;`` between blocks), ``--postamble "..."`` (before M30).

Compensation, as for ``postproc compensate``: ``--plugin NAME``, ``--ballbar FILE``,
``--probe FILE``, ``--calibration FILE``, ``--model FILE``, ``--machine FILE``,
``--tolerance MM``, ``--mode auto|arc|line``, ``--option [PLUGIN.]KEY=VALUE`` (repeatable
where postproc's are), and ``--postproc "ARGS"`` for any other postproc option, e.g.
``--postproc "--plugin parametric --ballbar /m/ccw.csv --ballbar /m/cw.csv --max-correction 0.05"``
(one word works too: ``--postproc --force``).
``--postproc-exe PATH`` names the postproc program.

In FreeCAD's GUI the posted program first opens in FreeCAD's editor (not with
``--no-show-editor``); what the editor returns is what gets compensated. With no
compensation argument the program is written as posted. With one, the posted program
goes through ``postproc compensate`` and the compensated program is written to the output
file; postproc's warnings and summary go to FreeCAD's report view. If postproc refuses (or
anything else fails), the error goes to FreeCAD's report view (``Console.PrintError``),
export returns None and nothing is written: the output file is replaced only, atomically,
by a complete program.

From a script::

    import postproc_fanuc_lathe_post as post
    post.export(objects, "/tmp/part.nc", "--no-show-editor --plugin parametric "
                "--ballbar /m/ccw.csv --ballbar /m/cw.csv")
"""

import argparse
import datetime
import os
import re
import shlex
import shutil
import subprocess
import tempfile
import unicodedata

import FreeCAD
from FreeCAD import Units

TOOLTIP = """FANUC lathe (G-code system A) from a toolpath in the XZ plane: diameter X, G18,
G99 feed per revolution, T0101 tools. Runs postproc compensate on the program when given
compensation arguments (--plugin, --ballbar, ... or --postproc "ARGS")."""

MACHINE_NAME = "FANUC lathe (postproc)"
UNITS = "G21"  # FreeCAD reads this to label the post metric; --inches writes G20

# One timestamp per load of the post: FreeCAD reloads a post for every export.
now = datetime.datetime.now()

parser = argparse.ArgumentParser(prog="postproc_fanuc_lathe", add_help=False, exit_on_error=False)
posting = parser.add_argument_group("posting")
posting.add_argument("--no-header", action="store_true", help="no header comments")
posting.add_argument("--no-comments", action="store_true", help="no comments at all")
posting.add_argument("--line-numbers", action="store_true", help="N10, N20, ... on every block")
posting.add_argument("--no-show-editor", action="store_true", help="do not open the editor on the posted program")
posting.add_argument("--precision", type=int, help="decimals of lengths (default 3, 4 in inches)")
units = posting.add_mutually_exclusive_group()
units.add_argument("--inches", action="store_true", help="G20: inches (default: from FreeCAD's unit schema)")
units.add_argument("--metric", action="store_true", help="G21: millimetres whatever the unit schema")
posting.add_argument("--feed-per-minute", action="store_true",
                     help="G98 feeds per minute instead of G99 per revolution")
posting.add_argument("--program-number", type=int, default=1, help="the O number (default 1)")
posting.add_argument("--preamble", default="", help='blocks after the start block, ";" between blocks')
posting.add_argument("--postamble", default="", help='blocks before M30, ";" between blocks')
compensation = parser.add_argument_group("compensation (postproc compensate)")
compensation.add_argument("--postproc-exe", help="the postproc program (default: postproc on PATH)")
compensation.add_argument("--postproc", default="", metavar="ARGS", help="further postproc compensate options, quoted")
for _name in ("--plugin", "--ballbar", "--probe", "--option"):
    compensation.add_argument(_name, action="append", default=[], help=f"as postproc's {_name} (repeatable)")
for _name in ("--calibration", "--model", "--machine", "--tolerance", "--mode"):
    compensation.add_argument(_name, help=f"as postproc's {_name}")

TOOLTIP_ARGS = parser.format_help()

COMMENT_CHARACTERS = re.compile(r"[^A-Z0-9 .,=_-]")
INCH_SCHEMA = re.compile(r"\b(in|ft)\b")
EXIT_CODES = {1: "the program would change", 2: "usage error", 3: "bad input", 4: "refused for safety",
              5: "internal error"}
COOLANT = {"Flood": "M08", "Mist": "M07"}
PASSED_M_CODES = {0, 1, 7, 8, 9}  # program stop, optional stop, coolant: written as they are
LATHE_AXES = {"X", "Y", "Z", "I", "J", "K", "F"}
EDITOR_LIMIT = 100000  # characters; FreeCAD's own posts skip the editor above this


class PostError(Exception):
    """Something this post cannot write; the message goes to FreeCAD's report view."""


def export(objectslist, filename, argstring):
    """FreeCAD's entry point: post ``objectslist`` to ``filename`` (``-``: only return it).

    Returns the program written, or None after reporting an error (nothing is written then).
    """
    try:
        args = parse_arguments(argstring)
        text = Lathe(args).post(objectslist)
        text = edit(text, args)
        options = compensation_arguments(args)
        if options:
            text = compensate(text, filename, args.postproc_exe, options)
        if filename != "-":
            write_atomically(filename, text)
    except PostError as error:
        FreeCAD.Console.PrintError(f"postproc_fanuc_lathe: {error}\n")
        return None
    return text


def parse_arguments(argstring):
    """The Job's PostProcessorArgs as a namespace; a bad argument is a PostError."""
    try:
        args, unknown = parser.parse_known_args(glue_postproc(shlex.split(argstring or "")))
    except (argparse.ArgumentError, ValueError) as error:
        raise PostError(f"bad post-processor arguments: {error}") from None
    if unknown:
        raise PostError(f"unknown post-processor arguments: {' '.join(unknown)}")
    if args.metric:
        args.inches = False
    elif not args.inches:
        args.inches = bool(INCH_SCHEMA.search(Units.listSchemas(Units.getSchema())))
    if args.precision is None:
        args.precision = 4 if args.inches else 3
    return args


def glue_postproc(words):
    """``--postproc VALUE`` as ``--postproc=VALUE``: argparse would take a lone value such as
    ``--force`` for an option of its own."""
    glued = []
    words = iter(words)
    for word in words:
        glued.append(f"--postproc={next(words, '')}" if word == "--postproc" else word)
    return glued


def compensation_arguments(args):
    """The ``postproc compensate`` options the arguments ask for, in postproc's own syntax."""
    words = [word for name in ("plugin", "ballbar", "probe") for value in getattr(args, name)
             for word in (f"--{name}", value)]
    for name in ("calibration", "model", "machine", "tolerance", "mode"):
        if getattr(args, name) is not None:
            words += [f"--{name}", getattr(args, name)]
    words += [word for value in args.option for word in ("--option", value)]
    try:
        return words + shlex.split(args.postproc)
    except ValueError as error:
        raise PostError(f"bad --postproc arguments: {error}") from None


def comment(text):
    """``text`` as a FANUC comment: upper case, safe characters only; '' if nothing is left."""
    text = unicodedata.normalize("NFKD", text).encode("ascii", "ignore").decode("ascii").upper()
    text = " ".join(COMMENT_CHARACTERS.sub(" ", text).split())
    return f"({text})" if text else ""


def blocks(text):
    """A --preamble/--postamble value as blocks: ``;`` (FANUC's end of block) or newlines between."""
    return [block.strip() for block in re.split(r"[;\n]", text) if block.strip()]


class Lathe:
    """One post run: walks the objects' commands and writes FANUC lathe blocks."""

    def __init__(self, args):
        self.args = args
        self.scale = 1 / 25.4 if args.inches else 1.0  # mm -> program units
        self.lines = []
        self.sequence = 0
        self.x = self.z = None  # radius and axial position, mm; None until known
        self.plane = 17  # FreeCAD's default plane, as for the control
        self.absolute = True
        self.absolute_centre = False
        self.motion = None  # the modal motion code last written
        self.feed = None  # FreeCAD's current feed, mm/s
        self.feed_written = None  # the F word last written
        self.speed = None  # spindle rpm while it runs, if known
        self.spindle = False  # running
        self.coolant = False  # turned on by the path itself (M07/M08)

    def post(self, objects):
        """The whole program for ``objects`` (FreeCAD's post list), as text."""
        for obj in objects:
            if not hasattr(obj, "Path"):
                raise PostError(f"{obj.Name} is not a Path object: select a Job, its operations and tool controllers")
        self.lines.append("%")
        title = self.job_title(objects)
        self.lines.append(f"O{self.args.program_number:04d}" + (f" {title}" if title else ""))
        if not self.args.no_header:
            self.comment("EXPORTED BY FREECAD")
            self.comment("POST PROCESSOR POSTPROC_FANUC_LATHE")
            self.comment(f"OUTPUT TIME {now:%Y-%m-%d %H.%M}")
        self.block(f"G18 {'G20' if self.args.inches else 'G21'} G40 {'G98' if self.args.feed_per_minute else 'G99'}")
        for text in blocks(self.args.preamble):
            self.block(text)
        for obj in objects:
            self.operation(obj)
        if self.coolant:
            self.block("M09")
        if self.spindle:
            self.block("M05")
        for text in blocks(self.args.postamble):
            self.block(text)
        self.block("M30")
        self.lines.append("%")
        return "\n".join(self.lines) + "\n"

    def job_title(self, objects):
        if self.args.no_comments:
            return ""
        from PathScripts import PathUtils

        for obj in objects:
            job = PathUtils.findParentJob(obj) if hasattr(obj, "InList") else None
            if job is not None:
                return comment(job.Label)
        return ""

    def block(self, text):
        if self.args.line_numbers:
            self.sequence += 10
            text = f"N{self.sequence} {text}"
        self.lines.append(text)

    def comment(self, text):
        text = comment(text)
        if text and not self.args.no_comments:
            self.block(text)

    def operation(self, obj):
        """One object of the post list: an operation, a tool controller or a compound."""
        if obj.Name == "Fixture" and not hasattr(obj, "TypeId"):  # the Job's G54 and mill clearance move
            return
        if not _active(obj):
            return
        if hasattr(obj, "Group"):
            for child in obj.Group:
                if hasattr(child, "Path"):
                    self.operation(child)
            return
        coolant = COOLANT.get(_property(obj, "CoolantMode"))
        if coolant:
            self.block(coolant)
        for command in obj.Path.Commands:
            try:
                self.command(command)
            except PostError as error:
                raise PostError(f"{obj.Label}: {command.toGCode()}: {error}") from None
        if coolant:
            self.block("M09")

    def command(self, command):
        name = command.Name.strip().upper()
        if name.startswith("("):
            self.comment(name[1:-1] if name.endswith(")") else name[1:])
            return
        match = re.fullmatch(r"([GM])(\d+(?:\.\d*)?)", name)
        if not match:
            raise PostError("not a command this post knows")
        letter, number = match.group(1), float(match.group(2))
        params = command.Parameters
        if "F" in params:
            self.feed = params["F"]
        if letter == "M":
            self.m_code(int(number), params)
        elif number in (0, 1, 2, 3):
            self.move(int(number), params)
        elif number in (17, 18, 19):
            self.plane = int(number)
        elif number in (90, 91):
            self.absolute = number == 90
        elif number in (90.1, 91.1):
            self.absolute_centre = number == 90.1
        elif number in (40, 41, 42):
            self.block(f"G{int(number)}")  # a D word has no use: the nose radius comes with the T offset
        elif number == 4:
            self.block(f"G04 P{round(params.get('P', 0.0) * 1000)}")  # FreeCAD's P is seconds, FANUC's ms
        else:
            raise PostError("not something a two-axis lathe post can write")

    def m_code(self, number, params):
        if number in (3, 4):
            self.spindle = True
            if params.get("S", 0) > 0:
                self.speed = params["S"]
                self.block(f"G97 S{round(self.speed)} M0{number}")
            else:
                self.block(f"M0{number}")
        elif number == 5:
            self.speed, self.spindle = None, False
            self.block("M05")
        elif number == 6:
            tool = params.get("T", 0)
            if tool != int(tool) or not 1 <= tool <= 99:
                raise PostError(f"tool number {tool:g}: a FANUC lathe T word takes tools 1 to 99")
            self.block(f"T{int(tool):02d}{int(tool):02d}")
        elif number in PASSED_M_CODES:
            self.coolant = number in (7, 8) or (self.coolant and number != 9)
            self.block(f"M{number:02d}")
        else:
            raise PostError("not something a two-axis lathe post can write")

    def move(self, code, params):
        other = sorted(set(params) - LATHE_AXES)
        if other:
            raise PostError(f"{', '.join(other)} words: a two-axis lathe has X and Z only")
        if abs(params.get("Y", 0.0)) > 1e-9:
            raise PostError("a Y move: the lathe toolpath must lie in the XZ plane (Y = 0)")
        x, z = self.target(params)
        words = []
        if code in (2, 3):
            words = self.arc_words(params, x, z)
        else:
            if x is not None and x != self.x:
                words.append("X" + self.length(2 * x))
            if z is not None and z != self.z:
                words.append("Z" + self.length(z))
            if not words:
                return  # nothing moves: the control would not either
        if code != 0:
            words += self.feed_words()
        if code != self.motion:
            words.insert(0, f"G{code:02d}")
            self.motion = code
        self.block(" ".join(words))
        self.x, self.z = x, z

    def target(self, params):
        """The end point in mm (absolute), from absolute or incremental (G91) words."""
        if self.absolute:
            return params.get("X", self.x), params.get("Z", self.z)
        if ("X" in params and self.x is None) or ("Z" in params and self.z is None):
            raise PostError("an incremental move (G91) from a position not yet known")
        return (self.x + params.get("X", 0.0) if self.x is not None else None,
                self.z + params.get("Z", 0.0) if self.z is not None else None)

    def arc_words(self, params, x, z):
        if self.plane != 18:
            raise PostError(f"an arc in the G{self.plane} plane: lathe arcs lie in the XZ plane (put G18 before it)")
        if abs(params.get("J", 0.0)) > 1e-9:
            raise PostError("an arc centre off the XZ plane (J other than 0)")
        if self.x is None or self.z is None:
            raise PostError("an arc from a position not yet known: move to its start first")
        i, k = params.get("I", 0.0), params.get("K", 0.0)
        if self.absolute_centre:
            i, k = i - self.x, k - self.z
        return ["X" + self.length(2 * x), "Z" + self.length(z), "I" + self.length(i), "K" + self.length(k)]

    def feed_words(self):
        if not self.feed:
            raise PostError("a feed move without a feed rate: set the tool controller's feeds or give F")
        per_minute = float(Units.Quantity(self.feed, Units.Velocity).getValueAs("mm/min")) * self.scale
        if self.args.feed_per_minute:
            word = "F" + _number(per_minute, self.args.precision)
        elif self.speed is None:
            raise PostError("feed per revolution (G99) needs the spindle running at a known speed: "
                            "set the tool controller's spindle speed, or use --feed-per-minute")
        else:
            word = "F" + _number(per_minute / self.speed, self.args.precision + 1)
        if word == self.feed_written:
            return []
        self.feed_written = word
        return [word]

    def length(self, mm):
        return _number(mm * self.scale, self.args.precision)


def _number(value, decimals):
    text = f"{value:.{decimals}f}"
    return text.lstrip("-") if float(text) == 0 else text  # never -0.000


def _property(obj, name):
    """A property of the operation or of the operation a dressup is based on (None if neither has it)."""
    while obj is not None:
        if hasattr(obj, name):
            return getattr(obj, name)
        obj = getattr(obj, "Base", None)
    return None


def _active(obj):
    return _property(obj, "Active") is not False


def edit(text, args):
    """In FreeCAD's GUI, let the user review (and edit) the posted program before compensation."""
    if not FreeCAD.GuiUp or args.no_show_editor or len(text) > EDITOR_LIMIT:
        return text
    from PathScripts import PostUtils

    dialog = PostUtils.GCodeEditorDialog()
    dialog.editor.setText(text)
    return dialog.editor.toPlainText() if dialog.exec_() else text


def compensate(text, filename, executable, options):
    """The posted program through ``postproc compensate OPTIONS``; returns the compensated program."""
    executable = executable or shutil.which("postproc")
    if not executable:
        raise PostError("postproc is not on PATH: install it (pip install postproc) or give --postproc-exe PATH")
    name = os.path.basename(filename) if filename != "-" else "freecad.nc"
    with tempfile.TemporaryDirectory(prefix="postproc-freecad-") as folder:
        posted_folder = os.path.join(folder, "posted")  # apart: the output's name may be anything
        os.mkdir(posted_folder)
        posted = os.path.join(posted_folder, name)
        compensated = os.path.join(folder, "compensated.nc")
        with open(posted, "w", encoding="ascii", errors="replace", newline="\n") as handle:
            handle.write(text)
        command = [executable, "compensate", *options, "-o", compensated, posted]
        try:
            result = subprocess.run(command, capture_output=True, stdin=subprocess.DEVNULL)
        except OSError as error:
            raise PostError(f"cannot run postproc ({executable}): {error.strerror}") from None
        # Messages name the posted program by the output's name, not by the temporary folder.
        messages = result.stderr.decode("utf-8", "replace").replace(posted_folder + os.sep, "")
        if result.returncode != 0:
            meaning = EXIT_CODES.get(result.returncode, "failed")
            raise PostError(f"postproc compensate: {meaning} (exit {result.returncode}); "
                            f"nothing was written\n{messages.rstrip()}")
        with open(compensated, encoding="ascii", errors="replace", newline="") as handle:
            text = handle.read()
    for line in messages.splitlines():
        report = FreeCAD.Console.PrintWarning if ": warning:" in line else FreeCAD.Console.PrintMessage
        report(line + "\n")
    return text


def write_atomically(filename, text):
    """Replace ``filename`` by the complete program, or leave it as it was."""
    folder = os.path.dirname(os.path.abspath(filename))
    try:
        handle, temporary = tempfile.mkstemp(dir=folder, prefix=".postproc-", suffix=".tmp")
    except OSError as error:
        raise PostError(f"cannot write {filename}: {error.strerror}; nothing was written") from None
    try:
        with os.fdopen(handle, "w", encoding="ascii", errors="replace", newline="\n") as output:
            output.write(text)
        # mkstemp makes the file private; give it the mode the program had, or an ordinary one.
        os.chmod(temporary, os.stat(filename).st_mode & 0o777 if os.path.exists(filename) else 0o644)
        os.replace(temporary, filename)
    except OSError as error:
        os.unlink(temporary)
        raise PostError(f"cannot write {filename}: {error.strerror}; nothing was written") from None
