"""A digital controller stepped sample by sample on MuJoCo: the way a drive, or another simulator,
calls a delta-pin controller.

Run: ``python examples/mujoco_digital_robust.py [--t-end 15] [--controller digital-robust]``
(needs MuJoCo: ``pip install -e '.[mujoco]'``).

The plant is MuJoCo (the Delta's MJCF built from its Pinocchio model, loops closed by stiff
``connect`` constraints, RK4 at 1 ms); delta-pin only supplies the controller. Every millisecond
the loop reads 17-bit encoders, calls ``controller.step`` with the path I reference, and hands the
torque to a drive with one sample of computation delay. The controller's nominal model is the
analytic Delta without friction or disturbance, as the MuJoCo model has none.
"""

import argparse

import numpy as np

import delta_pin as dp
from delta_pin.sim.drive import Drive
from delta_pin.sim.mujoco_delta import MujocoDelta

DT = 1e-3  # [s] the drive's period and MuJoCo's step
ALPHA0 = 0.3322  # [rad] the paper's initial angle on every joint


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=15.0, help="simulated time [s] (default 15)")
    parser.add_argument("--controller", choices=("digital-robust", "tdc"), default="digital-robust")
    args = parser.parse_args()

    robot = dp.load_delta()
    nominal = dp.DeltaNominalModel(robot, friction=None)
    make = dp.digital_robust if args.controller == "digital-robust" else dp.tdc
    controller = make(nominal, DT, delay=1)
    encoder, drive = dp.Encoder(bits=17, velocity="none"), Drive(3, delay=1)

    sim = MujocoDelta(robot, timestep=DT)
    start = dp.PinocchioPlant(robot).initial_state(np.full(3, ALPHA0), np.zeros(3))  # assembled pose
    nq = robot.pinocchio.model.nq
    sim.set_state(start[:nq], start[nq:])
    steps = round(args.t_end / DT)
    t = np.arange(steps) * DT
    reference = dp.PathI().joint_reference(robot, t)

    controller.reset()
    errors, torques, gaps = np.zeros((steps, 3)), np.zeros((steps, 3)), np.zeros(steps)
    for k in range(steps):
        alpha, alpha_dot = sim.joint_state()
        measured, _ = encoder.read(alpha, alpha_dot, DT)
        desired = dp.Reference(reference.alpha[k], reference.alpha_dot[k], reference.alpha_ddot[k])
        command = controller.step(t[k], measured, desired)
        torques[k] = drive.apply(command)
        errors[k] = alpha - reference.alpha[k]
        sim.step(torques[k])
        gaps[k] = sim.closure_gap()

    last = t >= t[-1] - min(5.0, t[-1] / 2)
    error = np.linalg.norm(errors, axis=1)
    roughness = np.sqrt(np.mean(np.sum(np.diff(torques[last], axis=0) ** 2, axis=1)))
    print(
        f"{args.controller} on MuJoCo, path I, {args.t_end:g} s at {1 / DT:g} Hz, 17-bit encoders, delay 1:"
    )
    print(f"  max ||alpha - alpha_d|| over the last {t[-1] - t[last][0]:.3g} s: {error[last].max():.3e} rad")
    print(f"  torque roughness there (RMS ||tau_k - tau_(k-1)||): {roughness:.3g} N m")
    print(f"  largest closure gap in MuJoCo: {gaps.max():.1e} m")


if __name__ == "__main__":
    main()
