"""The reference table of a run (delta_pin/sim/reference.py) for a trajectory in joint space."""

import numpy as np

import delta_pin as dp
from delta_pin.identification.excitation import FourierExcitation
from delta_pin.sim.reference import tabulate_reference


class _CountingRobot:
    """A robot whose forward kinematics counts the configurations it assembles."""

    def __init__(self, robot) -> None:
        self.robot, self.assembled = robot, 0

    def forward_kinematics(self, alpha, *args):
        self.assembled += len(np.atleast_2d(alpha))
        return self.robot.forward_kinematics(alpha, *args)

    def __getattr__(self, name):
        return getattr(self.robot, name)


def test_a_joint_space_trajectory_assembles_its_end_effector_at_the_samples_only():
    """A trajectory that declares ``joint_space`` (JointSinusoid, the identification's excitation;
    a planned trajectory file's ``joints`` is its joint names, not this) has its
    joints read on the whole grid (dt / 4 for a continuous run) and its end effector assembled at
    the samples only: the same table as its ``joint_reference`` on the whole grid (equal arrays:
    the same arithmetic at the same times) and the same xyz to 1e-12 m (Newton's tolerance, from
    other warm starts; measured 2e-15 m), a quarter of the assemblies."""
    robot = dp.load_robot("five_bar")
    trajectories = [
        dp.JointSinusoid(robot.home, amplitude=0.1, frequency=0.5, phase=[0.0, 1.0]),
        FourierExcitation(
            robot.home, np.full((2, 2), 0.02), np.full((2, 2), -0.01), period=2.0, duration=2.0
        ),
    ]
    steps, dt, per_sample = 200, 1e-3, 4
    grid = np.arange(steps * per_sample + 1) * (dt / per_sample)
    for trajectory in trajectories:
        counting = _CountingRobot(robot)
        table, xyz, alpha0 = tabulate_reference(counting, trajectory, None, 2, steps, dt, per_sample)
        assert counting.assembled == steps + 1, type(trajectory).__name__
        whole = trajectory.joint_reference(robot, grid)
        for name in ("alpha", "alpha_dot", "alpha_ddot"):
            np.testing.assert_array_equal(getattr(table, name), getattr(whole, name))
        # the assemblies start from other warm starts: Newton's 1e-12 closure tolerance
        np.testing.assert_allclose(xyz, whole.xyz[::per_sample], rtol=0, atol=1e-12)
        np.testing.assert_array_equal(alpha0, whole.alpha[0])
