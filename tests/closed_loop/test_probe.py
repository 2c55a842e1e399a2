"""Closed loop with the on-machine probe: cut on the virtual lathe, probe, compensate through the
command line, cut again, inspect with the virtual CMM (docs/methods.md §9, §10;
the dissertation's sections 6.4 and 7.5).

The virtual V40R of the samples (seeded) stands in for the machine. Figures are the four of
docs/methods.md §12; the CMM point at the pole lands on the nub, which no path can reach (the tool
never gets to the axis), so the figures are taken over the points off the axis, as the source
read its profiles ("neglecting the pole").
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from postproc.api import Pipeline
from postproc.cli.main import main
from postproc.diagnostics import EXIT_BAD_INPUT, EXIT_REFUSED
from support import INCH_HEMISHELL, REPO
from support.parts import SHAFT

HEMISHELL = str(REPO / "samples" / "programs" / "hemishell.nc")
SAMPLE_MACHINE = REPO / "samples" / "machines" / "v40r-sim.toml"
ARC_LINE = "10"  #: the hemishell's G03
R = 57.15
STOCK = 0.025  #: the first pass is cut this far outside (0.0254 mm in the source; 0.001 mm diameter grid here)


def postproc(*args, input: str | None = None):
    """``postproc ARGS`` through the real command line, in-process."""
    return CliRunner().invoke(main, [str(a) for a in args], input=input, catch_exceptions=False)


def ok(*args):
    result = postproc(*args)
    assert result.exit_code == 0, result.stderr
    return result


def machine(tmp_path: Path, name: str, **changes: str) -> str:
    """The sample machine with some lines of its [simulation] tables replaced: ``key=value``."""
    text = SAMPLE_MACHINE.read_text()
    for key, value in changes.items():
        lines = [line for line in text.splitlines() if line.startswith(f"{key} =")]
        assert len(lines) == 1, key
        text = text.replace(lines[0], f"{key} = {value}")
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def perfect_but(tmp_path: Path, table: str) -> str:
    """A machine with only the errors of a [simulation] table given as TOML text."""
    path = tmp_path / "machine.toml"
    path.write_text(f'name = "test"\n[simulation]\nseed = 11\n{table}')
    return str(path)


def first_pass(tmp_path: Path, stock: float) -> str:
    """The hemishell program, ``stock`` further out."""
    r = R + stock
    text = Path(HEMISHELL).read_text()
    text = text.replace("G01 Z57.15 F", f"G01 Z{r:.3f} F").replace(
        "G03 X114.3 Z0. I0. K-57.15", f"G03 X{2 * r:.3f} Z0. I0. K-{r:.3f}")
    path = tmp_path / "pass1.nc"
    path.write_text(text)
    return str(path)


def arc_lines(program: str) -> tuple[str, str]:
    """The lines of the blocks that now make the hemishell arc (both ends on its sphere)."""
    rows = ok("path", program).stdout.splitlines()[1:]
    lines = []
    for row in rows:
        line, kind, *numbers = row.split(",")
        if kind in ("line", "arc"):
            x0, z0, x1, z1 = (float(v) for v in numbers[:4])
            if abs(np.hypot(x0, z0) - R) < 0.1 and abs(np.hypot(x1, z1) - R) < 0.1:
                lines.append(int(line))
    return str(min(lines)), str(max(lines))


def inspect(the_machine: str, tmp_path: Path, program: str = HEMISHELL) -> dict:
    """The CMM's deviations of the surface ``program`` cuts from the nominal hemishell arc."""
    first, last = (ARC_LINE, ARC_LINE) if program == HEMISHELL else arc_lines(program)
    surface = tmp_path / "surface.csv"
    ok("simulate", "cut", program, "--machine", the_machine, "--from-line", first, "--to-line", last, "-o", surface)
    result = ok("simulate", "inspect", HEMISHELL, "--machine", the_machine, "--from-line", ARC_LINE, "--to-line",
                ARC_LINE, "--surface", surface, "--json")
    return json.loads(result.stdout)


