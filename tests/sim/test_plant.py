"""The two plants against each other, conservation of energy, dissipation by friction."""

import numpy as np
import pinocchio as pin
import pytest

from delta_pin.model.friction import Friction
from delta_pin.sim.plants import AnalyticPlant, PinocchioPlant
from delta_pin.sim.runner import simulate
from delta_pin.sim.uncertainty import FunctionUncertainty

START = np.array([0.02, -0.01, -0.35])  # [m]


def _holding_loop(robot):
    """Gravity holding at the start, a weak PD and sinusoids: the same torque law on both plants."""
    alpha0 = robot.inverse_kinematics(START)
    G0 = robot.analytic_dynamics(alpha0, np.zeros(3)).G

    def torque(t, alpha, alpha_dot):
        return G0 + 2.0 * (alpha0 - alpha) - 0.1 * alpha_dot + 0.05 * np.sin(np.array([3.0, 4.0, 5.0]) * t)

    return alpha0, torque


def test_plants_agree_under_the_same_torque_law(robot):
    alpha0, torque = _holding_loop(robot)
    runs = [
        simulate(robot, torque, alpha0=alpha0, plant=plant, t_end=2.0, dt=1e-3)
        for plant in ("analytic", "pinocchio")
    ]
    assert np.abs(runs[0].alpha - alpha0).max() > 0.01  # the robot really moves (rad)
    assert np.abs(runs[0].alpha - runs[1].alpha).max() <= 1e-8  # the bound [rad]
    assert runs[1].closure_residual.max() <= 1e-9
    np.testing.assert_allclose(runs[0].xyz, runs[1].xyz, atol=1e-9)


def _energy(robot, plant, x, stiffness, alpha_rest):
    """Total energy [J]: kinetic + gravity + spring, from each plant's own state."""
    alpha, alpha_dot = plant.joint_state(x)
    spring = 0.5 * stiffness * np.sum((alpha - alpha_rest) ** 2)
    if isinstance(plant, PinocchioPlant):
        q, v = x[: plant.nq], x[plant.nq :]
        kinetic = pin.computeKineticEnergy(plant.model, plant.data, q, v)
        potential = pin.computePotentialEnergy(plant.model, plant.data, q)
    else:
        kinetic = 0.5 * alpha_dot @ robot.analytic_dynamics(alpha, alpha_dot).M @ alpha_dot
        p = robot.params
        z = robot.forward_kinematics(alpha)[2]
        potential = p.g * (
            -0.5 * (p.m_a + p.m_b) * p.l_a * np.sin(alpha).sum() + p.platform_equivalent_mass * z
        )
    return kinetic + potential + spring


@pytest.mark.parametrize("plant_class", [AnalyticPlant, PinocchioPlant])
def test_energy_is_conserved_without_friction(robot, plant_class):
    """Springs to a rest pose (a conservative torque) in continuous mode: RK4 at 1 kHz keeps the
    total energy to 1e-8 of the energy exchanged over 5 s."""
    alpha_rest = robot.inverse_kinematics(START)
    alpha0 = alpha_rest + np.array([0.15, -0.1, 0.05])
    stiffness = 3.0  # [N m/rad]

    def spring(t, alpha, alpha_dot):
        return -stiffness * (alpha - alpha_rest)

    plant = plant_class(robot)
    run = simulate(
        robot, spring, alpha0=alpha0, plant=plant, t_end=5.0, dt=1e-3, mode="continuous", integrator="rk4"
    )
    states = [plant.initial_state(a, ad) for a, ad in zip(run.alpha[::50], run.alpha_dot[::50])]
    energy = np.array([_energy(robot, plant, x, stiffness, alpha_rest) for x in states])
    kinetic_scale = max(
        0.5 * ad @ robot.analytic_dynamics(a, ad).M @ ad
        for a, ad in zip(run.alpha[::50], run.alpha_dot[::50])
    )
    assert kinetic_scale > 1e-3  # [J] it really swings
    assert np.abs(energy - energy[0]).max() <= 1e-8 * kinetic_scale


def test_friction_only_dissipates(robot):
    alpha_rest = robot.inverse_kinematics(START)
    alpha0 = alpha_rest + np.array([0.15, -0.1, 0.05])
    stiffness = 3.0
    plant = AnalyticPlant(robot, friction=Friction())

    def spring(t, alpha, alpha_dot):
        return -stiffness * (alpha - alpha_rest)

    run = simulate(
        robot, spring, alpha0=alpha0, plant=plant, t_end=2.0, dt=1e-3, mode="continuous", integrator="rk4"
    )
    energy = np.array(
        [
            _energy(robot, plant, plant.initial_state(a, ad), stiffness, alpha_rest)
            for a, ad in zip(run.alpha, run.alpha_dot)
        ]
    )
    assert np.diff(energy).max() <= 1e-9  # [J] never increases (beyond integration error)
    assert energy[-1] < energy[0] - 0.01  # and friction really removed energy


def test_time_varying_platform_mass_reaches_the_pinocchio_model(robot):
    heavier = FunctionUncertainty(platform_mass=lambda t: robot.params.m_o * (1.0 + t))
    plant = PinocchioPlant(robot, uncertainty=heavier)
    alpha = robot.inverse_kinematics(START)
    x = plant.initial_state(alpha, np.zeros(3))
    plant.derivative(1.0, x, np.zeros(3))
    assert plant.model.inertias[plant._platform_joint].mass == pytest.approx(2 * robot.params.m_o)
    # the analytic plant with the same mass sees the same acceleration
    analytic = AnalyticPlant(robot, uncertainty=heavier)
    np.testing.assert_allclose(
        analytic.derivative(1.0, analytic.initial_state(alpha, np.zeros(3)), np.zeros(3))[3:],
        plant.derivative(1.0, x, np.zeros(3))[plant.nq + plant.active],
        rtol=1e-9,
    )
