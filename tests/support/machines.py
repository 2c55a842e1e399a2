"""Virtual lathes drawn at random within realistic ranges, and their ballbar tests on any arc.

The ranges: scaling up to +-120 ppm per axis, backlash up to 12 um, squareness up to
+-30 urad, a servo lag per axis up to 3 ms (their mismatch, at 500 to 1500 mm/min, is the
servo mismatch), a ballscrew-pitch term an order below the errors (up to 0.25 um, pitch 5 to
12 mm), the machine's reference anywhere within 50 mm of the test centre, the test centre
within 20 mm of the work origin, a 100 or 150 mm bar set up to 60 um off centre, and 0.15 to
0.5 um of bar noise. The arcs are a lathe's: the whole circle, 220 deg from -20 deg (the
turret stops short of the spindle, ISO 13041-6) and 180 deg from 0, with 2 deg of
over-travel either side of a partial capture.
"""

from __future__ import annotations

from postproc.measure.readers.ballbar import BallbarTrace, make_trace
from postproc.simulator import ballbar_test, generator
from postproc.simulator.config import from_table

ARCS = {360: (0.0, 360.0, 180.0), 220: (-20.0, 220.0, 2.0), 180: (0.0, 180.0, 2.0)}  #: low end, capture, over-travel


def machine_table(uniform, choice) -> dict:
    """A ``[simulation]`` table; ``uniform(low, high)`` and ``choice(options)`` draw the values."""
    def axis() -> dict:
        return {"scaling": uniform(-120e-6, 120e-6), "backlash_mm": uniform(0.0, 0.012), "lag_s": uniform(0.0, 0.003),
                "pitch_amplitude_mm": uniform(0.0, 0.00025)}

    return {"squareness_rad": uniform(-30e-6, 30e-6), "pitch_mm": choice([5.0, 10.0, 12.0]),
            "reference_x_mm": uniform(-50.0, 50.0), "reference_z_mm": uniform(-50.0, 50.0), "x": axis(), "z": axis(),
            "ballbar": {"radius_mm": choice([100.0, 150.0]), "feed_mm_min": choice([500.0, 1000.0, 1500.0]),
                        "setup_offset_x_mm": uniform(-0.06, 0.06), "setup_offset_z_mm": uniform(-0.06, 0.06),
                        "noise_mm": uniform(0.00015, 0.0005), "center_x_mm": uniform(-20.0, 20.0),
                        "center_z_mm": uniform(-20.0, 20.0)}}


def truth(table: dict) -> dict[str, float]:
    """The diagnosis's parameters of a machine table (servo mismatch: the lag difference at the feed)."""
    feed = table["ballbar"]["feed_mm_min"]
    return {"scaling_x": table["x"]["scaling"], "scaling_z": table["z"]["scaling"],
            "backlash_x": table["x"]["backlash_mm"], "backlash_z": table["z"]["backlash_mm"],
            "squareness": table["squareness_rad"],
            "servo_mismatch": feed / 60.0 * (table["x"]["lag_s"] - table["z"]["lag_s"])}


def traces(table: dict, span: int, seed: int) -> list[BallbarTrace]:
    """The ccw and cw runs of a test over one of ARCS, read as postproc's reader reads them."""
    simulation = from_table(table)
    low, capture, overtravel = ARCS[span]
    result = []
    for direction in ("ccw", "cw"):
        start = low + capture if direction == "ccw" and capture < 360.0 else low
        run = ballbar_test(simulation, generator(seed, direction), direction, "processed", start=start,
                           capture=capture, overtravel=overtravel)
        result.append(make_trace(f"{direction}-{span}.csv", run.radius, direction, run.angles, run.deviations,
                                 run.centre, run.feed))
    return result
