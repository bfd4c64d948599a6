"""Closed-chain identification on a robot delta-pin did not simulate (issue 37's acceptance
benchmark): a Delta run by MuJoCo from a model written for this benchmark, three noise draws,
worst case.

Run: ``python benchmarks/bench_identification_mujoco.py [--draws 3] [--iterations 5] [--quick]
[--json out.json] [--keep DIR]`` (needs MuJoCo: ``pip install -e '.[mujoco]'``; without it the
script prints a "skipped" line and exits 0).

The "real robot" is ``benchmarks/data/delta_mujoco_truth.xml``: a hand-edited copy of the shipped
Table-1 Delta MJCF (``delta_pin/robots/delta.xml``) with the upper arms' mass +19 %, the forearms'
-23 %, the platform's +27 % (m_a 0.238, m_b 0.154, m_o 0.381 kg against 0.2, 0.2, 0.3), and on each
actuated joint MuJoCo's own friction and rotor inertia: ``damping`` (viscous), ``frictionloss``
(Coulomb: a dry friction without Stribeck peak, so the true Stribeck term is 0) and ``armature``.
Every true number is read from that file (masses, damping, frictionloss, armature), nothing is
written twice; its inertias are checked against ``dp.load_delta(m_a=..., m_b=..., m_o=...)``.

1. Excitation: ``optimize_excitation`` on the CAD robot (``dp.load_delta()``, what ``delta-pin
   identify excite`` runs; 6 harmonics, period 2.5 s, +-0.6 rad about alpha = 0.3 rad, <= 8 rad/s,
   ``--iterations`` L-BFGS-B iterations), 20 s; written and read back with ``write_trajectory`` /
   ``read_trajectory`` (the ``identify excite --out`` file). The unseen trajectory: another seed,
   not optimised, 10 s (8 harmonics, period 5 s).
2. Tracking in MuJoCo (RK4, 1 ms, the file's own integrator) by a law of this script, not
   delta-pin's: joint PD (natural frequency 50 rad/s, damping ratio 0.7, scaled by the CAD mass
   matrix's smallest eigenvalue) plus the CAD robot's feed-forward M(alpha_d) alpha_ddot_d +
   C alpha_dot_d + G (eqs. 7-9 on the reference, no friction), on the 17-bit encoder angle and
   MuJoCo's joint velocity (a tachometer); torques through the motors (``data.ctrl``), held over the
   step. Logged at 1 kHz: the 17-bit encoder angle and the commanded torque plus Gaussian noise of
   1 % of each joint's RMS torque, one torque-noise seed per draw (the motion is the same); written
   in ``identify fit``'s CSV format (``write_log``, ``torque_hold: zoh``, no ``qd`` columns: the fit
   differentiates the positions, its default).
3. Fit: ``identify(dp.load_delta(), "fit.csv")`` with its defaults (essential fit, bounded
   friction, Stribeck column, physically consistent estimate), timed from the file after one
   untimed warm-up call (reported: the "first call"); timed twice: in this process (numpy's BLAS
   with its default threads) and in a fresh process with ``OPENBLAS_NUM_THREADS=1`` (on a shared
   2-core machine the default threads contend with other work; see ``single_thread_fits``).
   Compared with the truth:
   * mass-like base parameters: each base parameter of the tree whose true value is not 0 (its
     truth: ``BaseParameters.values`` of the true robot's standard parameters with the armature in
     the rotor-inertia column, ``Ia`` lumps with the arm's ``Iyy*``), relative error of WLS;
   * the Delta's lumped terms (docs/identification.md section 2): I_i = (m_a/3 + m_b/2) l_a^2 +
     armature, k_i = (m_a + m_b) l_a / 2, m_eq = m_o + 3/2 m_b (exact here: each forearm is two
     point masses);
   * friction per joint, the bounded fit (``result.friction``, what parameters.json reports): fc
     against frictionloss, fv against damping; fs (Stribeck excess, truth 0) is reported in N m.
     Beside it, for information, the fit with ``identify fit --friction-model coulomb`` (no
     Stribeck column: the model of MuJoCo's dry friction; not the default for a Delta).
     The rotor inertia is not identified alone (it lumps with the arm's inertia, so it is part of
     I_i and of ``Iyy[upper_arm_i]*``).
4. Unseen torque: ``validate(result, "unseen.csv")`` away from velocity reversals (its
   ``away_from_reversals``), the worst joint; beside it the same figure of the true parameters
   (the floor: how far delta-pin's model of this robot is from MuJoCo's, and the noise).
5. Design I at 1 kHz in MuJoCo, on the same MJCF: ``dp.design1(dp.DeltaNominalModel(robot,
   friction=dp.Friction()), sampling_period=1e-3)`` (the sampling-aware robust gain: with the
   paper's gains as they are, the 1 kHz loop oscillates at the Nyquist rate and diverges within 0.7
   s in MuJoCo, as the controller's docstring predicts) stepped once per 1 ms MuJoCo step
   (``controller.step`` with MuJoCo's exact joint angles and velocities: no sensor, no delay, so
   that only the model differs), path I for 15 s from rest on the path; max ||alpha - alpha_d||
   over the last 5 s. Robots: the identified one (``load_delta(**result.xacro_arguments)``, per
   draw), the true one (the Delta whose I, k, m_eq are the truth's, armature included, with mu_v =
   damping / r_a, mu_d = mu_s = frictionloss / (F_n r_a), F_n = 15 N: what ``xacro_arguments``
   would be for a perfect fit) and the CAD one (reference). Target: |identified / true - 1| <= 5 %.
   For scale, the true model with its m_o +0.2 % (m_eq +0.1 %) is run too: the metric's
   sensitivity to a model error far inside the 1 % parameter target.

Every target is printed by ``report_target`` (worst of the draws) and in a final table.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
from common import machine_info, report_target
from scipy.interpolate import CubicSpline

try:
    import mujoco
except ImportError:  # pragma: no cover - depends on the environment
    mujoco = None

import delta_pin as dp
from delta_pin.identification import identify, validate
from delta_pin.identification.base import base_parameters
from delta_pin.identification.excitation import ExcitationLimits, optimize_excitation
from delta_pin.identification.log import IdentificationLog, write_log
from delta_pin.identification.regressor import ClosedChainRegressor, JointColumns
from delta_pin.identification.workflow import delta_lumped_map, read_trajectory, write_trajectory

MJCF = Path(__file__).parent / "data" / "delta_mujoco_truth.xml"
DT = 1e-3  # [s] MuJoCo's step, the log's and the controllers' period
ENCODER_BITS = 17
TORQUE_NOISE = 0.01  # relative to each joint's RMS torque
NORMAL_FORCE = 15.0  # [N] eq. 12's F_n (dp.Friction's default), to express friction as mu
PD_FREQUENCY, PD_DAMPING = 50.0, 0.7  # [rad/s], [-] of the excitation's tracking law
LIMITS = {"mass": 0.01, "lumped": 0.01, "friction": 0.05, "unseen": 0.01, "design": 0.05, "time": 2.0}
ARMS = (1, 2, 3)


@dataclasses.dataclass
class Truth:
    """The MJCF's numbers: masses [kg], per actuated joint damping [N m s/rad], frictionloss
    [N m], armature [kg m^2]; and delta-pin's robot with those masses (its geometry the CAD's)."""

    m_a: float
    m_b: float
    m_o: float
    damping: np.ndarray
    frictionloss: np.ndarray
    armature: np.ndarray
    robot: object

    def joint_values(self) -> dict:
        """The regressor's joint columns of the truth (no Stribeck peak, no offset)."""
        return {"Ia": self.armature, "fv": self.damping, "fc": self.frictionloss, "fs": 0.0, "off": 0.0}

    def lumped(self, l_a: float) -> np.ndarray:
        """I_1..3, k_1..3, m_eq (docs/identification.md section 2), the armature in I."""
        inertia = (self.m_a / 3 + self.m_b / 2) * l_a**2 + self.armature
        lever = np.full(3, (self.m_a + self.m_b) * l_a / 2)
        return np.concatenate([inertia, lever, [self.m_o + 1.5 * self.m_b]])


