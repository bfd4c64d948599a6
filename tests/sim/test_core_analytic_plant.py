"""The paper's reduced Delta in the compiled core (delta_pin/core/plant/analytic_plant.cpp) against the
Python :class:`~delta_pin.sim.plants.AnalyticPlant` it copies, and the time-varying truth of
the core's continuous loop on either plant.

Tolerances:

* one derivative: 1e-12 relative -- the same eqs. 7-13 in C++ (the sums associated as Eigen
  does; measured ~1e-15);
* a sampled run against the readable Python loop (``simulate_reference``,
  tests/reference/python_loop.py): the same RK4 steps, the law in C++ (the analytic nominal model
  through ``DeltaTerms``): 1e-10 relative over 0.2 s, absolute 1e-12 in SI units;
* a continuous run (the core's Radau at rtol 1e-6) against the Python plant under LSODA at rtol
  1e-10 (``simulate_reference``), with the paper's uncertainty: the integration error only,
  within the issue's 1e-6 rad (the truth: linear interpolation between rows dt / 4 apart in the
  core, the profile itself in Python; the profiles are smooth, the interpolation error ~1e-7 of
  their amplitude).
"""

from __future__ import annotations

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.compiled.core import core
from delta_pin.sim.compiled_plant import build_core_analytic_plant
from tests.reference.laws import called_back
from tests.reference.plants import ReadableAnalyticPlant
from tests.reference.python_loop import simulate_reference

ALPHA0 = np.full(3, 0.3322)  # the paper's initial deviation (0.083 rad from path I's start)
TOLERANCE = 1e-6  # [rad]: the bound for a continuous run


@pytest.fixture(scope="module")
def needs_core():
    """The compiled core (a core that cannot be imported is an error, never a skip)."""
    return core()


def test_the_core_derivative_is_the_python_plants(robot, needs_core, rng):
    """dx/dt at random states, torques and stage rows, with eq. 12's friction and the paper's
    m_o(t), F_n(t), F(t) tabulated at the stage times (rows 0.5 ms apart)."""
    plant = ReadableAnalyticPlant(robot, dp.Friction(), dp.PaperUncertainty())
    step, count = 5e-4, 400
    plant.precompute_truth(step, count)
    compiled = build_core_analytic_plant(plant, step, count)
    for _ in range(20):
        x = np.concatenate([rng.uniform(0.1, 0.6, 3), rng.uniform(-2.0, 2.0, 3)])
        tau = rng.uniform(-3.0, 3.0, 3)
        row = int(rng.integers(0, count))
        expected = plant.derivative(row * step, x, tau)
        np.testing.assert_allclose(compiled.derivative(x, tau, float(row)), expected, rtol=1e-12, atol=1e-12)
    # between rows: the truth interpolated linearly (m_o enters M; F and F_n the right-hand side)
    x, tau = np.concatenate([np.full(3, 0.4), np.full(3, 0.5)]), np.ones(3)
    halfway = compiled.derivative(x, tau, 10.5)
    low, high = compiled.derivative(x, tau, 10.0), compiled.derivative(x, tau, 11.0)
    assert np.abs(halfway - 0.5 * (low + high)).max() < 1e-6 * np.abs(low).max()
    assert not np.array_equal(low, high)  # the truth changes between rows


def test_no_forward_kinematics_is_a_simulation_failure(robot, needs_core):
    """An arm folded back (3.1 rad): the forearm spheres do not meet, as in the Python plant."""
    compiled = build_core_analytic_plant(dp.AnalyticPlant(robot))
    with pytest.raises(needs_core.SimulationFailure, match="no forward kinematics"):
        compiled.derivative(np.array([3.1, 0.0, 0.0, 0.0, 0.0, 0.0]), np.zeros(3), 0.0)


