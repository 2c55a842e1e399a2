"""What each FANUC lathe G code means, per G-code system (A, B, C).

Codes are keyed as ten times their number (G01 -> 10, G07.1 -> 71, G112 -> 1120) so that
the decimal codes fit. A code that is not in the table is unknown to the interpreter: the
block passes through untouched and the position is unknown afterwards, because a modal
code nobody understands may change what every following block means.
"""

from __future__ import annotations

# Kinds of meaning.
MOTION = "motion"  #: group 01: the value is the motion mode
ONE_SHOT = "one-shot"  #: group 00 codes that use the block's words in their own way
MODAL = "modal"  #: a modal setting the interpreter tracks (the value says which)
HARMLESS = "harmless"  #: no effect on the programmed path
UNSUPPORTED = "unsupported"  #: known, but its path cannot be modelled here

# Motion modes (values of MOTION entries).
G00, G01, G02, G03, G32 = 0, 10, 20, 30, 320
TURN_CYCLE, THREAD_CYCLE, FACE_CYCLE = "turn-cycle", "thread-cycle", "face-cycle"

# One-shot meanings.
DWELL = "dwell"
DATA = "data"  #: G10 programmable data input: words are data, not a position
REF_CHECK = "reference-check"
HOME = "reference-return"
HOME2 = "second-reference-return"
SKIP = "skip"
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

_COMMON: dict[int, tuple[str, object]] = {
    0: (MOTION, G00),
    10: (MOTION, G01),
    20: (MOTION, G02),
    30: (MOTION, G03),
    40: (ONE_SHOT, DWELL),
    50: (HARMLESS, "high-speed-cycle"),
    51: (HARMLESS, "ai-contour"),  # G05.1
    71: (UNSUPPORTED, "cylindrical interpolation"),  # G07.1
    80: (HARMLESS, "look-ahead"),  # G08
    90: (HARMLESS, "exact-stop"),  # G09
    100: (ONE_SHOT, DATA),
    110: (HARMLESS, "data-input-cancel"),
    121: (UNSUPPORTED, "polar coordinate interpolation"),  # G12.1
    131: (HARMLESS, "polar-interpolation-cancel"),  # G13.1
    170: (MODAL, PLANE_XY),
    180: (MODAL, PLANE_ZX),
    190: (MODAL, PLANE_YZ),
    220: (ONE_SHOT, DATA),  # stored stroke check on: X Z I K are limits
    230: (HARMLESS, "stroke-check-off"),
    250: (HARMLESS, "spindle-fluctuation-off"),
    260: (ONE_SHOT, DATA),  # spindle speed fluctuation detection on: P Q R are data
    270: (ONE_SHOT, REF_CHECK),
    280: (ONE_SHOT, HOME),
    300: (ONE_SHOT, HOME2),
    310: (ONE_SHOT, SKIP),
    320: (MOTION, G32),
    340: (MOTION, G32),  # variable lead threading
    360: (ONE_SHOT, AUTO_OFFSET),
    370: (ONE_SHOT, AUTO_OFFSET),
    400: (MODAL, COMP_OFF),
    410: (MODAL, COMP_LEFT),
    420: (MODAL, COMP_RIGHT),
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
    670: (MODAL, MODAL_MACRO_CANCEL),
    680: (UNSUPPORTED, "mirror image for double turret"),
    690: (HARMLESS, "mirror-image-cancel"),
    800: (MODAL, DRILL_CANCEL),
    830: (MODAL, DRILL),
    840: (MODAL, DRILL),
    850: (MODAL, DRILL),
    870: (MODAL, DRILL),
    880: (MODAL, DRILL),
    890: (MODAL, DRILL),
    960: (MODAL, CSS_ON),
    970: (MODAL, CSS_OFF),
    1120: (UNSUPPORTED, "polar coordinate interpolation"),
    1130: (HARMLESS, "polar-interpolation-cancel"),
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
        500: (ONE_SHOT, COORDINATE),
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
        770: (MOTION, TURN_CYCLE),
        780: (MOTION, THREAD_CYCLE),
        790: (MOTION, FACE_CYCLE),
        900: (MODAL, ABSOLUTE),
        910: (MODAL, INCREMENTAL),
        920: (ONE_SHOT, COORDINATE),
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


def motion_code(system: str, mode: int | str) -> int:
    """The G code key that commands a motion mode in this system (for writing blocks)."""
    for key, (kind, value) in SYSTEMS[system].items():
        if kind == MOTION and value == mode:
            return key
    raise KeyError(mode)