class Sim:
    """The MJCF in MuJoCo, with delta-pin's joint order (the names are the same)."""

    def __init__(self, path: Path, robot) -> None:
        self.model = mujoco.MjModel.from_xml_path(str(path))
        self.data = mujoco.MjData(self.model)
        names = [robot.model.names[j] for j in range(1, robot.model.njoints)]
        self.qpos = np.array([self.model.joint(n).qposadr[0] for n in names])
        self.dof = np.array([self.model.joint(n).dofadr[0] for n in names])
        self.nq = robot.model.nq
        actuated = [names.index(j) for j in robot.actuated_joints]
        self.active_q, self.active_v = self.qpos[actuated], self.dof[actuated]
        motors = [self.model.actuator(f"motor_{i}") for i in ARMS]
        order = [int(m.trnid[0]) for m in motors]
        assert order == [self.model.joint(j).id for j in robot.actuated_joints], "motors on the arms"
        self.sites = [
            (self.model.site(f"closure_{i}_parent").id, self.model.site(f"closure_{i}_child").id)
            for i in ARMS
        ]
        self.plant = dp.PinocchioPlant(robot)

    def start(self, alpha0: np.ndarray) -> None:
        """At rest at alpha0, the loops assembled (delta-pin's Newton, mapped by joint name)."""
        mujoco.mj_resetData(self.model, self.data)
        x0 = self.plant.initial_state(alpha0, np.zeros(3))
        self.data.qpos[self.qpos] = x0[: self.nq]
        self.data.qvel[self.dof] = 0.0
        mujoco.mj_forward(self.model, self.data)

    def gap(self) -> float:
        xpos = self.data.site_xpos
        return max(float(np.linalg.norm(xpos[a] - xpos[b])) for a, b in self.sites)


