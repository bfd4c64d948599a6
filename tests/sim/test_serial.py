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
