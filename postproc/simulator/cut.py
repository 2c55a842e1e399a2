"""Cutting a program on the virtual lathe: the surface its profile's feed moves leave.

The control runs every move of the program (so that lost motion and servo lag carry over
from one move to the next); the surface is what the tool tip leaves along the profile
(:mod:`postproc.measure.nominal`), from the moment a lagging axis has caught up with the profile's start:

1. actual tool path = commanded + machine error (:mod:`.errors`) + tool-setting offset + the
   wear the program's G10 blocks gave the move's offset number (``wear``,
   :func:`.nominal.wear_added`);
2. cutting deflection: the tool is pushed away from the material along the nominal outward
   normal m, by ``deflection_x m_x^2 + deflection_z m_z^2`` (material is left: a positive
   deviation);
3. the tool tip stands ``tool_y`` off the Y = 0 plane, so it turns radius
   ``rho = sqrt(x^2 + tool_y^2)``;
4. the nub: where the profile starts or ends on the spindle axis (within ON_AXIS_MM of it:
   a compensated profile's pole moves by microns), the tool only comes as close to it as rho
   at that end (a tool that crosses the axis is cut where it crosses); the material inside
   stays, ``nub_height`` above the end along the outward normal's Z sense, as a flat-topped
   cylinder. With no nub height the gap is closed flat.

The tool is a point (no nose radius: the programmed path is the tip's path, G40).
"""

from __future__ import annotations

import numpy as np

from ..interpret.motion import Move
from ..measure.nominal import ON_AXIS_MM, Nominal
from .config import Simulation
from .errors import Machine
from .path import sample
from .surface import Turned


def cut(moves: list[Move], nominal: Nominal, simulation: Simulation,
        wear: dict[int, tuple[float, float]] | None = None) -> Turned:
    """The surface the profile of ``nominal`` leaves when ``moves`` run on the virtual lathe."""
    setup = simulation.cut
    place = {index: k for k, index in enumerate(nominal.indexes)}
    commanded = sample(moves, set(place), setup.step_mm, simulation, nominal.program)
    actual = Machine(simulation).tool_path(commanded)
    on_profile = np.isin(commanded.move, nominal.indexes)
    # a lagging axis spends its lag finishing the move before the profile (a rapid, at its own
    # speed): the tip is not on the profile yet, and what it passes then is no surface of it
    lag = max(simulation.x.lag_s, simulation.z.lag_s)
    if lag > 0.0 and on_profile.any():
        begin = commanded.time[on_profile].min()
        settled = on_profile & (commanded.time >= begin + lag)
        on_profile = settled if settled.sum() >= 2 else on_profile
    tip = actual[on_profile] + np.array([setup.tool_offset_x_mm, setup.tool_offset_z_mm])
    if wear:
        worn = np.array([wear.get(moves[i].offset, (0.0, 0.0)) for i in range(len(moves))])
        tip = tip + worn[commanded.move[on_profile]]
    segment = np.array([place[i] for i in commanded.move[on_profile]])
    outward = nominal.outward(segment, commanded.param[on_profile])
    tip = tip + (setup.deflection_x_mm * outward[:, 0] ** 2 + setup.deflection_z_mm * outward[:, 1] ** 2)[:, None] * outward
    keep = np.concatenate([[True], np.any(np.diff(tip, axis=0) != 0.0, axis=1)])
    tip, outward = tip[keep], outward[keep]

    start, end = nominal.profile.segments[0].start, nominal.profile.segments[-1].end
    if abs(start[0]) < ON_AXIS_MM:
        tip = _from_axis(tip)
    if abs(end[0]) < ON_AXIS_MM:
        tip = _from_axis(tip[::-1])[::-1]
    rho = np.hypot(tip[:, 0], setup.tool_y_mm)
    surface = np.column_stack([rho, tip[:, 1]])
    if abs(start[0]) < ON_AXIS_MM:
        surface = _nub(surface, float(np.sign(outward[0, 1])), setup.nub_height_mm)
    if abs(end[0]) < ON_AXIS_MM:
        surface = _nub(surface[::-1], float(np.sign(outward[-1, 1])), setup.nub_height_mm)[::-1]
    return Turned(surface)


def _from_axis(tip: np.ndarray) -> np.ndarray:
    """The tip path from where it leaves the axis: a start beyond it (x < 0) is cut at x = 0."""
    ahead = np.flatnonzero(tip[:, 0] >= 0.0)
    if tip[0, 0] >= 0.0 or ahead.size == 0:
        return tip
    k = int(ahead[0])
    a, b = tip[k - 1], tip[k]
    share = -a[0] / (b[0] - a[0])
    return np.concatenate([[[0.0, a[1] + share * (b[1] - a[1])]], tip[k:]])


def _nub(surface: np.ndarray, up: float, height: float) -> np.ndarray:
    """Close the surface to the axis at its first point: a flat-topped nub ``height`` high."""
    rho, z = surface[0]
    if rho < 1e-9:
        return surface
    if height == 0.0 or up == 0.0:
        return np.concatenate([[[0.0, z]], surface])
    top = z + up * height
    return np.concatenate([[[0.0, top], [rho, top]], surface])
