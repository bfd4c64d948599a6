"""The digital drive in the sampled loop: encoder, computation delay, torque limit, and controllers
stepped sample by sample outside ``simulate``.

References: closed forms (quantisation to round(alpha / q) q, a FIFO of commands, a clip), the
recorded controller command against the recorded applied torque, and the Python reference loop
(tests/reference/python_loop.py, what ``simulate`` ran before the core took every run) against the
same controller stepped by hand on the same plant (bit for bit: the same arithmetic in the same
order).
"""

import math

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.errors import InvalidParameterError
from delta_pin.sim.drive import Drive, Encoder
from delta_pin.sim.integrators import rk4_step
from tests.reference.plants import ReadableAnalyticPlant
from tests.reference.python_loop import simulate_reference

ALPHA0 = np.full(3, 0.3322)


def test_encoder_quantises_to_the_nearest_count(rng):
    encoder = Encoder(bits=12, velocity="difference")
    q = 2 * math.pi / 2**12
    assert encoder.resolution == q
    alpha = rng.uniform(-1.0, 1.0, 3)
    measured, velocity = encoder.read(alpha, np.ones(3), 1e-3)
    np.testing.assert_array_equal(measured, np.round(alpha / q) * q)
    assert np.abs(measured - alpha).max() <= q / 2
    np.testing.assert_array_equal(velocity, np.zeros(3))  # no previous reading yet
    later = alpha + np.array([3.2, -1.1, 0.0]) * q
    measured_later, velocity = encoder.read(later, np.ones(3), 1e-3)
    np.testing.assert_allclose(velocity, (measured_later - measured) / 1e-3, rtol=1e-15)


def test_encoder_velocity_modes():
    alpha, alpha_dot = np.array([0.1, 0.2, 0.3]), np.array([1.0, -2.0, 0.5])
    assert Encoder(velocity="none").read(alpha, alpha_dot, 1e-3)[1] is None
    np.testing.assert_array_equal(Encoder(velocity="exact").read(alpha, alpha_dot, 1e-3)[1], alpha_dot)


def test_encoder_noise_is_seeded_and_of_the_given_size():
    a, b = Encoder(bits=32, noise=1e-3, seed=4), Encoder(bits=32, noise=1e-3, seed=4)
    readings = np.array([a.read(np.zeros(3), np.zeros(3), 1e-3)[0] for _ in range(4000)])
    again = np.array([b.read(np.zeros(3), np.zeros(3), 1e-3)[0] for _ in range(4000)])
    np.testing.assert_array_equal(readings, again)
    # 12 000 samples: the sample standard deviation is within 3 % of sigma (its own s.d. is 0.65 %)
    assert readings.std() == pytest.approx(1e-3, rel=0.03)
    assert Encoder(noise=1e-3).seed is not None  # drawn, so that the run's metadata can replay it


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"bits": 7}, "bits=7"),
        ({"bits": 33}, "bits=33"),
        ({"velocity": "observer"}, "velocity='observer'"),
        ({"noise": -1e-3}, "noise=-0.001"),
    ],
)
def test_bad_encoders_are_refused(options, match):
    with pytest.raises(InvalidParameterError, match=match):
        Encoder(**options)


def test_drive_delays_then_saturates():
    drive = Drive(3, delay=2, torque_limit=(1.0, 2.0, 3.0))
    commands = [np.array([0.5, 0.5, 0.5]), np.array([2.0, -5.0, 1.0]), np.array([0.1, 0.2, 0.3])]
    applied = [drive.apply(c) for c in [*commands, np.zeros(3), np.zeros(3)]]
    np.testing.assert_array_equal(applied[0], np.zeros(3))
    np.testing.assert_array_equal(applied[1], np.zeros(3))
    np.testing.assert_array_equal(applied[2], commands[0])
    np.testing.assert_array_equal(applied[3], [1.0, -2.0, 1.0])  # clipped per joint
    np.testing.assert_array_equal(applied[4], commands[2])
    assert drive.hits == 1


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"delay": -1}, "delay=-1"),
        ({"delay": 1.5}, "delay=1.5"),
        ({"torque_limit": 0.0}, "torque_limit=0.0"),
        ({"torque_limit": (1.0, -1.0, 1.0)}, "torque_limit"),
        ({"mode": "continuous", "delay": 1}, "only in mode='sampled'"),
        ({"sensor": "encoder"}, "sensor='encoder'"),
    ],
)
def test_bad_drive_arguments_are_refused(robot, options, match):
    nominal = dp.DeltaNominalModel(robot)
    options = {"mode": "sampled", **options}
    with pytest.raises(InvalidParameterError, match=match):
        dp.simulate(robot, dp.design1(nominal), dp.PathI(), plant="analytic", t_end=0.01, **options)


def test_a_drive_runs_every_law_in_the_core(robot):
    """On a drive the core runs designs I/II and the digital laws compiled and a plain function
    called back once per sample: both run on the core's plant."""
    run = dp.simulate(robot, lambda t, a, v: np.zeros(3), dp.PathI(), plant="analytic", t_end=0.01,
                      mode="sampled", sensor=Encoder())  # fmt: skip
    assert run.metadata["core_plant"] and not np.any(run.tau)
    nominal = dp.DeltaNominalModel(robot)
    run = dp.simulate(robot, dp.design1(nominal), dp.PathI(), plant="analytic", t_end=0.01, mode="sampled",
                      sensor=Encoder())  # fmt: skip
    assert run.metadata["core_plant"] and run.metadata["sensor"]["bits"] == 17


