"""``postproc path --plot``: the nominal path and the compensated one, deviations magnified.

Corrections are micrometres on parts of tens of millimetres; drawn to scale they vanish.
Each point of the compensated path is drawn at its nearest point of the nominal path plus
the difference times a magnification chosen so the largest difference shows as a fixed
share of the drawing (stated on it).
"""

from __future__ import annotations

import numpy as np

from .geometry import Profile, segment_of
from .motion import ARC, LINE, RAPID, Move


def _points(moves: list[Move], step: float = 0.05) -> list[np.ndarray]:
    """Each chain of known moves as a dense polyline (rapids dashed apart: their own chains)."""
    chains, current = [], []
    for move in moves:
        if not move.known or move.kind not in (LINE, ARC, RAPID):
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


def plot_paths(nominal: list[Move], compensated: list[Move] | None, path: str, title: str = "") -> float:
    """Draw the paths to ``path`` (.png or .svg); returns the magnification used."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    from .output import write_atomically

    figure = Figure(figsize=(8, 6))
    axes = figure.add_subplot()
    feeds = [m for m in nominal if m.kind in (LINE, ARC) and m.known]
    for chain in _points(nominal):
        axes.plot(chain[:, 1], chain[:, 0], color="0.6", linewidth=0.8)
    magnification = 1.0
    if compensated and feeds:
        profile = Profile(tuple(segment_of(m) for m in feeds))
        chains = _points([m for m in compensated if m.kind in (LINE, ARC)])
        all_points = np.concatenate(chains) if chains else np.zeros((0, 2))
        if len(all_points):
            near = profile.closest(all_points)
            largest = float(near.distance.max())
            size = float(np.ptp(np.concatenate(_points(feeds)), axis=0).max()) or 1.0
            magnification = max(1.0, 0.05 * size / largest) if largest > 0 else 1.0
            start = 0
            for chain in chains:
                part = near.foot[start : start + len(chain)] + magnification * (chain - near.foot[start : start + len(chain)])
                axes.plot(part[:, 1], part[:, 0], color="tab:red", linewidth=1.0)
                start += len(chain)
        axes.plot([], [], color="tab:red", label=f"compensated, deviations x{magnification:.0f}")
    axes.plot([], [], color="0.6", label="nominal")
    axes.set_xlabel("z (mm)")
    axes.set_ylabel("x (radius, mm)")
    axes.set_aspect("equal", adjustable="datalim")
    axes.legend(loc="best")
    axes.set_title(title)
    import io

    buffer = io.BytesIO()
    kind = "svg" if path.lower().endswith(".svg") else "png"
    figure.savefig(buffer, format=kind, dpi=120)
    write_atomically(path, buffer.getvalue())
    return magnification
