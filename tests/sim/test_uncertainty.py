"""Uncertainty profiles of Section V: formulas, magnitudes, shapes, reproducibility, validation."""

import json
import math
import re

import numpy as np
import pytest

from delta_pin.errors import InvalidParameterError, NonFiniteError
from delta_pin.sim.uncertainty import (
    PAPER_NOMINAL_DISTURBANCE,
    PAPER_NOMINAL_NORMAL_FORCE,
    PAPER_NOMINAL_PLATFORM_MASS,
    FunctionUncertainty,
    NoUncertainty,
    PaperUncertainty,
    RandomUncertainty,
    make_uncertainty,
)

M0 = PAPER_NOMINAL_PLATFORM_MASS  # [kg]
FN0 = PAPER_NOMINAL_NORMAL_FORCE  # [N]
SAMPLE_TIMES = np.array([0.0, 0.1, 0.25, 0.5, 0.77, 1.0, 1.3, 2.7, 9.99])  # [s]
DENSE = np.linspace(0.0, 4.0, 40001)  # [s], step 0.1 ms, holds t = 0, 0.5, 1.5 (the extrema)


def all_kinds():
    return [
        NoUncertainty(),
        PaperUncertainty(),
        RandomUncertainty(seed=7),
        FunctionUncertainty(
            platform_mass=lambda t: 0.3 + 0.05 * math.sin(t),
            normal_force=lambda t: [10.0 + t, 12.0, 14.0],
            disturbance=lambda t: 0.5 * math.cos(t),
            nominal_disturbance=(0.1, 0.2, 0.3),
        ),
    ]


# --- the paper's profile ---------------------------------------------------------------------------


@pytest.mark.parametrize("nominal_mass", [M0, 0.5, 2.0])
def test_paper_profile_equals_the_formulas(nominal_mass):
    u = PaperUncertainty()
    t = SAMPLE_TIMES
    nominal_force = np.array([15.0, 12.0, 18.0])
    expected_mass = nominal_mass + 0.3 * nominal_mass * np.sin(np.pi * t)
    expected_force = nominal_force + 0.3 * nominal_force * np.sin(np.pi * t)[:, None]
    fbar = np.array([2.0, 4.0, 6.0])
    expected_disturbance = fbar + 0.3 * fbar * np.cos(2 * np.pi * t)[:, None]
    np.testing.assert_allclose(u.platform_mass(t, nominal_mass), expected_mass, rtol=1e-15, atol=0)
    np.testing.assert_allclose(u.normal_force(t, nominal_force), expected_force, rtol=1e-15, atol=0)
    np.testing.assert_allclose(u.disturbance(t), expected_disturbance, rtol=1e-15, atol=0)
    np.testing.assert_array_equal(u.nominal_disturbance, fbar)
    # Values read off by hand: t = 0.5 s is the peak of sin(πt), t = 0 the peak of cos(2πt).
    assert u.platform_mass(0.5, 0.3) == pytest.approx(0.39, abs=1e-15)
    np.testing.assert_allclose(u.normal_force(0.5, 15.0), [19.5] * 3, rtol=1e-15)
    np.testing.assert_allclose(u.disturbance(0.0), [2.6, 5.2, 7.8], rtol=1e-15)


@pytest.mark.parametrize(
    ("delta_m", "delta_fc", "delta_f"), [(0.3, 0.3, 0.3), (0.1, 0.6, 1.5), (0.0, 0.0, 0.0)]
)
def test_paper_max_deviation_is_the_magnitude(delta_m, delta_fc, delta_f):
    """Δ_m = max|Δm_o|/m̄_o, Δ_fc = max|ΔF_ni|/F̄_ni, Δ_f = max|ΔF_i|/F̄_i (Section V's definitions)."""
    fbar = np.array([2.0, 4.0, 6.0])
    u = PaperUncertainty(delta_m, delta_fc, delta_f, nominal_disturbance=fbar)
    nominal_force = np.array([15.0, 10.0, 20.0])
    dm = np.abs(u.platform_mass(DENSE, 0.5) - 0.5).max()
    dfn = np.abs(u.normal_force(DENSE, nominal_force) - nominal_force).max(axis=0)
    df = np.abs(u.disturbance(DENSE) - fbar).max(axis=0)
    assert dm == pytest.approx(delta_m * 0.5, abs=1e-6)
    np.testing.assert_allclose(dfn, delta_fc * nominal_force, atol=1e-6)
    np.testing.assert_allclose(df, delta_f * fbar, atol=1e-6)


