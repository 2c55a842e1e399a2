"""What each FANUC lathe G code means, per G-code system (A, B, C).

Codes are keyed as ten times their number (G01 -> 10, G07.1 -> 71, G112 -> 1120) so that
the decimal codes fit. A code that is not in the table is unknown to the interpreter: the
block passes through untouched and the position is unknown afterwards, because a modal
code nobody understands may change what every following block means.

The table follows the G code list of the FANUC Series 0i-TF/16i/18i-T manuals, system by
system: threading is G32 in system A and G33 in systems B and C (G32 there is no code at
all, and the control alarms, PS0010). A mode whose moves cannot be modelled here (polar
or cylindrical interpolation, mirror image, polygon turning) is UNMODELLED: the blocks up
to its cancel code pass through uninterpreted.
"""

from __future__ import annotations

# Kinds of meaning.
MOTION = "motion"  #: group 01: the value is the motion mode
ONE_SHOT = "one-shot"  #: group 00 codes that use the block's words in their own way
MODAL = "modal"  #: a modal setting the interpreter tracks (the value says which)
HARMLESS = "harmless"  #: no effect on the programmed path
UNMODELLED = "unmodelled"  #: starts a mode whose moves cannot be modelled (the value names it)
CANCEL = "cancel"  #: ends the UNMODELLED mode its value names

# Motion modes (values of MOTION entries): the key of the code in system A.
G00, G01, G02, G03, G32 = 0, 10, 20, 30, 320
VARIABLE_LEAD, CIRCULAR_THREAD = 340, 350  #: G34; G35 threading along an arc (clockwise)
THREADING = frozenset((G32, VARIABLE_LEAD, CIRCULAR_THREAD))
TURN_CYCLE, THREAD_CYCLE, FACE_CYCLE = "turn-cycle", "thread-cycle", "face-cycle"

# One-shot meanings.
DWELL = "dwell"
DATA = "data"  #: G10 programmable data input: words are data, not a position
REF_CHECK = "reference-check"
HOME = "reference-return"
HOME2 = "second-reference-return"
SKIP = "skip"
CORNER_ARC = "corner-circular-interpolation"  #: G39: an arc on the offset path only; I, K give a direction
PRESET = "workpiece-coordinate-preset"  #: G50.3 (A) / G92.1 (B, C): the position in new coordinates
COORDINATE = "coordinate-setting"  #: G50 (A) / G92 (B, C)
LOCAL = "local-coordinates"
MACHINE = "machine-coordinates"
MACRO_CALL = "macro-call"
AUTO_OFFSET = "automatic-tool-offset"
FINISH = "finishing-cycle"  #: G70
ROUGH_TURN = "stock-removal-turning"  #: G71
ROUGH_FACE = "stock-removal-facing"  #: G72
PATTERN = "pattern-repeating"  #: G73
FACE_PECK = "face-peck-drilling"  #: G74
GROOVE = "grooving"  #: G75
THREAD_MULTI = "multiple-threading"  #: G76

CONTOUR_CYCLES = (FINISH, ROUGH_TURN, ROUGH_FACE, PATTERN)
ONE_WAY_CYCLES = (ROUGH_TURN, ROUGH_FACE)  #: the cycles whose contour must run one way (FANUC alarm PS0064)

# Modal settings (values of MODAL entries).
INCH, METRIC = "inch", "metric"
ABSOLUTE, INCREMENTAL = "absolute", "incremental"
PER_MINUTE, PER_REV = "per-minute", "per-rev"
COMP_OFF, COMP_LEFT, COMP_RIGHT = "comp-40", "comp-41", "comp-42"
PLANE_XY, PLANE_ZX, PLANE_YZ = "plane-17", "plane-18", "plane-19"
WORK = "work-offset"
DRILL_CANCEL = "drill-cancel"
DRILL = "drill"  #: G83-G89 drilling cycles with live tools
MODAL_MACRO, MODAL_MACRO_CANCEL = "modal-macro", "modal-macro-cancel"
CSS_ON, CSS_OFF = "constant-surface-speed", "constant-surface-speed-cancel"

CYLINDRICAL = "cylindrical interpolation"
POLAR = "polar coordinate interpolation"
TURRET_MIRROR = "mirror image for double turrets or balance cutting"
MIRROR = "programmable mirror image"
POLYGON = "polygon turning"

