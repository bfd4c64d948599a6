"""The compiled core's time-delay control, digital-robust law (with its extended-state observer) and
LQR (``delta_pin/core/run/controller.hpp``, arithmetic in ``delta_pin/core/control/``) against the
readable Python laws they are compiled from (tests/reference/laws.py: time-delay control,
digital-robust, LQR), on the five-bar's projected nominal
model with a nominal disturbance and friction.

Two comparisons:

* sample by sample, the law alone: both laws are fed the same measured states and reference, each
  carrying its own state from sample to sample. Required: every torque within 1e-12 of the largest
  torque, every next state within 1e-12 relative. The arithmetic is the same; what differs is
  Eigen's LU and symmetric eigenvalue solver against LAPACK's (np.linalg.solve, eigvalsh), the order
  of a few sums in the matrix products and the Stribeck friction's expression, each ~1e-16 relative;
  the projected model is the same compiled Newton and projection, warm-started from the same
  previous configuration (measured: up to ~1e-14).
* in the closed loop (``simulate`` with the compiled law against the same controller called back
  from the compiled plant): every array within 1e-9 relative. Looser, because the loop amplifies
  those 1e-16 differences over the run (the friction's smoothed sign is steep near zero speed and
  TDC's second difference divides by T^2 = 1e-6 s^2; measured: 1e-16 .. 1e-10).
"""

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.control.base import ControlOutput, Reference
from tests.reference.laws import called_back, readable_evaluate
from tests.reference.python_loop import simulate_reference

DT = 1e-3


@pytest.fixture(scope="module")
def robot():
    return dp.load_robot("five_bar", end_effector="tip")


@pytest.fixture(scope="module")
def circle(robot):
    """A circle of the five-bar's tip above its home, 3 cm radius in 2 s."""
    home = robot.frame_placement(robot.reference_configuration).translation
    above = home + np.array([0.0, 0.0, 0.03])
    return dp.FramePath(dp.Circle(center=above, radius=0.03, period=2.0, plane="xz", phase=-np.pi / 2))


@pytest.fixture(scope="module")
def stribeck():
    return dp.StribeckParameters(r_a=0.05, v_s=0.1, mu_s=0.3, mu_d=0.2, mu_v=0.05)


@pytest.fixture(scope="module")
def nominal(robot, stribeck):
    return dp.ClosedChainNominalModel(
        robot, nominal_disturbance=[0.01, -0.02], friction=dp.Friction(stribeck=stribeck)
    )


LAWS = {
    "tdc": lambda nominal, robot, **o: dp.tdc(nominal, DT, **{"bandwidth": 40.0, **o}),
    "tdc-mean-delay-2": lambda nominal, robot, **o: dp.tdc(
        nominal, DT, **{"bandwidth": 40.0, "pairing": "mean", "delay": 2, **o}
    ),
    "digital-robust": lambda nominal, robot, **o: dp.digital_robust(nominal, DT, **{"rho0": 0.02, **o}),
    "digital-robust-delay-2-limit-order-2": lambda nominal, robot, **o: dp.digital_robust(
        nominal, DT, **{"rho0": 0.5, "delay": 2, "torque_limit": 0.3, "observer_order": 2, **o}
    ),
    "lqr": lambda nominal, robot, **o: dp.LQR(nominal, robot.home + 0.01, **o),
}


def _states(kind, robot, nominal, stribeck, circle):
    """Measured states (rad, rad/s) of 0.3 s of the law ``kind`` in the closed loop on the
    five-bar's circle with an unknown payload and friction (with the law's delay; its compiled law
    on the compiled plant where it has none), and the reference it tracked."""
    plant = dp.ClosedChainPlant(robot, dp.Friction(stribeck=stribeck), payload_mass=0.05)
    controller = LAWS[kind](nominal, robot)
    options = {"t_end": 0.3, "mode": "sampled", "alpha0": robot.home, "delay": controller.delay}
    run = dp.simulate(robot, controller, circle, plant=plant, **options)
    reference = circle.joint_reference(robot, run.t)
    return run.t, run.alpha, run.alpha_dot, reference.alpha, reference.alpha_dot, reference.alpha_ddot


