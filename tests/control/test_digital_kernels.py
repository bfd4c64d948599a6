"""The compiled steps of the digital laws (delta_pin.compiled.digital_laws) against their readable
reference (``evaluate_reference``, the law as its module docstring writes it).

Both are fed the same state at every sample of a 0.3 s closed-loop run (the compiled law's own
states, so every branch is visited: start-up, the observer, the prediction over the delay, the
dead zone, the torque limit). Tolerance 1e-9 relative (1e-9 N m, rad absolute near zero): the two
differ only in rounding (Cramer's rule against LAPACK's solve, sum orders), ~1e-14 per step.
"""

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.sim.drive import Encoder


def _compare_along_a_run(robot, controller):
    run = dp.simulate(
        robot, controller, dp.PathI(), plant="analytic", t_end=0.3, mode="sampled", alpha0=np.full(3, 0.3322),
        friction=dp.Friction(), uncertainty=dp.PaperUncertainty(), sensor=Encoder(bits=17),
        delay=controller.delay, compiled=False,
    )  # fmt: skip
    controller.reset()
    state = controller.initial_state()
    checked = 0
    for k, t in enumerate(run.t[:-1]):
        reference = dp.Reference(run.alpha_d[k], run.alpha_dot_d[k], np.zeros(3))
        alpha = run.alpha[k] + 1e-5 * np.sin(k + np.arange(3))  # off the path, like a reading
        compiled = controller.evaluate(t, alpha, run.alpha_dot[k], reference, state)
        readable = controller.evaluate_reference(t, alpha, run.alpha_dot[k], reference, state)
        np.testing.assert_allclose(compiled.tau, readable.tau, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(compiled.next_state, readable.next_state, rtol=1e-9, atol=1e-9)
        for name, value in readable.internals.items():
            np.testing.assert_allclose(compiled.internals[name], value, rtol=1e-9, atol=1e-9, err_msg=name)
        state = compiled.next_state
        checked += 1
    assert checked == 300


@pytest.mark.parametrize(
    "options",
    [{"delay": 0}, {"delay": 1}, {"delay": 3, "observer_order": 1}, {"delay": 1, "observer_order": 4},
     {"delay": 1, "torque_limit": 3.0}, {"delay": 0, "friction_compensation": False, "epsilon": 0.0}],
)  # fmt: skip
def test_digital_robust_compiled_step_is_the_readable_law(robot, options):
    nominal = dp.DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))
    controller = dp.digital_robust(nominal, 1e-3, **options)
    assert controller.compiled
    _compare_along_a_run(robot, controller)


@pytest.mark.parametrize("options", [{"delay": 0}, {"delay": 2, "pairing": "mean"}, {"delay": 1}])
def test_tdc_compiled_step_is_the_readable_law(robot, options):
    nominal = dp.DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))
    controller = dp.tdc(nominal, 1e-3, **options)
    assert controller.compiled
    _compare_along_a_run(robot, controller)
