"""postproc.geometry: where an arc's axes reverse, on a circle and on a spiral (an I/K arc whose
end radius differs from its start radius, run as a control runs it: the radius drifting evenly)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from postproc.geometry import QUADRANTS, Arc, reversal_params_of


def turning_points(arc: Arc, samples: int = 100_001) -> list[tuple[int, float]]:
    """(axis, parameter) of every sign change of dx/dt and dz/dt, sampled densely."""
    t = np.linspace(0.0, 1.0, samples)
    p = arc.point_at(t)
    found = []
    for axis in (0, 1):
        d = np.diff(p[:, axis])
        moving = np.flatnonzero(d != 0.0)  # a sample right on the apex moves by nothing: not a turn of its own
        signs = np.sign(d[moving])
        change = np.flatnonzero(signs[:-1] * signs[1:] < 0)
        found += [(axis, float(t[moving[i + 1]])) for i in change]
    return sorted(found, key=lambda item: item[1])


@given(st.floats(-math.pi, math.pi), st.floats(0.02, 5.0), st.booleans(), st.floats(1.0, 60.0),
       st.floats(-0.004, 0.004))
@settings(max_examples=200, deadline=None)
def test_reversals_are_where_the_axes_turn_on_a_circle_and_on_a_spiral(theta0, span, cw, radius, drift):
    """Each reversal within 2e-5 of the arc (the sampling's step, 2 um on a 100 mm arc) of where the axis turns."""
    arc = Arc(0.0, 0.0, radius, theta0, span if cw else -span, radius + drift if drift else None)
    measured = [t for _, t in turning_points(arc)]
    stated = list(arc.reversal_params())

    def inside(t: float) -> bool:  # a turn at an end may fall either side of it by a sampling step
        return 2e-4 < t < 1.0 - 2e-4

    for a in filter(inside, stated):
        assert any(abs(a - b) < 2e-5 for b in measured), (stated, measured)
    for b in filter(inside, measured):
        assert any(abs(a - b) < 2e-5 for a in stated), (stated, measured)


def test_the_apex_of_a_short_i_k_arc_whose_radius_drifts_is_where_its_r_form_has_it():
    """G03 X5.999 Z-0.079 I-5.999 K-0.131 from (5.999, 0.131): 0.9 um of radius drift over 2 deg puts
    the apex 26 um from the quadrant point, where the circle through the ends (the R form) has it."""
    spiral = Arc.through((5.999, 0.131), (5.999, -0.079), (0.0, 0.0), cw=False)
    (t,) = spiral.reversal_params()
    assert spiral.point_at(np.array([t]))[0, 1] == pytest.approx(0.026, abs=0.0005)


_quarter = st.sampled_from([k * math.pi / 2 for k in QUADRANTS])
_start = st.one_of(st.floats(-math.pi, math.pi), _quarter,  # on a quadrant point, or a hair either side of one
                   st.builds(lambda a, e: a + e, _quarter, st.floats(-1e-6, 1e-6)))
_arcs = st.builds(
    lambda theta0, span, cw, radius, drift: Arc(1.0, -2.0, radius, theta0, span if cw else -span,
                                                radius + drift if drift and radius + drift > 0 else None),
    _start, st.one_of(st.just(0.0), st.floats(1e-9, 2 * math.pi), st.floats(1e-9, 1e-3)), st.booleans(),
    st.one_of(st.floats(0.001, 500.0), st.floats(1e-6, 1e-3)),
    st.one_of(st.just(0.0), st.floats(-0.01, 0.01), st.floats(-1e-6, 1e-6)))


@given(st.lists(_arcs, max_size=12))
@settings(max_examples=300, deadline=None)
def test_reversals_of_many_arcs_at_once_are_those_of_each_arc_bit_for_bit(arcs):
    """The array pass leaves out only the quarter turns that cannot fall inside an arc's sweep."""
    assert reversal_params_of(arcs) == [arc.reversal_params() for arc in arcs]