def test_the_controller_sees_encoder_readings_and_its_torque_acts_later(robot):
    seen = []

    def pd(t, alpha, alpha_dot):
        seen.append(alpha.copy())
        return 2.0 * (ALPHA0 - alpha) - 0.2 * alpha_dot

    q = 2 * math.pi / 2**14
    run = dp.simulate(
        robot, pd, alpha0=ALPHA0, plant="analytic", t_end=0.05, sensor=Encoder(bits=14), delay=3,
        torque_limit=0.05,
    )  # fmt: skip
    seen = np.array(seen)
    np.testing.assert_allclose(seen / q, np.round(seen / q), rtol=0, atol=1e-9)  # whole counts
    assert np.abs(seen - run.alpha).max() <= q / 2 * (1 + 1e-12)
    command = run.internals["tau_command"]
    np.testing.assert_array_equal(run.tau[:3], np.zeros((3, 3)))
    np.testing.assert_array_equal(run.tau[3:], np.clip(command[:-3], -0.05, 0.05))
    assert run.metadata["delay"] == 3 and run.metadata["torque_limit_hits"] > 0
    assert run.metadata["sensor"]["bits"] == 14


def _stepped_by_hand(robot, controller, t_end, dt=1e-3):
    """The controller stepped sample by sample (Controller.step) on an analytic plant integrated
    with RK4 under a zero-order hold: what a user's own simulator would do."""
    plant = ReadableAnalyticPlant(robot, dp.Friction(), dp.PaperUncertainty())
    steps = round(t_end / dt)
    reference = dp.PathI().joint_reference(robot, np.arange(steps + 1) * dt)
    plant.precompute_truth(dt / 2, 2 * steps + 1)  # the truth table simulate reads
    x = plant.initial_state(ALPHA0, np.zeros(3))
    controller.reset()
    torques = []
    for k in range(steps):
        tau = controller.step(
            k * dt,
            x[:3],
            dp.Reference(reference.alpha[k], reference.alpha_dot[k], reference.alpha_ddot[k]),
            alpha_dot_measured=x[3:],
        )
        torques.append(tau)
        x = rk4_step(lambda ts, xs: plant.derivative(ts, xs, tau), k * dt, x, dt)  # noqa: B023
    return np.array(torques), x


@pytest.mark.parametrize(
    ("make", "moved"),
    [
        (lambda nominal: dp.design1(nominal, sampling_period=1e-3), "rho_hat"),
        (lambda nominal: dp.tdc(nominal, 1e-3), "lumped_estimate"),
        (lambda nominal: dp.digital_robust(nominal, 1e-3), "disturbance_estimate"),
    ],
    ids=["design1", "tdc", "digital-robust"],
)
def test_step_outside_simulate_is_the_sampled_loop(robot, make, moved):
    nominal = dp.DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))
    controller = make(nominal)
    run = simulate_reference(
        robot, controller, dp.PathI(), plant="analytic", t_end=0.2, alpha0=ALPHA0, friction=dp.Friction(),
        uncertainty=dp.PaperUncertainty(), mode="sampled",
    )  # fmt: skip
    torques, x = _stepped_by_hand(robot, controller, 0.2)
    # step() runs the compiled law, the reference loop the readable one: equal per evaluation to
    # round-off (tests/sim/test_core_laws.py), here to 1e-9 after 200 samples of the closed loop
    np.testing.assert_allclose(torques, run.tau[:-1], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(x[:3], run.alpha[-1], rtol=0, atol=1e-12)
    internal = np.reshape(run.internals[moved], (len(run.t), -1))
    assert np.abs(internal[-1] - internal[0]).max() > 1e-3  # the law's state really moved


def test_step_estimates_velocity_by_difference_when_none_is_measured():
    class Echo(dp.Controller):
        def evaluate(self, t, alpha, alpha_dot, reference, state):
            return dp.control.ControlOutput(alpha_dot.copy())

    echo = Echo()
    echo.reset()
    hold = dp.Reference.hold(np.zeros(3))
    np.testing.assert_array_equal(echo.step(0.0, np.zeros(3), hold), np.zeros(3))
    np.testing.assert_allclose(echo.step(0.002, np.array([1e-3, 0.0, -2e-3]), hold), [0.5, 0.0, -1.0])


def test_step_runs_a_built_in_law_compiled_and_a_users_law_as_written(robot):
    """Controller.step evaluates a built-in law by its compiled copy, the one simulate runs
    (CompiledController: the readable law is tests/reference/laws.py's), and a user's own law by
    its evaluate."""
    nominal = dp.DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))
    for controller in (dp.design1(nominal), dp.digital_robust(nominal, 1e-3)):
        assert type(controller).evaluate is dp.control.CompiledController.evaluate
        torques, _ = _stepped_by_hand(robot, controller, 0.01)
        assert torques.shape == (10, 3) and np.isfinite(torques).all()
    echoed = []

    class Own(dp.Controller):
        def evaluate(self, t, alpha, alpha_dot, reference, state):
            echoed.append(t)
            return dp.control.ControlOutput(np.zeros(3))

    _stepped_by_hand(robot, Own(), 0.005)
    assert len(echoed) == 5


def test_a_compiled_controller_without_its_law_says_so(robot):
    """A built-in controller whose compiled law is taken away (here by hand) cannot evaluate: one
    line naming it and what would work, not an AttributeError on None."""
    controller = dp.design1(dp.DeltaNominalModel(robot))
    controller.sampled_core_law = lambda: None
    with pytest.raises(dp.InvalidParameterError, match=r"designI.*has no compiled law.*defines evaluate"):
        controller.step(0.0, robot.home, dp.Reference.hold(robot.home))
