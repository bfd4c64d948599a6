"""The shipped Delta with ball-jointed parallelogram forearms (delta_pin/robots/delta_ballrods.xml).

The Table-1 Delta as an MJCF Delta is commonly written: per arm two parallel rods, each on a ball
joint at the elbow; the platform hangs from rod 1a by a ball joint (``platform_ball``) and the
five other rods hold it by ``connect`` equalities. 3 hinges + 7 balls = 24 joint velocities, 5
connects = 15 independent closure equations: mobility 9 = 3 actuated + 6 idle motions, one per
rod (its spin about its own axis, which moves nothing else; rod 1a's also turns platform_ball the
other way, so that the platform stays still).
The parallelograms keep the platform level, so the kinematics are the paper's; the rods carry
the inertia of two point masses at their ends, so the dynamics are the paper's lumped-forearm
eqs. 7-9 (the rods' absolute spin stays zero, the least-kinetic-energy motion).

References and tolerances (each check says which one it uses; "measured" is this machine):

* the file against scripts/make_example_robots.py: number by number, 1e-12 relative (its numbers
  come from sin, cos and atan2, whose last bit may differ between math libraries; the script's
  byte-for-byte list, ``files()``, does not hold it);
* the home pose written in the file (qpos0): closure gap < 1e-14 m (17 significant digits per
  number: only round-off, ~1e-16 m, separates the loops);
* kinematics against the analytic Delta (``dp.load_delta().forward_kinematics``): 1e-9 m on the
  platform centre and 1e-9 on its rotation (identity) -- the loader's Newton closes the loops to
  1e-12 m, times cond(J_p) ~ 44 (measured: 5e-16 m);
* reduced dynamics against the analytic model (eqs. 7-9): 1e-9 relative to each term's largest
  entry -- the mapping of masses is exact and only assembly (1e-12 m) and round-off separate the
  two (measured: 1.5e-13 relative);
* MuJoCo at our assembled configurations: its connect residuals ``efc_pos`` below 1e-11 m (the
  assembly's 1e-12 m, read through MuJoCo's own kinematics; measured 8e-16 m); MuJoCo's own
  constraint solver, hinges held, gravity off: the platform within 1e-9 m of the analytic pose
  (without a load the soft constraints settle exactly; measured 2.4e-15 m);
* free fall, 0.2 s from rest with zero torque (the arms swing by ~1 rad, the platform drops
  0.22 m): the reference is Pinocchio's ``constraintDynamics`` (exact KKT, no Baumgarte) integrated
  by SciPy's DOP853 at rtol 1e-12 in exponential coordinates about a base pose re-set every 20 ms
  (q = integrate(q_base, delta), delta_dot = dIntegrate^-1 v: the ball joints have
  quaternions); its closure drift stays below 1e-12 m (measured 2.2e-13 m). The plant (RK4 at
  0.5 ms: 1 ms samples, 2 substeps; Baumgarte, projection above 1e-10 m) to 1e-9 rad and 1e-9 m
  (measured 5.5e-11 rad, 4.3e-11 m; at 1 ms steps RK4's truncation gives 1.6e-9 rad, 30 times
  more); MuJoCo at the file's settings (RK4 at 1 ms, connect time constant 2 ms) to 5e-5 rad and
  3e-6 m (measured 4.2e-6 rad, 2.2e-7 m: its soft constraints give way under the load), and with
  a 0.1 ms step and a 0.2 ms time constant to 2e-8 rad and 2e-9 m (measured 1.9e-9 rad, 1.6e-10 m);
* design I on a joint sinusoid: the reason at the test.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from scipy.integrate import solve_ivp

import delta_pin as dp
from delta_pin.model.closed_chain import closure_rank
from delta_pin.model.loaders import load_robot
from tests.model.closed_chain_fixtures import pinocchio_accelerations

mujoco = pytest.importorskip("mujoco")

from delta_pin.model.mjcf_loader import _to_pinocchio_q, mjcf_to_pinocchio  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
PATH = ROOT / "delta_pin" / "robots" / "delta_ballrods.xml"
RODS = [f"{i}_{side}" for i in (1, 2, 3) for side in ("a", "b")]
ELBOWS = [f"elbow_{rod}" for rod in RODS]  # the rods' ball joints: one idle spin each
ACTUATED = ("active_1", "active_2", "active_3")
STATES = (  # (alpha [rad], alpha_dot [rad/s]) inside the Table 1 workspace
    (np.array([0.3, 0.45, 0.6]), np.array([0.7, -1.1, 0.4])),
    (np.array([0.1, -0.2, 0.35]), np.array([-0.5, 0.9, 1.3])),
    (np.array([0.55, 0.25, 0.05]), np.array([1.2, 0.3, -0.8])),
    (np.array([-0.3, 0.2, 0.9]), np.array([0.2, 0.2, -0.4])),
)


@pytest.fixture(scope="module")
def robot():
    return load_robot("delta_ballrods", end_effector="platform")


@pytest.fixture(scope="module")
def delta():
    return dp.load_delta()


@pytest.fixture(scope="module")
def compiled():
    """MuJoCo's model of the file and the map from its joints to Pinocchio's (the loader's)."""
    m = mujoco.MjModel.from_xml_path(str(PATH))
    _model, _bodies, q_maps = mjcf_to_pinocchio(m)
    return m, q_maps


def _to_qpos(m, q_maps, q: np.ndarray) -> np.ndarray:
    """MuJoCo's qpos for Pinocchio's q (the inverse of the loader's map): the hinges as they are,
    the balls' quaternions back to MuJoCo's (w, x, y, z)."""
    qpos = np.array(m.qpos0, dtype=float)
    for kind, a, i in q_maps:
        assert kind in ("hinge", "ball"), kind
        if kind == "hinge":
            qpos[a] = q[i]
        else:
            qpos[a : a + 4] = np.r_[q[i + 3], q[i : i + 3]]
    return qpos


def _hinge_addresses(m) -> tuple[list[int], list[int]]:
    joints = [m.joint(name) for name in ACTUATED]
    return [int(j.qposadr[0]) for j in joints], [int(j.dofadr[0]) for j in joints]


# ---------------------------------------------------------------------------------------- the file
def test_loads_with_six_idle_rod_spins(robot):
    assert robot.actuated_joints == ACTUATED  # the file's <motor> actuators
    assert (robot.model.nq, robot.model.nv) == (31, 24)  # 3 + 7 x 4 coefficients; 3 + 7 x 3
    assert [c.kind for c in robot.closures] == ["3d"] * 5  # 15 closure equations
    q = robot.reference_configuration
    assert closure_rank(robot, q) == 15  # all independent
    classification = robot.classification()
    assert classification["mobility"] == 9 and robot.dof == 3 and not robot.passive_joints
    assert robot.idle_dof == 6  # every rod's spin is free: six rods, six idle motions
    # one spin per rod: its elbow ball (and, for rod 1a, the platform's ball joint with it)
    expected = [[elbow] for elbow in ELBOWS[1:]] + [["elbow_1_a", "platform_ball"]]
    assert sorted(classification["idle"]) == sorted(expected)
    summary = robot.summary()
    assert "mobility: 9 = 3 actuated + 0 passive + 6 idle" in summary
    idle_line = next(line for line in summary.splitlines() if "idle motions:" in line)
    assert all(elbow in idle_line for elbow in ELBOWS) and "elbow_1_a + platform_ball" in idle_line
    assert "15 equations, 15 independent" in summary
    # the file's own home (qpos0, every hinge at 0) is already assembled, to round-off
    assert robot.closure_gap(q) < 1e-14
    np.testing.assert_array_equal(robot.home, np.zeros(3))
    # each idle motion turns one rod about its own axis (the rod body's z) and moves nothing else:
    # not the arms, not the platform (its 6D velocity: rod 1a's spin is undone by platform_ball),
    # not the other rods
    basis = robot.idle_motions(q)
    model, data = robot.model, robot.model.createData()
    pin.computeJointJacobians(model, data, q)
    pin.framesForwardKinematics(model, data, q)
    platform = pin.getFrameJacobian(
        model, data, robot.frame_id("platform"), pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    )
    np.testing.assert_allclose(platform @ basis, 0.0, rtol=0, atol=1e-12)
    for column in basis.T:
        size = [np.abs(column[model.idx_vs[j] :][: model.nvs[j]]).max() for j in range(1, model.njoints)]
        moving = [j for j in range(1, model.njoints) if size[j - 1] > 1e-12 * max(size)]
        names = [model.names[j] for j in moving]
        assert (len(names) == 1 and names[0] in ELBOWS) or names == ["elbow_1_a", "platform_ball"], names
        block = column[model.idx_vs[moving[0]] :][:3]  # the elbow's angular velocity in the rod frame
        np.testing.assert_allclose(block / np.linalg.norm(block), [0, 0, np.sign(block[2])], atol=1e-12)


def test_default_end_effector_and_delta_recognition():
    """What load_robot picks without ``end_effector=``: the first closure's first frame, which the
    file puts on the platform (at rod 1b's attachment, a constant offset from the centre: the
    platform keeps its orientation). The Delta recognition looks for three point closures and
    this robot has five, so it is not recognised (``robot.delta`` is None, no analytic plant)."""
    robot = load_robot("delta_ballrods")
    assert robot.delta is None and robot.params is None
    assert robot.end_effector_name == "rod_1_b_1"
    platform = robot.model.frames[robot.frame_id("platform")].parentJoint
    assert robot.model.names[platform] == "platform_ball"
    assert robot.model.frames[robot.end_effector].parentJoint == platform
    offset = np.array([0.084282032302755092, 0.014019237886466827, 0.0])  # site platform_1_b
    for alpha, _ in STATES[:2]:
        np.testing.assert_allclose(
            robot.forward_kinematics(alpha) - robot.forward_kinematics(alpha, "platform"),
            offset, rtol=0, atol=1e-14,
        )  # fmt: skip


# ---------------------------------------------------------------------------------------- the paper's model
def test_kinematics_and_dynamics_are_the_analytic_deltas(robot, delta):
    for alpha, alpha_dot in STATES:
        q = robot.configuration(alpha)
        pose = robot.frame_placement(q, "platform")
        np.testing.assert_allclose(pose.translation, delta.forward_kinematics(alpha), rtol=0, atol=1e-9)
        np.testing.assert_allclose(pose.rotation, np.eye(3), rtol=0, atol=1e-9)  # level
        np.testing.assert_allclose(robot.forward_kinematics(alpha), pose.translation, rtol=0, atol=1e-14)
        M, _C, G, coriolis = robot.reduced_terms(alpha, alpha_dot, q)
        reference = delta.analytic_dynamics(alpha, alpha_dot)
        for name, mine, theirs in (("M", M, reference.M), ("G", G, reference.G),
                                   ("C alpha_dot", coriolis, reference.coriolis)):  # fmt: skip
            np.testing.assert_allclose(mine, theirs, rtol=0, atol=1e-9 * np.abs(theirs).max(), err_msg=name)
    # the analytic Delta's inverse kinematics back through the rods
    target = np.array([0.03, -0.05, -0.32])
    alpha = robot.inverse_kinematics(target, "platform", initial_guess=np.zeros(3))
    np.testing.assert_allclose(alpha, delta.inverse_kinematics(target), rtol=0, atol=1e-9)


# ---------------------------------------------------------------------------------------- MuJoCo
def test_mujoco_closes_the_loops_at_our_configurations(robot, delta, compiled):
    m, q_maps = compiled
    d = mujoco.MjData(m)
    platform = m.body("platform").id
    for alpha, _ in STATES:
        q = robot.configuration(alpha)
        qpos = _to_qpos(m, q_maps, q)
        np.testing.assert_allclose(_to_pinocchio_q(robot.model, q_maps, qpos), q, rtol=0, atol=1e-15)
        d.qpos[:] = qpos
        mujoco.mj_forward(m, d)
        assert d.nefc == 15 and set(d.efc_type) == {int(mujoco.mjtConstraint.mjCNSTR_EQUALITY)}
        assert np.abs(d.efc_pos).max() < 1e-11  # MuJoCo's connect residuals [m]
        np.testing.assert_allclose(d.xpos[platform], delta.forward_kinematics(alpha), rtol=0, atol=1e-9)


def test_mujocos_own_solver_assembles_the_analytic_pose(delta):
    """From qpos0 (alpha = 0), the hinges ramped to alpha over 0.2 s and held (qpos and qvel set
    before every step), gravity off: MuJoCo's constraint forces alone pull the rods and the
    platform onto the loops (0.7 s in all; the residual falls by ~1e3 per 0.1 s once the hinges
    stop, to round-off by 0.6 s). The rods keep spinning at what the ramp gave them (~2 rad/s):
    idle motions, they move no closure point."""
    m = mujoco.MjModel.from_xml_path(str(PATH))  # own copy: gravity changed
    m.opt.gravity[:] = 0.0
    d = mujoco.MjData(m)
    q_addresses, v_addresses = _hinge_addresses(m)
    platform = m.body("platform").id
    for alpha, _ in STATES:
        mujoco.mj_resetData(m, d)
        ramp, hold = 200, 500
        for k in range(ramp + hold):
            d.qpos[q_addresses] = alpha * min(1.0, (k + 1) / ramp)
            d.qvel[v_addresses] = 0.0
            mujoco.mj_step(m, d)
        d.qpos[q_addresses], d.qvel[v_addresses] = alpha, 0.0
        mujoco.mj_forward(m, d)
        assert np.abs(d.efc_pos).max() < 1e-11
        np.testing.assert_allclose(d.xpos[platform], delta.forward_kinematics(alpha), rtol=0, atol=1e-9)
        np.testing.assert_allclose(d.xquat[platform], [1, 0, 0, 0], rtol=0, atol=1e-9)


# ---------------------------------------------------------------------------------------- free fall
def _pinocchio_free_fall(robot, alpha0: np.ndarray, t: np.ndarray):
    """(q samples, their absolute rod spins [rad/s]) of a zero-torque fall from rest: Pinocchio's
    constraintDynamics on the tree and its closures (exact KKT: mu = 0, the 15 equations are
    independent, no Baumgarte), integrated by SciPy's DOP853 at rtol 1e-12, atol 1e-14 in the
    tangent coordinates delta of a base pose, q = integrate(q_base, delta), delta_dot =
    dIntegrate(q_base, delta)^-1 v, the base re-set every 20 samples (|delta| stays small)."""
    model, data = robot.model, robot.model.createData()
    accelerations = pinocchio_accelerations(robot, pin.ProximalSettings(1e-14, 0.0, 1))
    nv, zero = model.nv, np.zeros(model.nv)
    q, v = robot.state(alpha0, np.zeros(3), initial_guess=robot.reference_configuration)
    samples, velocities, window = [q], [v], 20
    for start in range(0, len(t) - 1, window):
        base = q.copy()

        def rhs(_t, x, base=base):
            a = accelerations(pin.integrate(model, base, x[:nv]), x[nv:], zero)
            rate = np.linalg.solve(pin.dIntegrate(model, base, x[:nv], pin.ArgumentPosition.ARG1), x[nv:])
            return np.concatenate([rate, a])

        span = t[start : start + window + 1]
        solution = solve_ivp(
            rhs, (span[0], span[-1]), np.concatenate([zero, v]), method="DOP853", rtol=1e-12, atol=1e-14,
            t_eval=span,
        )  # fmt: skip
        assert solution.success
        for x in solution.y.T[1:]:
            samples.append(pin.integrate(model, base, x[:nv]))
            velocities.append(x[nv:].copy())
        q, v = samples[-1], velocities[-1]
    # each rod's absolute spin: its body's z is its axis, data.v the absolute velocity in its frame
    joints = [model.getJointId(f"elbow_{rod}") for rod in RODS]
    spins = []
    for q, v in zip(samples, velocities):
        pin.forwardKinematics(model, data, q, v)
        spins.append([data.v[joint].angular[2] for joint in joints])
    return np.array(samples), np.array(spins)


def test_free_fall_matches_pinocchio_and_mujoco(robot, compiled):
    alpha0 = np.array([0.2, -0.1, 0.35])
    t = np.linspace(0.0, 0.2, 201)
    reference, spins = _pinocchio_free_fall(robot, alpha0, t)
    assert max(robot.closure_gap(q) for q in reference) < 1e-12  # the reference's own drift
    alpha_ref = reference[:, robot.actuated_q_indices]
    platform_ref = np.array([robot.frame_placement(q, "platform").translation for q in reference])
    assert np.ptp(alpha_ref, axis=0).min() > 0.8  # it does fall: every arm swings by > 0.8 rad
    assert platform_ref[0, 2] - platform_ref[-1, 2] > 0.2  # the platform drops > 0.2 m
    # a symmetric rod's absolute spin is a constant of the motion: zero from rest (measured 3.8e-11
    # rad/s, the integration error, against rod swing rates of ~5 rad/s)
    assert np.abs(spins).max() < 1e-9
    # the plant: RK4 in full coordinates (q with its quaternions, v), two steps per 1 ms sample
    plant = dp.ClosedChainPlant(robot, coordinates="full")
    run = dp.simulate(
        robot, lambda t, a, ad: np.zeros(3), None, plant=plant, t_end=0.2, dt=1e-3, alpha0=alpha0,
        integrator="rk4", substeps=2,
    )  # fmt: skip
    np.testing.assert_allclose(run.t, t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(run.alpha, alpha_ref, rtol=0, atol=1e-9)
    np.testing.assert_allclose(run.xyz, platform_ref, rtol=0, atol=1e-9)
    assert run.closure_residual.max() < 1e-9
    # MuJoCo's own simulation from the same assembled state (soft connects)
    m = mujoco.MjModel.from_xml_path(str(PATH))  # own copy: step and softness changed below
    _m, q_maps = compiled
    d = mujoco.MjData(m)
    q_addresses, _ = _hinge_addresses(m)
    platform = m.body("platform").id
    for timestep, time_constant, impedance, alpha_tol, platform_tol in (
        (1e-3, None, None, 5e-5, 3e-6),  # the file's: RK4 at 1 ms, solref 0.002, solimp 0.99 0.999
        (1e-4, 2e-4, (0.9999, 0.9999, 0.001), 2e-8, 2e-9),  # 0.2 ms: the least MuJoCo allows at 0.1 ms
    ):
        m.opt.timestep = timestep
        if time_constant is not None:
            m.eq_solref[:] = [time_constant, 1.0]
            m.eq_solimp[:, :3] = impedance
        mujoco.mj_resetData(m, d)
        d.qpos[:] = _to_qpos(m, q_maps, reference[0])
        mujoco.mj_forward(m, d)
        alpha, position = [d.qpos[q_addresses].copy()], [d.xpos[platform].copy()]
        for _ in range(len(t) - 1):
            mujoco.mj_step(m, d, nstep=round(1e-3 / timestep))
            mujoco.mj_kinematics(m, d)
            alpha.append(d.qpos[q_addresses].copy())
            position.append(d.xpos[platform].copy())
        np.testing.assert_allclose(np.array(alpha), alpha_ref, rtol=0, atol=alpha_tol, err_msg=str(timestep))
        np.testing.assert_allclose(np.array(position), platform_ref, rtol=0, atol=platform_tol)


# ---------------------------------------------------------------------------------------- control
def test_design_one_tracks_a_joint_sinusoid(robot):
    """Design I (sampling-aware, 1 kHz) on the projected nominal model (the least-kinetic-energy
    map: the rods' spins do not enter it), on the constrained plant in full coordinates, for 0.5 s
    along a 0.02 rad, 1 Hz sinusoid of every arm about home, started on the reference (alpha_dot0
    its initial velocity, so no velocity step). The nominal model is the plant's own dynamics, so
    what remains is the zero-order hold and the robust term's boundary layer: within 5e-6 rad
    (1/4000 of the amplitude; measured 3.4e-7 rad, the platform within 6.8e-8 m of its reference)."""
    reference = dp.JointSinusoid(robot.home, amplitude=0.02, frequency=1.0)
    alpha_dot0 = reference.joint_reference(robot, np.array([0.0])).alpha_dot[0]
    np.testing.assert_allclose(alpha_dot0, 0.02 * 2 * np.pi, rtol=1e-15)
    plant = dp.ClosedChainPlant(robot, coordinates="full")
    run = dp.simulate(
        robot, dp.design1(dp.ClosedChainNominalModel(robot), sampling_period=1e-3), reference,
        plant=plant, t_end=0.5, dt=1e-3, mode="sampled", alpha_dot0=alpha_dot0,
    )  # fmt: skip
    assert np.isfinite(run.alpha).all() and np.isfinite(run.tau).all()
    assert np.ptp(run.alpha, axis=0).min() > 0.0199  # half a period: up to the 0.02 rad crest and back
    error = np.abs(run.alpha - run.alpha_d).max()
    assert error < 5e-6, error
    assert np.abs(run.xyz - run.xyz_d).max() < 1e-6
    assert run.closure_residual.max() < 1e-9
    assert np.abs(run.tau).max() < 5.0  # ~0.8 N m holds the arms and the platform against gravity
    # the same run on the paper-model MJCF Delta (delta.xml: universal-joint forearms, a platform on
    # three slides, its own constrained plant): one robot, so the runs agree to 1e-9 rad and 1e-8 N m
    # (its 1e-12 kg m^2 inertia floor moves the dynamics by ~1e-10 relative; measured 1.1e-13 rad and
    # 9e-13 N m)
    paper = load_robot("delta_mjcf")
    other = dp.simulate(
        paper, dp.design1(dp.ClosedChainNominalModel(paper), sampling_period=1e-3), reference,
        t_end=0.5, dt=1e-3, mode="sampled", alpha_dot0=alpha_dot0,
    )  # fmt: skip
    np.testing.assert_allclose(run.alpha, other.alpha, rtol=0, atol=1e-9)
    np.testing.assert_allclose(run.tau, other.tau, rtol=0, atol=1e-8)


def test_damped_ball_joints_are_read_and_move_as_mujoco_moves_them(tmp_path, robot, compiled):
    """Every ball joint given damping="0.002" (MuJoCo's per-dof damper, -d omega): the loader
    carries it (not refused), the plant applies it, and after 0.2 s of free fall the arms are
    where MuJoCo's own simulation at its stiffest constraints puts them (1.2e-9 rad) while the
    dampers moved them by 2.6e-2 rad against the undamped robot."""
    path = tmp_path / "damped.xml"
    path.write_text(PATH.read_text(encoding="utf-8").replace('type="ball"', 'type="ball" damping="0.002"'))
    damped = load_robot(path, end_effector="platform")
    assert damped.joint_springs["elbow_1_a"] == (0.0, 0.0, 0.002) and len(damped.joint_springs) == 7
    alpha0 = np.array([0.2, -0.1, 0.35])
    runs = {}
    for name, subject in (("damped", damped), ("plain", robot)):
        plant = dp.ClosedChainPlant(subject, coordinates="full")
        runs[name] = dp.simulate(
            subject, lambda t, a, ad: np.zeros(3), None, plant=plant, t_end=0.2, dt=1e-3, alpha0=alpha0,
            integrator="rk4", substeps=2,
        )  # fmt: skip
    effect = np.abs(runs["damped"].alpha - runs["plain"].alpha).max()
    m = mujoco.MjModel.from_xml_path(str(path))
    _m, q_maps = compiled
    d = mujoco.MjData(m)
    q_addresses, _ = _hinge_addresses(m)
    m.opt.timestep = 1e-4
    m.eq_solref[:] = [2e-4, 1.0]
    m.eq_solimp[:, :3] = (0.9999, 0.9999, 0.001)
    d.qpos[:] = _to_qpos(
        m, q_maps, damped.configuration(alpha0, initial_guess=damped.reference_configuration)
    )
    mujoco.mj_forward(m, d)
    mujoco.mj_step(m, d, nstep=2000)
    difference = np.abs(d.qpos[q_addresses] - runs["damped"].alpha[-1]).max()
    assert effect > 1e-2  # measured 2.6e-2 rad: the dampers matter
    assert difference < 1e-8  # measured 1.2e-9 rad (MuJoCo at 0.1 ms, time constant 2e-4 s)
