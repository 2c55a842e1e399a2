"""Robust screening of probe deviations: outliers, and the nub at the pole (docs/methods.md §9.5;
the dissertation's section 7.5.1).

When the tool sits slightly off the Y = 0 plane it leaves a nub on the spindle axis, and the
pole reads up to +0.02 mm high. Such a reading says nothing about the rest of the path and
must not drive the compensation; neither must a stray touch (a chip, a coolant drop).

Points are screened only against points of their own group: the feature of the profile they
lie on (:mod:`postproc.measure.features`). The error a cut leaves steps at a corner, so a trend taken
across one would call good points on either side outliers. Within a group, points ordered
by arc length ``s``:

1. a robust trend: from 6 points on, LOWESS (local straight lines, tricube weights over the
   ``frac`` nearest points, three bisquare robustness passes); with 3 to 5 points, the
   points that agree best stand for the group and the one left out is judged against them:
   with 4 or 5, the ``n - 1`` that lie closest to a straight line, the one left out judged
   against their line with the scatter about it as the scale; with 3, the two nearest the
   median, the third judged against their mean with their half-difference as the scale.
   None of those that stand for the group is dropped, so at most one point of so few is
   (a robust scale of 4 or 5 residuals is no scale: a line through two of them leaves two
   exact zeros, and a nub 28 um high hid behind it). Fewer than 3 points are not screened (one bad touch cannot be told
   from two good ones): whoever relies on them must say so (the probe compensators' minimum
   evidence per feature);
2. residuals from the trend, their robust scale ``sigma = 1.4826 MAD``, and a point is dropped
   when its residual exceeds ``max(cutoff * sigma, floor)`` (``floor``: differences below the
   probe's repeatability are never called outliers);
3. a dropped point with a positive residual within ``nub_zone`` of the spindle axis is the
   nub; any other is an outlier.

A dropped point is replaced, never silently removed, from good points of its own group:

- ``fill="extrapolate"`` (default): by a straight line fitted to the nearest ``FILL_POINTS``
  good points along the profile, evaluated at the dropped point: an interpolation when good
  points lie on both sides, an extrapolation at an end of the probed stretch (the pole). If the
  dropped point lies farther beyond those points than their own span, by the nearest good
  point's value instead;
- ``fill="nearest"``: by the nearest good point's value, always (the source's other suggestion).

More than ``max_fraction`` of a group's points dropped (and more than one) means the data do
not follow a smooth profile at all (a wrong calibration or program): that is an error, not a
cleaning job.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..diagnostics import Location, MeasurementError, Reporter

MAD_SIGMA = 1.4826  #: MAD to standard deviation for normal data
MIN_POINTS = 3  #: fewer points than this (in a group) are not screened
LOWESS_POINTS = 6  #: from this many points on, the trend is LOWESS; below, a robust straight line
FILL_POINTS = 4  #: good points a replacement is fitted to
FILLS = ("extrapolate", "nearest")


@dataclass(frozen=True, slots=True)
class Dropped:
    """A point that must not drive the compensation, and what replaces it."""

    index: int  #: position in the input arrays
    row: int | None  #: the data row (1-based line) of the probe file
    kind: str  #: "nub" or "outlier"
    deviation: float  #: mm, as measured
    trend: float  #: mm, the robust trend of its neighbours there
    replacement: float  #: mm
    how: str  #: "interpolated", "extrapolated" or "nearest"
    source_rows: tuple[int | None, ...]  #: the rows the replacement was taken from

    def describe(self) -> str:
        what = "the nub at the pole" if self.kind == "nub" else "an outlier"
        rows = ", ".join(str(r) for r in self.source_rows)
        return (f"dropped as {what}: deviation {self.deviation:+.4f} mm where its neighbours' trend is "
                f"{self.trend:+.4f} mm; replaced by {self.replacement:+.4f} mm ({self.how} from rows {rows})")


@dataclass(frozen=True)
class Screening:
    """Deviations with the dropped points replaced, in the order given."""

    deviation: np.ndarray  #: mm, cleaned
    kept: np.ndarray  #: bool, False where a point was dropped
    trend: np.ndarray  #: mm, the robust local trend of each point's group
    sigma: np.ndarray  #: mm, robust scale of the residuals from the trend, of each point's group
    threshold: np.ndarray  #: mm, the residual beyond which a point of that group is dropped
    dropped: tuple[Dropped, ...]
    notes: tuple[str, ...]


def lowess(s: np.ndarray, y: np.ndarray, frac: float = 0.3, passes: int = 3) -> np.ndarray:
    """Robust locally linear smooth of ``y`` over ``s`` (Cleveland 1979), at the points ``s``."""
    n = len(s)
    q = min(n, max(6, int(np.ceil(frac * n)) + 1))
    robust = np.ones(n)
    fitted = np.array(y, dtype=float)
    for step in range(passes + 1):
        for i in range(n):
            distance = np.abs(s - s[i])
            h = np.partition(distance, q - 1)[q - 1] * 1.0001 + 1e-12
            w = np.clip(1.0 - (distance / h) ** 3, 0.0, None) ** 3 * robust
            w[i] = 0.0
            fitted[i] = _line_at(s, y, w, s[i])
        if step == passes:
            break
        residuals = y - fitted
        scale = 6.0 * np.median(np.abs(residuals))
        if scale == 0.0:
            break
        robust = np.clip(1.0 - (residuals / scale) ** 2, 0.0, None) ** 2
    return fitted


def _line_at(s: np.ndarray, y: np.ndarray, w: np.ndarray, at: float) -> float:
    """Weighted least-squares straight line through (s, y), evaluated at ``at``."""
    total = w.sum()
    if total <= 0.0:
        return float(np.mean(y))
    sm, ym = (w @ s) / total, (w @ y) / total
    spread = w @ (s - sm) ** 2
    slope = (w @ ((s - sm) * (y - ym))) / spread if spread > 1e-12 * total else 0.0
    return float(ym + slope * (at - sm))


def _replacement(i: int, s: np.ndarray, y: np.ndarray, good: np.ndarray, fill: str) -> tuple[float, str, np.ndarray]:
    """(value, how, indexes used) for the dropped point ``i``."""
    candidates = np.nonzero(good)[0]
    order = candidates[np.argsort(np.abs(s[candidates] - s[i]), kind="stable")]
    nearest = order[:1]
    if fill == "nearest":
        return float(y[nearest[0]]), "nearest", nearest
    used = np.sort(order[:FILL_POINTS])
    low, high = s[used].min(), s[used].max()
    beyond = max(low - s[i], s[i] - high, 0.0)
    if len(used) < 2 or high - low <= 0.0 or beyond > high - low:
        return float(y[nearest[0]]), "nearest", nearest
    value = _line_at(s[used], y[used], np.ones(len(used)), s[i])
    return value, ("extrapolated" if beyond > 0.0 else "interpolated"), used


def _left_out(s: np.ndarray, y: np.ndarray, cutoff: float, floor: float) -> tuple[np.ndarray, float, float]:
    """(trend, sigma, threshold) of 4 or 5 points: the ``n - 1`` that lie closest to a straight
    line stand for the group, and the one left out is judged against their line, with their
    scatter about it (``n - 3`` degrees of freedom) as the scale."""
    n = len(y)
    best: tuple[float, np.ndarray] | None = None
    for out in range(n):
        others = np.arange(n) != out
        line = _line(s[others], y[others])
        scatter = float(np.sqrt(np.sum((y[others] - np.polyval(line, s[others])) ** 2) / (n - 3)))
        if best is None or scatter < best[0]:
            best = (scatter, np.polyval(line, s))
    sigma, trend = best
    return trend, sigma, max(cutoff * sigma, floor)


def _line(s: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Least-squares straight line (slope, level); a level alone when the points share one ``s``."""
    if np.ptp(s) == 0.0:
        return np.array([0.0, float(np.mean(y))])
    return np.polyfit(s, y, 1)