def off_pole(inspection: dict) -> tuple[float, float]:
    """Mean and standard deviation (um, ddof 0) of the points off the spindle axis."""
    deviation = np.array([p["deviation_mm"] for p in inspection["points"] if p["x_mm"] > 1.0]) * 1000.0
    return float(deviation.mean()), float(deviation.std())


def probe_and_calibrate(program: str, the_machine: str, tmp_path: Path, lines=(ARC_LINE, ARC_LINE)):
    probe, calibration = tmp_path / "p.csv", tmp_path / "c.csv"
    ok("simulate", "probe", program, "--machine", the_machine, "--from-line", lines[0], "--to-line", lines[1],
       "-o", probe)
    ok("simulate", "calibrate", "--machine", the_machine, "-o", calibration)
    return str(probe), str(calibration)


# -- omp-feedback ---------------------------------------------------------------------------


def test_omp_feedback_at_least_halves_the_mean_and_the_spread_of_a_cut_part(tmp_path):
    """Tool set 18 um off in X and 2 um in Z, deflection, a nub at the pole, a probe with lobing."""
    the_machine = machine(tmp_path, "v40r.toml", tool_offset_x_mm="0.018", tool_offset_z_mm="0.002")
    probe, calibration = probe_and_calibrate(first_pass(tmp_path, STOCK), the_machine, tmp_path)
    compensated = tmp_path / "hemishell-omp.nc"
    result = ok("compensate", HEMISHELL, "--plugin", "omp-feedback", "--probe", probe, "--calibration", calibration,
                "--option", f"stock={STOCK}", "-o", compensated)
    assert "dropped as the nub at the pole" in result.stderr

    before = off_pole(inspect(the_machine, tmp_path))
    after = off_pole(inspect(the_machine, tmp_path, str(compensated)))
    print(f"omp-feedback: mean {before[0]:+.2f} -> {after[0]:+.2f} um, sigma {before[1]:.2f} -> {after[1]:.2f} um")
    assert before[0] > 10.0 and before[1] > 3.0  # the error is there to be taken out
    assert abs(after[0]) <= abs(before[0]) / 2 and after[1] <= before[1] / 2
    # by the CMM, as the source measured its part after compensation (Table 7.11): 1.5 / 3.1 um; what the
    # on-machine probe cannot see (the machine's errors, read through its own axes) stays
    assert abs(after[0]) < 2.5 and after[1] < 1.5


def test_omp_feedback_reports_both_figures_and_the_dropped_nub(tmp_path):
    sample = REPO / "samples" / "probe"
    pipeline = Pipeline(plugins=["omp-feedback"], probe=[str(sample / "hemishell-pass1.csv")],
                        calibration=str(sample / "artifact-calibration.csv"))
    pipeline.compensate_text(Path(HEMISHELL).read_text())
    report = pipeline.core.report()[0]
    chain = report["chains"][0]
    assert chain["moves"] == "lines 9-11" and chain["points"] == 36
    assert [(d["row"], d["kind"]) for d in chain["dropped"]] == [(13, "nub")]
    nub = chain["dropped"][0]
    assert nub["deviation_mm"] - nub["replacement_mm"] > 0.015  # the nub stands 19 um above its neighbours' trend
    assert chain["measured_error_um"]["mean_um"] > chain["cleaned_error_um"]["mean_um"]
    assert chain["cleaned_error_um"]["mean_um"] == pytest.approx(12.1, abs=1.0)
    # the stretch runs from the pole to the equator: the whole arc and neither line
    assert chain["stretch_mm"] == pytest.approx([4.85, 4.85 + np.pi / 2 * R], abs=1e-6)
    assert any("datum x stable" in note for note in report["notes"])


