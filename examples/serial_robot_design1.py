"""Design I on a serial robot from example-robot-data (UR5) with an uncertain payload.

Run: ``python examples/serial_robot_design1.py [--t-end 4]`` (needs ``pip install example-robot-data``)
"""

import argparse

import numpy as np

import delta_pin as dp
from delta_pin.sim.serial import JointSinusoid, SerialPlant, load_example_robot


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=4.0)
    args = parser.parse_args()
    robot = load_example_robot("ur5")
    known = SerialPlant(robot, payload_mass=lambda t: 1.0)  # the controller believes in 1 kg
    known._set_payload(0.0)
    nominal = dp.PinocchioNominalModel(known.model)
    home = np.array([0.0, -1.2, 1.0, -1.0, -1.5, 0.0])
    run = dp.simulate(
        robot,
        dp.design1(nominal, sampling_period=1e-3),
        JointSinusoid(home, amplitude=0.3, frequency=0.5),
        plant=SerialPlant(robot, payload_mass=lambda t: 1.0 + 0.5 * np.sin(np.pi * t)),  # 0.5-1.5 kg
        t_end=args.t_end,
        dt=1e-3,
        alpha0=home + 0.05,
    )
    error = np.abs(run.error).max(axis=1)
    print(
        f"UR5, 1 kHz: max joint error after 1 s {error[run.t >= 1.0].max():.2e} rad "
        f"(start {error[0]:.2f} rad)"
    )


if __name__ == "__main__":
    main()
