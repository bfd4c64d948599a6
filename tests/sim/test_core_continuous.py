"""The continuous mode of closed chains in the compiled core (delta_pin/sim/loop.py, run_loop:
the core's plant and law integrated by its Radau IIA, delta_pin/core/integrate/radau.hpp) against the
Python route it replaced (``simulate_reference``, tests/reference/python_loop.py): the Python plant
in active coordinates with the readable law, integrated by LSODA at tight tolerances (rtol 1e-10,
atol 1e-12), the reference.

Tolerance: both integrate the same ODE (the core's completion and law equal the Python ones to
~1e-12, tests/sim/test_core_plant.py and test_core_laws.py); what differs is the integration
error. Radau at its default rtol 1e-6 / atol 1e-8 stays within the issue's 1e-6 rad of the tight
reference (measured ~1e-8 on these runs); the tight reference's own error is ~1e-10.
"""

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.errors import InvalidParameterError, SimulationError
from tests.reference.plants import ReadableClosedChainPlant
from tests.reference.python_loop import simulate_reference

T_END = 0.4  # [s]: the reaching phase and a stretch of tracking; the LSODA reference costs ~seconds
TOLERANCE = 1e-6  # [rad], the bound (module docstring)


def _case(name: str):
    robot = dp.load_robot(name)
    path = dp.JointSinusoid(robot.home, amplitude=0.1, frequency=0.5)
    return robot, path


@pytest.mark.parametrize("name", ["five_bar", "three_rrr"])
def test_core_radau_follows_the_tight_python_reference(name):
    """Design I, 0.4 s from 0.02 rad off the path: the default continuous run goes to the core's
    Radau (metadata: integrator radau, core_plant), and its joints stay within 1e-6 rad of the
    Python plant and law under LSODA at rtol 1e-10 (measured 1.4e-9 on the five-bar); rho_hat to
    1e-6 (measured 1.2e-7); the torques to 2e-3 of their RMS (measured 5e-4): the robust term's
    boundary-layer gain, Lambda / layer ~1e4 N m per rad/s, turns the integrators' velocity
    difference (~4e-7 rad/s at the layer's crossings) into up to ~3e-3 N m at single samples."""
    robot, path = _case(name)
    nominal = dp.ClosedChainNominalModel(robot)
    alpha0 = robot.home + 0.02
    core = dp.simulate(robot, dp.design1(nominal), path, t_end=T_END, mode="continuous", alpha0=alpha0)
    assert core.metadata["integrator"] == "radau" and core.metadata.get("core_plant")
    assert (
        core.metadata["radau_steps"] > 0 and core.metadata["rhs_evaluations"] > core.metadata["radau_steps"]
    )
    reference = simulate_reference(
        robot, dp.design1(nominal), path, t_end=T_END, mode="continuous", alpha0=alpha0, integrator="lsoda",
        rtol=1e-10, atol=1e-12,
    )  # fmt: skip
    assert reference.metadata["integrator"] == "lsoda" and not reference.metadata.get("core_plant")
    assert np.abs(core.alpha - reference.alpha).max() < TOLERANCE
    assert np.abs(core.alpha - core.alpha[0]).max() > 1e-2  # it moved
    rms = np.sqrt(np.mean((core.tau - reference.tau) ** 2))
    assert rms < 2e-3 * np.sqrt(np.mean(reference.tau**2))
    np.testing.assert_allclose(core.internals["rho_hat"], reference.internals["rho_hat"], rtol=0, atol=1e-6)
    # the full configuration of every sample, closed to the assembly tolerance
    assert core.q.shape == (len(core.t), robot.model.nq) and core.closure_residual.max() < 1e-9
    np.testing.assert_allclose(core.xyz, reference.xyz, rtol=0, atol=1e-6)


def _pd_gravity(robot):
    nominal = dp.ClosedChainNominalModel(robot)
    home = robot.home

    def law(t, alpha, alpha_dot):  # a user's law in Python: PD about home with gravity compensation
        return nominal.terms(alpha, np.zeros_like(alpha))[2] - 20.0 * (alpha - home) - 2.0 * alpha_dot

    return law


def test_a_python_law_runs_per_evaluation_in_the_core_loop():
    """A user's Python law in continuous mode gets the core's plant and Radau (called back per
    evaluation): within 1e-6 rad of the same law on the Python plant under LSODA at rtol 1e-10
    (module docstring), the plant's q recorded at every sample."""
    robot = dp.load_robot("five_bar")
    law = _pd_gravity(robot)
    options = {"t_end": 0.3, "mode": "continuous", "alpha0": robot.home + 0.05}
    run = dp.simulate(robot, law, None, **options)
    assert run.metadata["integrator"] == "radau" and run.metadata["core_plant"]
    reference = simulate_reference(robot, law, None, integrator="lsoda", rtol=1e-10, atol=1e-12, **options)
    assert reference.metadata["integrator"] == "lsoda" and not reference.metadata.get("core_plant")
    assert np.abs(run.alpha - reference.alpha).max() < TOLERANCE
    assert np.abs(run.alpha - run.alpha[0]).max() > 1e-2  # it moved (PD towards home)
    np.testing.assert_allclose(run.tau, reference.tau, rtol=0, atol=1e-5 * np.abs(reference.tau).max())
    assert run.q.shape == (len(run.t), robot.model.nq)