def _replay(controller, states):
    """Along ``states`` (:func:`_states`): (compiled torques, Python torques, compiled states,
    Python states) with each law advancing its own state (Controller.advance), and (compiled
    torques, compiled next states or rates) at the Python law's state of each sample."""
    law = controller.sampled_core_law()
    assert law is not None
    readable = readable_evaluate(controller)
    t, alpha, alpha_dot, ref, ref_dot, ref_ddot = states
    z_python = controller.initial_state().astype(float)
    z_core = z_python.copy()
    rows = ([], [], [], [], [], [])
    discrete = controller.dt is not None
    for k in range(len(t)):
        reference = Reference(ref[k], ref_dot[k], ref_ddot[k])
        out = readable(t[k], alpha[k], alpha_dot[k], reference, z_python)
        same = law.evaluate(alpha[k], alpha_dot[k], ref[k], ref_dot[k], ref_ddot[k], z_python)
        tau, step = law.evaluate(alpha[k], alpha_dot[k], ref[k], ref_dot[k], ref_ddot[k], z_core)
        python_step = out.next_state if discrete else out.state_derivative
        for row, value in zip(rows, (tau, out.tau, z_core, z_python, *same), strict=True):
            row.append(np.array(value, dtype=float))
        rows[5][-1] = rows[5][-1] - np.asarray(python_step, dtype=float)  # the step's difference
        core_out = ControlOutput(tau, state_derivative=step, next_state=step if discrete else None)
        z_python = controller.advance(z_python, out, DT)
        z_core = controller.advance(z_core, core_out, DT)
    return tuple(np.array(row) for row in rows)


def _torque_error(a, b) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


def _state_error(a, b) -> float:
    return float(np.abs(a - b).max() / max(1.0, np.abs(b).max())) if b.size else 0.0


@pytest.mark.parametrize("kind", sorted(LAWS))
def test_each_compiled_law_equals_its_readable_law_sample_by_sample(kind, robot, nominal, stribeck, circle):
    """The law alone along 301 samples of its closed loop. At the Python law's state of each
    sample: torques within 1e-12 of the largest, next states (or rates) within 1e-12 relative.
    Each law carrying its own state: torques within 1e-12 of the largest, except the
    digital-robust law's, 1e-11: its observer's disturbance states (f, f_dot, f_ddot, up to ~1e3
    rad/s^4) carry the rounding of every sample through its recursion (poles exp(-omega_o T) =
    0.86; measured 1.1e-12 over this run, 4e-14 per sample)."""
    controller = LAWS[kind](nominal, robot)
    tau_core, tau_python, z_core, z_python, tau_same, step_difference = _replay(
        controller, _states(kind, robot, nominal, stribeck, circle)
    )
    assert _torque_error(tau_same, tau_python) <= 1e-12
    if z_python.size:
        assert np.abs(step_difference).max() <= 1e-12 * max(1.0, np.abs(z_python).max())
    recursion = 1e-11 if kind.startswith("digital-robust") else 1e-12
    assert _torque_error(tau_core, tau_python) <= recursion
    assert _state_error(z_core, z_python) <= recursion
    assert np.abs(tau_python).max() > 0.1  # torques of the size the five-bar needs, N m


# each law's gains, one changed at a time: (option, value)
CHANGES = {
    "tdc": [("bandwidth", 60.0), ("pairing", "mean")],
    "tdc-mean-delay-2": [("delay", 1), ("pairing", "last")],
    "digital-robust": [
        ("bandwidth", 40.0), ("observer_bandwidth", 100.0), ("D", 20.0), ("layer_samples", 3.0),
        ("rho0", 0.005), ("beta", 5.0), ("b1", 100.0), ("b3", 3.0), ("friction_compensation", False),
    ],
    "digital-robust-delay-2-limit-order-2": [("delay", 1), ("torque_limit", 0.1), ("observer_order", 3)],
    "lqr": [
        ("Q", np.r_[np.full(2, 400.0), np.ones(2)]), ("R", np.full(2, 0.05)),
        ("friction_compensation", False),
    ],
}  # fmt: skip


@pytest.mark.parametrize("kind", sorted(LAWS))
def test_a_gain_the_compiled_law_ignored_would_show(kind, robot, nominal, stribeck, circle):
    """For each gain: the law with it changed moves the readable law's torques by > 1e-6 of the
    largest torque, and the compiled law at the same states follows to 1e-12 of the largest torque
    (so a gain the core dropped or misread would fail here)."""
    states = _states(kind, robot, nominal, stribeck, circle)
    base = _replay(LAWS[kind](nominal, robot), states)[1]
    for option, value in CHANGES[kind]:
        _, tau_python, _, _, tau_same, _ = _replay(LAWS[kind](nominal, robot, **{option: value}), states)
        assert _torque_error(tau_python, base) > 1e-6, option
        assert _torque_error(tau_same, tau_python) <= 1e-12, option


def _fail(*args, **kwargs):
    raise AssertionError("the Python law was called in a compiled-law run")