def percent(values, digits: int) -> list[float]:
    """Relative numbers as rounded percentages, for printing."""
    return np.round(np.asarray(values, dtype=float) * 100, digits).tolist()


def encoder(alpha: np.ndarray) -> np.ndarray:
    resolution = 2.0 * np.pi / 2**ENCODER_BITS
    return np.round(alpha / resolution) * resolution


def read_truth(path: Path) -> Truth:
    """The true numbers, from the MJCF; its inertias checked against dp.load_delta's at its masses."""
    model = mujoco.MjModel.from_xml_path(str(path))

    def same(values, what):
        values = np.asarray(values, dtype=float)
        if not np.allclose(values, values[0], rtol=1e-12, atol=0):
            raise SystemExit(f"{path}: the three arms' {what} differ: {values}")
        return float(values[0])

    m_a = same([model.body(f"active_{i}").mass[0] for i in ARMS], "upper arm masses")
    m_b = same([model.body(f"elbow_{i}_pitch").mass[0] for i in ARMS], "forearm masses")
    m_o = float(model.body("platform_x").mass[0])
    dofs = [model.joint(f"active_{i}").dofadr[0] for i in ARMS]
    truth = Truth(
        m_a,
        m_b,
        m_o,
        model.dof_damping[dofs].copy(),
        model.dof_frictionloss[dofs].copy(),
        model.dof_armature[dofs].copy(),
        dp.load_delta(m_a=m_a, m_b=m_b, m_o=m_o),
    )
    # the same bodies in both: mass, centre of mass and principal moments (MuJoCo's body frames
    # are the joints' here, as in the shipped file)
    pin_model = truth.robot.model
    for body, joint in (
        [(f"active_{i}", f"active_{i}") for i in ARMS]
        + [(f"elbow_{i}_pitch", f"elbow_{i}_roll") for i in ARMS]
        + [("platform_x", "platform_z")]
    ):
        inertia = pin_model.inertias[pin_model.getJointId(joint)]
        ours = np.sort(np.linalg.eigvalsh(inertia.inertia))
        theirs = np.sort(model.body(body).inertia)
        ok = (
            abs(model.body(body).mass[0] - inertia.mass) < 1e-12
            and np.allclose(model.body(body).ipos, inertia.lever, atol=1e-12)
            and np.allclose(ours, theirs, atol=1e-9)
        )
        if not ok:
            raise SystemExit(f"{path}: body {body} is not dp.load_delta's {joint} body at the MJCF's masses")
    return truth


def excitations(nominal, iterations: int, duration: float, folder: Path):
    """(the fit's trajectory, the unseen one, the optimiser's summary), the first through the
    identify-excite file."""
    regressor = ClosedChainRegressor(nominal)
    base = base_parameters(regressor)
    start = time.perf_counter()
    limits = ExcitationLimits(position_range=0.6, velocity_limit=8.0)
    trajectory, info = optimize_excitation(
        regressor,
        base,
        regressor.parameters(),
        alpha0=nominal.home + 0.3,
        limits=limits,
        max_iterations=iterations,
        duration=duration,
        seed=0,
        harmonics=6,
        period=2.5,
    )
    info["seconds"] = time.perf_counter() - start
    path = write_trajectory(folder / "excitation.csv", trajectory, nominal)
    trajectory = read_trajectory(path, nominal)
    unseen, _ = optimize_excitation(
        regressor,
        base,
        regressor.parameters(),
        alpha0=nominal.home + 0.3,
        limits=limits,
        max_iterations=0,
        duration=duration / 2,
        seed=7,
    )
    return trajectory, unseen, info


