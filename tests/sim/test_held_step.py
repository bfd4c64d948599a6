"""The sampled mode's fast path on the Pinocchio plant (``PinocchioPlant.held_rk4``, the closure
residual computed once per step) against the generic RK4 on ``Plant.derivative``."""

import numpy as np
import pinocchio as pin
import pytest

from delta_pin.model.friction import Friction
from delta_pin.sim import loop as loop_module
from delta_pin.sim.closed_chain_plant import PinocchioPlant
from delta_pin.sim.integrators import rk4_step
from delta_pin.sim.runner import simulate
from delta_pin.sim.uncertainty import FunctionUncertainty, PaperUncertainty
from delta_pin.studies.experiments import RunSpec, run_spec

RUN_ARRAYS = ("alpha", "alpha_dot", "tau", "xyz", "closure_residual")


def _assert_same_run(fast, reference):
    for name in RUN_ARRAYS:
        np.testing.assert_allclose(getattr(fast, name), getattr(reference, name), rtol=1e-12, atol=1e-300)
    assert fast.internals.keys() == reference.internals.keys()
    for name, values in reference.internals.items():
        np.testing.assert_allclose(fast.internals[name], values, rtol=1e-12, atol=1e-300)


def _both_paths(monkeypatch, run):
    """run() with the fast sampled path, then with the generic RK4 only."""
    fast = run()
    monkeypatch.setattr(loop_module, "USE_HELD_RK4", False)
    reference = run()
    return fast, reference


def test_fast_sampled_run_of_design_i_equals_the_reference_path(robot, monkeypatch):
    spec = RunSpec(controller="design1", plant="pinocchio", mode="sampled", sampling_aware=True, t_end=0.3)
    fast, reference = _both_paths(monkeypatch, lambda: run_spec(spec, robot))
    _assert_same_run(fast, reference)
    assert fast.closure_residual.max() <= 1e-9
    assert np.abs(fast.tau).max() > 0.1  # the loop does real work


@pytest.mark.parametrize("substeps", [1, 3])
def test_fast_path_with_substeps_and_projections_equals_the_reference_path(robot, monkeypatch, substeps):
    """Every step projected back (tiny projection tolerance) and several RK4 steps per sample:
    the stage indices into the truth table and the recorded residual after a projection."""
    alpha0 = robot.inverse_kinematics(np.array([0.0, 0.0, -0.35]))
    G0 = robot.analytic_dynamics(alpha0, np.zeros(3)).G

    def controller(t, a, ad):
        return G0 + 2.0 * (alpha0 - a) - 0.1 * ad + 0.05 * np.sin(9.0 * t)

    plants = []

    def run():
        plants.append(PinocchioPlant(robot, Friction(), PaperUncertainty(), projection_tolerance=1e-15))
        return simulate(robot, controller, alpha0=alpha0, plant=plants[-1], t_end=0.05, substeps=substeps)

    fast, reference = _both_paths(monkeypatch, run)
    _assert_same_run(fast, reference)
    assert plants[0].projections == plants[1].projections > 0
    assert fast.metadata["closure_projections"] == reference.metadata["closure_projections"]


def test_held_rk4_step_equals_rk4_on_derivative(robot):
    plant = PinocchioPlant(robot, Friction(), PaperUncertainty())
    h = 1e-3
    plant.precompute_truth(h / 2, 41)
    x = plant.initial_state(np.array([0.35, 0.25, 0.4]), np.array([0.3, -0.2, 0.5]))
    tau = np.array([0.4, -0.3, 0.2])
    for stage in (0, 2, 14, 38):
        t = stage * h / 2
        expected = rk4_step(lambda ts, xs: plant.derivative(ts, xs, tau), t, x, h)
        np.testing.assert_allclose(plant.held_rk4(x, tau, stage, h), expected, rtol=1e-12, atol=1e-300)
    assert plant.held_rk4(x, tau, 39, h) is None  # past the table
    assert plant.held_rk4(x, tau, 0, 2 * h) is None  # a table for another step
    active = PinocchioPlant(robot, coordinates="active")
    active.precompute_truth(h / 2, 41)
    assert active.held_rk4(np.zeros(6), tau, 0, h) is None


def test_platform_mass_is_rewritten_in_the_model(robot):
    """The in-place inertia update gives the model a freshly built pin.Inertia would."""
    heavier = FunctionUncertainty(platform_mass=lambda t: robot.params.m_o * (1.0 + t))
    plant = PinocchioPlant(robot, uncertainty=heavier)
    x = plant.initial_state(np.array([0.3, 0.2, 0.4]), np.array([0.1, -0.2, 0.3]))
    tau = np.array([0.5, 0.1, -0.2])
    ddq = plant.derivative(0.7, x, tau)[plant.nq :]
    mass = robot.params.m_o * 1.7
    nominal = pin.Inertia(robot.pinocchio.model.inertias[plant._payload_joint])
    assert plant.model.inertias[plant._payload_joint] == pin.Inertia(
        mass, nominal.lever, nominal.inertia * (mass / nominal.mass)
    )
    fresh = PinocchioPlant(robot)
    fresh.model.inertias[plant._payload_joint] = pin.Inertia(
        mass, nominal.lever, nominal.inertia * (mass / nominal.mass)
    )
    fresh._tau[fresh.active] = tau
    expected = pin.constraintDynamics(
        fresh.model,
        fresh.data,
        x[: fresh.nq],
        x[fresh.nq :],
        fresh._tau,
        fresh.constraint_models,
        fresh.constraint_datas,
        fresh.settings,
    )
    np.testing.assert_array_equal(ddq, expected)
    assert not np.allclose(ddq, PinocchioPlant(robot).derivative(0.7, x, tau)[plant.nq :])


def test_closure_gap_is_the_largest_closure_residual(robot, rng):
    model = robot.pinocchio
    for _ in range(50):
        q = model.configuration(rng.uniform(0.0, 0.6, 3)) + rng.normal(0.0, 1e-4, model.model.nq)
        assert model.closure_gap(q) == np.abs(model.closure_residual(q)).max()
    q[3] = np.nan
    assert np.isnan(model.closure_gap(q))
