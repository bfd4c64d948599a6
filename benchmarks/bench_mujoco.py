"""MuJoCo reference: the same Delta simulated for 15 s (RK4, 1 ms) by MuJoCo and by Pinocchio.

Run: ``python benchmarks/bench_mujoco.py [--repeats 3] [--t-end 15] [--calls 2000]``
(needs ``pip install -e '.[bench]'``; without MuJoCo it prints a "skipped" line and exits 0).

The MJCF is built by ``delta_pin.model.mjcf.delta_mjcf`` from the robot's Pinocchio model (Table 1):
every joint placement, axis, mass and inertia and the closure points are read from it, nothing is
written down twice. Massless links (the elbow cross, the platform slides) are merged into the
next body as consecutive joints, since MuJoCo rejects moving bodies without mass; rod inertias
that are singular in the URDF (no inertia about the rod's axis) get 1e-9 kg m^2 on the diagonal.
The three loops are closed by ``connect`` equality constraints between sites at the forearm tips
and the platform attachment points; the platform moves on three slides, as in the URDF. The connects
are stiffened (``SOFTNESS``) so that the two engines agree to ~1e-7 rad; this does not change the
cost. Sanity checks printed first: total mass, closure gap at the assembled start pose, free-fall
joint acceleration against ``pin.constraintDynamics``, and 0.3 s at zero torque (the platform must
fall, the loops must hold, both engines must agree).

Both engines run the same torque law, evaluated once per 1 ms step in Python and held over the
step: a joint PD about a slow sinusoid (precomputed table) plus the gravity torque at the start
pose, computed once. The Pinocchio runs integrate the full 12-joint tree with RK4 by hand: on
``PinocchioPlant.derivative`` (the readable Python plant of tests/reference/plants.py; no friction,
no uncertainty, Baumgarte 20 rad/s) and on bare
``pin.constraintDynamics`` (the floor for Pinocchio from Python). Closures are not projected.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np
from common import Timing, machine_info, measure, per_call, print_table, report_target

try:
    import mujoco
except ImportError:  # pragma: no cover - depends on the environment
    mujoco = None

import pinocchio as pin

import delta_pin as dp
from delta_pin.model.mjcf import STIFF_CONNECT
from delta_pin.sim.mujoco_delta import MujocoDelta
from tests.reference.plants import ReadableClosedChainPlant as PinocchioPlant  # the Python plant

DT = 1e-3  # [s]
ALPHA0 = 0.3322  # [rad] the paper's initial angle on every joint
KP, KD = 40.0, 2.0  # [N m/rad], [N m s/rad]
AMPLITUDE, FREQUENCY = 0.15, 0.5  # [rad], [Hz] of the reference sinusoid
SOFTNESS = STIFF_CONNECT


def torque_law(robot: dp.Delta, steps: int):
    """The law both engines run: tau_k = G(alpha_0) + KP (ref_k - alpha) - KD alpha_dot."""
    alpha0 = np.full(3, ALPHA0)
    gravity = robot.analytic_dynamics(alpha0, np.zeros(3)).G  # computed once
    t = np.arange(steps)[:, None] * DT
    phases = np.array([0.0, 2.0, 4.0]) * np.pi / 3.0
    reference = alpha0 + AMPLITUDE * np.sin(2.0 * np.pi * FREQUENCY * t + phases) * np.minimum(t, 1.0)
    return alpha0, gravity, reference


def mujoco_run(sim: MujocoDelta, q0, v0, gravity, reference, gaps: list | None = None) -> None:
    """The torque law under ``mj_step``; ``gaps`` collects the closure gap after each step."""
    model, data, active, active_qpos = sim.model, sim.data, sim.active_dof, sim.active_qpos
    sim.set_state(q0, v0)
    step = mujoco.mj_step
    for ref in reference:
        data.qfrc_applied[active] = gravity + KP * (ref - data.qpos[active_qpos]) - KD * data.qvel[active]
        step(model, data)
        if gaps is not None:
            gaps.append(sim.closure_gap())  # site positions of the step's first stage: one step late


def rk4_run(derivative, x0, active, nq, gravity, reference, kp=KP, kd=KD) -> np.ndarray:
    """Classic RK4 at DT with the torque held over each step; returns the final state."""
    x, h, t = x0.copy(), DT, 0.0
    for ref in reference:
        tau = gravity + kp * (ref - x[active]) - kd * x[nq + active]
        k1 = derivative(t, x, tau)
        k2 = derivative(t + 0.5 * h, x + 0.5 * h * k1, tau)
        k3 = derivative(t + 0.5 * h, x + 0.5 * h * k2, tau)
        k4 = derivative(t + h, x + h * k3, tau)
        x = x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        t += h
    return x


def constraint_dynamics_function(plant: PinocchioPlant):
    """x' = [v, constraintDynamics(q, v, tau)] on the plant's model, without the plant's wrapper."""
    model, data, cms, cds, settings = (
        plant.model,
        plant.data,
        plant.constraint_models,
        plant.constraint_datas,
        plant.settings,
    )
    nq, active, full_tau = plant.nq, plant.active, np.zeros(plant.model.nv)

    def derivative(t, x, tau):
        full_tau[active] = tau
        v = x[nq:]
        return np.concatenate(
            [v, pin.constraintDynamics(model, data, x[:nq], v, full_tau, cms, cds, settings)]
        )

    return derivative


