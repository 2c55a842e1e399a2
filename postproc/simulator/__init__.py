"""A deterministic virtual two-axis lathe, to judge compensation methods as docs/methods.md §8 does.

One job per module:

- :mod:`.config`: the ``[simulation]`` table of a machine profile (every key documented there);
- :mod:`.errors`: the machine error model (equations and sign conventions there);
- :mod:`.path`: commanded paths sampled in time; :mod:`postproc.measure.nominal`: a program's profile
  (:mod:`.nominal`: the wear offsets its G10 blocks set);
- :mod:`.surface`: what a stylus or a CMM touches;
- :mod:`.ballbar`, :mod:`.cut`, :mod:`.touch` + :mod:`.probe`, :mod:`.calibrate`, :mod:`.cmm`:
  the ballbar test, cutting, probing a profile, calibrating on the sphere, inspecting;
- :mod:`.files`: the results as files of docs/formats.md §4-§6 and §17.

Conventions (docs/formats.md §1): radius coordinates x and z in mm; theta from +X towards +Z; ``cw``
(G02) runs with theta increasing, ``ccw`` (G03) decreasing. An error is actual minus
commanded. Ballbar deviation: bar length minus nominal radius (positive outside). Profile
deviation: along the normal out of the material, positive = material left. Noise comes from
:func:`.config.generator`: the same seed gives the same files.
"""

from .nominal import run_program  # the submodule first: the function ``nominal`` below then takes its name here
from ..measure.nominal import Nominal, nominal, read_program
from .ballbar import BallbarRun, ballbar_test, program_test
from .calibrate import CalibrationRun, artifact_round, calibrate
from .cmm import Inspection, inspect
from .config import Simulation, generator, load
from .cut import cut
from .errors import Machine
from .probe import ProbeRun, probe_profile
from .surface import Turned

__all__ = ["BallbarRun", "CalibrationRun", "Inspection", "Machine", "Nominal", "ProbeRun", "Simulation", "Turned",
           "artifact_round", "ballbar_test", "calibrate", "cut", "generator", "inspect", "load", "nominal",
           "probe_profile", "program_test", "read_program", "run_program"]