def track(sim: Sim, trajectory, cad) -> dict:
    """Run the excitation in MuJoCo under this script's PD + feed-forward; what the drive saw."""
    steps = round(trajectory.duration / DT) + 1
    t = np.arange(steps) * DT
    alpha_d, alpha_dot_d, alpha_ddot_d = trajectory.evaluate(t)
    coarse = np.arange(0, steps + 4, 5)
    coarse = coarse[coarse < steps]
    if coarse[-1] != steps - 1:
        coarse = np.append(coarse, steps - 1)
    feed = []
    for k in coarse:  # the CAD model's torque along the reference, every 5 ms, splined
        terms = cad.delta.analytic_dynamics(alpha_d[k], alpha_dot_d[k])
        feed.append(terms.M @ alpha_ddot_d[k] + terms.coriolis + terms.G)
    feed_forward = CubicSpline(t[coarse], np.array(feed), axis=0)(t)
    smallest = float(np.linalg.eigvalsh(cad.delta.analytic_dynamics(trajectory.alpha0, np.zeros(3)).M).min())
    kp, kd = smallest * PD_FREQUENCY**2, 2.0 * PD_DAMPING * smallest * PD_FREQUENCY
    sim.start(trajectory.alpha0)
    model, data = sim.model, sim.data
    alpha, tau = np.zeros((steps, 3)), np.zeros((steps, 3))
    gap, error = 0.0, 0.0
    start = time.perf_counter()
    for k in range(steps):
        true_alpha = data.qpos[sim.active_q]
        measured = encoder(true_alpha)
        command = (
            feed_forward[k] + kp * (alpha_d[k] - measured) + kd * (alpha_dot_d[k] - data.qvel[sim.active_v])
        )
        data.ctrl[:] = command
        alpha[k], tau[k] = measured, command
        error = max(error, float(np.abs(true_alpha - alpha_d[k]).max()))
        mujoco.mj_step(model, data)
        gap = max(gap, sim.gap())
    return {
        "t": t,
        "alpha": alpha,
        "tau": tau,
        "gap": gap,
        "tracking_error": error,
        "seconds": time.perf_counter() - start,
        "gains": (kp, kd),
    }


def noisy_log(run: dict, joints, seed: int, path: Path) -> Path:
    rng = np.random.default_rng(seed)
    rms = np.sqrt((run["tau"] ** 2).mean(axis=0))
    tau = run["tau"] + rng.normal(0.0, 1.0, run["tau"].shape) * TORQUE_NOISE * rms
    header = {
        "source": "benchmarks/bench_identification_mujoco.py (MuJoCo, delta_mujoco_truth.xml)",
        "encoder_bits": ENCODER_BITS,
        "torque_noise_relative": TORQUE_NOISE,
        "torque_hold": "zoh",
        "seed": seed,
    }
    return write_log(path, IdentificationLog(run["t"].copy(), run["alpha"], tau, tuple(joints), None, header))


def compare(result, truth: Truth, theta_true: np.ndarray, lumped_true: np.ndarray, lumped_A) -> dict:
    """Relative errors of the mass-like base parameters, the lumped terms and the friction."""
    beta_true = result.base.values(theta_true)
    n = result.regressor.inertial_count
    mass, names = [], []
    for i, k in enumerate(result.base.independent):
        if k < n or result.names[i].startswith("Ia["):
            if abs(beta_true[i]) < 1e-9:
                continue
            mass.append(abs(result.wls.beta[i] - beta_true[i]) / abs(beta_true[i]))
            names.append(result.names[i])
    lumped = np.asarray(result.lumped["values"])
    lumped_error = np.abs(lumped - lumped_true) / np.abs(lumped_true)
    # the lumped terms of the true base parameters, by the fit's own map: checks the truth above
    lumped_of_truth = np.linalg.lstsq(lumped_A, beta_true, rcond=None)[0]
    fc, fv = np.asarray(result.friction["fc"]), np.asarray(result.friction["fv"])
    fs = np.asarray(result.friction.get("fs", [np.nan] * 3))
    friction = {
        "fc": (np.abs(fc - truth.frictionloss) / truth.frictionloss).tolist(),
        "fv": (np.abs(fv - truth.damping) / truth.damping).tolist(),
        "fc_value": fc.tolist(),
        "fv_value": fv.tolist(),
        "fs_value": fs.tolist(),
        "fc_wls": result.friction_unconstrained["fc"],
        "fv_wls": result.friction_unconstrained["fv"],
        "Ia_value": result.friction.get("Ia"),
    }
    worst = int(np.argmax(mass))
    return {
        "mass": mass,
        "mass_worst": float(mass[worst]),
        "mass_worst_name": names[worst],
        "mass_count": len(mass),
        "lumped": lumped.tolist(),
        "lumped_error": lumped_error.tolist(),
        "lumped_truth_map_error": float(
            np.abs(lumped_of_truth - lumped_true).max() / np.abs(lumped_true).max()
        ),
        "friction": friction,
        "friction_worst": float(max(max(friction["fc"]), max(friction["fv"]))),
        "beta_true": beta_true,
    }


