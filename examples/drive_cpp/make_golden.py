"""Golden vectors for examples/drive_cpp: design I (or II), or the digital-robust law, on the
Delta's analytic nominal model, computed by delta-pin's law (``Controller.evaluate``: the compiled
core's copy, which tests/sim/test_core_laws.py holds to the readable laws of tests/reference/laws.py)
along the joint states of a simulated run, sample by sample with the law's state advancing as a
drive advances it.

Writes ``parameters.txt`` (the controller's numbers, ``name value ...``) and ``golden.csv`` (per
sample: measured alpha, alpha_dot, the reference alpha, alpha_dot, alpha_ddot, then the torque
and the rho_hat the law used), which ``drive_replay`` replays through the C library. The
digital-robust law (``--design digital-robust``: one sample of delay, a torque limit) reads only
the angles; its file carries the observer's matrices and ``law 2``.

Run: ``python make_golden.py OUT_DIR [--design I|II|digital-robust] [--samples 2000] [--paper-law]``
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import delta_pin as dp
from delta_pin.control.base import Reference
from delta_pin.model.kinematics import chain_trigonometry


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--design", choices=("I", "II", "digital-robust"), default="I")
    parser.add_argument("--samples", type=int, default=2000)
    parser.add_argument(
        "--paper-law", action="store_true", help="the paper's robust gain (diverges at 1 kHz after ~0.58 s)"
    )
    args = parser.parse_args()
    dt = 1e-3
    robot = dp.load_delta()
    nominal = dp.DeltaNominalModel(robot, nominal_disturbance=(0.02, -0.01, 0.03))
    if args.design == "digital-robust":
        digital_robust(robot, nominal, dt, args)
        return
    options = {} if args.paper_law else {"sampling_period": dt}  # the sampling-aware law by default
    controller = (dp.design1 if args.design == "I" else dp.design2)(nominal, **options)
    # the joint states of a real run (the analytic plant, the paper's friction), as a drive would read them
    options = {"plant": "analytic", "t_end": args.samples * dt, "mode": "sampled", "dt": dt}
    run = dp.simulate(robot, controller, dp.PathI(), friction=dp.Friction(), **options)
    ctc, gains = controller.computed_torque, controller.gains  # the numbers the C library reads, by name
    numbers = {
        **nominal_numbers(nominal, controller.friction_compensation),
        "D": ctc.D, "T_p": ctc.T_p, "T_v": ctc.T_v, "beta": gains.beta, "xi": gains.xi,
        "epsilon": gains.epsilon, "b1": gains.b1, "b2": gains.b2, "b3": gains.b3,
        "design_two": int(controller.design == "II"), "vector_rho": int(controller.vector_rho),
        "sampling_period": controller.sampling_period or 0.0, "sampling_margin": controller.sampling_margin,
        "rho0": gains.rho0, "period": dt,
    }  # fmt: skip
    write_parameters(args.out, numbers)
    path = dp.PathI().joint_reference(robot, run.t)  # alpha^d, alpha_dot^d, alpha_ddot^d per sample
    z = controller.initial_state()
    rows = []
    for k in range(len(run.t)):
        reference = Reference(path.alpha[k], path.alpha_dot[k], path.alpha_ddot[k])
        out = controller.evaluate(run.t[k], run.alpha[k], run.alpha_dot[k], reference, z)
        rows.append([*run.alpha[k], *run.alpha_dot[k], *reference.alpha, *reference.alpha_dot,
                     *reference.alpha_ddot, *out.tau, z[0]])  # fmt: skip
        z = controller.advance(z, out, dt)
    write_golden(args.out, rows)


def digital_robust(robot, nominal, dt: float, args) -> None:
    """The digital-robust law's golden vectors: the law's own closed loop (analytic plant, the
    paper's friction, one sample of delay, a torque limit the observer is told of)."""
    controller = dp.digital_robust(nominal, dt, delay=1, torque_limit=5.0, rho0=0.05)
    options = {"plant": "analytic", "t_end": args.samples * dt, "mode": "sampled", "dt": dt, "delay": 1}
    run = dp.simulate(robot, controller, dp.PathI(), friction=dp.Friction(), **options)
    observer = controller.observer
    numbers = {
        "law": 2, **nominal_numbers(nominal, controller.friction_compensation), "period": dt,
        "delay": controller.delay,
        "K_p": controller.K_p, "K_v": controller.K_v, "D": controller.D, "beta": controller.beta,
        "b1": controller.b1, "b2": controller.b2, "b3": controller.b3, "epsilon": controller.epsilon,
        "layer_samples": controller.layer_samples, "rho0": controller.rho0, "has_limit": 1,
        "torque_limit": controller.torque_limit, "observer_size": observer.size,
        "transition": observer.transition.ravel(), "input_gain": observer.input_gain,
        "observer_gain": observer.gain,
    }  # fmt: skip
    write_parameters(args.out, numbers)
    path = dp.PathI().joint_reference(robot, run.t)
    z = controller.initial_state()
    rows = []
    for k in range(len(run.t)):
        reference = Reference(path.alpha[k], path.alpha_dot[k], path.alpha_ddot[k])
        out = controller.evaluate(run.t[k], run.alpha[k], run.alpha_dot[k], reference, z)
        rows.append([*run.alpha[k], *run.alpha_dot[k], *reference.alpha, *reference.alpha_dot,
                     *reference.alpha_ddot, *out.tau, z[-2]])  # fmt: skip
        z = controller.advance(z, out, dt)
    write_golden(args.out, rows)


def nominal_numbers(nominal, friction_compensation: bool) -> dict:
    """The Delta's analytic nominal model as the C library reads it: the geometry (lengths [m],
    the arm's part of M [kg m^2] and of G [N m], g [m/s^2]), m_eq [kg], the chain azimuths, F̄ [N m]
    and the compensated Stribeck friction (zeros and ``friction 0`` where none is compensated)."""
    p = nominal.robot.params
    cos_phi, sin_phi = chain_trigonometry()
    compensated = friction_compensation and nominal.stribeck is not None
    s = nominal.stribeck if compensated else None
    return {
        "R": p.R, "r": p.r, "l_a": p.l_a, "l_b": p.l_b, "arm_inertia": p.arm_equivalent_inertia,
        "arm_gravity": 0.5 * (p.m_a + p.m_b) * p.g * p.l_a, "g": p.g, "m_eq": nominal.m_eq,
        "cos_phi": cos_phi, "sin_phi": sin_phi, "friction": int(compensated),
        "r_a": s.r_a if s else 0.0, "v_s": s.v_s if s else 0.0, "mu_s": s.mu_s if s else 0.0,
        "mu_d": s.mu_d if s else 0.0, "mu_v": s.mu_v if s else 0.0,
        "sign_scale": nominal.friction_model.sign_velocity_scale if s else 0.0,
        "normal_force": nominal.normal_force if s else np.zeros(3), "disturbance": nominal.disturbance(),
    }  # fmt: skip


def write_parameters(out: Path, numbers: dict) -> None:
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "parameters.txt", "w") as file:
        for name, value in numbers.items():
            values = np.atleast_1d(np.asarray(value, dtype=float))
            file.write(name + " " + " ".join(repr(float(v)) for v in values) + "\n")


def write_golden(out: Path, rows: list) -> None:
    header = (
        "alpha0,alpha1,alpha2,alpha_dot0,alpha_dot1,alpha_dot2,ref0,ref1,ref2,ref_dot0,ref_dot1,ref_dot2,"
    )
    header += "ref_ddot0,ref_ddot1,ref_ddot2,tau0,tau1,tau2,rho"
    np.savetxt(out / "golden.csv", np.array(rows), delimiter=",", header=header, comments="", fmt="%.17g")
    print(f"wrote {len(rows)} samples to {out / 'golden.csv'}")


if __name__ == "__main__":
    main()
