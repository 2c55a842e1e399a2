"""The report's figures, rendered to PNG in memory.

The ballbar plots are :mod:`postproc.report.plotting`'s own (the polar trace plot with the test's
figures, deviation against angle), so the report shows what ``postproc ballbar --plot``
draws; the profile plots and the verdict's chart (before and after against the band) are
drawn here the same way (matplotlib's object API, imported on use, no pyplot). Deviations are
plotted in micrometres against theta or the arc length along the profile. A legend label
may hold a file name: it is drawn literally (``$`` escaped, so mathtext never parses it).
"""

from __future__ import annotations

import io
import os
import struct
import tempfile
from collections.abc import Sequence

import numpy as np

from ..measure.readers.ballbar import BallbarTrace
from .pathplot import magnification_for
from .document import Image

DPI = 100


def png_image(png: bytes, alt: str, caption: str = "") -> Image:
    """An Image of PNG bytes, its pixel size read from the IHDR chunk."""
    if png[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError("not a PNG")
    width, height = struct.unpack(">II", png[16:24])
    return Image(png, width, height, alt, caption)


def _through_file(draw, *args, **options) -> bytes:
    """Run one of postproc.report.plotting's functions, which write a file, and keep the bytes."""
    with tempfile.TemporaryDirectory(prefix="postproc-report-") as folder:
        path = os.path.join(folder, "figure.png")
        draw(*args, path, **options)
        with open(path, "rb") as handle:
            return handle.read()


def _png(figure) -> bytes:
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=DPI)
    return buffer.getvalue()


def _figure(width: float = 8.0, height: float = 4.2):
    from matplotlib.figure import Figure

    figure = Figure(figsize=(width, height), dpi=DPI, layout="constrained")
    return figure, figure.add_subplot()


def polar(traces: Sequence[BallbarTrace], caption: str, test=None, diagnosis=None, measured: str | None = None) -> Image:
    """The traces about the nominal circle, magnified, with the test's ISO figures and diagnosis
    written beside them (postproc.report.plotting.plot_traces: the plot ``postproc ballbar`` draws)."""
    from .plotting import plot_traces

    png = _through_file(plot_traces, list(traces), test=test, diagnosis=diagnosis, measured=measured)
    return png_image(png, "polar plot of the ballbar traces", caption)


def against_angle(series: Sequence[tuple[str, np.ndarray, np.ndarray]], caption: str) -> Image:
    """Deviation in um against theta; ``series`` are (label, angles_deg, deviations_mm), each in
    the order to draw it (a partial arc from its start, NaN at its gaps: plotting.along_arc)."""
    from .plotting import plot_deviation_vs_angle

    return png_image(_through_file(plot_deviation_vs_angle, list(series)), "ballbar deviation against angle", caption)


def probe_deviations(s: np.ndarray, measured: np.ndarray, cleaned: np.ndarray, kept: np.ndarray, caption: str) -> Image:
    """Probed deviations along the profile: as measured, the dropped ones marked, and as cleaned."""
    figure, axes = _figure()
    order = np.argsort(s)
    s, measured, cleaned, kept = s[order], measured[order] * 1000.0, cleaned[order] * 1000.0, kept[order]
    axes.plot(s, cleaned, "-", color="tab:blue", linewidth=1.0, label="cleaned (drives compensation)")
    axes.plot(s[kept], measured[kept], "o", color="tab:blue", markersize=3.5, label="measured")
    if not kept.all():
        axes.plot(s[~kept], measured[~kept], "x", color="tab:red", markersize=7, label="dropped (nub or outlier)")
    _deviation_axes(axes, "s, arc length along the profile (mm)")
    return png_image(_png(figure), "probed deviation against arc length", caption)


def touched_points(points: np.ndarray, caption: str) -> Image:
    """Touched points in the XZ plane, seen from +Y: Z to the right, X up."""
    figure, axes = _figure(6.0, 4.5)
    axes.plot(points[:, 1], points[:, 0], "o", markersize=3.5, color="tab:blue")
    axes.set_xlabel("z (mm)")
    axes.set_ylabel("x (radius mm)")
    axes.set_aspect("equal", adjustable="datalim")
    axes.grid(True, linewidth=0.3)
    return png_image(_png(figure), "touched points in the XZ plane", caption)


def calibration(theta: np.ndarray, k: np.ndarray, curve: tuple[np.ndarray, np.ndarray], caption: str) -> Image:
    """Pretravel k at each calibration touch, and the fitted model."""
    figure, axes = _figure()
    axes.plot(theta, k * 1000.0, "o", markersize=3.5, color="tab:blue", label="k at each touch")
    axes.plot(curve[0], curve[1] * 1000.0, "-", color="tab:orange", linewidth=1.2, label="fitted model")
    axes.set_xlabel("theta of the surface normal (deg, from +X towards +Z)")
    axes.set_ylabel("k (um)")
    axes.grid(True, linewidth=0.3)
    axes.legend(fontsize="small")
    return png_image(_png(figure), "probe pretravel against direction", caption)


