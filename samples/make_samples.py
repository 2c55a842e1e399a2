"""Regenerate the sample measurements from the virtual V40R (issue 4, item 8).

    /tmp/venv/bin/python samples/make_samples.py

Deterministic: the machine's seed and a fixed stream per file, so a second run rewrites the
same bytes. Writes samples/ballbar/, samples/probe/ and samples/README.md; paths in the files
are relative to the repository.
"""

from __future__ import annotations

import os
from pathlib import Path

from postproc.files.output import write_atomically
from postproc.simulator import ballbar_test, calibrate, cut, generator, load, nominal, probe_profile, read_program
from postproc.simulator.files import calibration_text, probe_text, trace_text

REPO = Path(__file__).resolve().parents[1]
MACHINE = "samples/machines/v40r-sim.toml"
HEMISHELL = "samples/programs/hemishell.nc"
ARC_LINE = 10  #: the G03 of the hemishell: the 57.15 mm arc from the pole to the equator

README = """# Sample measurements

Made by `samples/make_samples.py` (run it with the project's Python to regenerate them: the
output is the same byte for byte) on the virtual lathe of `postproc simulate`, configured by
the `[simulation]` table of `machines/v40r-sim.toml`: a V40R-like machine with +80/-100 ppm
scaling, 4/3 um backlash, a 0.3/0.2 um ballscrew-pitch term, 0.4 um/100 mm squareness, a
30 us X-behind-Z servo mismatch, a tool set 8 um off in X and 4 um in Z, cutting deflection
of 2-3 um, a tool 0.25 mm off centre height (a 20 um nub at the pole), a probe with 6 um
pretravel and 1.5 um three-lobe lobing. The seed is the table's ({seed}).

| file | what | the same readings from the command line (only the `x-` provenance keys differ) |
|---|---|---|
| `ballbar/v40r-100-ccw.csv` | 100 mm ballbar test, G03 (ccw), 1000 mm/min, processed form (720 samples, 0.5 deg) | `postproc simulate ballbar --machine {machine} --direction ccw --form processed` |
| `ballbar/v40r-100-cw.csv` | the same test, G02 (cw) | `... --direction cw --form processed` |
| `ballbar/v40r-100-ccw-raw.csv` | the ccw test, raw form: 4320 time-ordered readings from 0 deg, six per processed sample | `... --direction ccw --form raw` |
| `ballbar/v40r-100-cw-raw.csv` | the cw test, raw form | `... --direction cw --form raw` |
| `probe/artifact-calibration.csv` | probe calibration on the 50.8 mm sphere at (80, 30): 73 touches every 2.5 deg over its top 180 deg | `postproc simulate calibrate --machine {machine}` |
| `probe/hemishell-pass1.csv` | 36 touches from the pole to the equator of a first (uncompensated) pass of `{program}` (its line {line}), with the datum ring probed before and after | `postproc simulate probe {program} --machine {machine} --from-line {line} --to-line {line}` |

Try them:

    postproc ballbar samples/ballbar/v40r-100-ccw.csv samples/ballbar/v40r-100-cw.csv
    postproc compensate {program} --plugin omp-feedback --probe samples/probe/hemishell-pass1.csv \\
        --calibration samples/probe/artifact-calibration.csv
    postproc simulate inspect {program} --machine {machine} --from-line {line} --to-line {line}

The pole reads about 20 um high in the probe file: that is the nub (docs/methods.md §9.5), which the
probe compensators must screen out.
"""


def main() -> None:
    os.chdir(REPO)
    simulation, profile = load(MACHINE)
    seed = simulation.seed
    provenance = {"simulated-by": "samples/make_samples.py", "machine": MACHINE, "seed": seed}
    for direction in ("ccw", "cw"):
        for form in ("processed", "raw"):
            run = ballbar_test(simulation, generator(seed, f"ballbar-{direction}-{form}"), direction, form)
            suffix = "-raw" if form == "raw" else ""
            _write(f"samples/ballbar/v40r-100-{direction}{suffix}.csv", trace_text(run, provenance))

    calibration = calibrate(simulation, generator(seed, "calibrate"))
    _write("samples/probe/artifact-calibration.csv", calibration_text(calibration, provenance))

    name, moves = read_program(HEMISHELL, profile)
    arc = nominal(moves, ARC_LINE, ARC_LINE, program=name)
    surface = cut(moves, arc, simulation)
    probe = probe_profile(surface, arc, simulation, generator(seed, "probe"))
    _write("samples/probe/hemishell-pass1.csv", probe_text(probe, provenance | {"program": name}))

    _write("samples/README.md", README.format(seed=seed, machine=MACHINE, program=HEMISHELL, line=ARC_LINE))


def _write(path: str, text: str) -> None:
    write_atomically(path, text.encode())
    print(path)


if __name__ == "__main__":
    main()