def test_omp_feedback_moves_only_the_stretch_the_touches_cover(tmp_path):
    """A profile of lines and arcs probed from part way down its cylinder to its shoulder."""
    program = tmp_path / "shaft.nc"
    program.write_text(SHAFT)
    the_machine = perfect_but(tmp_path, "[simulation.cut]\ntool_offset_x_mm = 0.010\ntool_offset_z_mm = -0.006\n")
    probe = tmp_path / "p.csv"
    ok("simulate", "probe", program, "--machine", the_machine, "-o", probe)
    rows = probe.read_text().splitlines()
    header = rows.index("x_mm,z_mm,approach_x,approach_z") + 1
    kept = [row for row in rows[header:] if float(row.split(",")[1]) < -2.0]  # not the chamfer, not the top
    probe.write_text("\n".join(rows[:header] + kept) + "\n")
    first_z = max(float(row.split(",")[1]) for row in kept)

    text = ok("compensate", program, "--plugin", "omp-feedback", "--probe", probe).stdout
    assert "G01 X100. Z5. F200.\n" in text  # the chamfer: not covered, unchanged
    path = [row.split(",") for row in postproc("path", "-", input=text).stdout.splitlines()[1:]]
    moves = [(kind, *(float(v) for v in numbers[:4])) for _, kind, *numbers in path if kind in ("line", "arc")]
    top = [m for m in moves if m[0] == "line" and m[1] == m[3] == 50.0 and m[2] == 5.0]
    # the cylinder above the first touch stays, up to the core's last sample before it (0.05 mm apart)
    assert len(top) == 1 and abs(top[0][4] - first_z) <= 0.05
    body = [m for m in moves if m[0] == "line" and m[1] == m[3] and m[4] < first_z - 0.05]
    assert body and all(m[1] == m[3] == pytest.approx(50.0 - 0.010, abs=0.0011) for m in body)
    shoulder = moves[-1]  # the face at z = -40 is 6 um low: it moves up by 6 um
    assert shoulder[2] == shoulder[4] == pytest.approx(-40.0 + 0.006, abs=0.0011)


def sample_rows(tmp_path: Path, keep: list[int]) -> tuple[str, str]:
    """The sample probe file with only some of its touches (1-based touch numbers: 1 is the nub at the pole)."""
    sample = REPO / "samples" / "probe"
    lines = (sample / "hemishell-pass1.csv").read_text().splitlines()
    header = lines.index("x_mm,z_mm,approach_x,approach_z") + 1
    kept = lines[:header] + [lines[header + i - 1] for i in keep]
    path = tmp_path / "few.csv"
    path.write_text("\n".join(kept) + "\n")
    return str(path), str(sample / "artifact-calibration.csv")


@pytest.mark.parametrize("keep", [[1], [1, 2], [2, 19]])
def test_omp_feedback_refuses_thin_evidence_naming_the_feature_and_its_rows(keep, tmp_path):
    """One or two touches on the arc cannot be screened for the nub: the run is refused, not a dip cut."""
    probe, calibration = sample_rows(tmp_path, keep)
    result = postproc("compensate", HEMISHELL, "--plugin", "omp-feedback", "--probe", probe, "--calibration",
                      calibration)
    assert result.exit_code == EXIT_BAD_INPUT and result.stdout == ""
    rows = ", ".join(str(12 + i) for i in range(1, len(keep) + 1))
    assert f"the G03 arc R57.15 on line 10 has {len(keep)} touch" in result.stderr and f"(row{'s' if len(keep) > 1 else ''} {rows})" in result.stderr
    assert "no feature of the profile has the 3 touches omp-feedback needs" in result.stderr


def test_omp_feedback_screens_the_nub_out_of_three_touches(tmp_path):
    """The nub (26.4 um high) and two touches beside it: the nub is dropped, no dip is cut at the pole."""
    probe, calibration = sample_rows(tmp_path, [1, 2, 3])
    pipeline = Pipeline(plugins=["omp-feedback"], probe=[probe], calibration=calibration)
    text = pipeline.compensate_text(Path(HEMISHELL).read_text())
    report = pipeline.core.report()[0]
    chain = report["chains"][0]
    assert [(d["row"], d["kind"]) for d in chain["dropped"]] == [(13, "nub")]
    arc = next(f for f in chain["features"] if f["lines"] == [10, 10])
    assert arc["status"] == "corrected" and arc["touches"] == 3
    assert arc["cleaned_error_um"]["mean_um"] < arc["measured_error_um"]["mean_um"] - 5.0
    assert report["minimum_touches_per_feature"] == 3
    pole = next(line for line in text.splitlines() if line.startswith("G01 X0. Z"))
    assert float(pole.split("Z")[1].split()[0]) > 57.15 - 0.012  # the touches beside it read 8-9 um, the nub 28