def fs_kept(result) -> dict:
    """{fs[J]: (WLS value [N m], |beta|/sigma)} of the Stribeck columns the essential fit kept."""
    out = {}
    for i, name in enumerate(result.names):
        if name.startswith("fs[") and result.wls.beta[i] != 0.0:
            out[name] = (
                round(float(result.wls.beta[i]), 5),
                round(float(abs(result.wls.beta[i]) / result.wls.std[i]), 2),
            )
    return out


def design1_error(sim: Sim, robot, t_end: float = 15.0) -> tuple[float, float]:
    """Design I with ``robot``'s nominal model, 1 kHz in MuJoCo along path I: (max, RMS) of
    ||alpha - alpha_d|| [rad] over the last 5 s."""
    controller = dp.design1(dp.DeltaNominalModel(robot, friction=dp.Friction()), sampling_period=DT)
    steps = round(t_end / DT)
    t = np.arange(steps) * DT
    reference = dp.PathI().joint_reference(robot, t)
    sim.start(reference.alpha[0])
    controller.reset()
    model, data = sim.model, sim.data
    errors = np.zeros(steps)
    for k in range(steps):
        alpha, alpha_dot = data.qpos[sim.active_q].copy(), data.qvel[sim.active_v].copy()
        desired = dp.Reference(reference.alpha[k], reference.alpha_dot[k], reference.alpha_ddot[k])
        data.ctrl[:] = controller.step(t[k], alpha, desired, alpha_dot)
        errors[k] = np.linalg.norm(alpha - reference.alpha[k])
        mujoco.mj_step(model, data)
    last = errors[t >= t_end - 5.0]
    return float(last.max()), float(np.sqrt(np.mean(last**2)))


def true_design_robot(truth: Truth, l_a: float, r_a: float, platform: float = 1.0):
    """The Delta whose lumped terms are the truth's (the armature inside I) and whose friction is
    the MJCF's: the xacro arguments a perfect fit would give (``platform``: a factor on its m_o, for
    the metric's sensitivity)."""
    values = truth.lumped(l_a)
    inertia, lever, m_eq = float(values[:3].mean()), float(values[3:6].mean()), float(values[6])
    m_a = 6.0 * (lever / l_a - inertia / l_a**2)
    m_b = 2.0 * lever / l_a - m_a
    mu_d = float(truth.frictionloss.mean()) / (NORMAL_FORCE * r_a)
    return dp.load_delta(
        m_a=m_a,
        m_b=m_b,
        m_o=(m_eq - 1.5 * m_b) * platform,
        mu_v=float(truth.damping.mean()) / r_a,
        mu_d=mu_d,
        mu_s=mu_d,
    )


SINGLE_THREAD_FITS = """
import json, sys, time
import delta_pin as dp
from delta_pin.identification import identify
nominal = dp.load_delta()
identify(nominal, sys.argv[1])  # warm-up, untimed
times = []
for path in sys.argv[1:]:
    start = time.perf_counter()
    identify(nominal, path)
    times.append(time.perf_counter() - start)
print(json.dumps(times))
"""


