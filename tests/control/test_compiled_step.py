"""The compiled step of designs I and II equals the readable reference law (<= 1e-12 relative)."""

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.control import Reference
from delta_pin.model.validation import sample_states

OPTIONS = [
    {},
    {"sampling_period": 1e-3},
    {"vector_rho": True},
    {"friction_compensation": False},
    {"xi": 0.5, "epsilon": 1e3},
]  # the last: boundary layer and dead-zone branches


@pytest.mark.parametrize("make", [dp.design1, dp.design2])
@pytest.mark.parametrize("options", OPTIONS)
def test_compiled_step_equals_the_reference(robot, make, options):
    nominal = dp.DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))
    controller = make(nominal, **options)
    assert controller.compiled
    rng = np.random.default_rng(11)
    alphas, alpha_dots = sample_states(robot, 40, seed=12)
    for alpha, alpha_dot in zip(alphas, alpha_dots):
        reference = Reference(alpha + rng.normal(scale=0.05, size=3), rng.normal(size=3), rng.normal(size=3))
        state = controller.initial_state() * rng.uniform(0.01, 3.0)
        fast = controller.evaluate(0.0, alpha, alpha_dot, reference, state)
        slow = controller.evaluate_reference(0.0, alpha, alpha_dot, reference, state)
        np.testing.assert_allclose(fast.tau, slow.tau, rtol=1e-12, atol=1e-12 * np.abs(slow.tau).max())
        np.testing.assert_allclose(fast.state_derivative, slow.state_derivative, rtol=1e-12, atol=1e-15)
        for name in ("Lambda", "robust_gain", "omega_norm", "adaptation_active"):
            assert fast.internals[name] == pytest.approx(slow.internals[name], rel=1e-12, abs=1e-15), name
        np.testing.assert_allclose(
            fast.internals["robust_torque"],
            slow.internals["robust_torque"],
            rtol=1e-12,
            atol=1e-12 * max(1.0, np.abs(slow.tau).max()),
        )


def test_a_run_is_the_same_with_and_without_the_compiled_step(robot):
    nominal = dp.DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))
    runs = [
        dp.simulate(
            robot,
            dp.design1(nominal, compiled=compiled),
            dp.PathI(),
            plant="analytic",
            t_end=0.5,
            alpha0=np.full(3, 0.3322),
            mode="continuous",
            integrator="lsoda",  # the same integrator both times: only the controller's step differs
            friction=dp.Friction(),
            uncertainty=dp.PaperUncertainty(),
        )
        for compiled in (True, False)
    ]
    np.testing.assert_allclose(runs[0].alpha, runs[1].alpha, rtol=0, atol=1e-12)  # [rad]
    # the robust gain (~2000 N m s/rad in the boundary layer) turns 1e-13 rad of round-off into
    # up to ~1e-7 relative in tau (LSODA then picks slightly different steps)
    np.testing.assert_allclose(runs[0].tau, runs[1].tau, rtol=1e-6, atol=1e-9)


def test_serial_nominal_models_use_the_reference_law():
    class Unit(dp.control.NominalModel):
        dof = 3

        def terms(self, q, q_dot):
            return np.eye(3), np.zeros((3, 3)), np.zeros(3)

    assert not dp.design1(Unit()).compiled


@pytest.mark.parametrize("friction_compensation", [True, False])
def test_compiled_lqr_law_equals_the_readable_one(robot, friction_compensation):
    """The LQR's compiled law (delta_pin.compiled.lqr, what the compiled closed loops run) against
    LQR.evaluate at random states and references: 1e-13 relative (the same sums in its order;
    numpy's matrix products may group them differently)."""
    from delta_pin.compiled.layouts import INFO, record
    from delta_pin.compiled.lqr import lqr_law_into

    nominal = dp.DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))
    alpha0 = robot.inverse_kinematics(dp.PathI().position(0.0))
    controller = dp.LQR(nominal, alpha0, friction_compensation=friction_compensation)
    assert controller.compiled
    info = record(INFO)
    rng = np.random.default_rng(13)
    alphas, alpha_dots = sample_states(robot, 40, seed=14)
    for alpha, alpha_dot in zip(alphas, alpha_dots):
        reference = Reference(alpha + rng.normal(scale=0.05, size=3), rng.normal(size=3), rng.normal(size=3))
        slow = controller.evaluate(0.0, alpha, alpha_dot, reference, controller.initial_state())
        fast = np.empty(3)
        lqr_law_into(
            controller.kernel_parameters, alpha, alpha_dot, reference.alpha, reference.alpha_dot,
            reference.alpha_ddot, fast, info,
        )  # fmt: skip
        np.testing.assert_allclose(fast, slow.tau, rtol=1e-13, atol=1e-13 * np.abs(slow.tau).max())
        assert info.ok
