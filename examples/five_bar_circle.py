"""Design I on a planar five-bar linkage (a URDF with a <constraint>): its tip draws a circle
while it carries an unmodelled payload that the controller does not know.

Run: ``python examples/five_bar_circle.py [--t-end 4] [--html five_bar.html]``
"""

import argparse

import numpy as np

import delta_pin as dp


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=4.0, help="duration [s]")
    parser.add_argument("--html", default=None, help="also export a meshcat page of the run")
    args = parser.parse_args()
    robot = dp.load_robot("five_bar", end_effector="tip")  # delta_pin/robots/five_bar.urdf
    print(robot)
    home = robot.frame_placement(robot.reference_configuration).translation  # the tip, near full stretch
    above = home + np.array([0.0, 0.0, 0.03])  # the circle rises from home, away from full stretch
    circle = dp.Circle(center=above, radius=0.03, period=2.0, plane="xz", phase=-np.pi / 2)
    nominal = dp.ClosedChainNominalModel(robot)  # the projected model, no payload
    plant = dp.ClosedChainPlant(
        robot, payload_mass=lambda t: 0.2 * (1.0 + np.sin(np.pi * t)), coordinates="active"
    )  # 0-0.4 kg at the tip
    run = dp.simulate(
        robot, dp.design1(nominal), dp.FramePath(circle), plant=plant, t_end=args.t_end, mode="continuous",
        alpha0=robot.home,
    )  # fmt: skip
    error = np.linalg.norm(run.xyz - run.xyz_d, axis=1)
    late = run.t >= min(1.0, run.t[-1] / 2)
    print(
        f"five-bar, continuous design I: tip within {error[late].max() * 1e3:.4f} mm of the circle "
        f"after {run.t[late][0]:.1f} s; closure gap {run.closure_residual.max():.1e} m"
    )
    if args.html:
        from delta_pin.viz.meshcat_export import export_html

        print(f"wrote {export_html(run, args.html, robot)}")


if __name__ == "__main__":
    main()