def single_thread_fits(paths: list[Path]) -> list[float]:
    """The same fits timed in a fresh process whose BLAS runs one thread (OPENBLAS_NUM_THREADS=1:
    on a shared 2-core machine, OpenBLAS's threads contend with the other work and the fit's many
    small least-squares problems slow down several-fold, unevenly)."""
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    done = subprocess.run(
        [sys.executable, "-c", SINGLE_THREAD_FITS, *map(str, paths)],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--draws", type=int, default=3, help="torque-noise draws (default 3)")
    parser.add_argument("--iterations", type=int, default=5, help="excitation optimiser iterations")
    parser.add_argument("--duration", type=float, default=20.0, help="the fit's log [s] (unseen: half)")
    parser.add_argument(
        "--quick", action="store_true", help="one draw, 10 s log, no optimiser iterations, no design I"
    )
    parser.add_argument("--json", default=None, help="write the numbers here")
    parser.add_argument("--keep", default=None, help="write the logs and the excitation in this folder")
    args = parser.parse_args()
    if mujoco is None:
        print("skipped: MuJoCo is not installed (pip install -e '.[mujoco]')")
        return
    if args.quick:
        args.draws, args.duration, args.iterations = 1, 10.0, 0
    warnings.simplefilter("ignore", RuntimeWarning)
    wall = time.perf_counter()
    print(machine_info(), f"MuJoCo {mujoco.__version__}")
    folder = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="bench_ident_mujoco_"))
    folder.mkdir(parents=True, exist_ok=True)

    nominal = dp.load_delta()
    truth = read_truth(MJCF)
    p = nominal.delta.params
    print(
        f"truth ({MJCF.name}): m_a {truth.m_a:g}, m_b {truth.m_b:g}, m_o {truth.m_o:g} kg; damping "
        f"{truth.damping.tolist()}, frictionloss {truth.frictionloss.tolist()}, armature "
        f"{truth.armature.tolist()}"
    )
    trajectory, unseen_trajectory, info = excitations(nominal, args.iterations, args.duration, folder)
    print(
        f"excitation: cond {info['condition_initial']:.0f} -> {info['condition']:.0f} in "
        f"{info['iterations']} iterations, {info['seconds']:.1f} s"
    )

    sim = Sim(MJCF, nominal)
    fit_run = track(sim, trajectory, nominal)
    unseen_run = track(sim, unseen_trajectory, nominal)
    for name, run in (("fit", fit_run), ("unseen", unseen_run)):
        speed = np.abs(np.gradient(run["alpha"], DT, axis=0)).max(axis=0)
        print(
            f"MuJoCo {name} run: {run['t'][-1]:g} s in {run['seconds']:.1f} s, max |alpha - alpha_d| "
            f"{run['tracking_error']:.2e} rad, closure gap <= {run['gap']:.1e} m, torque RMS "
            f"{np.sqrt((run['tau'] ** 2).mean(axis=0)).round(3).tolist()} N m, peak speed "
            f"{speed.round(2).tolist()} rad/s"
        )

    regressor = ClosedChainRegressor(nominal)
    theta_true = regressor.parameters(truth.robot, truth.joint_values())
    lumped_true = truth.lumped(p.l_a)
    joints = nominal.actuated_joints
    draws = []
    warm = None
    for draw in range(args.draws):
        fit_path = noisy_log(fit_run, joints, 100 + draw, folder / f"fit_{draw}.csv")
        unseen_path = noisy_log(unseen_run, joints, 200 + draw, folder / f"unseen_{draw}.csv")
        if warm is None:  # the first call's imports and caches, untimed (reported)
            start = time.perf_counter()
            identify(nominal, fit_path)
            warm = time.perf_counter() - start
        start = time.perf_counter()
        result = identify(nominal, fit_path)
        fit_s = time.perf_counter() - start
        start = time.perf_counter()
        quick_result = identify(nominal, fit_path, consistent=False)
        fit_plain_s = time.perf_counter() - start
        del quick_result
        # the friction model that fits MuJoCo's dry friction (identify fit --friction-model coulomb)
        coulomb = identify(nominal, fit_path, consistent=False, columns=JointColumns())
        _, A, _ = delta_lumped_map(result.regressor, result.base)
        numbers = compare(result, truth, theta_true, lumped_true, A)
        validation = validate(result, unseen_path)
        floor = validate(
            dataclasses.replace(result, wls=dataclasses.replace(result.wls, beta=numbers.pop("beta_true"))),
            unseen_path,
        )
        numbers.update(
            fit_s=fit_s,
            fit_plain_s=fit_plain_s,
            timings=result.timings,
            dropped=result.dropped,
            kept=result.base.rank - len(result.dropped),
            rank=result.base.rank,
            consistent_converged=None if result.consistent is None else bool(result.consistent.success),
            warnings=result.warnings,
            unseen_away=validation["away_from_reversals"]["rms_relative"],
            unseen_away_all=validation["away_from_reversals"]["rms_relative_all"],
            unseen_every_row=validation["rms_relative"],
            unseen_fraction_near=validation["reversal_mask"]["fraction_near"],
            truth_unseen_away=floor["away_from_reversals"]["rms_relative"],
            xacro_arguments=result.xacro_arguments,
            fs_kept=fs_kept(result),
            coulomb_model={
                "fc": (
                    np.abs(np.asarray(coulomb.friction["fc"]) - truth.frictionloss) / truth.frictionloss
                ).tolist(),
                "fv": (np.abs(np.asarray(coulomb.friction["fv"]) - truth.damping) / truth.damping).tolist(),
            },
        )
        draws.append(numbers)
        print(
            f"\ndraw {draw} (noise seeds {100 + draw}, {200 + draw}): fit {fit_s:.2f} s "
            f"({fit_plain_s:.2f} s without the consistent estimate), {numbers['kept']}/{numbers['rank']} "
            f"base parameters kept; consistent converged: {numbers['consistent_converged']}"
        )
        print(
            f"  mass-like base parameters: worst {numbers['mass_worst']:.3%} ({numbers['mass_worst_name']}, "
            f"{numbers['mass_count']} with a nonzero truth)"
        )
        print(
            "  lumped I_1..3, k_1..3, m_eq: "
            + ", ".join(
                f"{v:.5g} ({e:+.2%})" for v, e in zip(numbers["lumped"], numbers["lumped_error"], strict=True)
            )
            + f"; truth {lumped_true.round(6).tolist()} (the fit's own map of the true base parameters "
            f"agrees to {numbers['lumped_truth_map_error']:.1e})"
        )
        f = numbers["friction"]
        print(
            f"  fc {np.round(f['fc_value'], 5).tolist()} (truth {truth.frictionloss.tolist()}), fv "
            f"{np.round(f['fv_value'], 5).tolist()} (truth {truth.damping.tolist()}), fs "
            f"{np.round(f['fs_value'], 5).tolist()} (truth 0), Ia {f['Ia_value']}"
        )
        print(
            f"  unseen torque RMS away from reversals {percent(numbers['unseen_away'], 3)} "
            f"% (true parameters: {percent(numbers['truth_unseen_away'], 3)} %); "
            f"every row {percent(numbers['unseen_every_row'], 3)} %, "
            f"near a reversal {np.round(numbers['unseen_fraction_near'], 3).tolist()}"
        )
        print(
            f"  Stribeck excess kept (|beta|/sigma >= 3; truth 0): {numbers['fs_kept'] or 'none'}; with "
            "--friction-model coulomb: fc error "
            f"{percent(numbers['coulomb_model']['fc'], 2)} %, fv error "
            f"{percent(numbers['coulomb_model']['fv'], 2)} %"
        )
        print(f"  dropped: {[name for name, _ in result.dropped]}")
        for line in result.warnings:
            print("  " + line)

    single = single_thread_fits([folder / f"fit_{draw}.csv" for draw in range(args.draws)])
    for d, seconds in zip(draws, single, strict=True):
        d["fit_one_thread_s"] = seconds
    print(f"\nthe same fits with one BLAS thread: {[round(x, 2) for x in single]} s")

    design = None
    if not args.quick:
        start = time.perf_counter()
        true_robot = true_design_robot(truth, p.l_a, p.friction.r_a)
        # the metric's sensitivity: the true model with m_o + 0.2 % (m_eq + 0.1 %)
        nudged = true_design_robot(truth, p.l_a, p.friction.r_a, platform=1.002)
        runs = {
            "true": design1_error(sim, true_robot),
            "cad": design1_error(sim, nominal),
            "true_m_o_plus_0.2%": design1_error(sim, nudged),
        }
        runs["identified"] = [design1_error(sim, dp.load_delta(**d["xacro_arguments"])) for d in draws]
        design = {
            key: value[0] if key != "identified" else [e[0] for e in value] for key, value in runs.items()
        }
        design["rms"] = runs
        design["ratio"] = [e / design["true"] for e in design["identified"]]
        design["seconds"] = time.perf_counter() - start
        print(
            f"\ndesign I in MuJoCo, 1 kHz, path I, max ||alpha - alpha_d|| last 5 s (RMS): true model "
            f"{runs['true'][0]:.4g} ({runs['true'][1]:.3g}) rad, CAD model {runs['cad'][0]:.4g} "
            f"({runs['cad'][1]:.3g}), true with m_o +0.2 % {runs['true_m_o_plus_0.2%'][0]:.4g} "
            f"({runs['true_m_o_plus_0.2%'][1]:.3g}), identified "
            + ", ".join(f"{e[0]:.4g} ({e[1]:.3g})" for e in runs["identified"])
            + f" rad ({design['seconds']:.0f} s)"
        )

    n = len(draws)
    worst = {
        "mass": max(d["mass_worst"] for d in draws),
        "lumped": max(max(d["lumped_error"]) for d in draws),
        "friction": max(d["friction_worst"] for d in draws),
        "unseen": max(max(d["unseen_away"]) for d in draws),
        "time": max(d["fit_s"] for d in draws),
        "time_one_thread": max(d["fit_one_thread_s"] for d in draws),
    }
    fc_worst = max(max(d["friction"]["fc"]) for d in draws)
    fv_worst = max(max(d["friction"]["fv"]) for d in draws)
    fs_worst = max(
        float(np.nanmax(np.abs(d["friction"]["fs_value"])))
        if np.isfinite(d["friction"]["fs_value"]).any()
        else 0.0
        for d in draws
    )
    coulomb_worst = max(max(max(d["coulomb_model"]["fc"]), max(d["coulomb_model"]["fv"])) for d in draws)
    coulomb_row = (
        "the same with --friction-model coulomb (no Stribeck column; not the default)",
        "friction",
        f"{coulomb_worst:.2%}",
        coulomb_worst,
    )
    rows = [
        (
            "mass-like base parameters, each with a nonzero truth, max relative error",
            "mass",
            f"{worst['mass']:.3%}",
            worst["mass"],
        ),
        (
            "lumped I_i (armature in), k_i, m_eq, max relative error",
            "lumped",
            f"{worst['lumped']:.3%}",
            worst["lumped"],
        ),
        (
            "friction: fc vs frictionloss, fv vs damping, each joint, max relative error",
            "friction",
            f"{worst['friction']:.2%} (fc {fc_worst:.2%}, fv {fv_worst:.2%}; fs {fs_worst:.2g} N m, truth 0)",
            worst["friction"],
        ),
        coulomb_row,
        (
            "unseen torque RMS away from reversals, worst joint",
            "unseen",
            f"{worst['unseen']:.3%} (true parameters {max(max(d['truth_unseen_away']) for d in draws):.3%})",
            worst["unseen"],
        ),
    ]
    if design is not None:
        deviation = max(abs(r - 1.0) for r in design["ratio"])
        worst["design"] = deviation
        rows.append(
            (
                "design I 1 kHz (MuJoCo, path I): identified / true - 1 of the largest tracking error, "
                "last 5 s",
                "design",
                f"{deviation:.2%} (ratios {', '.join(f'{r:.3f}' for r in design['ratio'])}; true "
                f"{design['true']:.3g} rad, CAD {design['cad']:.3g}; true with m_o +0.2 % "
                f"{design['true_m_o_plus_0.2%'] / design['true'] - 1:+.0%})",
                deviation,
            )
        )
    rows.append(
        (
            f"the fit: identify(CAD, {args.duration:g} s CSV at 1 kHz), defaults",
            "time",
            f"{worst['time']:.2f} s (without the consistent estimate "
            f"{max(d['fit_plain_s'] for d in draws):.2f} s; first call {warm:.2f} s)",
            worst["time"],
        )
    )
    rows.append(
        (
            "the same fit with OPENBLAS_NUM_THREADS=1 (a check: identify takes one BLAS thread itself)",
            "time",
            f"{worst['time_one_thread']:.2f} s",
            worst["time_one_thread"],
        )
    )
    print()
    for label, key, _, value in rows:
        report_target(
            f"identification on MuJoCo: {label} (worst of {n})",
            value,
            LIMITS[key],
            "s" if key == "time" else "relative",
        )
    print(f"\n| target | worst of {n} draw{'s' if n > 1 else ''} | limit | |\n|---|---|---|---|")
    for label, key, text, value in rows:
        limit = f"<= {LIMITS[key]:g} s" if key == "time" else f"<= {LIMITS[key]:.0%}"
        print(f"| {label} | {text} | {limit} | {'met' if value <= LIMITS[key] else 'not met'} |")
    if design is None:
        print("| design I 1 kHz, identified vs true model | not measured (--quick) | within 5 % | |")
    if args.keep:
        print(f"\nwall time {time.perf_counter() - wall:.0f} s; logs and excitation in {folder}")
    else:
        shutil.rmtree(folder)
        print(f"\nwall time {time.perf_counter() - wall:.0f} s")
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(
                {"draws": draws, "worst": worst, "design": design, "excitation": info},
                handle,
                indent=2,
                default=lambda o: o.tolist() if isinstance(o, np.ndarray) else str(o),
            )
    sys.stdout.flush()


if __name__ == "__main__":
    main()