@pytest.mark.parametrize("law", ["design1", "python"])
def test_a_sampled_run_in_the_core_is_the_python_loops(robot, needs_core, law):
    """Design I (its compiled law) and a user's Python law (called back once per sample) at
    1 kHz along path I with friction and the paper's uncertainty, two RK4 sub-steps: the core's
    reduced Delta gives the Python loop's arrays (module docstring: 1e-10)."""
    nominal = dp.DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))

    def pd(t, alpha, alpha_dot):  # a user's law: PD with the nominal gravity
        return nominal.terms(alpha, np.zeros(3))[2] - 40.0 * (alpha - ALPHA0) - 4.0 * alpha_dot

    runs = []
    for simulate in (dp.simulate, simulate_reference):
        controller = dp.design1(nominal, sampling_period=1e-3) if law == "design1" else pd
        plant = dp.AnalyticPlant(robot, dp.Friction(), dp.PaperUncertainty())
        runs.append(
            simulate(robot, controller, dp.PathI(), plant=plant, t_end=0.2, substeps=2, alpha0=ALPHA0)
        )
    fast, reference = runs
    assert fast.metadata.get("core_plant") and not reference.metadata.get("core_plant")
    for name in ("alpha", "alpha_dot", "tau", "xyz"):
        np.testing.assert_allclose(getattr(fast, name), getattr(reference, name), rtol=1e-10, atol=1e-12)
    for name, values in reference.internals.items():
        np.testing.assert_allclose(fast.internals[name], values, rtol=1e-10, atol=1e-12)
    assert fast.q is None and np.abs(fast.tau).max() > 1.0
    assert np.abs(fast.alpha - ALPHA0).max() > 1e-2  # it moved


@pytest.mark.parametrize("plant", ["analytic", "pinocchio"])
def test_a_continuous_run_with_uncertainty_runs_in_the_core(robot, needs_core, plant):
    """Design I with friction and the paper's time-varying truth, 0.3 s from the paper's initial
    deviation: the default continuous run takes the core's Radau on either plant (the truth
    tabulated on the reference's grid) and stays within 1e-6 rad of the Python plant under LSODA
    at rtol 1e-10 (module docstring)."""
    nominal = dp.DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))
    options = dict(
        plant=plant, t_end=0.3, mode="continuous", alpha0=ALPHA0, friction=dp.Friction(),
        uncertainty=dp.PaperUncertainty(),
    )  # fmt: skip
    run = dp.simulate(robot, dp.design1(nominal), dp.PathI(), **options)
    assert run.metadata["integrator"] == "radau" and run.metadata.get("core_plant")
    reference = simulate_reference(
        robot, dp.design1(nominal), dp.PathI(), integrator="lsoda", rtol=1e-10, atol=1e-12, **options
    )
    assert not reference.metadata.get("core_plant")
    assert np.abs(run.alpha - reference.alpha).max() < TOLERANCE
    np.testing.assert_allclose(run.internals["rho_hat"], reference.internals["rho_hat"], rtol=0, atol=1e-5)
    assert np.abs(run.alpha - ALPHA0).max() > 1e-2


