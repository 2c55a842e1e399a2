"""A shop's own postproc plugin: a compensator and a reader for its ballbar software's export."""

from __future__ import annotations

import numpy as np

from postproc.compensator import Compensator, Measurements, Option
from postproc.diagnostics import Location, MeasurementError
from postproc.geometry import Arc
from postproc.hookspecs import hookimpl
from postproc.measure.readers.ballbar import BallbarTrace, make_trace
from postproc.measure.readers.csvfile import snapshot
from postproc.measure.readers.registry import MeasurementReader, first_line


class RadialAllowance(Compensator):
    """Leave a finishing allowance on every feed arc.

    Moves every G02/G03 feed arc outward by ``--option allowance=MM`` along its radius, so
    that curved faces keep stock for grinding while straight faces are cut to size.
    Example, ``allowance=0.05`` on the 57.15 mm hemishell::

        G03 X114.3 Z0. I0. K-57.15   becomes   G03 X114.4 Z0. I0. K-57.2
    """

    name = "radial-allowance"
    options = (Option("allowance", float, 0.0, "mm to leave on every feed arc"),)

    def fit(self, measurements: Measurements) -> None:
        self.allowance = self.settings["allowance"]

    def correct(self, piece):
        arc = piece.segment
        if not isinstance(arc, Arc) or self.allowance == 0.0:
            return None
        unit = (piece.points - np.array(arc.centre)) / arc.r
        return unit * self.allowance

    def model(self) -> dict:
        return {"allowance": self.allowance}

    def load(self, model: dict) -> None:
        self.allowance = float(model["allowance"])


def _is_shopbar(path: str) -> bool:
    return first_line(path).upper().startswith("SHOPBAR EXPORT")


def _read_shopbar(path: str, context) -> BallbarTrace:
    """SHOPBAR EXPORT;RADIUS=100;DIR=CW, then ANGLE;DEV_UM rows."""
    lines = snapshot(path).data.decode("utf-8", "replace").splitlines()  # the file's one read: pipes work too
    fields = dict(part.split("=", 1) for part in lines[0].split(";")[1:] if "=" in part)
    try:
        radius = float(fields["RADIUS"])
        direction = {"CW": "cw", "CCW": "ccw"}[fields["DIR"].strip().upper()]
    except (KeyError, ValueError):
        raise MeasurementError("the SHOPBAR EXPORT line needs RADIUS=... and DIR=CW or CCW", Location(path, 1)) from None
    angles, deviations = [], []
    for number, line in enumerate(lines[2:], 3):
        if not line.strip():
            continue
        try:
            angle, deviation_um = (float(cell) for cell in line.split(";"))
        except ValueError:
            raise MeasurementError(f"expected ANGLE;DEV_UM, not {line!r}", Location(path, number)) from None
        angles.append(angle)
        deviations.append(deviation_um / 1000.0)
    # sorted, held to the minimum evidence and centred as postproc's own reader does
    return make_trace(path, radius, direction, angles, deviations)


@hookimpl
def postproc_compensators():
    return [RadialAllowance]


@hookimpl
def postproc_measurement_readers():
    return [MeasurementReader("ballbar", "SHOPBAR EXPORT", _is_shopbar, _read_shopbar)]
