"""The Table 1 Delta from three file shapes -- MJCF, URDF + Gepetto robot.yaml, and the xacro's
URDF with <constraint> elements -- recognised as the same robot, and the paper's design I run on
the MJCF one's constrained plant.

Run: ``python examples/delta_from_three_files.py [--t-end 2]`` (the MJCF needs ``pip install mujoco``)
"""

import argparse

import numpy as np

import delta_pin as dp
from delta_pin.model.delta_recognition import same_reduced_dynamics


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=2.0, help="duration [s]")
    args = parser.parse_args()
    xacro = dp.load_delta()
    for name in ("delta_mjcf", "delta_gepetto"):
        robot = dp.load_robot(name, g=9.8)
        difference = same_reduced_dynamics(robot, xacro, tolerance=np.inf)
        print(f"{name}: {robot}")
        print(f"  recognised: {robot.delta}; M, C a_dot, G vs eqs. 7-9: {difference:.1e} relative")
    robot = dp.load_robot("delta_mjcf", g=9.8)
    nominal = dp.DeltaNominalModel(robot.delta, nominal_disturbance=(2, 4, 6))  # the paper's controller
    options = dict(t_end=args.t_end, mode="continuous", alpha0=np.full(3, 0.3322))  # the core's Radau IIA
    runs = [dp.simulate(plant, dp.design1(nominal), dp.PathI(), **options) for plant in (robot, xacro)]
    gap = np.abs(runs[0].alpha - runs[1].alpha).max()
    error = np.abs(runs[0].alpha - runs[0].alpha_d).max(axis=1)
    print(
        f"design I, path I, {args.t_end:g} s on the MJCF Delta's plant: final error {error[-1]:.2e} rad; "
        f"{gap:.1e} rad from the same run on the xacro Delta"
    )


if __name__ == "__main__":
    main()