def test_a_feature_in_the_probed_stretch_without_touches_is_left_as_programmed_and_named(tmp_path):
    """The shaft probed on its cylinder and its face, not on the fillet between them."""
    program = tmp_path / "shaft.nc"
    program.write_text(SHAFT)
    the_machine = perfect_but(tmp_path, "[simulation.cut]\ntool_offset_x_mm = 0.010\ntool_offset_z_mm = -0.006\n")
    probe = tmp_path / "p.csv"
    ok("simulate", "probe", program, "--machine", the_machine, "--inset", "0.5", "--points", "12", "-o", probe)
    rows = probe.read_text().splitlines()
    header = rows.index("x_mm,z_mm,approach_x,approach_z") + 1
    # the fillet's touches come in at a slant; the cylinder's along X, the chamfer's at 45 deg from -Z
    fillet = [row for row in rows[header:] if float(row.split(",")[1]) < -20.0 and 0.0 not in
              [float(value) for value in row.split(",")[2:]]]
    assert len(fillet) == 3
    probe.write_text("\n".join(row for row in rows if row not in fillet) + "\n")
    result = ok("compensate", program, "--plugin", "omp-feedback", "--probe", probe)
    assert ("warning: omp-feedback: the G02 arc R20 on line 8 has no touch; at least 3 per feature are needed to "
            "screen them for the nub and outliers: left as programmed") in result.stderr
    assert "G02 X140. Z-40. R20.\n" in result.stdout  # as it was


# -- tool-offset ----------------------------------------------------------------------------

TOOL_SET = (0.020, -0.012)  #: the injected tool-setting error, radius mm


@pytest.fixture
def tool_set(tmp_path):
    """A machine whose only cutting error is a tool set (20, -12) um off, probed and calibrated."""
    the_machine = perfect_but(tmp_path, f"""
[simulation.probe]
pretravel_mm = 0.006
lobing_mm = 0.0015
noise_mm = 0.0005
[simulation.cut]
tool_offset_x_mm = {TOOL_SET[0]}
tool_offset_z_mm = {TOOL_SET[1]}
[simulation.cmm]
noise_mm = 0.0003
""")
    return (the_machine, *probe_and_calibrate(HEMISHELL, the_machine, tmp_path))


def test_tool_offset_recovers_the_tool_setting_error_and_compensating_removes_it(tool_set, tmp_path):
    the_machine, probe, calibration = tool_set
    pipeline = Pipeline(plugins=["tool-offset"], probe=[probe], calibration=calibration)
    pipeline.compensate_text(Path(HEMISHELL).read_text())
    report = pipeline.core.report()[0]
    offset, sigma = report["offset_mm"], report["offset_sigma_mm"]
    assert abs(offset["x"] - TOOL_SET[0]) < 0.0005 and abs(offset["z"] - TOOL_SET[1]) < 0.0005
    assert 0 < sigma["x"] < 0.0005 and 0 < sigma["z"] < 0.0005
    assert report["tool"] == 1 and report["largest_residual_mm"] <= report["residual_allowed_mm"] == 0.005

    compensated = tmp_path / "hemishell-offset.nc"
    ok("compensate", HEMISHELL, "--plugin", "tool-offset", "--probe", probe, "--calibration", calibration,
       "-o", compensated)
    before = off_pole(inspect(the_machine, tmp_path))
    after = off_pole(inspect(the_machine, tmp_path, str(compensated)))
    print(f"tool-offset: mean {before[0]:+.2f} -> {after[0]:+.2f} um, sigma {before[1]:.2f} -> {after[1]:.2f} um")
    assert before[1] > 5.0
    # what is left is the output's rounding: the G03 is written on the 0.001 mm grid within 1 um of the target
    assert abs(after[0]) < 1.0 and after[1] < 1.0


