"""The distance of a written cut from the nominal path (postproc.compensate.farthest): exact where it is
computed in closed form, checked against dense sampling of both the cut and the nominal."""

from __future__ import annotations

import math
import os

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from postproc.compensate.farthest import farthest
from postproc.geometry import Arc, Line
from postproc.compensate.segmenter import Cut

SPACING = 0.01  #: mm between the samples of the oracle
coordinate = st.floats(-20, 20, allow_nan=False)
radius = st.floats(0.5, 20)
angle = st.floats(-math.pi, math.pi)
drift = st.one_of(st.just(0.0), st.floats(-0.01, 0.01))  # an arc whose end radius differs, as a control allows


@st.composite
def nominals(draw):
    if draw(st.booleans()):
        return Line(draw(coordinate), draw(coordinate), draw(coordinate), draw(coordinate))
    r = draw(radius)
    change = draw(drift)
    return Arc(draw(coordinate), draw(coordinate), r, draw(angle), draw(st.floats(-6.2, 6.2)) or 0.1,
               None if change == 0.0 else r + change)


@st.composite
def cuts(draw):
    if draw(st.booleans()):
        return Cut(draw(coordinate), draw(coordinate), draw(coordinate), draw(coordinate))
    xc, zc, r = draw(coordinate), draw(coordinate), draw(radius)
    a0, a1, change = draw(angle), draw(angle), draw(drift)
    return Cut(xc + r * math.cos(a0), zc + r * math.sin(a0), xc + (r + change) * math.cos(a1),
               zc + (r + change) * math.sin(a1), xc, zc, draw(st.booleans()))


def _sampled(cut: Cut, nominal) -> float:
    """The largest distance from the cut's samples to the nominal's samples."""
    points = cut.sample(SPACING)
    along = nominal.point_at(np.linspace(0.0, 1.0, max(2, math.ceil(nominal.length / SPACING) + 1)))
    nearest = np.full(len(points), np.inf)
    for first in range(0, len(along), 2000):
        block = along[first : first + 2000]
        gaps = np.hypot(points[:, None, 0] - block[None, :, 0], points[:, None, 1] - block[None, :, 1])
        nearest = np.minimum(nearest, gaps.min(axis=1))
    return float(nearest.max())


@settings(max_examples=150, deadline=None)
@given(cuts(), nominals())
def test_the_farthest_point_is_found_as_dense_sampling_finds_it(cut, nominal):
    exact = farthest(cut, nominal)
    sampled = _sampled(cut, nominal)
    assert abs(exact - sampled) <= SPACING, (exact, sampled)


def test_a_chord_of_the_hemishell_arc_is_its_sagitta_from_it():
    """The arc of samples/programs/hemishell.nc, and its chord: 16.7 mm apart at the middle."""
    arc = Arc.through((0.0, 57.15), (57.15, 0.0), (0.0, 0.0), cw=False)
    chord = Cut(0.0, 57.15, 57.15, 0.0)
    assert math.isclose(farthest(chord, arc), 57.15 * (1 - math.cos(math.pi / 4)), rel_tol=1e-12)
    assert farthest(Cut(0.0, 57.15, 57.15, 0.0, 0.0, 0.0, False), arc) < 1e-12


def test_a_cut_beyond_the_nominal_end_is_measured_from_that_end():
    line = Line(0.0, 0.0, 10.0, 0.0)
    assert math.isclose(farthest(Cut(10.0, 0.0, 13.0, 4.0), line), 5.0)
    assert math.isclose(farthest(Cut(-3.0, 0.0, 5.0, 0.0), line), 3.0)


@st.composite
def cuts_along(draw, arc: Arc):
    """A cut that follows an arc closely: a chord of part of it, or an arc about a nearby centre."""
    a, b = sorted((draw(st.floats(-0.01, 1.01)), draw(st.floats(-0.01, 1.01))))  # a sliver beyond the ends too
    start, end = arc.point_at(np.array([a, b])).tolist()
    if draw(st.booleans()):
        return Cut(*start, *end)
    xc, zc = arc.xc + draw(st.floats(-0.05, 0.05)), arc.zc + draw(st.floats(-0.05, 0.05))
    return Cut(*start, *end, xc, zc, arc.sweep > 0)


@settings(max_examples=int(os.environ.get("POSTPROC_FUZZ_EXAMPLES", "300")), deadline=None)
@given(st.data())
def test_the_quick_bound_along_an_arc_is_never_below_the_exact_distance(data):
    from postproc.compensate.farthest import _along_arc, within

    arc = data.draw(nominals().filter(lambda n: isinstance(n, Arc)))
    cut = data.draw(cuts_along(arc))
    exact = farthest(cut, arc)
    bound = _along_arc(cut, arc)
    if bound is not None:
        assert bound >= exact - 1e-9
    assert within(cut, arc, exact + 1e-9)
    if exact > 1e-9:
        assert not within(cut, arc, exact - 1e-9)
