"""Time-delay control (delta_pin.control.digital) against closed forms and in the sampled loop.

The closed form: on a unit double integrator alpha_ddot = tau - N with a constant N under a
zero-order hold, the second difference of the angles is T^2 times the mean of the last two
periods' accelerations, so the "mean" pairing recovers N exactly (to rounding, 1e-9 relative
after the 1/T^2 amplification) whatever the computation delay; the textbook "last" pairing is
off by half the last torque increment.
"""

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.control.nominal import NominalModel
from delta_pin.errors import InvalidParameterError
from delta_pin.sim.drive import Drive
from tests.reference.laws import readable_evaluate


class UnitInertia(NominalModel):
    """M̄ = I, no Coriolis, gravity or disturbance: the double integrator's nominal model."""

    dof = 3

    def terms(self, q, q_dot):
        return np.eye(3), np.zeros((3, 3)), np.zeros(3)


def _double_integrator(controller, lumped, delay, steps=40, dt=1e-3):
    """Run the controller (evaluate, then advance its state, as the sampled loop does) on
    alpha_ddot = tau - lumped, integrated exactly under a zero-order hold, through a drive of
    ``delay`` samples; returns the last lumped estimate and the applied torques."""
    drive = Drive(3, delay=delay)
    alpha, velocity, state = np.zeros(3), np.zeros(3), controller.initial_state()
    reference = dp.Reference(np.array([0.01, -0.02, 0.03]), np.zeros(3), np.zeros(3))
    applied = []
    law = readable_evaluate(controller)  # the readable law: its lumped estimate is an internal
    for k in range(steps):
        out = law(k * dt, alpha, velocity, reference, state)
        compiled = controller.evaluate(k * dt, alpha, velocity, reference, state)
        np.testing.assert_allclose(compiled.tau, out.tau, rtol=1e-12, atol=1e-12)
        state = controller.advance(state, out, dt)
        tau = drive.apply(out.tau)
        applied.append(tau)
        acceleration = tau - lumped
        alpha = alpha + dt * velocity + 0.5 * dt**2 * acceleration
        velocity = velocity + dt * acceleration
    return out.internals["lumped_estimate"], np.array(applied)


@pytest.mark.parametrize("delay", [0, 1, 3])
def test_mean_pairing_recovers_a_constant_disturbance_exactly(delay):
    lumped = np.array([0.7, -1.3, 2.1])
    controller = dp.tdc(UnitInertia(), 1e-3, bandwidth=30.0, delay=delay, pairing="mean")
    estimate, applied = _double_integrator(controller, lumped, delay)
    np.testing.assert_allclose(estimate, lumped, rtol=1e-9, atol=1e-9)
    assert np.abs(np.diff(applied, axis=0)).max() > 1e-3  # the torque really varied


def test_last_pairing_is_off_by_half_the_last_increment():
    lumped = np.array([0.7, -1.3, 2.1])
    controller = dp.tdc(UnitInertia(), 1e-3, bandwidth=30.0, pairing="last")
    estimate, applied = _double_integrator(controller, lumped, 0)
    # at the last sample k: N̂ = tau_{k-1} - (tau_{k-1} + tau_{k-2}) / 2 + N
    np.testing.assert_allclose(estimate, lumped + 0.5 * (applied[-2] - applied[-3]), rtol=1e-9, atol=1e-9)


def test_tdc_tracks_path_i_in_the_sampled_loop(robot):
    """Exact state, no delay, 1 kHz, the paper's friction and uncertainty on the analytic plant:
    within 1.5e-3 rad after the first second of path I (measured 5.0e-4 rad over 10-15 s)."""
    nominal = dp.DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))
    run = dp.simulate(
        robot, dp.tdc(nominal, 1e-3), dp.PathI(), plant="analytic", t_end=3.0, alpha0=np.full(3, 0.3322),
        friction=dp.Friction(), uncertainty=dp.PaperUncertainty(),
    )  # fmt: skip
    assert np.abs(run.error[run.t >= 1.0]).max() < 1.5e-3
    assert run.internals["lumped_estimate"].shape == (len(run.t), 3)
    assert run.metadata["controller"]["dt"] == 1e-3


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"dt": 2e-3}, r"dt=0.001 s but the loop samples at dt=0.002"),
        ({"mode": "continuous"}, "discrete-time"),
    ],
)
def test_a_digital_law_runs_only_at_its_own_period(robot, options, match):
    nominal = dp.DeltaNominalModel(robot)
    options = {"mode": "sampled", **options}
    with pytest.raises(InvalidParameterError, match=match):
        dp.simulate(robot, dp.tdc(nominal, 1e-3), dp.PathI(), plant="analytic", t_end=0.01, **options)


@pytest.mark.parametrize(
    ("options", "match"),
    [({"dt": 0.0}, "dt=0.0"), ({"bandwidth": -1.0}, "bandwidth=-1.0"), ({"delay": -1}, "delay=-1"),
     ({"pairing": "median"}, "pairing='median'")],
)  # fmt: skip
def test_bad_tdc_arguments_are_refused(robot, options, match):
    with pytest.raises(InvalidParameterError, match=match):
        dp.tdc(dp.DeltaNominalModel(robot), **{"dt": 1e-3, **options})