_COMMON: dict[int, tuple[str, object]] = {
    0: (MOTION, G00),
    10: (MOTION, G01),
    20: (MOTION, G02),
    30: (MOTION, G03),
    40: (ONE_SHOT, DWELL),
    50: (HARMLESS, "high-speed-cycle"),
    51: (HARMLESS, "ai-contour"),  # G05.1
    54: (HARMLESS, "hrv3"),  # G05.4 HRV3 on/off
    71: (UNMODELLED, CYLINDRICAL),  # G07.1 (G07.1 C0 cancels it)
    80: (HARMLESS, "look-ahead"),  # G08
    90: (HARMLESS, "exact-stop"),  # G09
    100: (ONE_SHOT, DATA),
    106: (ONE_SHOT, DATA),  # G10.6 tool retract and recover: the retract amount
    110: (HARMLESS, "data-input-cancel"),
    121: (UNMODELLED, POLAR),  # G12.1
    131: (CANCEL, POLAR),  # G13.1
    170: (MODAL, PLANE_XY),
    180: (MODAL, PLANE_ZX),
    190: (MODAL, PLANE_YZ),
    220: (ONE_SHOT, DATA),  # stored stroke check on: X Z I K are limits
    230: (HARMLESS, "stroke-check-off"),
    250: (HARMLESS, "spindle-fluctuation-off"),
    260: (ONE_SHOT, DATA),  # spindle speed fluctuation detection on: P Q R are data
    270: (ONE_SHOT, REF_CHECK),
    280: (ONE_SHOT, HOME),
    282: (ONE_SHOT, HOME),  # G28.2 reference position return without the in-position check
    300: (ONE_SHOT, HOME2),
    301: (ONE_SHOT, HOME2),  # G30.1 floating reference position return
    310: (ONE_SHOT, SKIP),
    311: (ONE_SHOT, SKIP),  # G31.1-G31.3 multi-step skip
    312: (ONE_SHOT, SKIP),
    313: (ONE_SHOT, SKIP),
    318: (ONE_SHOT, SKIP),  # G31.8 EGB skip
    340: (MOTION, VARIABLE_LEAD),
    350: (MOTION, CIRCULAR_THREAD),  # G35; G36 is circular threading only by parameter 3405#3
    360: (ONE_SHOT, AUTO_OFFSET),
    370: (ONE_SHOT, AUTO_OFFSET),
    371: (ONE_SHOT, AUTO_OFFSET),  # G37.1, G37.2: automatic tool offset when G36 threads (parameter 3405#3)
    372: (ONE_SHOT, AUTO_OFFSET),
    390: (ONE_SHOT, CORNER_ARC),
    400: (MODAL, COMP_OFF),
    410: (MODAL, COMP_LEFT),
    420: (MODAL, COMP_RIGHT),
    501: (CANCEL, MIRROR),  # G50.1
    502: (CANCEL, POLYGON),  # G50.2
    511: (UNMODELLED, MIRROR),  # G51.1
    512: (UNMODELLED, POLYGON),  # G51.2
    520: (ONE_SHOT, LOCAL),
    530: (ONE_SHOT, MACHINE),
    540: (MODAL, WORK),
    541: (MODAL, WORK),
    550: (MODAL, WORK),
    560: (MODAL, WORK),
    570: (MODAL, WORK),
    580: (MODAL, WORK),
    590: (MODAL, WORK),
    610: (HARMLESS, "exact-stop-mode"),
    620: (HARMLESS, "automatic-corner-override"),
    630: (HARMLESS, "tapping-mode"),
    640: (HARMLESS, "cutting-mode"),
    650: (ONE_SHOT, MACRO_CALL),
    660: (MODAL, MODAL_MACRO),
    661: (MODAL, MODAL_MACRO),  # G66.1: every following block is a macro call
    670: (MODAL, MODAL_MACRO_CANCEL),
    680: (UNMODELLED, TURRET_MIRROR),
    690: (CANCEL, TURRET_MIRROR),
    800: (MODAL, DRILL_CANCEL),
    804: (HARMLESS, "egb-cancel"),  # G80.4 electronic gear box: synchronisation off (a rotary axis only)
    810: (MODAL, DRILL),  # G81 spot drilling, G82 counter boring (FS10/11-T format)
    814: (HARMLESS, "egb-start"),  # G81.4
    820: (MODAL, DRILL),
    830: (MODAL, DRILL),
    831: (MODAL, DRILL),  # G83.1 high-speed peck drilling (FS10/11-T format)
    840: (MODAL, DRILL),
    842: (MODAL, DRILL),  # G84.2 rigid tapping (FS15 format)
    843: (MODAL, DRILL),  # G84.3 reverse rigid tapping (FS15 format)
    850: (MODAL, DRILL),
    870: (MODAL, DRILL),
    880: (MODAL, DRILL),
    890: (MODAL, DRILL),
    911: (ONE_SHOT, DATA),  # G91.1 checking the maximum incremental amount: the amounts
    960: (MODAL, CSS_ON),
    961: (ONE_SHOT, DATA),  # G96.1-G96.4 spindle indexing and SV speed control
    962: (ONE_SHOT, DATA),
    963: (ONE_SHOT, DATA),
    964: (ONE_SHOT, DATA),
    970: (MODAL, CSS_OFF),
    1070: (UNMODELLED, CYLINDRICAL),  # G107 = G07.1
    1120: (UNMODELLED, POLAR),  # G112 = G12.1
    1130: (CANCEL, POLAR),  # G113 = G13.1
    2500: (CANCEL, POLYGON),  # G250 = G50.2
    2510: (UNMODELLED, POLYGON),  # G251 = G51.2
}

