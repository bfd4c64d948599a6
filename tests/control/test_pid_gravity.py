"""PID + gravity, the law added through the declarations (issue 38, item 3): its compiled twin
(delta_pin/core/laws/pid_gravity.cpp, bound by itself) against its readable Python law, its
declaration collected from its own module, and the one thing the integral is for."""

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.control.base import Reference
from delta_pin.control.pid_gravity import PIDGravity
from delta_pin.control.registry import declaration
from delta_pin.errors import InvalidParameterError
from tests.reference.laws import readable_evaluate


@pytest.mark.parametrize("robot", ["delta", "five_bar"])
def test_the_compiled_law_is_its_python_twin(robot):
    """At 20 random states: the same torque and the same state derivative (the error r). The Delta's
    nominal model is the analytic one on both sides, the five-bar's the projection (C++ and Python
    projections agree to ~1e-12 N m: tests/sim/test_core_laws.py); tolerance 1e-9 N m."""
    model = dp.load_delta() if robot == "delta" else dp.load_robot("five_bar")
    nominal = dp.DeltaNominalModel(model) if robot == "delta" else dp.ClosedChainNominalModel(model)
    controller = PIDGravity(nominal, K_p=[80.0] * model.dof, K_i=30.0, K_d=7.0)
    law = controller.sampled_core_law()
    assert law is not None
    rng = np.random.default_rng(4)
    for _ in range(20):
        alpha = model.home + rng.uniform(-0.05, 0.05, model.dof)
        alpha_dot, ref, ref_dot = (rng.normal(0, 0.3, model.dof) for _ in range(3))
        ref = model.home + 0.05 * ref
        state = rng.normal(0, 0.01, model.dof)
        python = readable_evaluate(controller)(
            0.0, alpha, alpha_dot, Reference(ref, ref_dot, np.zeros(model.dof)), state
        )
        tau, state_dot = law.evaluate(alpha, alpha_dot, ref, ref_dot, np.zeros(model.dof), state)
        np.testing.assert_allclose(tau, python.tau, atol=1e-9, rtol=0)
        np.testing.assert_allclose(state_dot, alpha - ref, atol=1e-15, rtol=0)


def test_the_integral_removes_the_steady_error_pd_keeps():
    """The nominal model's platform mass is 0.3 kg, the plant's 0.5 kg: holding alpha = 0.5 rad,
    PD + gravity (K_i = 0, the PD law) settles 1.52e-3 rad off and stays; with K_i = 200 the error
    has decayed to 1.2e-4 rad after 3 s (both measured); the bound is a tenth of PD's. Both in the
    compiled core (continuous, Radau), on the analytic plant."""
    nominal = dp.DeltaNominalModel(dp.load_delta())
    plant = dp.load_delta(m_o=0.5)
    alpha0 = np.full(3, 0.5)
    final = {}
    for K_i in (0.0, 200.0):
        run = dp.simulate(plant, PIDGravity(nominal, K_i=K_i), None, t_end=3.0, mode="continuous",
                          plant="analytic", alpha0=alpha0)  # fmt: skip
        assert run.metadata["integrator"] == "radau"
        final[K_i] = np.abs(run.error[-1]).max()
    assert final[0.0] > 1e-3  # PD's steady error: the gravity the nominal model misses / K_p
    assert final[200.0] < 0.1 * final[0.0]


def test_it_is_declared_by_its_own_module_and_runs_from_the_cli(tmp_path):
    from delta_pin.cli import main

    law = declaration("pid")
    assert law.law is PIDGravity and law.compiled_continuous and law.label == "PID"
    with pytest.raises(InvalidParameterError, match="K_i=-1"):
        PIDGravity(dp.DeltaNominalModel(dp.load_delta()), K_i=-1.0)
    argv = ["run", "--controller", "pid", "--plant", "analytic", "--t-end", "0.3", "--out", str(tmp_path)]
    assert main(argv) == 0
    assert dp.load_run(tmp_path / "run.npz").metadata["controller"]["name"] == "pid"
