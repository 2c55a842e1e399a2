"""postproc.report.quantities: every figure named as people say it, in the unit they read it in."""

from __future__ import annotations

import pytest
from hypothesis import given, strategies as st

from postproc.measure.ballbar_fit import LABELS
from postproc.report.quantities import path_quantity, quantity, significant, with_sigma


@pytest.mark.parametrize("key, name, unit, factor", [
    ("backlash_x_mm", "backlash X", "um", 1e3),  # the diagnosis's key: shown in um, never as the key
    ("backlash_x_um", "backlash X", "um", 1.0),  # the key's own unit decides the factor
    ("backlash_x", "backlash X", "um", 1e3),
    ("scaling_z_plus", "scaling Z (+ side)", "ppm", 1e6),
    ("squareness_rad", "squareness", "urad", 1e6),
    ("servo_lag_ms", "servo lag, X behind Z", "ms", 1.0),
    ("setup_centre_z_mm", "set-up centre z", "um", 1e3),
    ("deviation_um", "deviation", "um", 1.0),
    ("deviation_mm", "deviation", "um", 1e3),
    ("lean_rad", "lean", "urad", 1e6),  # a third-party plugin's key: named from its words, unit from its suffix
    ("shift_x_mm", "shift x", "mm", 1.0),
    ("minimum_touches", "minimum touches", "", 1.0),
])
def test_a_key_becomes_a_name_and_a_unit(key, name, unit, factor):
    found = quantity(key)
    assert (found.name, found.unit) == (name, unit) and found.factor == pytest.approx(factor, rel=1e-12)
    assert "_" not in found.name


def test_an_unknown_length_among_fitted_errors_is_shown_in_um():
    found = quantity("shift_x_mm", errors=True)
    assert (found.name, found.unit, found.factor) == ("shift x", "um", 1e3)


@given(st.sampled_from(sorted(LABELS)), st.sampled_from(["", "_mm", "_um"]))
def test_every_ballbar_parameter_reads_as_postproc_ballbar_prints_it(name, suffix):
    label, factor, unit = LABELS[name]
    found = quantity(name + suffix)
    assert found.name == label
    if unit == "um":  # a length: the factor follows the unit the key states (none: mm)
        assert found.factor == pytest.approx({"": factor, "_mm": 1e3, "_um": 1.0}[suffix])
    elif suffix == "":
        assert (found.unit, found.factor) == (unit, factor)


def test_a_nested_key_is_one_name_with_the_unit_of_its_last_part():
    found = path_quantity("chains[1].features[2].measured_error_um")
    assert (found.name, found.unit) == ("chain 1, feature 2, error as measured", "um")
    assert path_quantity("box_mm.x").name == "box the test arcs span, x"


def test_numbers_for_people():
    assert significant(0.0040072002) == "0.004007" and significant(29.7312) == "29.73" and significant(0) == "0"
    assert with_sigma(4.0072002, 0.0812) == ("4.007", "0.081")
    assert with_sigma(-19.313, 0.28) == ("-19.31", "0.28") and with_sigma(3.0, None) == ("3.000", "")
