"""The virtual machine's results as files: the formats of docs/formats.md, and its own surface file.

Traces, probe files and calibrations are written exactly as docs/formats.md §4-§6 describes, so the
project's readers take them; provenance goes into ``x-`` header keys, which readers keep and
ignore. Lengths get 7 decimals (0.1 nm): the noise, not the format, limits the data.

The surface of a cut (postproc's own format, docs/formats.md §17):

    # postproc surface 1
    # x-program = part.nc
    x_mm,z_mm
    0.0000000,57.1700000
    ...

rows ordered along the tool path, x the radius (>= 0) of the turned surface.
"""

from __future__ import annotations

import numpy as np

from ..measure.readers.csvfile import read_table
from ..measure.readers.probe import CALIBRATION_MAGIC, PROBE_MAGIC
from .ballbar import BallbarRun
from .calibrate import CalibrationRun
from .cmm import Inspection
from .probe import ProbeRun
from .surface import Turned

SURFACE_MAGIC = "# postproc surface 1"
BALLBAR_MAGIC = "# postproc ballbar 1"


def _number(value: float) -> str:
    text = f"{value:.7f}"
    return "0.0000000" if text == "-0.0000000" else text


def _header(magic: str, keys: dict[str, object], provenance: dict[str, object]) -> list[str]:
    lines = [magic]
    lines += [f"# {key} = {value}" for key, value in keys.items()]
    lines += [f"# x-{key} = {value}" for key, value in provenance.items()]
    return lines


def trace_text(run: BallbarRun, provenance: dict[str, object], centered: bool = False) -> str:
    """A trace file; ``centered`` marks it so (the bar not re-mounted since the trace whose centre counts)."""
    keys: dict[str, object] = {"radius_mm": f"{run.radius:.10g}", "direction": run.direction,
                               "center_x_mm": f"{run.centre[0]:.10g}", "center_z_mm": f"{run.centre[1]:.10g}",
                               "feed_mm_min": f"{run.feed:.10g}"}
    if centered:
        keys["centered"] = "true"
    if run.raw:
        keys |= {"start_angle_deg": f"{run.start_angle:.10g}", "capture_arc_deg": f"{run.capture:.10g}"}
        rows = ["deviation_mm"] + [_number(value) for value in run.deviations]
    else:
        angles = np.mod(run.angles, 360.0)
        rows = ["angle_deg,deviation_mm"] + [f"{angle:.6f},{_number(value)}" for angle, value in zip(angles, run.deviations)]
    return "\n".join(_header(BALLBAR_MAGIC, keys, provenance) + rows) + "\n"


def _touch_rows(centres: np.ndarray, approach: np.ndarray) -> list[str]:
    rows = ["x_mm,z_mm,approach_x,approach_z"]
    for (x, z), (ax, az) in zip(centres, approach):
        rows.append(f"{_number(x)},{_number(z)},{_number(ax)},{_number(az)}")
    return rows


def probe_text(run: ProbeRun, provenance: dict[str, object]) -> str:
    keys: dict[str, object] = {"stylus_radius_mm": f"{run.stylus_radius:.10g}"}
    for axis in sorted(run.datum_before):
        keys[f"datum_before_{axis}_mm"] = _number(run.datum_before[axis])
        keys[f"datum_after_{axis}_mm"] = _number(run.datum_after[axis])
    if run.datum_before:
        keys["repeatability_mm"] = f"{run.repeatability:.10g}"
    return "\n".join(_header(PROBE_MAGIC, keys, provenance) + _touch_rows(run.centres, run.approach)) + "\n"


def cmm_probe_text(inspection: Inspection, stylus_radius: float, provenance: dict[str, object]) -> str:
    """The CMM's points as a probe file: at each point the stylus centre a CMM with a ball of
    ``stylus_radius`` reports, touching along the nominal normal (its own probing errors already
    compensated, as a CMM's software does), so that ``C + R_stylus n`` is the measured point."""
    normals = inspection.normals
    measured = inspection.points + inspection.deviations[:, None] * normals
    keys = {"stylus_radius_mm": f"{stylus_radius:.10g}"}
    return "\n".join(_header(PROBE_MAGIC, keys, provenance)
                     + _touch_rows(measured + stylus_radius * normals, -normals)) + "\n"


def calibration_text(run: CalibrationRun, provenance: dict[str, object]) -> str:
    artifact = run.artifact
    keys = {"stylus_radius_mm": f"{run.stylus_radius:.10g}", "artifact_radius_mm": f"{artifact.radius_mm:.10g}",
            "artifact_center_x_mm": f"{artifact.center_x_mm:.10g}", "artifact_center_z_mm": f"{artifact.center_z_mm:.10g}"}
    return "\n".join(_header(CALIBRATION_MAGIC, keys, provenance) + _touch_rows(run.centres, run.approach)) + "\n"


def surface_text(surface: Turned, provenance: dict[str, object]) -> str:
    rows = ["x_mm,z_mm"] + [f"{_number(x)},{_number(z)}" for x, z in surface.points]
    return "\n".join(_header(SURFACE_MAGIC, {}, provenance) + rows) + "\n"


def read_surface(path: str) -> Turned:
    """A surface file written by ``postproc simulate cut``."""
    table = read_table(path, SURFACE_MAGIC, set(), [["x_mm", "z_mm"]])
    points = np.column_stack([table.column("x_mm"), table.column("z_mm")])
    if len(points) < 2:
        raise table.error("a surface needs at least two points")
    negative = np.flatnonzero(points[:, 0] < 0.0)
    if negative.size:
        raise table.error("a surface radius cannot be negative", int(table.lines[negative[0]]))
    return Turned(points)
