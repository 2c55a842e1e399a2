"""The bounds a fitted machine parameter is held to, whether it comes out of a fit or a saved model."""

from __future__ import annotations

import pytest

from postproc.diagnostics import Location, MeasurementError, ModelError
from postproc.measure.parameters import Estimate, check_fitted, check_saved


@pytest.mark.parametrize("name, value", [("scaling_x_minus", -2862e-6), ("backlash_z", 0.2), ("squareness", 1e-3),
                                         ("servo_mismatch", -0.5)])
def test_a_fit_beyond_what_any_machine_has_is_refused_as_a_saved_model_is(name, value):
    """A term a partial arc holds only loosely (a sliver of one side, max-uncertainty set wide)
    can come out at -2862 ppm: the fit is refused at the trace, as the same value in a saved
    model is, instead of being applied."""
    parameters = {"scaling_x_plus": Estimate(80e-6, 1e-6), name: Estimate(value, 1e-4)}
    with pytest.raises(MeasurementError, match=rf"the fit gives {name} .* is beyond") as refused:
        check_fitted("parametric", parameters, Location("ccw.csv"))
    assert str(refused.value).startswith("ccw.csv: error: parametric:") and "max-uncertainty" in str(refused.value)
    with pytest.raises(ModelError, match=rf"the saved model's {name}"):
        check_saved("parametric", parameters)
    check_fitted("parametric", {"scaling_x_plus": Estimate(80e-6, 1e-6)}, Location("ccw.csv"))
