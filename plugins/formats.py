"""The measurement formats of docs/formats.md §3-§6, registered as every shop's reader would be.

Their hook implementation is ``trylast``, so pluggy puts them after every shop reader that
is not; they accept any file, so that a file no shop reader takes gets the built-in reader's
exact message (wrong magic line, empty, binary, UTF-16...).
"""

from __future__ import annotations

from postproc.hookspecs import hookimpl
from postproc.measure.readers.ballbar import read_ballbar
from postproc.measure.readers.probe import read_calibration, read_probe
from postproc.measure.readers.registry import MeasurementReader


def _any(path: str) -> bool:
    return True


@hookimpl(trylast=True)
def postproc_measurement_readers():
    return [
        MeasurementReader("ballbar", "postproc ballbar 1", _any,
                          lambda path, context: read_ballbar(path, context.reporter, context.averaging, context.max_deviation)),
        MeasurementReader("probe", "postproc probe 1", _any, lambda path, context: read_probe(path)),
        MeasurementReader("calibration", "postproc probe-calibration 1", _any, lambda path, context: read_calibration(path)),
    ]