def test_a_wear_offset_is_added_by_an_incremental_g10_after_the_units_and_stated(tool_set, tmp_path):
    _, probe, calibration = tool_set
    report = tmp_path / "report.json"
    base = ["compensate", HEMISHELL, "--plugin", "tool-offset", "--probe", probe, "--calibration", calibration,
            "--option", "apply=wear-offset"]
    result = ok(*base, "--report", report)
    text = result.stdout
    # 20 um too big in radius: U-0.040 on the diameter; 12 um short in Z: W+0.012; added to what the register holds,
    # right after the block that sets the units and the plane, before the tool call
    lines = text.splitlines()
    at = lines.index("G18 G21 G40 G99")
    assert lines[at + 1] == "G10 P1 U-0.040 W0.012" and lines.index("T0101") > at + 1
    assert "(TOOL-OFFSET ADDED G10 P1 U-0.040 W0.012 AFTER LINE 4)" in lines
    provenance = ("(POSTPROC", "(PLUGIN", "(OPTION", "(INPUT", "(TOLERANCE", "(MACHINE", "(LARGEST", "(BLOCKS", "(TOOL-OFFSET", "G10 ")
    assert [line for line in lines if not line.startswith(provenance)] == Path(HEMISHELL).read_text().splitlines()
    assert "(BLOCKS REPLACED 0 BY 0)" in text
    assert ("warning: tool-offset: G10 P1 U-0.040 W0.012 opens the program: it adds -0.040 mm (a diameter) to the X "
            "wear and 0.012 mm to the Z wear of offset 1 each time the program runs") in result.stderr
    stated = json.loads(report.read_text())["compensators"][0]
    assert stated["g10"] == "G10 P1 U-0.040 W0.012"
    assert stated["wear_offset"] == {"number": 1, "u_mm": pytest.approx(-0.040, abs=5e-4),
                                     "w_mm": pytest.approx(0.012, abs=5e-4), "incremental": True}
    assert "\nG10 P12 U-0.040 W0.012\n" in ok(*base, "--option", "offset=12").stdout


def test_a_wear_offset_in_an_inch_program_is_written_in_inches(tool_set, tmp_path):
    _, probe, calibration = tool_set
    inch = tmp_path / "inch.nc"
    inch.write_text(INCH_HEMISHELL)
    text = ok("compensate", inch, "--plugin", "tool-offset", "--probe", probe, "--calibration", calibration,
              "--option", "apply=wear-offset").stdout.splitlines()
    assert text[text.index("G18 G20 G40 G99") + 1] == "G10 P1 U-0.0016 W0.0005"  # -0.040 and 0.012 mm


@pytest.mark.parametrize("eol", ["\r\n", "\r"])
def test_the_wear_offset_block_takes_the_programs_line_ending(tool_set, tmp_path, eol):
    _, probe, calibration = tool_set
    program = tmp_path / "part.nc"
    program.write_bytes(Path(HEMISHELL).read_text().replace("\n", eol).encode())
    result = postproc("compensate", program, "--plugin", "tool-offset", "--probe", probe, "--calibration",
                      calibration, "--option", "apply=wear-offset")
    assert result.exit_code == 0, result.stderr
    assert f"{eol}G18 G21 G40 G99{eol}G10 P1 U-0.040 W0.012{eol}G50 S2000{eol}".encode() in result.stdout_bytes


@pytest.mark.parametrize("opening, problem", [
    ("G18 G40 G99\nT0101\n", "sets no units (G20/G21) before its first tool call or move"),
    ("T0101\nG18 G21 G40 G99\n", "sets no units (G20/G21) before its first tool call or move"),
    # with the block delete switch on, the control skips the units: a G10 after them would be read in any;
    # the message names the block that sets them and its switch, not a program without units
    ("/G18 G21 G40 G99\nT0101\n", ":4:1: error: the program sets its units (G20/G21) only in a block behind the "
                                  "block delete '/', which the control skips with the block delete switch on"),
    ("/2 G21\nG18 G40 G99\nT0101\n", ":4:1: error: the program sets its units (G20/G21) only in a block behind "
                                      "the block delete '/2'"),
    ("G18 G40 G99\n/G20\n/G21\nT0101\n", ":5:1: error: the program sets its units (G20/G21) only in a block "
                                         "behind the block delete '/'"),
    ("G18 G40 G99\nG21 G00 X200. Z100.\nT0101\n", "before its first tool call or move (it sets them in that block: "
                                                  "the opening blocks go before the tool moves or is called)"),
])
def test_a_wear_offset_is_refused_where_the_units_are_not_set_before_the_tool_call(tool_set, tmp_path, opening,
                                                                                      problem):
    _, probe, calibration = tool_set
    text = Path(HEMISHELL).read_text().replace("G18 G21 G40 G99\nG50 S2000\nT0101\n", opening + "G50 S2000\n")
    program = tmp_path / "part.nc"
    program.write_text(text)
    result = postproc("compensate", program, "--plugin", "tool-offset", "--probe", probe, "--calibration",
                      calibration, "--option", "apply=wear-offset")
    assert result.exit_code == EXIT_REFUSED and result.stdout == ""
    assert problem in result.stderr and "read in whatever units the control was left in" in result.stderr
    assert f"{program}:" in result.stderr


