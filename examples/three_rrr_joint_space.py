"""A planar 3-RRR parallel robot closed by one point and one weld constraint, from URDF and from
MJCF: the two files give the same model, and design I drives its joints along sinusoids.

Run: ``python examples/three_rrr_joint_space.py [--t-end 2]`` (the MJCF needs ``pip install mujoco``)
"""

import argparse

import numpy as np

import delta_pin as dp
from delta_pin.sim.serial import JointSinusoid


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=2.0, help="duration [s]")
    args = parser.parse_args()
    urdf, mjcf = dp.load_robot("three_rrr"), dp.load_robot("three_rrr_mjcf")
    print(urdf)
    alpha, alpha_dot = urdf.home + np.array([0.05, -0.03, 0.02]), np.array([0.4, -0.2, 0.3])
    a, b = urdf.reduced_terms(alpha, alpha_dot), mjcf.reduced_terms(alpha, alpha_dot)
    difference = max(np.abs(x - y).max() / np.abs(y).max() for x, y in zip(a, b))
    print(f"URDF vs MJCF: M, C, G, C a_dot agree to {difference:.1e} relative")
    reference = JointSinusoid(center=urdf.home, amplitude=0.05, frequency=0.5)
    run = dp.simulate(
        urdf, dp.design1(dp.ClosedChainNominalModel(urdf)), reference, t_end=args.t_end, mode="continuous",
        alpha0=urdf.home,
    )  # fmt: skip
    print(
        f"3-RRR, continuous design I: joint error {np.abs(run.alpha - run.alpha_d).max():.2e} rad over the "
        f"run; closure gap {run.closure_residual.max():.1e}"
    )


if __name__ == "__main__":
    main()