_CYCLES_AB = {
    700: (ONE_SHOT, FINISH),
    710: (ONE_SHOT, ROUGH_TURN),
    720: (ONE_SHOT, ROUGH_FACE),
    730: (ONE_SHOT, PATTERN),
    740: (ONE_SHOT, FACE_PECK),
    750: (ONE_SHOT, GROOVE),
    760: (ONE_SHOT, THREAD_MULTI),
}

SYSTEMS: dict[str, dict[int, tuple[str, object]]] = {
    "A": {
        **_COMMON,
        **_CYCLES_AB,
        200: (MODAL, INCH),
        210: (MODAL, METRIC),
        320: (MOTION, G32),
        500: (ONE_SHOT, COORDINATE),
        503: (ONE_SHOT, PRESET),
        900: (MOTION, TURN_CYCLE),
        920: (MOTION, THREAD_CYCLE),
        940: (MOTION, FACE_CYCLE),
        980: (MODAL, PER_MINUTE),
        990: (MODAL, PER_REV),
    },
    "B": {
        **_COMMON,
        **_CYCLES_AB,
        200: (MODAL, INCH),
        210: (MODAL, METRIC),
        330: (MOTION, G32),
        770: (MOTION, TURN_CYCLE),
        780: (MOTION, THREAD_CYCLE),
        790: (MOTION, FACE_CYCLE),
        900: (MODAL, ABSOLUTE),
        910: (MODAL, INCREMENTAL),
        920: (ONE_SHOT, COORDINATE),
        921: (ONE_SHOT, PRESET),
        940: (MODAL, PER_MINUTE),
        950: (MODAL, PER_REV),
        980: (HARMLESS, "drilling-initial-level"),
        990: (HARMLESS, "drilling-r-level"),
    },
    "C": {
        **_COMMON,
        200: (MOTION, TURN_CYCLE),
        210: (MOTION, THREAD_CYCLE),
        240: (MOTION, FACE_CYCLE),
        330: (MOTION, G32),
        700: (MODAL, INCH),
        710: (MODAL, METRIC),
        720: (ONE_SHOT, FINISH),
        730: (ONE_SHOT, ROUGH_TURN),
        740: (ONE_SHOT, ROUGH_FACE),
        750: (ONE_SHOT, PATTERN),
        760: (ONE_SHOT, FACE_PECK),
        770: (ONE_SHOT, GROOVE),
        780: (ONE_SHOT, THREAD_MULTI),
        900: (MODAL, ABSOLUTE),
        910: (MODAL, INCREMENTAL),
        920: (ONE_SHOT, COORDINATE),
        921: (ONE_SHOT, PRESET),
        940: (MODAL, PER_MINUTE),
        950: (MODAL, PER_REV),
        980: (HARMLESS, "drilling-initial-level"),
        990: (HARMLESS, "drilling-r-level"),
    },
}


def code_key(value: float) -> int:
    """G01 -> 10, G7.1 -> 71."""
    return int(round(value * 10))


def code_name(key: int) -> str:
    whole, tenth = divmod(key, 10)
    return f"G{whole:02d}" if tenth == 0 else f"G{whole:02d}.{tenth}"


_DESCRIBED = {G32: "threading", PER_REV: "feed per revolution", PER_MINUTE: "feed per minute",
              ABSOLUTE: "absolute programming", INCREMENTAL: "incremental programming", INCH: "inch input",
              METRIC: "metric input", TURN_CYCLE: "the turning cycle", THREAD_CYCLE: "the threading cycle",
              FACE_CYCLE: "the facing cycle", COORDINATE: "coordinate system setting",
              VARIABLE_LEAD: "variable lead threading", CIRCULAR_THREAD: "circular threading"}


def describe(meaning) -> str:
    """A code's meaning in words, for a message."""
    return _DESCRIBED.get(meaning, str(meaning).replace("-", " "))


def elsewhere(key: int, system: str) -> str:
    """For a code that ``system`` lacks, what the other G-code systems make of it, as a note for
    the warning ('' when none has it): G95 or G91 in a system-A reading most often means the
    program was written for a control set to system B or C, and every G90 and G92 in it then
    means something else too."""
    others = [name for name in sorted(SYSTEMS) if name != system and key in SYSTEMS[name]]
    if not others:
        return ""
    meaning = SYSTEMS[others[0]][key][1]
    described = describe(meaning)
    return (f"; in G-code system {' and '.join(others)} it is {code_name(key)} ({described}): if the control is set to "
            f"{'that system' if len(others) == 1 else 'one of them'}, state gcode_system in the machine profile")


def motion_code(system: str, mode: int | str) -> int:
    """The G code key that commands a motion mode in this system (for writing blocks)."""
    for key, (kind, value) in SYSTEMS[system].items():
        if kind == MOTION and value == mode:
            return key
    raise KeyError(mode)
