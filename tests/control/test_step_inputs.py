"""``Controller.step``, the call offered to drives and other simulators, checks its inputs before
they reach compiled code (issue 25: a length-2 angle vector on a 3-joint law read past the array
and returned NaN or garbage torques from one call to the next)."""

from __future__ import annotations

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.errors import InvalidParameterError


@pytest.fixture()
def law():
    return dp.design1(dp.DeltaNominalModel(dp.load_delta()))


@pytest.mark.parametrize(
    "alpha", [[0.1, 0.2], [0.1], [0.1, 0.2, 0.3, 0.4], [np.nan, 0.0, 0.0], [[0.1, 0.2, 0.3]]]
)
def test_angles_of_the_wrong_length_or_not_finite_are_refused_every_time(law, alpha):
    reference = dp.Reference.hold(np.zeros(3))
    for _ in range(5):  # the same call five times: always the same one-line refusal
        law.reset()
        with pytest.raises(InvalidParameterError, match=r"alpha_measured=.* must be 3 finite numbers"):
            law.step(0.0, alpha, reference)


def test_a_reference_of_another_length_and_time_running_backwards_are_refused(law):
    law.reset()
    tau = law.step(0.0, [0.1, 0.2, 0.3], dp.Reference.hold(np.zeros(3)))
    assert tau.shape == (3,) and np.isfinite(tau).all()
    with pytest.raises(InvalidParameterError, match=r"reference\.alpha=\[0\.0, 0\.0\] must be 3 finite"):
        law.step(0.001, [0.1, 0.2, 0.3], dp.Reference(np.zeros(2), np.zeros(2), np.zeros(2)))
    with pytest.raises(InvalidParameterError, match=r"t=-0\.001 must be a finite time \[s\] after"):
        law.step(-0.001, [0.1, 0.2, 0.3], dp.Reference.hold(np.zeros(3)))
    with pytest.raises(InvalidParameterError, match=r"alpha_dot_measured=.* must be 3 finite"):
        law.step(0.001, [0.1, 0.2, 0.3], dp.Reference.hold(np.zeros(3)), alpha_dot_measured=[0.0])
    # a refused call changes nothing: the next good sample is the one a fresh law computes
    second = law.step(0.001, [0.1, 0.2, 0.3], dp.Reference.hold(np.zeros(3)))
    fresh = dp.design1(dp.DeltaNominalModel(dp.load_delta()))
    fresh.step(0.0, [0.1, 0.2, 0.3], dp.Reference.hold(np.zeros(3)))
    np.testing.assert_array_equal(second, fresh.step(0.001, [0.1, 0.2, 0.3], dp.Reference.hold(np.zeros(3))))
