"""The control's number grid: rounding as Python's round() does it, and snapping onto the grid."""

from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st

from postproc.machine.resolution import Grid, rounded


@settings(max_examples=2000, deadline=None)
@given(st.floats(allow_nan=False, allow_infinity=False, min_value=-1e6, max_value=1e6), st.integers(0, 12))
def test_rounded_is_round(value, decimals):
    assert rounded(value, decimals) == round(value, decimals)
    assert math.copysign(1.0, rounded(value, decimals)) == math.copysign(1.0, round(value, decimals))


@given(st.integers(-10**7, 10**7), st.integers(1, 5))
def test_rounded_breaks_ties_to_even_like_round(numerator, decimals):
    value = numerator / 2 / 10**decimals  # exactly halfway only where binary allows: both must agree anyway
    assert rounded(value, decimals) == round(value, decimals)


def test_a_snapped_point_is_on_the_grid_of_its_words():
    grid = Grid(3, False, True)
    x, z = grid.snap(12.34567, -0.00049)
    assert (grid.x_word(x), grid.z_word(z)) == (24.691, 0.0) and math.copysign(1.0, z) == 1.0


def test_a_profiles_grid_is_its_decimals_in_the_programs_units_and_its_x_as_it_is_programmed():
    from dataclasses import replace

    from postproc.machine.profile import DEFAULT

    radius = replace(DEFAULT, diameter_x=False, output_decimals_mm=4, output_decimals_inch=5)
    assert radius.grid(False) == Grid(4, False, False) and radius.grid(True) == Grid(5, True, False)
    assert DEFAULT.grid(False).x_step == 0.0005 and DEFAULT.grid(True).z_step == 0.0001 * 25.4
