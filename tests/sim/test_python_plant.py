"""A plant written in Python in the core's sampled loop (``PythonPlant``,
``delta_pin/core/python/python_plant.cpp``): the core's RK4 calls the plant's ``derivative`` back at every
stage, so a user's plant runs on the one loop every run takes (issue 38, item 1)."""

from __future__ import annotations

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.errors import InvalidParameterError, SimulationError
from tests.reference.plants import ReadableAnalyticPlant
from tests.reference.python_loop import simulate_reference


class UsersPlant(ReadableAnalyticPlant):
    """The paper's reduced Delta as a user would write a plant: Python only, no compiled copy."""

    name = "users_plant"

    def build(self, step: float = 0.0, count: int = 0):
        return None


@pytest.fixture(scope="module")
def delta():
    return dp.load_delta()


def test_a_python_plant_steps_as_the_python_reference_loop(delta):
    """0.3 s of design I with friction and the paper's uncertainty on the plant written in Python:
    the core's loop against the readable Python loop (tests/reference) on the same plant class.
    Both take the same RK4 stages of the same derivative, so they agree to round-off: 1e-12 rad
    and 1e-9 N m (measured 3e-17 rad, 7e-15 N m); the run never touched a compiled plant."""
    nominal = dp.DeltaNominalModel(delta)
    options = dict(t_end=0.3, mode="sampled")
    uncertainty = dp.PaperUncertainty()
    run = dp.simulate(
        delta, dp.design1(nominal), dp.PathI(), plant=UsersPlant(delta, True, uncertainty), **options
    )
    reference = simulate_reference(
        delta, dp.design1(nominal), dp.PathI(), plant=UsersPlant(delta, True, uncertainty), **options
    )
    assert "core_plant" not in run.metadata
    assert np.ptp(run.alpha) > 1e-3  # it moves
    np.testing.assert_allclose(run.alpha, reference.alpha, rtol=0, atol=1e-12)
    np.testing.assert_allclose(run.tau, reference.tau, rtol=0, atol=1e-9)
    np.testing.assert_allclose(run.xyz, reference.xyz, rtol=0, atol=1e-12)


def test_what_a_python_plant_raises_reaches_the_caller_with_its_time(delta):
    """An error inside the plant's derivative passes through the core unchanged (its time kept);
    a derivative of the wrong length is one line naming the plant and both shapes."""

    class Failing(UsersPlant):
        def derivative(self, t, x, tau):
            if t > 0.05:
                raise SimulationError("the gearbox seized", t)
            return super().derivative(t, x, tau)

    class Short(UsersPlant):
        def derivative(self, t, x, tau):
            return super().derivative(t, x, tau)[:5]

    law = lambda t, a, ad: np.zeros(3)  # noqa: E731
    with pytest.raises(SimulationError, match="gearbox seized") as error:
        dp.simulate(delta, law, dp.PathI(), plant=Failing(delta), t_end=0.2)
    assert 0.05 < error.value.time <= 0.0515  # the RK4 stage that raised
    with pytest.raises(
        SimulationError, match=r"'users_plant''s derivative returned shape \(5,\), expected \(6,\)"
    ):
        dp.simulate(delta, law, dp.PathI(), plant=Short(delta), t_end=0.2)


def test_continuous_mode_refuses_a_python_plant_in_one_line(delta):
    """The continuous loop is the core's Radau IIA on a compiled plant: a plant written in Python
    is refused before the run, in one line that says what works."""
    with pytest.raises(InvalidParameterError, match=r"no compiled copy.*mode='sampled'") as error:
        dp.simulate(delta, lambda t, a, ad: np.zeros(3), dp.PathI(), plant=UsersPlant(delta), t_end=0.1,
                    mode="continuous")  # fmt: skip
    assert "\n" not in str(error.value)
