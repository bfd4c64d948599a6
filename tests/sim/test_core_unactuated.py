"""Robots that move in ways their motors do not determine, in the compiled core: idle motions
(Gepetto's ``5bar_linkage`` and ``robot_delta`` as shipped, whose welded coaxial revolutes spin
freely; the ball-ball Delta, whose six rods spin between their ball joints), passive joints (a
sprung five-bar in MJCF), a free base (Gepetto's five-bar on a free flyer) and a joint coupling
(menagerie's Robotiq 2F-85 as shipped: its drivers tied by an ``<equality joint>``, two sprung
passive links).

The references are the Python robot and plant the core replaces: ``ClosedChainRobot``'s
``configuration``, ``velocity_map``, ``reduced_terms``, ``frame_acceleration_drift`` and
``project_state`` (numpy's LAPACK SVD where the core uses Eigen's Jacobi SVD), the Python plant's
``derivative`` under ``rk4_step`` with ``finish_step``, the readable Python loop
(``simulate_reference``, tests/reference/python_loop.py) and LSODA there at a tight tolerance on
the Python plant in full coordinates.

Tolerances: the pseudo-inverses of the two SVDs agree to ~1e-15 relative on these Jacobians
(condition numbers below 4e3), and the idle projection multiplies a handful of them, so 1e-10
relative bounds a term (measured up to ~1e-12) -- except where the idle motions move almost no
mass: their share of S is then fixed by N^T M N, and a rounding of M moves it by
eps |M| / lambda_min(N^T M N) (robot_delta's spinning links weigh grams: 4.5e-10, measured
8.5e-10 in S), so the bound is the larger of 1e-10 and ten times that estimate; an RK4 step
and its projection, 1e-10 relative (measured ~1e-13); a sampled closed loop, 1e-9 rad (measured
~1e-14); a continuous run against LSODA at rtol 1e-10, 1e-6 rad, the bound of the core's
continuous tests (measured up to ~5e-8, LSODA's own error: the core's Radau at rtol 1e-8 is within
~1e-10 of the exact solution, which for design I started on its reference with an exact nominal
model is the reference itself).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.model.core_model import core_model
from delta_pin.sim.compiled_plant import build_core_plant
from delta_pin.sim.integrators import rk4_step
from tests.model.closed_chain_fixtures import SPRUNG_FIVE_BAR
from tests.reference import projection as readable
from tests.reference.assembly import newton_configuration
from tests.reference.plants import ReadableClosedChainPlant
from tests.reference.python_loop import simulate_reference

DATA = Path(__file__).resolve().parents[1] / "data"
IDLE = ["5bar_linkage", "robot_delta", "delta_ballrods"]


def load(name: str) -> dp.ClosedChainRobot:
    if name == "delta_ballrods":
        return dp.load_robot(name)
    return dp.load_robot(DATA / "gepetto" / name / "robot.urdf")


@pytest.fixture(scope="module", params=IDLE)
def idle_robot(request) -> dp.ClosedChainRobot:
    return load(request.param)


@pytest.fixture(scope="module")
def sprung(tmp_path_factory) -> dp.ClosedChainRobot:
    pytest.importorskip("mujoco")  # MuJoCo compiles MJCF files
    path = tmp_path_factory.mktemp("sprung") / "sprung.xml"
    path.write_text(SPRUNG_FIVE_BAR)
    return dp.load_robot(path)


@pytest.fixture(scope="module")
def robotiq() -> dp.ClosedChainRobot:
    pytest.importorskip("mujoco")
    with pytest.warns(UserWarning, match="is a position servo in the file"):
        return dp.load_robot(DATA / "menagerie" / "robotiq_2f85" / "2f85.xml")


@pytest.fixture(scope="module")
def free_base() -> dp.ClosedChainRobot:
    return dp.load_robot(DATA / "gepetto" / "5bar_linkage" / "robot.urdf", free_flyer=True)


def _relative(a, b) -> float:
    return float(np.abs(np.asarray(a) - np.asarray(b)).max() / max(1.0, np.abs(b).max()))


def _moving_state(plant, robot, rng) -> np.ndarray:
    """A closed full state near home with random actuated rates and the idle motions and passive
    joints moving too (their own state, which active coordinates cannot hold)."""
    x = plant.initial_state(robot.home + rng.uniform(-0.02, 0.02, robot.dof), rng.normal(size=robot.dof))
    nq = robot.model.nq
    q, v = x[:nq], x[nq:].copy()
    if robot.idle_dof:
        v += robot.idle_motions(q) @ rng.normal(scale=0.5, size=robot.idle_dof)
    for index in robot.passive_joint_indices:
        v[index] += rng.normal(scale=0.5)
    q, v = robot.project_state(q, v)  # the passive rates made consistent with the loops
    return np.concatenate([q, v])


def test_the_core_model_with_idle_motions_equals_the_python_projection(idle_robot):
    """Minimum-norm assembly, S of least kinetic energy, the projected (M, C, G, C alpha_dot),
    the end effector's acceleration drift and the state projection at random states: 1e-10
    relative (module docstring)."""
    robot = idle_robot
    model = core_model(robot)
    assert model is not None and model.unactuated
    q0 = robot.reference_configuration
    M0, N0 = robot.mass_matrix(q0), robot.idle_motions(q0)
    conditioning = np.finfo(float).eps * np.linalg.norm(M0, 2) / np.linalg.eigvalsh(N0.T @ M0 @ N0).min()
    bound = max(1e-10, 10.0 * conditioning)  # module docstring
    rng = np.random.default_rng(11)
    for _ in range(3):
        alpha = robot.home + rng.uniform(-0.03, 0.03, robot.dof)
        alpha_dot = rng.normal(size=robot.dof)
        q_python = newton_configuration(robot, alpha, robot.reference_configuration)[0]
        closed, q = model.configuration(alpha, robot.reference_configuration)
        assert closed and _relative(q, q_python) < bound
        assert _relative(model.velocity_map(q), readable.velocity_map(robot, q)) < bound
        for got, expected in zip(
            model.reduced_terms(q, alpha_dot), readable.reduced_terms(robot, q, alpha_dot)
        ):
            assert _relative(got, expected) < bound
            assert np.abs(expected).max() > 0.0  # a real term, not zeros on both sides
        drift = model.frame_acceleration_drift(q, alpha_dot, int(robot.end_effector))
        assert (
            _relative(drift, readable.frame_acceleration_drift(robot, q, alpha_dot, robot.end_effector))
            < bound
        )
        # a state off the loops, its idle rates moving: projected as the readable twin projects it
        q_off = q + rng.normal(scale=1e-4, size=q.shape)
        v_off = readable.velocity_map(robot, q) @ alpha_dot + robot.idle_motions(q) @ rng.normal(
            size=robot.idle_dof
        )
        closed, q_core, v_core = model.project_state(q_off, v_off)
        q_ref, v_ref = readable.project_state(robot, q_off, v_off)
        assert closed and _relative(q_core, q_ref) < bound and _relative(v_core, v_ref) < bound
        assert np.abs(q_core[robot.actuated_q_indices] - q_off[robot.actuated_q_indices]).max() == 0.0


@pytest.mark.parametrize("subject", [*IDLE, "sprung", "free_base", "robotiq"])
def test_rk4_steps_and_projections_equal_the_python_plant(subject, request):
    """20 RK4 steps of 1 ms under a held torque from a state whose idle motions and passive joints
    move, every step projected back (projection_tolerance=1e-15), the projections keeping that
    motion: the core's step against rk4_step on the Python plant's derivative plus finish_step,
    1e-10 relative per step, and the same number of projections."""
    robot = request.getfixturevalue(subject) if subject not in IDLE else load(subject)
    assert robot.has_unactuated_motion
    plant = ReadableClosedChainPlant(robot, projection_tolerance=1e-15)
    h = 1e-3
    compiled = build_core_plant(plant, h / 2, 43)
    assert compiled.integrates_full_state
    rng = np.random.default_rng(5)
    x = _moving_state(plant, robot, rng)
    x0, tau = x.copy(), 0.01 * rng.normal(size=robot.dof)
    for k in range(20):
        stepped = rk4_step(lambda t, y: plant.derivative(t, y, tau), k * h, x, h)
        expected = plant.finish_step(stepped, (k + 1) * h)
        got, gap = compiled.step(x, tau, k * h, h)
        assert _relative(got, expected) < 1e-10, k
        assert gap <= 1e-12
        x = expected
    assert np.abs(x - x0).max() > 1e-3  # it moved
    assert compiled.projections == plant.projections == 20


@pytest.mark.parametrize("name", ["5bar_linkage", "delta_ballrods"])
def test_sampled_design_one_with_idle_motions_in_the_core_equals_the_python_loop(name):
    """Design I (sampling-aware, 1 kHz) on the projected nominal model, 0.1 s along a joint
    sinusoid: the core's plant and law against the Python loop on the Python plant (1e-9 rad,
    1e-8 relative in torque: module docstring); the run really took the core. (robot_delta's
    gram-weight links put a 1 kHz loop with these gains past stability: both loops diverge at
    2 ms, tests/model/test_idle_motions.py.)"""
    robot = load(name)
    path = dp.JointSinusoid(robot.home, amplitude=0.02, frequency=1.0)
    runs = []
    for simulate in (dp.simulate, simulate_reference):
        plant = dp.ClosedChainPlant(robot)
        law = dp.design1(dp.ClosedChainNominalModel(robot), sampling_period=1e-3)
        runs.append(simulate(robot, law, path, plant=plant, t_end=0.1, mode="sampled"))
        assert plant.stepped_in_core == (simulate is dp.simulate)
    core_run, python_run = runs
    np.testing.assert_allclose(core_run.alpha, python_run.alpha, rtol=0, atol=1e-9)
    np.testing.assert_allclose(core_run.tau, python_run.tau, rtol=0, atol=1e-8 * np.abs(python_run.tau).max())
    np.testing.assert_allclose(core_run.q, python_run.q, rtol=0, atol=1e-9)
    assert np.ptp(core_run.alpha, axis=0).min() > 1e-3  # it moved along the path


def test_a_python_law_on_the_core_plant_of_an_underactuated_robot(sprung):
    """The sprung five-bar has no reduced model (controllers refuse it), but a user's own law runs
    on its compiled plant: a PD on the motor for 0.3 s against the Python loop, 1e-9 rad on every
    joint, the passive spring joint moving as the Python plant moves it."""
    robot = sprung

    def pd(t, alpha, alpha_dot):
        return 2.0 * (robot.home + 0.1 - alpha) - 0.2 * alpha_dot

    runs = []
    for simulate in (dp.simulate, simulate_reference):
        plant = dp.ClosedChainPlant(robot)
        runs.append(simulate(robot, pd, None, plant=plant, t_end=0.3, mode="sampled", alpha0=robot.home))
        assert plant.stepped_in_core == (simulate is dp.simulate)
    np.testing.assert_allclose(runs[0].q, runs[1].q, rtol=0, atol=1e-9)
    spring = robot.model.idx_qs[robot.model.getJointId("spring_joint")]
    assert np.ptp(runs[0].q[:, spring]) > 1e-3  # the passive joint moved


@pytest.mark.parametrize("name", ["5bar_linkage", "delta_ballrods"])
def test_continuous_runs_with_idle_motions_integrate_the_whole_state_in_the_core(name):
    """Design I in continuous time, started on its reference: the core's Radau IIA on y = [q, v,
    rho_hat] (rtol 1e-8) against LSODA on the Python plant in full coordinates at rtol 1e-10, 1e-6
    rad over the run; the idle momentum N^T M v stays zero (1e-9 of the momentum scale), and the
    loops stay closed (1e-9)."""
    robot = load(name)
    path = dp.JointSinusoid(robot.home, amplitude=0.02, frequency=1.0)
    options = {"t_end": 0.2, "mode": "continuous", "alpha_dot0": np.full(robot.dof, 0.02 * 2 * np.pi)}
    law = dp.design1(dp.ClosedChainNominalModel(robot))
    core_run = dp.simulate(robot, law, path, integrator="radau", rtol=1e-8, **options)
    reference = simulate_reference(robot, law, path, integrator="lsoda", rtol=1e-10, **options)
    assert core_run.metadata["integrator"] == "radau" and reference.metadata["integrator"] == "lsoda"
    assert core_run.metadata["core_plant"] and core_run.metadata["coordinates"] == "full"
    np.testing.assert_allclose(core_run.alpha, reference.alpha, rtol=0, atol=1e-6)
    assert core_run.closure_residual.max() < 1e-9
    q, v = core_run.q[-1], core_run.v[-1]
    M = robot.mass_matrix(q)
    momentum = robot.idle_motions(q).T @ M @ v
    assert np.abs(momentum).max() <= 1e-9 * np.abs(M @ v).max()


def test_a_continuous_python_law_on_an_underactuated_robot_in_the_core(sprung):
    """The sprung five-bar under a continuous-time PD of the user's (a plain function), 0.3 s: the
    core's Radau on the whole state (rtol 1e-9) against LSODA on the Python plant (rtol 1e-10),
    1e-6 rad on every joint."""
    robot = sprung

    def pd(t, alpha, alpha_dot):
        return 2.0 * (robot.home + 0.1 - alpha) - 0.2 * alpha_dot

    options = {"t_end": 0.3, "mode": "continuous", "alpha0": robot.home}
    core_run = dp.simulate(robot, pd, None, integrator="radau", rtol=1e-9, **options)
    reference = simulate_reference(robot, pd, None, integrator="lsoda", rtol=1e-10, **options)
    assert core_run.metadata["integrator"] == "radau"
    np.testing.assert_allclose(core_run.q, reference.q, rtol=0, atol=1e-6)
    spring = robot.model.idx_qs[robot.model.getJointId("spring_joint")]
    assert np.ptp(core_run.q[:, spring]) > 1e-3


def test_a_joint_coupling_holds_in_the_core_as_in_the_python_plant(robotiq):
    """The Robotiq under a constant tendon force of the user's (1 N on left_driver_joint), 0.1 s:
    sampled at 1 kHz (4 RK4 sub-steps) in the core against the Python loop (1e-9 rad), and in
    continuous time by the core's Radau on the whole state (rtol 1e-9) against LSODA on the
    Python plant (rtol 1e-10; 1e-6 rad); the coupled drivers stay together (1e-9 rad) and it moved
    (measured 0.38 rad in 0.1 s from the same start in tests/model/test_menagerie_models.py)."""
    robot = robotiq
    right, left = (robot.model.idx_qs[robot.model.getJointId(f"{s}_driver_joint")] for s in ("right", "left"))

    def pull(t, alpha, alpha_dot):
        return np.array([1.0])

    runs = {}
    for mode, core in (("sampled", True), ("sampled", False), ("continuous", True), ("continuous", False)):
        options = {"t_end": 0.1, "mode": mode, "alpha0": robot.home, "substeps": 4}
        if mode == "continuous":
            options |= {"rtol": 1e-9} if core else {"integrator": "lsoda", "rtol": 1e-10}
            del options["substeps"]
        run = (dp.simulate if core else simulate_reference)(robot, pull, None, **options)
        assert np.abs(run.q[:, right] - run.q[:, left]).max() < 1e-9
        runs[mode, core] = run
    assert runs["continuous", True].metadata["integrator"] == "radau"
    assert runs["continuous", False].metadata["integrator"] == "lsoda"
    assert all(run.metadata.get("core_plant", False) == core for (_, core), run in runs.items())
    np.testing.assert_allclose(runs["sampled", True].q, runs["sampled", False].q, rtol=0, atol=1e-9)
    np.testing.assert_allclose(runs["continuous", True].q, runs["continuous", False].q, rtol=0, atol=1e-6)
    assert np.ptp(runs["sampled", True].q[:, left]) > 0.05