def test_a_python_law_that_fails_inside_the_core_loop():
    """What a Python law raises passes through the compiled loop unchanged; a non-finite torque or
    one of the wrong shape stops the run in one line naming the controller and the time."""
    robot = dp.load_robot("five_bar")
    law = _pd_gravity(robot)
    options = {"t_end": 0.2, "mode": "continuous", "alpha0": robot.home}

    class BrokenLawError(RuntimeError):
        pass

    def raising(t, alpha, alpha_dot):
        if t > 0.05:
            raise BrokenLawError(f"the user's law broke at t = {t:.3f}")
        return law(t, alpha, alpha_dot)

    with pytest.raises(BrokenLawError, match=r"the user's law broke at t = 0\.05"):
        dp.simulate(robot, raising, None, **options)

    def nan_law(t, alpha, alpha_dot):
        return law(t, alpha, alpha_dot) * (np.nan if t > 0.1 else 1.0)

    with pytest.raises(SimulationError, match=r"returned a non-finite torque \[nan, nan\]") as info:
        dp.simulate(robot, nan_law, None, **options)
    assert 0.1 <= info.value.time <= 0.11 and "\n" not in str(info.value)

    def wide_law(t, alpha, alpha_dot):
        return np.zeros(3)

    with pytest.raises(SimulationError, match=r"torque of shape \(3,\), expected \(2,\)"):
        dp.simulate(robot, wide_law, None, **options)


def test_continuous_mode_names_why_a_run_has_no_core_loop():
    """The ball-ball Delta's idle rod spins run in the core's Radau (its whole state), the default
    continuous integrator. What has no core loop in continuous mode -- a plant without a compiled
    copy (a user's Plant in Python), a discrete-time law, LSODA -- is refused in one line that
    says why and what works (sampled mode, or Radau/BDF2); the user's plant runs sampled (the
    core's loop calls its derivative back)."""
    robot = dp.load_robot("delta_ballrods")
    path = dp.JointSinusoid(robot.home, amplitude=0.05, frequency=0.5)
    ctc = dp.ComputedTorque(dp.ClosedChainNominalModel(robot))
    options = {"t_end": 0.01, "mode": "continuous"}
    run = dp.simulate(robot, ctc, path, **options)
    assert run.metadata["integrator"] == "radau" and run.metadata["core_plant"]
    refused = r"integrator='lsoda' does not run mode='continuous': .*'radau' or 'bdf2' continuous mode"
    with pytest.raises(InvalidParameterError, match=refused) as info:
        dp.simulate(robot, ctc, path, integrator="lsoda", **options)
    assert "\n" not in str(info.value)

    five_bar, five_bar_path = _case("five_bar")
    nominal = dp.ClosedChainNominalModel(five_bar)

    class UsersPlant(dp.Plant):  # a plant written in Python: no compiled copy
        def __init__(self):
            self.inner = ReadableClosedChainPlant(five_bar, coordinates="active")
            super().__init__(five_bar)

        def initial_state(self, alpha, alpha_dot):
            return self.inner.initial_state(alpha, alpha_dot)

        def derivative(self, t, x, tau):
            return self.inner.derivative(t, x, tau)

        def joint_state(self, x):
            return self.inner.joint_state(x)

        def platform_position(self, x):
            return self.inner.platform_position(x)

    no_copy = r"mode='continuous' runs in the compiled core's Radau IIA.*no compiled copy.*use mode='sampled'"
    with pytest.raises(InvalidParameterError, match=no_copy) as info:
        dp.simulate(five_bar, dp.ComputedTorque(nominal), five_bar_path, plant=UsersPlant(), **options)
    assert "\n" not in str(info.value)
    digital = r"is discrete-time \(dt=0\.001\): only in mode='sampled'"
    with pytest.raises(InvalidParameterError, match=digital) as info:
        dp.simulate(five_bar, dp.tdc(nominal, 1e-3), five_bar_path, **options)
    assert "\n" not in str(info.value)
    sampled = dp.simulate(five_bar, dp.ComputedTorque(nominal), five_bar_path, plant=UsersPlant(), t_end=0.1)
    assert sampled.metadata["integrator"] == "rk4" and not sampled.metadata.get("core_plant")
    assert np.abs(sampled.alpha - sampled.alpha[0]).max() > 1e-3  # it moved along the path
    assert np.abs(sampled.alpha - sampled.alpha_d).max() < 1e-3  # computed torque on the exact model