def core_stage_calls(plant: PinocchioPlant, x0: np.ndarray, calls: int, repeats: int) -> list[Timing]:
    """Seconds per evaluation of the two stages of the compiled core's plant
    (``ClosedChainPlant.accelerations``: delta-pin's axis-tree algorithms and Pinocchio's
    ``constraintDynamics``), ``calls`` evaluations per repeat at x0 with a small velocity that
    changes each call, each call from Python (about 1 us of nanobind's dispatch included); empty
    where the core refuses the plant's model."""
    from delta_pin.sim.compiled_plant import build_core_plant

    compiled = build_core_plant(plant)
    if compiled is None:
        return []
    nq = plant.nq
    q, v = x0[:nq].copy(), x0[nq:].copy()
    tau = np.zeros(plant.dof)
    rows = []
    for stage in ("constraint_dynamics", "axis_tree"):
        compiled.use_axis_tree(stage == "axis_tree")
        assert compiled.stage == stage, compiled.stage

        def run(counter=[0]):  # noqa: B006 - the call count, kept across calls
            counter[0] += 1
            v[0] = 1e-3 * (counter[0] % 1000)
            compiled.accelerations(q, v, tau, 0)

        timing = per_call(run, calls, repeats)
        rows.append(Timing(f"core stage {stage} (one evaluation, from Python)", timing))
    return rows