def along_profile(lines: Sequence[tuple[str, np.ndarray, np.ndarray, str]], caption: str) -> Image:
    """Deviations along the profile; ``lines`` are (label, s_mm, deviation_mm, style)."""
    figure, axes = _figure()
    for label, s, deviation, style in lines:
        axes.plot(s, np.asarray(deviation) * 1000.0, style, label=_literal(label), linewidth=1.1, markersize=3.5)
    _deviation_axes(axes, "s, arc length along the profile (mm)")
    return png_image(_png(figure), "predicted deviation along the profile", caption)


def profile_shape(points: np.ndarray, shapes: Sequence[tuple[str, np.ndarray, np.ndarray, np.ndarray, str]],
                  caption: str) -> Image:
    """The nominal profile (``points`` along it) and deviated ones, magnified along the normal.

    ``shapes`` are (label, points, outward normals, deviation_mm at each point, style); NaN
    leaves a gap.
    """
    figure, axes = _figure(6.4, 5.6)
    axes.plot(points[:, 1], points[:, 0], "-", color="grey", linewidth=0.9, label="nominal")
    largest = max((float(np.nanmax(np.abs(d))) for *_, d, _ in shapes if np.any(np.isfinite(d))), default=0.0)
    extent = float(np.ptp(points, axis=0).max()) or 1.0
    magnification = magnification_for(largest, extent, 0.08)
    for label, where, normals, deviation, style in shapes:
        shown = where + (np.asarray(deviation) * magnification)[:, None] * normals
        axes.plot(shown[:, 1], shown[:, 0], style, linewidth=1.1, markersize=3.5, label=_literal(label))
    axes.set_xlabel("z (mm)")
    axes.set_ylabel("x (radius mm)")
    axes.set_aspect("equal", adjustable="datalim")
    axes.grid(True, linewidth=0.3)
    axes.legend(fontsize="small", title=f"deviation magnified \u00d7{magnification:,.0f} along the normal",
                title_fontsize="small")
    return png_image(_png(figure), "nominal profile and the predicted profiles", caption)


def _literal(label: str) -> str:
    return label.replace("$", r"\$")


def _deviation_axes(axes, xlabel: str) -> None:
    axes.axhline(0.0, color="grey", linewidth=0.8)
    axes.set_xlabel(xlabel)
    axes.set_ylabel("deviation (um), + = material left")
    axes.grid(True, linewidth=0.3)
    axes.legend(fontsize="small")


VERDICT_COLOURS = {"before": ("tab:orange", "tab:brown", "tab:pink"), "after": ("tab:blue", "tab:green", "tab:purple")}


def verdict(series: Sequence[tuple[str, np.ndarray, np.ndarray, str, bool]], band_mm: float, xlabel: str,
            caption: str) -> Image:
    """Before and after against the band: ``series`` are (label, where, deviation_mm, "before" or
    "after", measured); a measurement is drawn as its points, a prediction as a line; the band
    is shaded and its edges drawn."""
    figure, axes = _figure(8.0, 3.6)
    band_um = band_mm * 1000.0
    axes.axhspan(-band_um, band_um, color="tab:green", alpha=0.12, linewidth=0)
    for edge in (-band_um, band_um):
        axes.axhline(edge, color="tab:green", linewidth=1.0, linestyle="--")
    axes.plot([], [], color="tab:green", linewidth=6, alpha=0.25, label=f"band \u00b1{band_um:g} um")
    axes.axhline(0.0, color="grey", linewidth=0.8)
    used = {"before": 0, "after": 0}
    for label, where, deviation, which, measured in series:
        colour = VERDICT_COLOURS[which][used[which] % 3]
        used[which] += 1
        order = np.argsort(where, kind="stable")
        x, y = np.asarray(where)[order], np.asarray(deviation, dtype=float)[order] * 1000.0
        if measured:
            size = 4.0 if len(x) <= 200 else 1.6
            axes.plot(x, y, "o" if which == "after" else "s", color=colour, markersize=size, label=_literal(label),
                      alpha=0.9 if which == "after" else 0.7, markeredgewidth=0)
        else:
            axes.plot(x, y, "-", color=colour, linewidth=2.0 if which == "after" else 1.3, label=_literal(label))
    axes.set_xlabel(xlabel)
    axes.set_ylabel("deviation (um), + = material left")
    axes.grid(True, linewidth=0.3)
    axes.legend(fontsize="small", loc="best")
    return png_image(_png(figure), "deviation before and after compensation against the band", caption)
