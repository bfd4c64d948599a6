"""Mechanisms with joints no motor drives, as people ship them: Gepetto's example-parallel-robots
``5bar_linkage`` and ``robot_delta`` (tests/data/gepetto, unmodified), whose loops are closed
by two coaxial revolutes welded together, so each loop leaves a spin that no motor drives.

The references are independent of the reduced model under test: ``pin.constraintDynamics`` on
the tree (the truth the plant integrates), finite differences with Richardson extrapolation and
their own error estimate, and scipy's DOP853 at a tight tolerance.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from scipy.integrate import solve_ivp

import delta_pin as dp
from delta_pin.errors import AssemblyError, InvalidParameterError
from delta_pin.sim.integrators import rk4_step
from tests.model.closed_chain_fixtures import pinocchio_accelerations
from tests.reference.plants import ReadableClosedChainPlant
from tests.reference.projection import idle_projection

DATA = Path(__file__).resolve().parents[1] / "data" / "gepetto"
MODELS = {
    # name: (actuated, idle motions as sets of joints)
    "5bar_linkage": (["mot1", "mot2"], [{"closedloop1_A", "closedloop1_B"}]),
    "robot_delta": (
        ["mot1_rod1", "mot1_rod2"],
        [
            {"closedloop1_A", "closedloop1_B"},
            {"closedloop2_A", "closedloop2_B"},
            {"closedloop3_A", "closedloop3_B"},
        ],
    ),
}


def load(name: str) -> dp.ClosedChainRobot:
    return dp.load_robot(DATA / name / "robot.urdf")


@pytest.fixture(scope="module", params=sorted(MODELS))
def robot(request) -> dp.ClosedChainRobot:
    return load(request.param)


def random_state(robot, rng, spread=0.05):
    alpha = robot.home + rng.uniform(-spread, spread, robot.dof)
    alpha_dot = rng.normal(0.0, 1.0, robot.dof)
    q = robot.configuration(alpha)
    return alpha, alpha_dot, q


def test_each_loads_as_shipped_and_classifies_its_idle_spins(robot):
    actuated, idle = MODELS[Path(robot.base_dir).name]
    assert list(robot.actuated_joints) == actuated  # robot.yaml's name_mot
    assert robot.idle_dof == len(idle)
    found = robot.classification()
    assert sorted(map(frozenset, found["idle"]), key=sorted) == sorted(map(frozenset, idle), key=sorted)
    assert found["mobility"] == robot.dof + robot.idle_dof
    assert found["fully_actuated"]
    assert robot.closure_gap(robot.reference_configuration) < 1e-12
    text = robot.summary()
    assert f"mobility: {found['mobility']} = {robot.dof} actuated + 0 passive + {robot.idle_dof} idle" in text
    for joints in idle:
        assert " + ".join(sorted(joints)) in text or " + ".join(sorted(joints, reverse=True)) in text


def test_each_idle_motion_moves_no_actuated_joint_and_not_the_end_effector(robot):
    q = robot.reference_configuration
    N = robot.idle_motions(q)
    assert N.shape == (robot.model.nv, robot.idle_dof)
    np.testing.assert_allclose(robot.closure_jacobian(q) @ N, 0.0, atol=1e-12)
    np.testing.assert_array_equal(N[robot.actuated_indices], 0.0)
    pin.computeJointJacobians(robot.model, robot.data, q)
    pin.updateFramePlacements(robot.model, robot.data)
    J_ee = pin.getFrameJacobian(robot.model, robot.data, robot.end_effector, pin.LOCAL_WORLD_ALIGNED)
    np.testing.assert_allclose(J_ee[:3] @ N, 0.0, atol=1e-12)


def test_reduced_dynamics_equal_constraint_dynamics_at_zero_idle_momentum(robot):
    """The reduced model takes the velocity map of least kinetic energy (N^T M S = 0): at
    v = S alpha_dot the actuated equations hold exactly, so M^-1 (tau - C alpha_dot - G) equals
    the actuated part of Pinocchio's constrained accelerations. 1e-9 relative: the models'
    cond(J_p) reaches 4e3 (robot_delta) and the proximal reference converges to 1e-14.
    N^T M S = 0 relative to |N^T M| |S|: S is the core's, N the robot's own basis of the idle
    motions (an SVD; the core's is a QR), so the two null spaces' round-off enters; bound
    max(1e-12, 10 eps |M| / lambda_min(N^T M N)), the core tests' (measured 1.2e-9 against 6e-9
    on robot_delta, whose idle spins carry 1e-11 kg m^2)."""
    rng = np.random.default_rng(7)
    for _ in range(3):
        alpha, alpha_dot, q = random_state(robot, rng)
        S = robot.velocity_map(q)
        v = S @ alpha_dot
        M_tree = robot.mass_matrix(q)
        N = robot.idle_motions(q)
        scale = np.abs(N.T @ M_tree).max() * np.abs(S).max()
        conditioning = (
            np.finfo(float).eps * np.linalg.norm(M_tree, 2) / np.linalg.eigvalsh(N.T @ M_tree @ N).min()
        )
        assert np.abs(N.T @ M_tree @ S).max() <= max(1e-12, 10.0 * conditioning) * scale
        tau = rng.normal(0.0, 1.0, robot.dof) * np.abs(robot.reduced_terms(alpha, alpha_dot, q)[2]).max()
        tau_full = np.zeros(robot.model.nv)
        tau_full[robot.actuated_indices] = tau
        expected = pinocchio_accelerations(robot)(q, v, tau_full)[robot.actuated_indices]
        M, C, G, coriolis = robot.reduced_terms(alpha, alpha_dot, q)
        np.testing.assert_allclose(
            C @ alpha_dot, coriolis, rtol=0, atol=1e-9 * (np.abs(coriolis).max() + 1e-300)
        )
        projected = np.linalg.solve(M, tau - coriolis - G)
        np.testing.assert_allclose(projected, expected, rtol=0, atol=1e-9 * np.abs(expected).max())


def richardson(f, h):
    """Central difference of f at 0 with Richardson extrapolation: (value, error estimate)."""
    d1 = (f(h) - f(-h)) / (2 * h)
    d2 = (f(h / 2) - f(-h / 2)) / h
    return (4 * d2 - d1) / 3, np.abs(d2 - d1).max() / 3


def test_velocity_map_derivative_and_skew_coriolis_match_finite_differences():
    """S_dot (closed form, pseudo-inverse and projector derivatives) against Richardson-extrapolated
    central differences of S along the motion, and M_dot - 2 C skew-symmetric with M_dot from
    the same differences: within 10x the differences' own error estimate plus 1e-9 of the scale
    (the assembly's 1e-14 tolerance over h = 1e-3 bounds the round-off)."""
    robot = load("5bar_linkage")
    rng = np.random.default_rng(11)
    alpha, alpha_dot, q = random_state(robot, rng)

    def along(h):
        return robot.configuration(alpha + h * alpha_dot, initial_guess=q, tol=1e-14)

    S_dot = idle_projection(robot, q, alpha_dot)["S_dot"]  # the readable twin's closed form
    fd, estimate = richardson(lambda h: robot.velocity_map(along(h)), 1e-3)
    assert np.abs(S_dot - fd).max() <= 10 * estimate + 1e-9 * np.abs(fd).max()
    _, C, _, _ = robot.reduced_terms(alpha, alpha_dot, q)
    M_dot, estimate = richardson(
        lambda h: robot.reduced_terms(alpha + h * alpha_dot, alpha_dot, along(h))[0], 1e-3
    )
    skew = M_dot - 2 * C
    assert np.abs(skew + skew.T).max() <= 20 * estimate + 1e-9 * np.abs(M_dot).max()


T_FALL = 0.03  # [s]


def plant_free_fall(robot, t_end, h):
    plant = ReadableClosedChainPlant(robot)
    x = plant.initial_state(robot.home, np.zeros(robot.dof))
    tau = np.zeros(robot.dof)
    for k in range(round(t_end / h)):
        x = rk4_step(lambda t, y: plant.derivative(t, y, tau), k * h, x, h)
        x = plant.finish_step(x, (k + 1) * h)
    return plant, x


@pytest.mark.parametrize("name", sorted(MODELS))
def test_free_fall_matches_a_pinocchio_only_reference_and_keeps_its_idle_momentum(name):
    """Free fall of the five-bar (a 654 t sphere at the loop, Gepetto's file as shipped) for the
    0.03 s before it collapses through its straight-arm singularity (at ~0.05 s the joint rates
    pass 30 rad/s): the plant (RK4 at 1 ms, Baumgarte and projection) against constraintDynamics
    integrated by DOP853 at rtol 1e-11 without any stabilisation (its closure drift stays below
    1e-9). Tolerances: 10x RK4's global error at 1 ms on this motion, measured 9.9e-10 rad and
    4.7e-8 rad/s (6.2e-11 rad at 0.5 ms: fourth order, so the error is the integrator's; robot_delta
    2.7e-10 rad). The idle momentum (the sphere's spin about its axis, decoupled) stays zero to
    1e-9 of the momentum scale."""
    robot = load(name)
    _, x = plant_free_fall(robot, T_FALL, 1e-3)
    nq = robot.model.nq
    q0, v0 = robot.state(robot.home, np.zeros(robot.dof))

    accelerations = pinocchio_accelerations(robot)

    def f(t, y):
        return np.concatenate([y[nq:], accelerations(y[:nq], y[nq:], np.zeros(robot.model.nv))])

    reference = solve_ivp(f, (0.0, T_FALL), np.concatenate([q0, v0]), method="DOP853", rtol=1e-11, atol=1e-12)
    q_ref, v_ref = reference.y[:nq, -1], reference.y[nq:, -1]
    assert robot.closure_gap(q_ref) < 1e-9
    moved = np.abs(q_ref[robot.actuated_q_indices] - robot.home).max()
    assert moved > 0.02  # it really falls
    np.testing.assert_allclose(
        x[robot.actuated_q_indices], q_ref[robot.actuated_q_indices], atol=1e-8, rtol=0
    )
    np.testing.assert_allclose(
        x[nq + robot.actuated_indices], v_ref[robot.actuated_indices], atol=5e-7, rtol=0
    )
    q, v = x[:nq], x[nq:]
    momentum = robot.idle_motions(q).T @ robot.mass_matrix(q) @ v
    scale = np.abs(robot.mass_matrix(q) @ v).max()
    assert np.abs(momentum).max() <= 1e-9 * scale


def test_design1_tracks_on_both_models_and_the_run_keeps_q():
    """Design I acts on the actuated joints only; the plant carries the idle spins. Started on
    the reference (alpha_dot0 = the sinusoid's initial rate). The five-bar sampled at 1 kHz;
    robot_delta in continuous mode: its links weigh grams (reduced inertia ~1e-5 kg m^2), so the
    paper's absolute gains (T_v = 9 N m s/rad) put its 1 kHz sampled loop far past stability
    (it diverges in 4 ms, computed torque too); scaled gains or continuous time are needed.
    Bounds: 10x the measured errors (3.0e-5 and 1.6e-8 rad)."""
    for name, mode, t_end, bound in (
        ("5bar_linkage", "sampled", 0.5, 3e-4),
        ("robot_delta", "continuous", 0.1, 2e-7),
    ):
        robot = load(name)
        path = dp.JointSinusoid(robot.home, amplitude=0.02, frequency=1.0)
        run = dp.simulate(
            robot, dp.design1(dp.ClosedChainNominalModel(robot)), path, t_end=t_end, mode=mode,
            alpha_dot0=np.full(robot.dof, 0.02 * 2 * np.pi),
        )  # fmt: skip
        assert np.abs(run.error).max() < bound, name
        assert run.q.shape == (len(run.t), robot.model.nq) and run.v.shape == (len(run.t), robot.model.nv)
        np.testing.assert_array_equal(run.q[:, robot.actuated_q_indices], run.alpha)
        assert max(robot.closure_gap(q) for q in run.q[::10]) < 1e-9
        assert run.metadata["idle_dof"] == robot.idle_dof


def test_run_saved_with_q_loads_back_and_older_runs_without_it_load_too(tmp_path):
    robot = load("5bar_linkage")
    path = dp.JointSinusoid(robot.home, amplitude=0.01, frequency=1.0)
    run = dp.simulate(robot, dp.ComputedTorque(dp.ClosedChainNominalModel(robot)), path, t_end=0.02)
    back = dp.load_run(run.save(tmp_path / "run.npz"))
    np.testing.assert_array_equal(back.q, run.q)
    np.testing.assert_array_equal(back.v, run.v)
    run.q = run.v = None  # a run as saved before q was kept
    older = dp.load_run(run.save(tmp_path / "older.npz"))
    assert older.q is None and older.v is None


def test_a_missing_actuator_is_named():
    """The five-bar with one motor: the free motions then move the end effector."""
    robot = load("5bar_linkage")
    with pytest.raises(AssemblyError, match=r"missing actuator.*mot2|missing actuator"):
        dp.ClosedChainRobot(
            robot.tree, robot.closures, ["mot1"], reference_configuration=robot.reference_configuration
        )


def test_passive_joints_are_simulated_and_refused_by_controllers():
    """mot2 named passive: the mechanism is underactuated. The plant simulates it (with a spring
    on the passive joint), a controller's nominal model refuses it in one line."""
    robot = load("5bar_linkage")
    passive = dp.ClosedChainRobot(
        robot.tree, robot.closures, ["mot1"], passive=["mot2"],
        reference_configuration=robot.reference_configuration,
    )  # fmt: skip
    assert passive.classification()["passive"] == ["mot2"] and passive.idle_dof == 1
    assert "underactuated" in passive.summary()
    with pytest.raises(InvalidParameterError, match=r"underactuated.*mot2"):
        dp.ClosedChainNominalModel(passive).terms(passive.home, np.zeros(1))
    with pytest.raises(InvalidParameterError, match=r"coordinates='active'.*coordinates='full'"):
        dp.ClosedChainPlant(passive, coordinates="active")
    with pytest.raises(InvalidParameterError, match="both actuated and passive"):
        dp.ClosedChainRobot(robot.tree, robot.closures, ["mot1", "mot2"], passive=["mot2"])
    with pytest.raises(InvalidParameterError, match="passive joint 'nope' is not in the model"):
        dp.ClosedChainRobot(robot.tree, robot.closures, ["mot1"], passive=["nope"])


def test_configuration_rate_matches_differences_of_pin_integrate():
    """Ball, free, continuous and planar joints: the coefficient rate equals the central
    difference of pin.integrate (h = 1e-6: truncation ~1e-12, round-off ~1e-10)."""
    robot = load("5bar_linkage")
    model = pin.Model()
    parent = 0
    for joint in (
        pin.JointModelSpherical(), pin.JointModelFreeFlyer(), pin.JointModelRUBX(), pin.JointModelPlanar(),
        pin.JointModelRY(), pin.JointModelPZ(),
    ):  # fmt: skip
        parent = model.addJoint(parent, joint, pin.SE3.Random(), f"j{parent}")
        model.appendBodyToJoint(parent, pin.Inertia.Random(), pin.SE3.Identity())
    robot.model, robot._rates = model, None  # only the joint table is read
    rng = np.random.default_rng(5)
    q = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
    v = rng.normal(size=model.nv)
    h = 1e-6
    fd = (pin.integrate(model, q, h * v) - pin.integrate(model, q, -h * v)) / (2 * h)
    np.testing.assert_allclose(robot.configuration_rate(q, v), fd, atol=1e-8, rtol=0)


def test_validate_passes_on_both_and_reports_the_classification():
    """The honest checks on Gepetto's models as shipped: every check passes, and the report
    opens with the idle motions. robot_delta's free motion is short here: its grams-light links
    and tiny spin bodies make the motion fast (DOP853 takes ~5e4 steps/s) and its redundant welds
    cost constraintDynamics proximal iterations (~0.17 ms an evaluation), so 0.2 s takes ~50 s."""
    from delta_pin.sim.closed_chain_validation import validate_closed_chain

    for name, duration in (("5bar_linkage", 0.2), ("robot_delta", 0.01)):
        report = validate_closed_chain(load(name), samples=8, energy_duration=duration)
        assert report.passed, report.table()
        assert set(report.checks) == {"closure", "plant", "gravity", "coriolis", "energy", "loop gap"}
        assert "idle motions: closedloop" in report.table()


def test_a_saved_run_of_a_gepetto_robot_rebuilds_its_robot_and_draws(tmp_path):
    """The run's URDF has no <constraint> (the loops came from robot.yaml): the run records the
    closure frames, so the robot is rebuilt from the file alone, with the same dynamics (1e-12
    relative: the same numbers through JSON), and its page draws Gepetto's package:/// meshes."""
    pytest.importorskip("meshcat")
    from delta_pin.viz.meshcat_export import _rebuild_closed_chain, export_html

    robot = load("5bar_linkage")
    path = dp.JointSinusoid(robot.home, amplitude=0.01, frequency=1.0)
    run = dp.simulate(robot, dp.ComputedTorque(dp.ClosedChainNominalModel(robot)), path, t_end=0.05)
    saved = dp.load_run(run.save(tmp_path / "run.npz"))
    rebuilt = _rebuild_closed_chain(saved)
    assert rebuilt.idle_dof == 1 and rebuilt.actuated_joints == robot.actuated_joints
    alpha, alpha_dot = robot.home + 0.02, np.array([0.3, -0.1])
    for a, b in zip(robot.reduced_terms(alpha, alpha_dot), rebuilt.reduced_terms(alpha, alpha_dot)):
        np.testing.assert_allclose(b, a, rtol=0, atol=1e-12 * np.abs(a).max())
    page = export_html(saved, tmp_path / "run.html")
    assert page.stat().st_size > 100_000  # the STL meshes are in the page
