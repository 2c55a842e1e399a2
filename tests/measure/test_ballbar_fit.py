"""postproc.measure.ballbar_fit: the joint fit of error models and set-up centres to any number of traces.

Exact recovery on noise-free traces of several tests (radii, centres, set-ups of their own),
the refusals (inseparable, undetermined), the reversal's take-up and the second-order set-up,
a model of the caller's own (as an error map would bring), and the property the issue asks
for: on virtual lathes drawn at random within realistic ranges, a 220 deg test recovers
scaling within 4 ppm and backlash within 0.6 um, and a 180 deg test lies within its own
stated 3 sigma.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from postproc.measure import ballbar_fit
from postproc.measure.ballbar_analysis import diagnose, model_names
from postproc.measure.readers.ballbar import make_trace, read_ballbar
from support import machines
from support.long_traces import peak_bytes, python_lines, write_trace

#: a machine: scaling, backlash, squareness, servo mismatch (mm at the feed)
MACHINE = {"scaling_x": 35e-6, "scaling_z": -55e-6, "backlash_x": 0.0045, "backlash_z": 0.0025,
           "squareness": -8e-6, "servo_mismatch": 0.0012}


def reading(angles, direction, radius, pivot, machine=MACHINE, straightness=0.0):
    """What a bar reads on the model machine: first order in its errors (offsets about the test
    centre), second order in the set-up; ``straightness``: an X error q w^2 the model leaves out."""
    k = 1.0 if direction == "cw" else -1.0
    theta = np.radians(angles)
    cos, sin = np.cos(theta), np.sin(theta)
    dx, dz = np.sign(np.round(-k * sin, 12)), np.sign(np.round(k * cos, 12))
    dx, dz = np.where(dx == 0, np.sign(np.round(cos, 12)), dx), np.where(dz == 0, np.sign(np.round(sin, 12)), dz)
    u, w = radius * cos, radius * sin
    e_x = (machine["scaling_x"] * u + machine["squareness"] * w - machine["backlash_x"] / 2 * dx
           + machine["servo_mismatch"] * k * sin + straightness * w**2)
    e_z = machine["scaling_z"] * w - machine["backlash_z"] / 2 * dz
    return (e_x * cos + e_z * sin - pivot[0] * cos - pivot[1] * sin
            + (pivot[1] * cos - pivot[0] * sin) ** 2 / (2 * radius))


def test_several_tests_fit_jointly_each_with_its_own_set_up_centre():
    """Two circles (other radius, other centre, other mount) and a partial arc: one machine, three centres."""
    tests = [((100.0, (0.0, 0.0), (0.031, -0.018)), np.arange(0.0, 360.0, 0.5)),
             ((150.0, (40.0, -25.0), (-0.052, 0.007)), np.arange(-20.0, 200.0, 0.5)),
             ((75.0, (-10.0, 60.0), (0.012, 0.044)), np.arange(0.0, 180.01, 0.5))]
    traces = [make_trace(f"{d}-{radius:g}.csv", radius, d, angles, reading(angles, d, radius, pivot), centre)
              for (radius, centre, pivot), angles in tests for d in ("ccw", "cw")]
    diagnosis = diagnose(traces)
    for name, value in MACHINE.items():
        assert getattr(diagnosis, name).value == pytest.approx(value, abs=1e-9), name
    for ((_, _, pivot), _), centre in zip(tests, diagnosis.centres):
        assert [e.value for e in centre] == pytest.approx([-pivot[0], -pivot[1]], abs=1e-9)
    assert diagnosis.residual.rms < 1e-6


def test_a_constant_error_between_tests_goes_with_each_tests_centre():
    """Scaling about the machine's reference, not the test centre: at each test's centre the
    machine is off by a_x (xc - x_ref), which a ballbar reads as set-up."""
    reference = (-30.0, 12.0)
    traces = []
    for radius, centre in ((100.0, (0.0, 0.0)), (120.0, (50.0, 40.0))):
        shift = (MACHINE["scaling_x"] * (centre[0] - reference[0]) + MACHINE["squareness"] * (centre[1] - reference[1]),
                 MACHINE["scaling_z"] * (centre[1] - reference[1]))
        angles = np.arange(-20.0, 200.0, 0.5)
        for d in ("ccw", "cw"):  # the tool displaced by the shift reads as a pivot displaced by minus it
            values = reading(angles, d, radius, (-shift[0], -shift[1]))
            traces.append(make_trace(f"{d}{radius:g}.csv", radius, d, angles, values, centre))
        expected_shift = shift
    diagnosis = diagnose(traces)
    assert diagnosis.scaling_x.value == pytest.approx(MACHINE["scaling_x"], abs=1e-9)
    assert [e.value for e in diagnosis.centres[1]] == pytest.approx(list(expected_shift), abs=1e-9)


def test_parameters_no_trace_sees_are_inseparable_and_named():
    angles = np.arange(0.0, 180.01, 0.5)
    traces = [make_trace(f"{d}.csv", 100.0, d, angles, reading(angles, d, 100.0, (0.0, 0.0))) for d in ("ccw", "cw")]
    samples = ballbar_fit.Samples.of(traces)
    zero = np.zeros_like(samples.u)
    below = (zero, np.where(samples.w < 0, samples.w, 0.0))  # a Z scaling below the centre: never reached
    with pytest.raises(ballbar_fit.Inseparable, match="do not see below") as caught:
        ballbar_fit.fit(samples, {"below": below} | ballbar_fit.machine_errors(samples, model_names(traces)))
    assert caught.value.names == ("below",)
    twice = ballbar_fit.machine_errors(samples, ["scaling_x"])["scaling_x"]
    with pytest.raises(ballbar_fit.Inseparable, match="cannot be told apart"):
        ballbar_fit.fit(samples, {"scaling_x": twice, "again": twice})


def test_the_reversal_take_up_is_left_out_of_the_fit():
    angles = np.arange(0.0, 360.0, 0.5)
    traces = [make_trace(f"{d}.csv", 100.0, d, angles, reading(angles, d, 100.0, (0.0, 0.0))) for d in ("ccw", "cw")]
    samples = ballbar_fit.Samples.of(traces)
    inside = ballbar_fit.take_up(samples, 0.012, 0.0)
    theta = np.degrees(np.arctan2(samples.sin, samples.cos))
    # X turns at 0 and 180 deg; 12 um of play at 100 mm is taken up within acos(1 - 0.00012) = 0.89 deg after
    assert set(np.round(np.abs(theta[inside]), 1)) <= {0.0, 0.5, 179.5, 180.0}
    after_cw = inside & (samples.trace == 1)
    assert set(np.round(theta[after_cw], 1)) == {0.0, 0.5, 180.0, -179.5}
    result = ballbar_fit.fit(samples, ballbar_fit.machine_errors(samples, model_names(traces)))
    fitted = ballbar_fit.take_up(samples, MACHINE["backlash_x"], MACHINE["backlash_z"])
    assert fitted.sum() >= 8 and np.array_equal(result.used, ~fitted)  # 2 turns per axis and run, at least


def test_a_model_of_the_callers_own_fits_the_same_way():
    """What an error map brings: its own basis functions of x and z, several tests, one centre each."""
    traces = []
    for radius, centre in ((100.0, (0.0, 0.0)), (60.0, (30.0, 20.0))):
        angles = np.arange(0.0, 360.0, 1.0)
        for d in ("ccw", "cw"):
            traces.append(make_trace(f"{d}{radius:g}.csv", radius, d, angles,
                                     reading(angles, d, radius, (0.01, -0.02), straightness=2e-7), centre))
    samples = ballbar_fit.Samples.of(traces)
    model = ballbar_fit.machine_errors(samples, model_names(traces))
    model["straightness"] = (samples.w**2, np.zeros_like(samples.w))  # X error over Z, about each test's centre
    result = ballbar_fit.fit(samples, model)
    assert result.estimate("straightness").value == pytest.approx(2e-7, abs=1e-12)
    assert result.estimate("scaling_x").value == pytest.approx(MACHINE["scaling_x"], abs=1e-9)
    assert len(samples.groups) == 2 and result.centre(1)[0].value == pytest.approx(-0.01, abs=1e-6)


def test_undetermined_parameters_are_refused_with_the_limit_stated():
    rng = np.random.default_rng(3)
    angles = np.arange(20.0, 120.01, 0.5)
    traces = [make_trace(f"{d}.csv", 100.0, d, angles, reading(angles, d, 100.0, (0.0, 0.0))
                         + rng.normal(0.0, 0.0004, angles.size)) for d in ("ccw", "cw")]
    samples = ballbar_fit.Samples.of(traces)
    result = ballbar_fit.fit(samples, ballbar_fit.machine_errors(samples, model_names(traces)))
    with pytest.raises(ballbar_fit.Undetermined, match=r"100 deg from 20 to 120 deg\), scaling"):
        ballbar_fit.require(result)
    kept, dropped = ballbar_fit.fit_determined(samples, ballbar_fit.machine_errors(samples, model_names(traces)))
    assert dropped and all(3 * kept.effect(name) <= ballbar_fit.EFFECT_LIMIT_MM for name in kept.names)


# -- virtual lathes drawn at random --------------------------------------------------------------

LATHES = settings(max_examples=25, deadline=None, derandomize=True,
                  suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


@st.composite
def lathes(draw):
    def uniform(low, high):
        return draw(st.floats(low, high, allow_nan=False))

    def choice(options):
        return draw(st.sampled_from(options))

    return machines.machine_table(uniform, choice), draw(st.integers(0, 2**31 - 1))


@LATHES
@given(lathes())
def test_on_random_lathes_220_deg_recovers_scaling_and_backlash_and_180_deg_keeps_its_3_sigma(lathe):
    table, seed = lathe
    truth = machines.truth(table)
    on_220 = diagnose(machines.traces(table, 220, seed)).parameters()
    for axis in "xz":
        assert abs(on_220[f"scaling_{axis}"].value - truth[f"scaling_{axis}"]) < 4e-6
        assert abs(on_220[f"backlash_{axis}"].value - truth[f"backlash_{axis}"]) < 0.0006
    on_180 = diagnose(machines.traces(table, 180, seed)).parameters()
    for name, value in truth.items():
        assert abs(on_180[name].value - value) <= 3.0 * on_180[name].sigma, name


def test_uncertainty_is_honest_over_many_lathes():
    """Over 40 lathes and three arcs, recovered minus true over the stated sigma behaves like a
    standard normal: under 2 % beyond 3 sigma (noise and correlated residuals are in the sigma; an
    unmodelled error that looks like a parameter, such as a pitch error's extreme at a pole, is not)."""
    rng = np.random.default_rng(1306)
    scores = []
    for seed in range(40):
        table = machines.machine_table(lambda low, high: float(rng.uniform(low, high)),
                                       lambda options: options[int(rng.integers(len(options)))])
        truth = machines.truth(table)
        for span in (360, 220, 180):
            found = diagnose(machines.traces(table, span, seed)).parameters()
            scores += [(found[name].value - value) / found[name].sigma for name, value in truth.items()]
    scores = np.abs(np.array(scores))
    assert np.mean(scores > 3.0) < 0.02
    assert 0.5 < np.median(scores) < 1.0  # a standard normal's is 0.67


@pytest.mark.parametrize("directions, start, span", [(("ccw", "cw"), 20.0, 100.0), (("ccw",), 20.0, 100.0),
                                                     (("cw",), -75.0, 150.0), (("ccw", "cw"), 0.0, 359.5)])
def test_the_remedy_of_an_undetermined_fit_asks_only_for_what_the_traces_lack(directions, start, span):
    """'measure both directions' was asked of traces of both directions, and 'a longer arc' of
    whole circles: the remedy names what is missing."""
    rng = np.random.default_rng(3)
    angles = np.arange(start, start + span + 0.01, 0.5)
    traces = [make_trace(f"{d}.csv", 100.0, d, angles, reading(angles, d, 100.0, (0.0, 0.0))
                         + rng.normal(0.0, 0.0004, angles.size)) for d in directions]
    asked = ballbar_fit.more_evidence(traces, "a quieter trace")
    assert ("both directions" in asked) == (len(directions) == 1)
    assert ("a longer arc" in asked) == (span < 359.0)
    assert asked.endswith("a quieter trace")
    samples = ballbar_fit.Samples.of(traces)
    try:
        result = ballbar_fit.fit(samples, ballbar_fit.machine_errors(samples, model_names(traces)))
        ballbar_fit.require(result)
    except (ballbar_fit.Inseparable, ballbar_fit.Undetermined) as refused:
        assert span < 359.0
        assert ("both directions" in refused.message) == (len(directions) == 1), refused.message
        assert "a longer arc" in refused.message, refused.message
    else:
        assert span > 359.0  # a whole circle determines the model; no partial arc of these does


# -- traces of hundreds of thousands of samples -------------------------------------------------------


@settings(max_examples=40, deadline=None)
@given(count=st.integers(2, 400), fraction=st.floats(0.0, 0.5), block=st.sampled_from([1, 3, 7, 64, 1 << 16]),
       seed=st.integers(0, 2**16))
def test_bartlett_windows_equal_the_lag_by_lag_sum(count, fraction, block, seed):
    """The windowed form of the Newey-West sum, read a block at a time, is the lag-by-lag sum."""
    rng = np.random.default_rng(seed)
    scores = np.cumsum(rng.normal(size=(count, 3)), axis=0)
    bandwidth = int(fraction * count)
    direct = scores.T @ scores
    for lag in range(1, bandwidth + 1):
        cross = scores[lag:].T @ scores[:-lag]
        direct += (1.0 - lag / (bandwidth + 1)) * (cross + cross.T)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(ballbar_fit, "WINDOW_BLOCK", block)
        windows = ballbar_fit._bartlett_windows(lambda a, b: scores[a:b], count, 3, bandwidth)
    assert np.allclose(windows, direct, rtol=1e-10, atol=1e-10 * np.abs(direct).max())


def test_a_fit_in_blocks_is_the_fit_of_the_whole_design(monkeypatch):
    """Above BLOCKED_SAMPLES the design is reduced by QR a block at a time: the same parameters,
    uncertainties and refusals as the design decomposed whole (here forced on a small test)."""
    angles = np.arange(-20.0, 200.0, 0.25)
    rng = np.random.default_rng(7)
    traces = [make_trace(f"{d}.csv", 100.0, d, angles, reading(angles, d, 100.0, (0.02, -0.01))
                         + np.cumsum(rng.normal(0.0, 2e-5, angles.size))) for d in ("ccw", "cw")]
    whole = diagnose(traces)
    monkeypatch.setattr(ballbar_fit, "BLOCKED_SAMPLES", 10)
    monkeypatch.setattr(ballbar_fit, "SOLVE_BLOCK", 100)
    monkeypatch.setattr(ballbar_fit, "DIRECT_LAG_PRODUCTS", 0)
    blocked = diagnose(traces)
    for name, estimate in whole.parameters().items():
        other = blocked.parameters()[name]
        assert other.value == pytest.approx(estimate.value, rel=1e-9, abs=1e-15), name
        assert other.sigma == pytest.approx(estimate.sigma, rel=1e-9), name
    samples = ballbar_fit.Samples.of(traces)
    twice = ballbar_fit.machine_errors(samples, ["scaling_x"])["scaling_x"]
    with pytest.raises(ballbar_fit.Inseparable, match="cannot be told apart"):
        ballbar_fit.fit(samples, {"scaling_x": twice, "again": twice})


def test_diagnosing_long_traces_does_no_python_work_per_sample_or_lag(tmp_path):
    """Ten times the samples of correlated residuals, about the same Python run: the Newey-West
    sum once took a pass over the samples per lag, and the bandwidth of a long trace is
    thousands of lags (quadratic in the samples); and at most a few arrays per sample held."""
    lines, peaks = [], []
    for count in (20_000, 200_000):
        traces = [read_ballbar(str(write_trace(tmp_path / f"{count}-{d}.csv", count, d, seed=count + i)))
                  for i, d in enumerate(("ccw", "cw"))]
        ran, diagnosis = python_lines(diagnose, traces)
        lines.append(ran)
        peaks.append(peak_bytes(diagnose, traces)[0] / (2 * count))
        assert diagnosis.scaling_x.value == pytest.approx(4e-6, abs=1e-6)
        assert diagnosis.squareness.value == pytest.approx(12e-6, abs=2e-6)
    assert lines[1] < 2 * lines[0] + 1000, lines
    assert peaks[1] < 400, f"{peaks[1]:.0f} bytes per sample"
