"""The extended-state observer (delta_pin.control.observer) against closed forms.

References: the characteristic polynomial (z - exp(-omega_o T))^N its gain was placed for
(Ackermann's formula, checked on the coefficients: eigenvalues of a matrix with one N-fold
eigenvalue are ill-conditioned, its polynomial is not), and the exact solution of
alpha_ddot = u + f(t) with u held over each period and f a polynomial of degree ``order - 1``,
which the observer's model represents exactly, so its estimate must converge to the true
angle, velocity and f to rounding.
"""

import math

import numpy as np
import pytest

from delta_pin.control.observer import ExtendedStateObserver
from delta_pin.errors import InvalidParameterError


@pytest.mark.parametrize("order", [1, 2, 3, 4])
def test_the_error_dynamics_have_the_placed_characteristic_polynomial(order):
    observer = ExtendedStateObserver(1e-3, 150.0, order)
    correction = np.eye(observer.size)
    correction[:, 0] -= observer.gain
    polynomial = np.poly(correction @ observer.transition)
    wanted = np.poly(np.full(observer.size, math.exp(-150.0 * 1e-3)))
    # the coefficients are O(1) binomials; 1e-9 is far above the rounding of a 6 x 6 product
    np.testing.assert_allclose(polynomial, wanted, rtol=0, atol=1e-9)


def _exact_readings(order, steps, dt, u, f_coefficients):
    """alpha_k of alpha_ddot = u_k + f(t) from rest, f(t) = sum_i c_i t^i / i!, by the Taylor series
    (exact for a polynomial f and u held over each period); also alpha_dot and f at the end."""
    alpha, velocity = 0.0, 0.0
    readings = []
    for k in range(steps):
        readings.append(alpha)
        t = k * dt
        # derivatives of f at t_k: f^(j)(t) = sum_i c_i t^(i-j) / (i-j)!
        fj = [sum(c * t ** (i - j) / math.factorial(i - j) for i, c in enumerate(f_coefficients) if i >= j)
              for j in range(order)]  # fmt: skip
        acceleration = u[k] + fj[0]
        alpha += (
            velocity * dt
            + acceleration * dt**2 / 2
            + sum(fj[j] * dt ** (j + 2) / math.factorial(j + 2) for j in range(1, order))
        )
        velocity += acceleration * dt + sum(
            fj[j] * dt ** (j + 1) / math.factorial(j + 1) for j in range(1, order)
        )
    t = steps * dt
    f_end = sum(c * t**i / math.factorial(i) for i, c in enumerate(f_coefficients))
    readings.append(alpha)
    return np.array(readings), velocity, f_end


@pytest.mark.parametrize("order", [1, 2, 3])
def test_a_polynomial_disturbance_is_recovered_exactly(order):
    dt, steps = 1e-3, 1000
    u = np.sin(np.arange(steps) * 0.01)  # a known, varying input
    coefficients = [3.0, -20.0, 150.0][:order]  # f = 3 - 20 t + 75 t^2 (degree order - 1)
    readings, velocity, f_end = _exact_readings(order, steps, dt, u, coefficients)
    observer = ExtendedStateObserver(dt, 150.0, order)
    estimate = observer.start(readings[:1])
    for k in range(steps):
        estimate = observer.correct(observer.predict(estimate, u[k : k + 1]), readings[k + 1 : k + 2])
    # after 1 s the start-up error has decayed by (1 + ...) exp(-150): what is left is rounding,
    # amplified by L's entries (up to omega_o^N T^(N-1) ~ 1e3 for f); 1e-6 of f's size bounds it
    assert estimate[0, 0] == pytest.approx(readings[-1], abs=1e-12)
    assert estimate[1, 0] == pytest.approx(velocity, abs=1e-8)
    assert estimate[2, 0] == pytest.approx(f_end, abs=1e-6 * abs(f_end))


def test_a_disturbance_beyond_the_order_is_tracked_with_the_closed_form_lag():
    """order = 1 on a ramp f = 200 t. The error e = x - x̂ obeys e_k = A e_{k-1} + (I - L H) w,
    A = (I - L H) Phi, w = f_dot [T^3/6, T^2/2, T] what the constant-f model misses per period;
    its steady state is (I - A)^-1 (I - L H) w (about 3 f_dot / omega_o = 4 rad/s^2, the
    continuous three-fold pole's lag; 3.91 here, at omega_o T = 0.15)."""
    dt, steps, slope = 1e-3, 1000, 200.0
    readings, _, f_end = _exact_readings(2, steps, dt, np.zeros(steps), [0.0, slope])
    observer = ExtendedStateObserver(dt, 150.0, 1)
    estimate = observer.start(readings[:1])
    for k in range(steps):
        estimate = observer.correct(observer.predict(estimate, np.zeros(1)), readings[k + 1 : k + 2])
    correction = np.eye(3)
    correction[:, 0] -= observer.gain
    missed = slope * np.array([dt**3 / 6, dt**2 / 2, dt])
    steady = np.linalg.solve(np.eye(3) - correction @ observer.transition, correction @ missed)
    # after 1 s the start-up transient is (1 + ...) exp(-150) of its size: 1e-9 relative is rounding
    assert f_end - estimate[2, 0] == pytest.approx(steady[2], rel=1e-9)
    assert steady[2] == pytest.approx(3 * slope / 150.0, rel=0.03)


@pytest.mark.parametrize(
    ("arguments", "match"),
    [
        ((1e-3, 150.0, 0), "order=0"),
        ((1e-3, 150.0, 5), "order=5"),
        ((1e-3, -1.0, 3), "observer_bandwidth=-1.0"),
    ],
)
def test_bad_observers_are_refused(arguments, match):
    with pytest.raises(InvalidParameterError, match=match):
        ExtendedStateObserver(*arguments)
