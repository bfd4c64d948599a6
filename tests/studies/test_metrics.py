"""Performance indices against closed-form values on synthetic runs."""

import numpy as np
import pytest

from delta_pin.sim.run import Run
from delta_pin.studies.metrics import compute_metrics


def _run(t, error, tau, xyz_error=None, rho=None):
    n = len(t)
    zeros = np.zeros((n, 3))
    xyz_error = zeros if xyz_error is None else xyz_error
    internals = {} if rho is None else {"rho_hat": rho[:, None]}
    return Run(
        t=t,
        alpha=error,
        alpha_dot=zeros,
        alpha_d=zeros,
        alpha_dot_d=zeros,
        xyz=xyz_error,
        xyz_d=zeros,
        tau=tau,
        closure_residual=np.zeros(n),
        internals=internals,
        metadata={"wall_time": 1.5},
    )


def test_indices_of_a_linear_error_and_constant_torque():
    t = np.linspace(0.0, 10.0, 10001)
    error = np.zeros((len(t), 3))
    error[:, 0] = 0.1 * t / 10.0  # ||r|| grows linearly to 0.1 rad
    tau = np.tile([3.0, 4.0, 0.0], (len(t), 1))  # ||tau|| = 5 N m
    xyz = np.zeros((len(t), 3))
    xyz[:, 2] = 1e-3 * np.sin(t)  # 1 mm amplitude
    rho = 2.0 - 0.1 * t
    m = compute_metrics(_run(t, error, tau, xyz, rho))
    assert m.iae == pytest.approx(0.5, rel=1e-12)  # int_0^10 0.01 t dt
    assert m.ise == pytest.approx(1e-4 / 3 * 1000 / 1, rel=1e-6)  # int (0.01 t)^2 = 1e-4 * 1000 / 3
    assert m.control_effort == pytest.approx(50.0, rel=1e-12)
    assert m.control_effort_sum == pytest.approx(5.0 * 10001, rel=1e-12)
    assert m.rho_hat_max == pytest.approx(2.0) and m.rho_hat_final == pytest.approx(1.0)
    assert m.max_task_error_mm_last_5s == pytest.approx(1.0, abs=1e-6)  # sin reaches 1 near t = 7.85 s
    assert m.max_joint_error_last_5s == pytest.approx(0.1)
    assert m.wall_time == 1.5


def test_runs_without_an_estimate_report_none():
    t = np.linspace(0.0, 1.0, 11)
    m = compute_metrics(_run(t, np.zeros((11, 3)), np.zeros((11, 3))))
    assert m.rho_hat_max is None and m.rho_hat_final is None


def test_last_5_s_indices_of_a_shorter_run_are_nan_and_say_so():
    """Over "the last 5 s" of a 3 s run the indices used to describe the initial transient under
    the name of the steady state; now they are NaN (None in the dict), and a note says why."""
    from delta_pin.studies.metrics import window_note

    for duration, short in ((3.0, True), (5.0, False), (8.0, False)):
        t = np.linspace(0.0, duration, round(duration * 1000) + 1)
        error = np.zeros((len(t), 3))
        error[:, 0] = 0.1 * np.exp(-t)
        run = _run(t, error, np.ones((len(t), 3)))
        m = compute_metrics(run)
        names = ("max_task_error_mm_last_5s", "max_joint_error_last_5s", "torque_increment_rms_last_5s")
        if short:
            assert all(np.isnan(getattr(m, name)) and m.as_dict()[name] is None for name in names)
            assert window_note(run) == (
                "the run lasts 3 s, less than the 5 s of the 'last_5s' indices: they are NaN"
            )
        else:
            expected = 0.1 * np.exp(-(duration - 5.0))  # [rad] the error 5 s before the end
            assert m.max_joint_error_last_5s == pytest.approx(expected, rel=1e-12)
            assert window_note(run) is None
        assert m.iae > 0  # the whole-run indices are always there