# --- shapes and the nominal plant ------------------------------------------------------------------


@pytest.mark.parametrize("u", all_kinds(), ids=lambda u: type(u).__name__)
def test_scalar_and_array_evaluation_agree(u):
    t = SAMPLE_TIMES
    mass, force, torque = u.platform_mass(t, M0), u.normal_force(t, FN0), u.disturbance(t)
    assert mass.shape == (t.size,) and force.shape == (t.size, 3) and torque.shape == (t.size, 3)
    for k, tk in enumerate(t):
        m_k, f_k, d_k = u.platform_mass(float(tk), M0), u.normal_force(float(tk), FN0), u.disturbance(tk)
        assert np.shape(m_k) == () and f_k.shape == (3,) and d_k.shape == (3,)
        assert m_k == mass[k]
        np.testing.assert_array_equal(f_k, force[k])
        np.testing.assert_array_equal(d_k, torque[k])
    assert u.nominal_disturbance.shape == (3,)
    assert u.platform_mass(np.array([]), M0).shape == (0,)


def test_no_uncertainty_is_the_nominal_plant():
    u = NoUncertainty()
    np.testing.assert_array_equal(u.platform_mass(DENSE, 0.7), 0.7)
    np.testing.assert_array_equal(
        u.normal_force(DENSE, [1.0, 2.0, 3.0]), np.tile([1.0, 2.0, 3.0], (DENSE.size, 1))
    )
    np.testing.assert_array_equal(u.disturbance(DENSE), 0.0)
    np.testing.assert_array_equal(u.nominal_disturbance, 0.0)


def test_nominal_disturbance_cannot_be_modified_in_place():
    u = PaperUncertainty()
    with pytest.raises(ValueError):
        u.nominal_disturbance[0] = 100.0


# --- random profiles -------------------------------------------------------------------------------


def deviations(u, t):
    """Normalised deviations [Δm/(Δ_m m̄), ΔF_n/(Δ_fc F̄_n), ΔF/(Δ_f F̄)] (N, 7), each bounded by 1."""
    fbar = u.nominal_disturbance
    return np.column_stack(
        [
            (u.platform_mass(t, M0) - M0) / (u.delta_m * M0),
            (u.normal_force(t, FN0) - FN0) / (u.delta_fc * FN0),
            (u.disturbance(t) - fbar) / (u.delta_f * fbar),
        ]
    )


def test_random_is_reproducible_by_seed():
    t = np.linspace(0.0, 5.0, 501)
    a, b, c = RandomUncertainty(seed=3), RandomUncertainty(seed=3), RandomUncertainty(seed=4)
    np.testing.assert_array_equal(a.disturbance(t), b.disturbance(t))
    np.testing.assert_array_equal(a.platform_mass(t, M0), b.platform_mass(t, M0))
    np.testing.assert_array_equal(a.normal_force(t, FN0), b.normal_force(t, FN0))
    assert np.abs(a.disturbance(t) - c.disturbance(t)).max() > 0.1
    assert np.abs(a.platform_mass(t, M0) - c.platform_mass(t, M0)).max() > 1e-3
    assert a.metadata()["seed"] == 3 and c.metadata()["seed"] == 4


def test_random_without_seed_records_the_drawn_seed():
    u = RandomUncertainty(seed=None)
    rebuilt = make_uncertainty(**json.loads(json.dumps(u.metadata())))
    t = np.linspace(0.0, 3.0, 301)
    np.testing.assert_array_equal(u.disturbance(t), rebuilt.disturbance(t))
    np.testing.assert_array_equal(u.platform_mass(t, M0), rebuilt.platform_mass(t, M0))


@pytest.mark.parametrize("seed", [0, 1, 2, 3, 4])
def test_random_is_bounded_by_its_magnitudes(seed):
    u = RandomUncertainty(delta_m=0.2, delta_fc=0.4, delta_f=0.6, seed=seed)
    t = np.linspace(0.0, 20.0, 20001)  # [s]
    peak = np.abs(deviations(u, t)).max(axis=0)  # fraction of Δ·nominal reached by each signal
    assert np.all(peak <= 1.0 + 1e-12)
    assert np.all(peak >= 0.3)
    assert np.all(u.platform_mass(t, M0) > 0.0)


