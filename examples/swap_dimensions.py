"""Swap the robot's dimensions and masses with xacro arguments: every model follows the URDF.

Run: ``python examples/swap_dimensions.py``
"""

import numpy as np

import delta_pin as dp


def main() -> None:
    for args in ({}, {"l_a": 0.25, "l_b": 0.5}, {"m_o": 1.0}, {"R": 0.2, "r": 0.05}):
        robot = dp.load_delta(**args)
        alpha = robot.inverse_kinematics([0.0, 0.0, -0.4])
        dynamics = robot.pinocchio_dynamics(alpha, np.zeros(3))
        print(
            f"{robot!r}\n  alpha at (0, 0, -0.4) m: {np.round(alpha, 4)} rad, "
            f"holding torque G: {np.round(dynamics.G, 4)} N m"
        )
    print(dp.compile_urdf(l_a=0.25)[:200], "...")


if __name__ == "__main__":
    main()
