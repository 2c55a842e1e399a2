"""``postproc path --plot``: the nominal path and the compensated one, the correction magnified.

Drawn as a programmer reads a path: feeds solid, rapids dashed (each kind its own chains, so a
rapid never looks like a cut). Corrections are micrometres on parts of tens of millimetres;
drawn to scale they vanish. Each point of the compensated path is drawn at its nearest point
of the nominal path plus the difference times a magnification, a round number (1, 2 or 5
times a power of ten) that makes the largest difference a fixed share of the drawing; the
legend states it.
"""

from __future__ import annotations

import io
import math

import numpy as np

from ..geometry import Profile, segment_of
from ..interpret.motion import ARC, LINE, RAPID, Move

SHARE = 0.05  #: the largest correction is drawn this share of the part's size


def _chains(moves: list[Move], kinds: tuple[str, ...], step: float = 0.05) -> list[np.ndarray]:
    """Each run of known moves of the given kinds as a dense polyline; any other move ends a run."""
    chains, current = [], []
    for move in moves:
        if not move.known or move.kind not in kinds:
            if current:
                chains.append(np.concatenate(current))
            current = []
            continue
        segment = segment_of(move)
        count = max(2, int(segment.length / step) + 1)
        current.append(segment.point_at(np.linspace(0, 1, count)))
    if current:
        chains.append(np.concatenate(current))
    return chains


def magnification_for(largest: float, size: float, share: float = SHARE) -> float:
    """A round magnification that draws ``largest`` (mm) at most ``share`` of ``size`` (mm), at least 1."""
    if largest <= 0.0:
        return 1.0
    # a round number a rounding error short of the share still fits: 0.01 / 1e-05 is 999.9999999999999,
    # whose log10 is 3.0, and 1000 draws the correction at exactly its share
    wanted = share * size / largest * (1.0 + 1e-9)
    if wanted <= 1.0:
        return 1.0
    wanted *= 1.0 + 1e-9  # a quotient one rounding below a round number (999.9999999999999) is that number
    power = 10.0 ** math.floor(math.log10(wanted))
    return max(step * power for step in (1.0, 2.0, 5.0) if step * power <= wanted)


def plot_paths(nominal: list[Move], compensated: list[Move] | None, path: str, title: str = "") -> float:
    """Draw the paths to ``path`` (.png or .svg); returns the magnification used."""
    import matplotlib
    from matplotlib.figure import Figure

    from ..files.output import write_atomically

    figure = Figure(figsize=(8, 6))
    axes = figure.add_subplot()
    for chain in _chains(nominal, (RAPID,)):
        axes.plot(chain[:, 1], chain[:, 0], color="0.55", linewidth=0.8, linestyle=(0, (5, 4)))
    feeds = [m for m in nominal if m.kind in (LINE, ARC) and m.known]
    for chain in _chains(nominal, (LINE, ARC)):
        axes.plot(chain[:, 1], chain[:, 0], color="0.35", linewidth=1.0)
    axes.plot([], [], color="0.35", linewidth=1.0, label="nominal feed")
    axes.plot([], [], color="0.55", linewidth=0.8, linestyle=(0, (5, 4)), label="rapid (G00)")
    magnification = 1.0
    if compensated and feeds:
        profile = Profile(tuple(segment_of(m) for m in feeds))
        chains = _chains(compensated, (LINE, ARC))
        all_points = np.concatenate(chains) if chains else np.zeros((0, 2))
        if len(all_points):
            near = profile.closest(all_points)
            largest = float(near.distance.max())
            size = float(np.ptp(np.concatenate(_chains(feeds, (LINE, ARC))), axis=0).max()) or 1.0
            magnification = magnification_for(largest, size)
            start = 0
            for chain in chains:
                foot = near.foot[start: start + len(chain)]
                part = foot + magnification * (chain - foot)
                axes.plot(part[:, 1], part[:, 0], color="tab:red", linewidth=1.1)
                start += len(chain)
            axes.plot([], [], color="tab:red", linewidth=1.1,
                      label=f"compensated feed, correction magnified \u00d7{magnification:,.0f}"
                            f" (largest {largest * 1000:.1f} um)")
    axes.set_xlabel("z (mm)")
    axes.set_ylabel("x (radius, mm)")
    axes.set_aspect("equal", adjustable="datalim")
    axes.grid(True, linewidth=0.3)
    axes.legend(loc="best", fontsize="small")
    axes.set_title(title)
    buffer = io.BytesIO()
    kind = "svg" if path.lower().endswith(".svg") else "png"
    with matplotlib.rc_context({"svg.fonttype": "none"}):  # an SVG keeps its text as text
        figure.savefig(buffer, format=kind, dpi=120, metadata={"Date": None} if kind == "svg" else None)
    write_atomically(path, buffer.getvalue())
    return magnification