def _judged(s: np.ndarray, y: np.ndarray, cutoff: float, floor: float) -> tuple[np.ndarray, float, float]:
    """(trend, sigma, threshold) of one group of at least MIN_POINTS points, in their order."""
    n = len(y)
    if n == 3:
        suspect = int(np.argmax(np.abs(y - np.median(y))))
        others = [i for i in range(3) if i != suspect]
        trend = y.copy()
        trend[suspect] = y[others].mean()
        sigma = abs(y[others[0]] - y[others[1]]) / 2.0
        return trend, sigma, max(cutoff * sigma, floor)
    if n < LOWESS_POINTS:
        return _left_out(s, y, cutoff, floor)
    order = np.argsort(s, kind="stable")
    trend = np.empty(n)
    trend[order] = lowess(s[order], y[order])
    residual = y - trend
    sigma = MAD_SIGMA * float(np.median(np.abs(residual - np.median(residual))))
    return trend, sigma, max(cutoff * sigma, floor)


def screen(deviation, s, rows=None, *, groups=None, names=None, axis_distance=None, nub_zone: float = 3.0,
           cutoff: float = 3.5, floor: float = 0.002, fill: str = "extrapolate", max_fraction: float = 0.25,
           path: str | None = None, reporter: Reporter | None = None) -> Screening:
    """Find the nub and outliers among ``deviation`` (mm) at arc lengths ``s`` and replace them.

    :param rows: the data row of each point, for the notes (1-based lines of the probe file).
    :param groups: the group (feature) of each point, integers: points are screened, and
        dropped ones replaced, only within their group. None: one group.
    :param names: a name for each group number (``names[g]``), for notes and errors.
    :param axis_distance: each touched point's distance from the spindle axis (|x|, mm); without
        it no point is called the nub.
    :param nub_zone: how near the axis (mm) a high point is the nub; the stylus radius is a good
        choice: a nub on the axis is touched only while the ball overlaps it.
    :param cutoff: multiples of the robust sigma beyond which a point is dropped.
    :param floor: mm; residuals below this are never dropped (the probe's repeatability).
    :param fill: "extrapolate" or "nearest" (see the module documentation).
    :param path: the probe file, for messages; ``reporter`` gets one warning per dropped point.
    :returns: the cleaned deviations, which points were dropped, why, and what replaced them.
    :raises MeasurementError: a group with more bad points than ``max_fraction`` allows.
    """
    if fill not in FILLS:
        raise ValueError(f"fill must be one of {FILLS}, not {fill!r}")
    y = np.asarray(deviation, dtype=float)
    s = np.asarray(s, dtype=float)
    n = len(y)
    rows = tuple(rows) if rows is not None else (None,) * n
    group = np.zeros(n, dtype=int) if groups is None else np.asarray(groups, dtype=int)
    near = np.zeros(n, dtype=bool) if axis_distance is None else np.asarray(axis_distance, dtype=float) <= nub_zone
    kept = np.ones(n, dtype=bool)
    trend, sigma, threshold = y.copy(), np.zeros(n), np.zeros(n)
    cleaned = y.copy()
    dropped: list[Dropped] = []
    notes: list[str] = []
    for g in np.unique(group):
        members = np.flatnonzero(group == g)
        count = len(members)
        name = f"{names[g]}: " if names is not None else ""
        if count < MIN_POINTS:
            notes.append(f"{name}{count} point{'s' if count != 1 else ''}: too few to screen for outliers "
                         f"(at least {MIN_POINTS}); none dropped")
            continue
        ys, ss = y[members], s[members]
        local_trend, local_sigma, local_threshold = _judged(ss, ys, cutoff, floor)
        residual = ys - local_trend
        good = np.abs(residual) <= local_threshold
        trend[members], sigma[members], threshold[members] = local_trend, local_sigma, local_threshold
        bad = int(count - good.sum())
        if bad > max(1.0, max_fraction * count):
            raise MeasurementError(
                f"{name}{bad} of {count} points lie more than {local_threshold:.4f} mm from the trend of their "
                "neighbours: the points do not follow a smooth profile (check the calibration, the program and the "
                "file)", Location(path) if path else None)
        notes.append(f"{name}{count} points: robust sigma {local_sigma:.4f} mm, threshold {local_threshold:.4f} mm "
                         f"({cutoff:g} sigma, at least {floor:g})")
        kept[members] = good
        for k in np.flatnonzero(~good):
            i = int(members[k])
            value, how, used = _replacement(int(k), ss, ys, good, fill)
            kind = "nub" if near[i] and residual[k] > 0 else "outlier"
            cleaned[i] = value
            dropped.append(Dropped(i, rows[i], kind, float(y[i]), float(local_trend[k]), value, how,
                                   tuple(rows[members[j]] for j in used)))
    dropped.sort(key=lambda d: d.index)
    nubs = sum(d.kind == "nub" for d in dropped)
    where = "" if groups is None else f" in {len(np.unique(group))} features, each against its own"
    notes.append(f"screening {n} points{where}: {nubs} nub and {len(dropped) - nubs} outlier points dropped")
    for d in dropped:
        notes.append(f"{path or 'probe'}:{d.row}: {d.describe()}" if d.row is not None else d.describe())
        if reporter is not None:
            reporter.warn(d.describe(), Location(path, d.row) if path else None)
    return Screening(cleaned, kept, trend, sigma, threshold, tuple(dropped), tuple(notes))