def sanity_checks(robot: dp.Delta, sim: MujocoDelta, plant: PinocchioPlant) -> list[str]:
    """Physical checks of the MJCF against the Pinocchio model; returns printable lines."""
    params = robot.params
    lines = []
    total = float(sim.model.body_subtreemass[0])
    expected = 3 * params.m_a + 3 * params.m_b + params.m_o
    lines.append(f"total mass {total:.6f} kg (3 m_a + 3 m_b + m_o = {expected:.6f} kg)")
    alpha0 = np.full(3, ALPHA0)
    x0 = plant.initial_state(alpha0, np.zeros(3))
    q0, v0 = x0[: plant.nq], x0[plant.nq :]
    sim.set_state(q0, v0)
    lines.append(f"closure gap at the Pinocchio-assembled start pose: {sim.closure_gap():.1e} m")
    mj_acc = sim.data.qacc[sim.dof_index].copy()  # zero torque, at rest
    pin_acc = plant.derivative(0.0, x0, np.zeros(3))[plant.nq :]
    difference = np.abs(mj_acc - pin_acc)[plant.active].max() / np.abs(pin_acc[plant.active]).max()
    lines.append(
        f"free-fall joint acceleration at rest: MuJoCo {np.round(mj_acc[plant.active], 3).tolist()}, "
        f"Pinocchio {np.round(pin_acc[plant.active], 3).tolist()} rad/s^2 "
        f"(relative difference {difference:.1e})"
    )
    # zero torque for 0.3 s: the robot falls, the loops must hold
    steps = 300
    z0 = float(sim.data.qpos[sim.platform_qpos[2]])
    gaps = []
    for _ in range(steps):
        mujoco.mj_step(sim.model, sim.data)
        gaps.append(sim.closure_gap())
    mujoco.mj_forward(sim.model, sim.data)
    x = rk4_run(plant.derivative, x0, plant.active, plant.nq, np.zeros(3), np.zeros((steps, 3)), 0.0, 0.0)
    z_mj = float(sim.data.qpos[sim.platform_qpos[2]])
    z_pin = float(plant.platform_position(x)[2])
    alpha_gap = np.abs(sim.data.qpos[sim.active_qpos] - x[plant.active]).max()
    lines.append(
        f"zero torque, 0.3 s: platform z {z0:.4f} -> {z_mj:.4f} m (MuJoCo), -> {z_pin:.4f} m (Pinocchio); "
        f"largest closure gap {max(gaps):.1e} m; |alpha_MuJoCo - alpha_Pinocchio| <= {alpha_gap:.1e} rad"
    )
    return lines


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--t-end", type=float, default=15.0, help="simulated time of each run [s]")
    parser.add_argument("--calls", type=int, default=2000, help="calls per repeat of the per-call rows")
    args = parser.parse_args()
    if mujoco is None:
        print("bench_mujoco: skipped: MuJoCo is not installed (pip install -e '.[bench]')")
        return 0
    robot = dp.load_delta()
    plant = PinocchioPlant(robot)
    sim = MujocoDelta(robot, **SOFTNESS)
    print(f"machine: {machine_info()}, MuJoCo {mujoco.__version__}, Pinocchio {pin.__version__}")
    for title, checked in (
        (f"connect {SOFTNESS}, as timed", sim),
        ("MuJoCo's default connect softness, for comparison", MujocoDelta(robot, solref=None, solimp=None)),
    ):
        print(f"\nMJCF sanity checks, {title}:")
        for line in sanity_checks(robot, checked, plant):
            print(f"  - {line}")

    steps = round(args.t_end / DT)
    alpha0, gravity, reference = torque_law(robot, steps)
    x0 = plant.initial_state(alpha0, np.zeros(3))
    q0, v0 = x0[: plant.nq], x0[plant.nq :]
    bare = constraint_dynamics_function(plant)
    label = f"{args.t_end:g} s, RK4 at 1 kHz, PD + G in Python"
    final: dict[str, np.ndarray] = {}

    def pinocchio_run(derivative, key):
        def run():
            final[key] = rk4_run(derivative, x0, plant.active, plant.nq, gravity, reference)

        return run

    runs = [
        measure(
            "MuJoCo mj_step loop", lambda: mujoco_run(sim, q0, v0, gravity, reference), args.repeats, label
        ),
        measure(
            "Pinocchio: PinocchioPlant.derivative",
            pinocchio_run(plant.derivative, "plant"),
            args.repeats,
            label,
        ),
        measure("Pinocchio: bare pin.constraintDynamics", pinocchio_run(bare, "bare"), args.repeats, label),
    ]
    gaps: list[float] = []
    mujoco_run(sim, q0, v0, gravity, reference, gaps)  # again, untimed, recording the closure gap
    mujoco.mj_forward(sim.model, sim.data)
    difference = np.abs(sim.data.qpos[sim.active_qpos] - final["plant"][plant.active]).max()
    motion = np.ptp(reference, axis=0).max()
    print(
        f"\nPD run ({motion:.2f} rad peak to peak): after {args.t_end:g} s "
        f"|alpha_MuJoCo - alpha_Pinocchio| <= {difference:.1e} rad; largest closure gap "
        f"MuJoCo {max([*gaps, sim.closure_gap()]):.1e} m, "
        f"Pinocchio {plant.closure_residual(final['plant']):.1e} m at the end (Baumgarte only)"
    )
    print_table(f"the same Delta for {args.t_end:g} s", runs, reference=runs[0])

    # issue 14: MuJoCo's own C++ loop (mujoco.rollout, zero torque: no Python per step) against
    # delta-pin's compiled sampled loop (design I, sampling-aware, the paper's scenario), both 15 s
    # of RK4 at 1 ms on the Pinocchio-assembled start pose
    from mujoco import rollout

    from delta_pin.studies.experiments import RunSpec, run_spec

    sim.set_state(q0, v0)
    state0 = np.empty(mujoco.mj_stateSize(sim.model, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    mujoco.mj_getState(sim.model, sim.data, state0, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    steps = round(args.t_end / DT)
    spec = RunSpec(
        controller="design1", plant="pinocchio", mode="sampled", sampling_aware=True, t_end=args.t_end
    )

    loops = [
        measure(
            "mujoco.rollout (C++, zero torque)",
            lambda: rollout.rollout(sim.model, sim.data, state0[None, :], nstep=steps),
            args.repeats,
            f"{args.t_end:g} s, RK4 1 ms",
        ),
        measure(
            "delta-pin compiled core, sampled design I (the core's plant and law)",
            lambda: run_spec(spec, robot),
            args.repeats,
            f"{args.t_end:g} s, RK4 1 ms, controller and friction included",
            warmup=lambda: run_spec(spec.with_(t_end=0.2), robot),
        ),
    ]
    print_table(f"{args.t_end:g} s of the Delta in a compiled loop", loops, reference=loops[0])
    for issue, limit in ((14, 1.0), (38, 0.5)):
        report_target(
            f"compiled sampled design I / mujoco.rollout, 15 s RK4 1 ms (issue {issue})",
            loops[1].median / loops[0].median,
            limit,
            unit="x",
        )
    sim.set_state(q0, v0)
    qpos0, data = sim.data.qpos.copy(), sim.data

    def mj_step_from_start():  # every call from the start pose, as the Pinocchio rows
        data.qpos[:] = qpos0
        data.qvel[:] = 0.0
        mujoco.mj_step(sim.model, data)

    tau = np.zeros(3)
    calls = [
        Timing(
            "mj_step, RK4: 4 evaluations (state reset included)",
            per_call(mj_step_from_start, args.calls, args.repeats),
        ),
        Timing(
            "pin.constraintDynamics (one evaluation)",
            per_call(
                lambda: pin.constraintDynamics(
                    plant.model,
                    plant.data,
                    q0,
                    v0,
                    np.zeros(plant.model.nv),
                    plant.constraint_models,
                    plant.constraint_datas,
                    plant.settings,
                ),
                args.calls,
                args.repeats,
            ),
        ),
        Timing(
            "PinocchioPlant.derivative (one evaluation)",
            per_call(lambda: plant.derivative(0.0, x0, tau), args.calls, args.repeats),
        ),
    ]
    calls += core_stage_calls(plant, x0, args.calls, args.repeats)
    print_table("one call", calls, reference=calls[0])
    report_target("pin.constraintDynamics per call (reference, about 10 us)", calls[1].median, None)
    for timing in calls[3:]:
        report_target(timing.name, timing.median, None)
    report_target(f"MuJoCo {args.t_end:g} s RK4 1 ms (reference, 0.5-0.8 s for 15 s)", runs[0].median, None)
    return 0


if __name__ == "__main__":
    sys.exit(main())