def test_tool_offset_leaves_a_thinly_probed_feature_out_of_the_registration(tmp_path):
    program = tmp_path / "shaft.nc"
    program.write_text(SHAFT)
    the_machine = perfect_but(tmp_path, "[simulation.cut]\ntool_offset_x_mm = 0.010\ntool_offset_z_mm = -0.006\n")
    probe, report = tmp_path / "p.csv", tmp_path / "report.json"
    ok("simulate", "probe", program, "--machine", the_machine, "--inset", "0.5", "--points", "12", "-o", probe)
    rows = probe.read_text().splitlines()
    face = [row for row in rows if row.endswith(",0.0000000,-1.0000000")]
    kept = [row for row in rows if row != face[0]]  # 2 touches left on the face
    probe.write_text("\n".join(kept) + "\n")
    first, second = (kept.index(row) + 1 for row in face[1:])
    result = ok("compensate", program, "--plugin", "tool-offset", "--probe", probe, "--report", report)
    assert (f"warning: tool-offset: the face on line 9 has 2 touches (rows {first}, {second}); at least 3 per feature "
            "are needed to screen them for the nub and outliers: left out of the registration") in result.stderr
    fitted = json.loads(report.read_text())["compensators"][0]
    assert fitted["left_out"] == [{"feature": "the face on line 9", "rows": [first, second]}]
    assert fitted["points_used"] == 9
    assert fitted["offset_mm"]["x"] == pytest.approx(0.010, abs=1e-4)  # the chamfer still fixes Z
    assert fitted["offset_mm"]["z"] == pytest.approx(-0.006, abs=1e-4)


def test_a_saved_model_compensates_as_the_files_do(tmp_path):
    sample = REPO / "samples" / "probe"
    files = ["--probe", sample / "hemishell-pass1.csv", "--calibration", sample / "artifact-calibration.csv"]
    for plugin, options in (("omp-feedback", []), ("tool-offset", ["--option", "apply=wear-offset"])):
        model = tmp_path / f"{plugin}.json"
        ok("fit", "--plugin", plugin, *files, *options, "-o", model)
        direct = ok("compensate", HEMISHELL, "--plugin", plugin, *files, *options).stdout
        applied = ok("compensate", HEMISHELL, "--model", model).stdout
        assert [line for line in applied.splitlines() if not line.startswith("(")] == \
            [line for line in direct.splitlines() if not line.startswith("(")]


# -- the datum check ------------------------------------------------------------------------


@pytest.mark.parametrize("plugin", ["omp-feedback", "tool-offset"])
def test_a_datum_that_moved_refuses_the_points_and_force_overrides(plugin, tmp_path):
    the_machine = machine(tmp_path, "warm.toml", drift_x_mm="0.006")  # over repeatability_mm = 0.003
    probe, calibration = probe_and_calibrate(HEMISHELL, the_machine, tmp_path)
    base = ["compensate", HEMISHELL, "--plugin", plugin, "--probe", probe, "--calibration", calibration]
    result = postproc(*base)
    assert result.exit_code == EXIT_REFUSED and result.stdout == ""
    assert f"{probe}: error: the machine moved during the inspection: datum_before_x_mm" in result.stderr
    forced = ok(*base, "--force")
    assert "used anyway (--force)" in forced.stderr and "(POSTPROC" in forced.stdout
