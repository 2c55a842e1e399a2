"""Lengths in the wrong unit (postproc.measure.readers.lengths): the sizes a stylus and a
coordinate can have, and the misreading named for one that cannot."""

from __future__ import annotations

from hypothesis import given, strategies as st

from postproc.measure.readers.lengths import (DIAMETERS, RADII, STYLUS_RADIUS_MM, UNITS, WRITTEN, misreading,
                                              stylus_problem, travel_problem)

STYLI = st.floats(*STYLUS_RADIUS_MM)


@given(STYLI)
def test_every_probes_stylus_radius_is_taken(radius):
    assert stylus_problem(radius) is None


@given(STYLI)
def test_a_stylus_radius_in_um_is_refused_naming_um(radius):
    problem = stylus_problem(radius * 1000.0)
    assert problem and f"micrometres written as millimetres? ({radius * 1000:g} um is" in problem


@given(st.floats(12.5 / 25.4 + 1e-6, 12.5 / 25.4 * 10))
def test_a_printout_headed_g20_with_its_stylus_in_mm_is_refused_with_a_reading_that_fits(radius):
    """R in mm under G 20 is 25.4 times too large; the reading named brings it back to a stylus."""
    problem = stylus_problem(radius * 25.4)
    assert problem is not None
    named = [(factor, why(radius * 25.4)) for factor, why in UNITS if why(radius * 25.4) in problem]
    assert len(named) == 1 and STYLUS_RADIUS_MM[0] <= radius * 25.4 * named[0][0] <= STYLUS_RADIUS_MM[1]


@given(st.floats(-10_000.0, 10_000.0))
def test_a_coordinate_within_any_lathes_travel_is_taken(value):
    assert travel_problem(value) is None


@given(st.floats(10.001, 9_999.0), st.sampled_from([-1.0, 1.0]))
def test_a_coordinate_in_um_beyond_the_travel_names_um(value, sign):
    problem = travel_problem(sign * value * 1000.0)
    assert problem and "beyond any lathe's travel (10000 mm): micrometres written as millimetres?" in problem


def test_the_readings_first_to_fit_is_named():
    assert misreading(6.0, lambda meant: meant == 3.0, RADII) == "a diameter where a radius is meant? (halved, 3 mm)"
    assert misreading(0.5, lambda meant: abs(meant - 12.7) < 1e-9, WRITTEN) == \
        "inches written as millimetres? (0.5 in is 12.7 mm)"
    assert misreading(6.0, lambda meant: meant == 3.0, WRITTEN) is None
    assert RADII == UNITS + DIAMETERS and UNITS[:2] == WRITTEN
