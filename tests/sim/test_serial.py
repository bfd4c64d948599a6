"""Design I on a serial robot from example-robot-data (UR5) with an uncertain payload."""

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.sim.serial import JointSinusoid, SerialPlant, example_robot_urdf, load_example_robot

try:
    example_robot_urdf("ur5")
except dp.DeltaPinError:  # pragma: no cover - the [test] extra installs it
    pytest.skip(
        "example-robot-data is not installed (pip install example-robot-data)", allow_module_level=True
    )

HOME = np.array([0.0, -1.2, 1.0, -1.0, -1.5, 0.0])  # [rad]


def payload(t):
    """The true payload: 1 kg +- 50 % at 0.5 Hz [kg]."""
    return 1.0 + 0.5 * np.sin(np.pi * t)


@pytest.fixture(scope="module")
def ur5_runs():
    robot = load_example_robot("ur5")
    nominal_robot = SerialPlant(robot, payload_mass=lambda t: 1.0)  # the controller knows 1 kg
    nominal_robot._set_payload(0.0)
    nominal = dp.PinocchioNominalModel(nominal_robot.model)
    reference = JointSinusoid(center=HOME, amplitude=0.3, frequency=0.5)
    start = HOME + np.array([0.05, 0.05, 0.0, 0.0, 0.0, 0.0])
    runs = {}
    for name, controller in (
        ("design1", dp.design1(nominal, sampling_period=1e-3)),
        ("ctc", dp.ComputedTorque(nominal)),
    ):
        runs[name] = dp.simulate(
            robot, controller, reference, plant=SerialPlant(robot, payload), t_end=4.0, dt=1e-3, alpha0=start
        )
    return runs


def test_design1_tracks_the_ur5_with_an_uncertain_payload(ur5_runs):
    run = ur5_runs["design1"]
    assert run.alpha.shape == (4001, 6)
    error = np.abs(run.error).max(axis=1)
    assert error[0] == pytest.approx(0.05)
    assert error[run.t >= 1.0].max() < 1e-3  # [rad] on every joint after 1 s (measured 4.1e-4)
    assert np.ptp(run.alpha_d, axis=0).min() > 0.5  # the reference really moves (0.6 rad)


def test_the_robust_term_beats_its_nominal_part(ur5_runs):
    design1, ctc = (np.abs(ur5_runs[k].error).max(axis=1) for k in ("design1", "ctc"))
    t = ur5_runs["ctc"].t
    assert design1[t >= 1.0].max() < 0.5 * ctc[t >= 1.0].max()


def test_unknown_example_robot_is_refused():
    with pytest.raises(dp.InvalidParameterError, match="'spot'"):
        example_robot_urdf("spot")


def test_the_serial_plant_runs_in_the_core_as_the_readable_loop_runs_it():
    """The UR5's plant is the core's (a tree without closures: Pinocchio's forward dynamics, the
    payload m(t) a point mass at tool0), not the Python plant called back: 1 s of design I equals
    the readable loop on the Python plant's pin.aba (tests/reference/python_loop.py) to 1e-9 rad
    and 1e-9 N m relative to the largest torque (the same library's dynamics, the payload's
    inertia summed in another order: measured 6e-17 rad, 1.4e-12 N m); continuous mode, refused
    before for want of a compiled plant, now runs it in the core's Radau IIA."""
    from tests.reference.python_loop import simulate_reference

    robot = load_example_robot("ur5")
    known = SerialPlant(robot, payload_mass=lambda t: 1.0)
    known._set_payload(0.0)
    nominal = dp.PinocchioNominalModel(known.model)
    reference = JointSinusoid(center=HOME, amplitude=0.3, frequency=0.5)
    start = HOME + np.array([0.05, 0.05, 0.0, 0.0, 0.0, 0.0])
    options = {"t_end": 1.0, "dt": 1e-3, "alpha0": start}
    runs = [
        simulate(
            robot,
            dp.design1(nominal, sampling_period=1e-3),
            reference,
            plant=SerialPlant(robot, payload),
            **options,
        )
        for simulate in (dp.simulate, simulate_reference)
    ]
    core, python = runs
    assert core.metadata["core_plant"] and not python.metadata.get("core_plant")
    np.testing.assert_allclose(core.alpha, python.alpha, rtol=0, atol=1e-9)
    np.testing.assert_allclose(core.alpha_dot, python.alpha_dot, rtol=0, atol=1e-9)
    np.testing.assert_allclose(core.tau, python.tau, rtol=0, atol=1e-9 * np.abs(python.tau).max())
    np.testing.assert_allclose(core.xyz, python.xyz, rtol=0, atol=1e-9)
    continuous = dp.simulate(
        robot, dp.design1(nominal), reference, plant=SerialPlant(robot, payload), t_end=1.0,
        mode="continuous", alpha0=start,
    )  # fmt: skip
    assert continuous.metadata["integrator"] == "radau" and continuous.metadata["core_plant"]
    assert np.abs(continuous.error[continuous.t >= 0.5]).max() < 1e-3  # [rad] it tracks