@pytest.mark.parametrize("bandwidth", [0.5, 2.0])
def test_random_is_band_limited(bandwidth):
    """Power above 1.5·bandwidth is < 1e-6 of the total (Hann-windowed FFT of 200 s at 50 Hz)."""
    fs, duration = 50.0, 200.0  # [Hz], [s]
    t = np.arange(0.0, duration, 1.0 / fs)
    window = np.hanning(t.size)[:, None]

    def fraction_above(u):
        s = deviations(u, t)
        power = np.abs(np.fft.rfft((s - s.mean(axis=0)) * window, axis=0)) ** 2
        frequencies = np.fft.rfftfreq(t.size, 1.0 / fs)
        return power[frequencies > 1.5 * bandwidth].sum(axis=0) / power.sum(axis=0)

    assert np.all(fraction_above(RandomUncertainty(bandwidth=bandwidth, seed=11)) < 1e-6)
    # The check can fail: a profile of 4× the bandwidth puts much of its power above 1.5·bandwidth.
    assert np.all(fraction_above(RandomUncertainty(bandwidth=4 * bandwidth, seed=11)) > 1e-2)


# --- user functions --------------------------------------------------------------------------------


def test_function_uncertainty_uses_the_user_functions():
    u = FunctionUncertainty(
        platform_mass=lambda t: 0.3 + 0.1 * t,
        normal_force=lambda t: [t, 2 * t, 3 * t],
        disturbance=lambda t: 2.0 * t,  # a float is broadcast to every joint
        nominal_disturbance=[1.0, 2.0, 3.0],
    )
    t = SAMPLE_TIMES
    np.testing.assert_allclose(u.platform_mass(t, 99.0), 0.3 + 0.1 * t, rtol=1e-15)
    np.testing.assert_allclose(u.normal_force(t, 99.0), np.outer(t, [1.0, 2.0, 3.0]), rtol=1e-15)
    np.testing.assert_allclose(u.disturbance(t), np.outer(2.0 * t, np.ones(3)), rtol=1e-15)
    np.testing.assert_array_equal(u.nominal_disturbance, [1.0, 2.0, 3.0])
    defaults = FunctionUncertainty()
    np.testing.assert_array_equal(defaults.platform_mass(t, 0.4), 0.4)
    np.testing.assert_array_equal(defaults.normal_force(t, [1.0, 2.0, 3.0])[-1], [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(defaults.disturbance(t), 0.0)
    json.dumps(u.metadata())


@pytest.mark.parametrize(
    ("kwargs", "call", "error", "message"),
    [
        ({"platform_mass": lambda t: 0.3 - t}, "mass", InvalidParameterError, "platform_mass(t=0.5)"),
        ({"platform_mass": lambda t: math.nan if t > 0.2 else 0.3}, "mass", NonFiniteError, "(t=0.25)"),
        ({"normal_force": lambda t: [1.0, 2.0]}, "force", InvalidParameterError, "normal_force(t=0.0)"),
        ({"normal_force": lambda t: [1.0, 1.0, -t]}, "force", InvalidParameterError, "normal_force(t=0.1)"),
        ({"disturbance": lambda t: [0.0, math.inf, 0.0]}, "torque", NonFiniteError, "disturbance(t=0.0)"),
        ({"disturbance": lambda t: np.zeros((3, 1))}, "torque", InvalidParameterError, "(t=0.0)"),
    ],
)
def test_function_uncertainty_errors_name_the_time(kwargs, call, error, message):
    u = FunctionUncertainty(**kwargs)
    t = np.array([0.0, 0.1, 0.25, 0.5, 1.0])
    evaluate = {
        "mass": lambda: u.platform_mass(t, M0),
        "force": lambda: u.normal_force(t, FN0),
        "torque": lambda: u.disturbance(t),
    }[call]
    with pytest.raises(error, match=re.escape(message)):
        evaluate()


def test_function_uncertainty_rejects_non_callables():
    with pytest.raises(InvalidParameterError, match="platform_mass"):
        FunctionUncertainty(platform_mass=0.3)


# --- parameter validation --------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("cls", "kwargs", "message"),
    [
        (PaperUncertainty, {"delta_m": 1.0}, "delta_m=1.0"),
        (PaperUncertainty, {"delta_m": -0.1}, "delta_m=-0.1"),
        (PaperUncertainty, {"delta_fc": math.nan}, "delta_fc=nan"),
        (PaperUncertainty, {"delta_fc": 1.5}, "delta_fc=1.5"),
        (PaperUncertainty, {"delta_f": math.inf}, "delta_f=inf"),
        (RandomUncertainty, {"delta_m": 1.5}, "delta_m=1.5"),
        (RandomUncertainty, {"delta_f": -2.0}, "delta_f=-2.0"),
        (RandomUncertainty, {"bandwidth": 0.0}, "bandwidth=0.0"),
        (RandomUncertainty, {"components": 0}, "components=0"),
        (RandomUncertainty, {"seed": -1}, "seed=-1"),
        (PaperUncertainty, {"nominal_disturbance": (1.0, 2.0)}, "shape (2,)"),
    ],
)
def test_bad_parameters_raise_naming_the_value(cls, kwargs, message):
    with pytest.raises(InvalidParameterError, match=re.escape(message)):
        cls(**kwargs)


def test_bad_times_and_nominals_raise():
    u = PaperUncertainty()
    with pytest.raises(NonFiniteError, match="t=nan"):
        u.disturbance(np.array([0.0, math.nan]))
    with pytest.raises(InvalidParameterError, match=re.escape("shape (2, 2)")):
        u.disturbance(np.zeros((2, 2)))
    with pytest.raises(InvalidParameterError, match=re.escape("got 0.0 kg")):
        u.platform_mass(0.0, 0.0)
    with pytest.raises(InvalidParameterError, match="nominal normal force"):
        u.normal_force(0.0, [15.0, -1.0, 15.0])
    with pytest.raises(NonFiniteError, match="nominal_disturbance"):
        PaperUncertainty(nominal_disturbance=(1.0, math.nan, 0.0))


# --- metadata and factory --------------------------------------------------------------------------


@pytest.mark.parametrize("u", all_kinds(), ids=lambda u: type(u).__name__)
def test_metadata_is_json_and_rebuilds(u):
    meta = json.loads(json.dumps(u.metadata()))
    assert meta["kind"] in {"none", "paper", "random", "function"}
    if meta["kind"] == "function":
        with pytest.raises(InvalidParameterError, match="function"):
            make_uncertainty(**meta)
        return
    rebuilt = make_uncertainty(**meta)
    assert type(rebuilt) is type(u) and rebuilt.metadata() == u.metadata()
    np.testing.assert_array_equal(rebuilt.disturbance(SAMPLE_TIMES), u.disturbance(SAMPLE_TIMES))
    np.testing.assert_array_equal(rebuilt.normal_force(SAMPLE_TIMES, FN0), u.normal_force(SAMPLE_TIMES, FN0))


def test_factory_defaults_are_the_papers():
    meta = make_uncertainty("paper").metadata()
    assert meta == {
        "kind": "paper",
        "delta_m": 0.3,
        "delta_fc": 0.3,
        "delta_f": 0.3,
        "nominal_disturbance": list(PAPER_NOMINAL_DISTURBANCE),
    }
    with pytest.raises(InvalidParameterError, match="'gaussian'"):
        make_uncertainty("gaussian")
    with pytest.raises(InvalidParameterError, match="bandwidth_hz"):
        make_uncertainty("random", bandwidth_hz=1.0)


@pytest.mark.parametrize(
    "profile", [NoUncertainty(), PaperUncertainty(0.2, 0.4, 0.6), RandomUncertainty(seed=3)]
)
def test_fast_scalar_evaluation_matches_the_public_methods(profile):
    for t in (0.0, 0.37, 2.5):
        mass, normal, disturbance = profile.at(t, 0.3, np.full(3, 15.0))
        assert mass == profile.platform_mass(t, 0.3)
        np.testing.assert_array_equal(normal, profile.normal_force(t, 15.0))
        np.testing.assert_array_equal(disturbance, profile.disturbance(t))