@pytest.mark.parametrize("kind", ["tdc", "digital-robust", "lqr"])
def test_each_compiled_law_in_the_loop_equals_the_readable_law_in_the_loop(
    kind, robot, nominal, stribeck, circle
):
    """simulate with the compiled law (Python's evaluate is not called: it raises) against the
    same controller called back from the compiled plant: alpha, alpha_dot, tau, q, v and the
    internals within 1e-9 relative over 0.3 s of the five-bar's circle with an unknown payload and
    friction (module docstring)."""
    runs = []
    for compiled_law in (True, False):
        controller = LAWS[kind](nominal, robot)
        if compiled_law:
            controller.evaluate = _fail
        else:
            controller = called_back(controller)
        plant = dp.ClosedChainPlant(robot, dp.Friction(stribeck=stribeck), payload_mass=0.05)
        options = {"t_end": 0.3, "mode": "sampled", "alpha0": robot.home}
        runs.append(dp.simulate(robot, controller, circle, plant=plant, **options))
    core, python = runs
    for name in ("alpha", "alpha_dot", "tau", "q", "v"):
        assert _state_error(getattr(core, name), getattr(python, name)) <= 1e-9, name
    assert sorted(core.internals) == sorted(python.internals)
    for name, values in python.internals.items():
        assert core.internals[name].shape == values.shape, name
        assert _state_error(core.internals[name], values) <= 1e-9, name
    assert np.abs(python.alpha - python.alpha[0]).max() > 1e-5  # it moved [rad]


DRIVES = {
    "digital-robust": {"sensor": ("noise", 2e-5), "delay": 1, "torque_limit": 0.4},
    "tdc": {"sensor": ("velocity", "none"), "delay": 0, "torque_limit": 0.3},
    "lqr": {"sensor": ("velocity", "exact"), "delay": 2, "torque_limit": 0.25},
}


@pytest.mark.parametrize("kind", sorted(DRIVES))
def test_each_compiled_law_on_a_drive_equals_the_readable_law_on_it(kind, robot, nominal, stribeck, circle):
    """An encoder (17 bits, seeded noise or another velocity), a delay and a torque limit that
    binds, in the compiled loop with the compiled law against the Python loop's drive with the
    readable law: alpha, tau (what acted), the command and the internals within 1e-9 relative over
    0.3 s (module docstring), and the same count of saturated samples. With a quantised reading a
    1e-16 difference can land a reading on the next count (4.8e-5 rad); these runs do not."""
    setting = DRIVES[kind]
    runs = []
    for compiled_law in (True, False):
        option, value = setting["sensor"]
        sensor = dp.Encoder(17, **{option: value, **({"seed": 7} if option == "noise" else {})})
        controller = LAWS[kind](nominal, robot, **({"delay": setting["delay"]} if kind != "lqr" else {}))
        if compiled_law:
            controller.evaluate = _fail
        else:
            controller = called_back(controller)
        plant = dp.ClosedChainPlant(robot, dp.Friction(stribeck=stribeck), payload_mass=0.05)
        options = {"t_end": 0.3, "mode": "sampled", "alpha0": robot.home, "delay": setting["delay"]}
        options.update(sensor=sensor, torque_limit=setting["torque_limit"])
        runs.append(dp.simulate(robot, controller, circle, plant=plant, **options))
    core, python = runs
    for name in ("alpha", "alpha_dot", "tau", "q", "v"):
        assert _state_error(getattr(core, name), getattr(python, name)) <= 1e-9, name
    assert sorted(core.internals) == sorted(python.internals)
    assert "tau_command" in core.internals
    for name, values in python.internals.items():
        assert _state_error(core.internals[name], values) <= 1e-9, name
    hits = python.metadata["torque_limit_hits"]
    assert core.metadata["torque_limit_hits"] == hits > 0
    assert np.abs(python.internals["tau_command"] - python.tau).max() > 1e-3  # the drive acted [N m]


DELTA_LAWS = {
    "design-I": lambda nominal, delta: dp.design1(nominal, sampling_period=DT),
    "design-II-vector-rho": lambda nominal, delta: dp.design2(nominal, vector_rho=True),
    "tdc": lambda nominal, delta: dp.tdc(nominal, DT, bandwidth=40.0),
    "digital-robust": lambda nominal, delta: dp.digital_robust(nominal, DT, rho0=0.02),
    "lqr": lambda nominal, delta: dp.LQR(nominal, delta.home + 0.01),
}


@pytest.fixture(scope="module")
def delta():
    return dp.load_delta()