def test_the_readable_law_called_back_on_the_core_plant_is_the_compiled_law(robot, needs_core):
    """Design I with its compiled law hidden (tests/reference/laws.py: called_back): the core's
    plant calls the readable evaluate back once per sample instead of running its C++ copy; the
    two agree to the module's 1e-10."""
    nominal = dp.DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))
    options = dict(plant="analytic", t_end=0.1, alpha0=ALPHA0, friction=dp.Friction())
    compiled = dp.design1(nominal, sampling_period=1e-3)
    readable = called_back(dp.design1(nominal, sampling_period=1e-3))
    assert compiled.sampled_core_law() is not None and readable.sampled_core_law() is None
    runs = [dp.simulate(robot, controller, dp.PathI(), **options) for controller in (compiled, readable)]
    assert all(run.metadata["core_plant"] for run in runs)
    np.testing.assert_allclose(runs[0].alpha, runs[1].alpha, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(runs[0].tau, runs[1].tau, rtol=1e-10, atol=1e-12)


def test_a_nominal_model_written_in_python_gets_the_compiled_law(robot, needs_core):
    """A controller's nominal model may be any object with the NominalModel methods. One the core
    does not hold (here without ``core_law``) gets the compiled law all the same, its ``terms`` and
    ``compensation`` called back at every evaluation (``PythonTerms``; before, the controller's
    readable ``evaluate`` was the run-time path): the run equals the readable law called back
    (tests/reference/laws.py) to the module's 1e-10, sampled and continuous; in continuous mode the
    torque to 1e-4 of its RMS: inside the robust term's boundary layer its gain (measured ~3e5
    N m per rad/s here) turns the two runs' velocity difference (~7e-11 rad/s, Radau's steps
    taken on two law implementations equal to round-off) into ~2e-5 N m."""

    class Terms:  # the analytic model's terms, no core_law
        dof = 3

        def __init__(self):
            self._nominal = dp.DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))
            self.calls = 0

        def terms(self, q, q_dot):
            self.calls += 1
            return self._nominal.terms(q, q_dot)

        def compensation(self, q_dot, friction):
            return self._nominal.compensation(q_dot, friction)

        def metadata(self):
            return {"name": "terms"}

    for mode in ("sampled", "continuous"):
        terms = Terms()
        compiled, readable = dp.design1(terms), called_back(dp.design1(terms))
        assert compiled.sampled_core_law() is not None and readable.sampled_core_law() is None
        options = dict(plant="analytic", t_end=0.05, alpha0=ALPHA0, friction=dp.Friction(), mode=mode)
        runs = [dp.simulate(robot, controller, dp.PathI(), **options) for controller in (compiled, readable)]
        assert terms.calls > 50 and all(run.metadata["core_plant"] for run in runs)
        np.testing.assert_allclose(runs[0].alpha, runs[1].alpha, rtol=1e-10, atol=1e-12)
        if mode == "sampled":
            np.testing.assert_allclose(runs[0].tau, runs[1].tau, rtol=1e-10, atol=1e-10)
        else:
            rms = np.sqrt(np.mean(runs[1].tau ** 2))
            assert np.abs(runs[0].tau - runs[1].tau).max() < 1e-4 * rms
        np.testing.assert_allclose(runs[0].internals["rho_hat"], runs[1].internals["rho_hat"], rtol=1e-10)


class _Failing:
    """A nominal model whose terms raise after ``after`` calls, and one whose terms have the wrong
    shape."""

    dof = 3

    def __init__(self, robot, after: int, shape_ok: bool = True):
        self._nominal, self.after, self.shape_ok, self.calls = dp.DeltaNominalModel(robot), after, shape_ok, 0

    def terms(self, q, q_dot):
        self.calls += 1
        if self.calls > self.after:
            raise KeyError("the user's model broke")
        M, C, G = self._nominal.terms(q, q_dot)
        return (M, C, G) if self.shape_ok else (M[:2, :2], C, G)

    def compensation(self, q_dot, friction):
        return np.zeros(3)

    def metadata(self):
        return {}


@pytest.mark.parametrize("mode", ["sampled", "continuous"])
def test_what_a_python_nominal_model_raises_passes_through_the_compiled_run(robot, needs_core, mode):
    """The user's own exception, unchanged (not a SimulationError the integrator made of it), from
    inside the core's run, sampled (RK4) and continuous (Radau, which turns other exceptions of a
    step into a failure); a wrong shape is one line naming what was expected."""
    options = dict(plant="analytic", t_end=0.05, alpha0=ALPHA0, mode=mode)
    with pytest.raises(KeyError, match="the user's model broke"):
        dp.simulate(robot, dp.design1(_Failing(robot, after=10)), dp.PathI(), **options)
    with pytest.raises(ValueError, match=r"expected \(3, 3\), \(3, 3\) and 3"):
        dp.simulate(robot, dp.PDGravity(_Failing(robot, after=10**6, shape_ok=False)), dp.PathI(), **options)