@pytest.mark.parametrize("kind", sorted(DELTA_LAWS))
def test_the_delta_analytic_nominal_model_in_the_core(kind, delta):
    """Each law on the Delta's analytic nominal model (DeltaNominalModel: eqs. 7-10 with the
    paper's friction compensated and a nominal disturbance) compiled in the core
    (core/control/delta_analytic.hpp) against the readable law, sample by sample along 0.2 s of
    path I: torques within 1e-12 of the largest, states within 1e-12 relative (the same arithmetic,
    module docstring); digital-robust's carried state 1e-11 (its observer's recursion, above)."""
    nominal = dp.DeltaNominalModel(delta, nominal_disturbance=[0.01, -0.02, 0.015])
    controller = DELTA_LAWS[kind](nominal, delta)
    run = dp.simulate(delta, controller, dp.PathI(), t_end=0.2, mode="sampled", delay=controller.delay)
    reference = dp.PathI().joint_reference(delta, run.t)
    states = (run.t, run.alpha, run.alpha_dot, reference.alpha, reference.alpha_dot, reference.alpha_ddot)
    tau_core, tau_python, z_core, z_python, tau_same, step_difference = _replay(
        DELTA_LAWS[kind](nominal, delta), states
    )
    assert _torque_error(tau_same, tau_python) <= 1e-12
    if z_python.size:
        assert np.abs(step_difference).max() <= 1e-12 * max(1.0, np.abs(z_python).max())
    recursion = 1e-11 if kind == "digital-robust" else 1e-12
    assert _torque_error(tau_core, tau_python) <= recursion
    assert _state_error(z_core, z_python) <= recursion
    assert np.abs(tau_python).max() > 0.1  # the Delta's torques, N m


def test_a_recognised_delta_with_the_analytic_nominal_model_runs_in_the_core_as_in_python():
    """Design I (sampling-aware) on the analytic nominal model of a Delta written in MJCF (a
    recognised Delta: robot.delta), sampled at 1 kHz: the default run takes the core's plant and
    law, and equals the Python reference loop (simulate_reference) within 1e-10 (rad, N m,
    internals) over 0.5 s of path I (one RK4 arithmetic; the law's arithmetic equal to ~1e-16, above)."""
    robot = dp.load_robot("delta_mjcf")
    controllers = [dp.design1(dp.DeltaNominalModel(robot), sampling_period=DT) for _ in range(2)]
    options = {"t_end": 0.5, "mode": "sampled"}
    runs = [
        simulate(robot, controller, dp.PathI(), **options)
        for controller, simulate in zip(controllers, (dp.simulate, simulate_reference))
    ]
    core, python = runs
    assert core.metadata.get("core_plant") and not python.metadata.get("core_plant")
    for name in ("alpha", "alpha_dot", "tau", "xyz"):
        assert np.abs(getattr(core, name) - getattr(python, name)).max() < 1e-10, name
    for name, values in python.internals.items():
        assert np.abs(core.internals[name] - values).max() < 1e-10, name


def test_gains_cross_the_binding_by_name():
    """Designs I/II's and the digital robust law's gains reach the core as named structs (issue 38,
    item 3: they were 13 and 16 positional numbers): each field the law sets is read back as set,
    a missing or unknown name is refused naming it, and an observer table larger than the core's
    compile-time size is refused before it is copied (it would write past the fixed storage)."""
    from delta_pin.compiled.core import core
    from delta_pin.control.nominal import gains_fields, named_gains

    module = core()
    delta = dp.load_delta()
    nominal = dp.DeltaNominalModel(delta)
    design = dp.design2(nominal, sampling_period=1e-3)
    assert gains_fields(module.AdaptiveRobustGains) == {
        "D", "T_p", "T_v", "beta", "xi", "epsilon", "b1", "b2", "b3", "design_two", "vector_rho",
        "sampling_period", "sampling_margin",
    }  # fmt: skip
    gains = {name: 0.5 for name in gains_fields(module.AdaptiveRobustGains)}
    gains.update(
        D=np.array([1.0, 2.0, 3.0]), T_p=np.ones(3), T_v=np.ones(3), design_two=True, vector_rho=False
    )
    struct = named_gains(module, "AdaptiveRobust", gains)
    np.testing.assert_array_equal(struct.D, [1.0, 2.0, 3.0])
    assert struct.design_two is True and struct.xi == 0.5
    with pytest.raises(ValueError, match=r"missing \['xi'\], unknown \['ksi'\]"):
        named_gains(module, "AdaptiveRobust", {**{k: v for k, v in gains.items() if k != "xi"}, "ksi": 1e-3})
    assert design.sampled_core_law() is not None  # the laws build their structs by name
    digital = dp.digital_robust(nominal, 1e-3, delay=1).sampled_core_law()
    assert digital is not None
    struct = module.DigitalRobustGains()
    with pytest.raises(ValueError, match=r"transition has shape \(7, 7\), expected at most \(6, 6\)"):
        struct.transition = np.eye(7)
    with pytest.raises(ValueError, match="observer_gain has 7 entries, expected at most 6"):
        struct.observer_gain = np.ones(7)
    struct.transition = np.eye(4)
    np.testing.assert_array_equal(struct.transition, np.eye(4))
