"""The shipped 6-UPS Stewart-Gough platform (delta_pin/robots/stewart.urdf and stewart.xml).

References and tolerances (every check below says which one it uses):

* the files against scripts/make_example_robots.py: number by number, 1e-12 relative, with every
  shipped robot in tests/model/test_example_robots.py;
* the home pose written in the files: closure gap < 1e-14 m and platform pose 1e-14 -- the files
  hold 17 significant digits of each number, so only round-off (~1e-16 m) separates the loops;
* assembly (``robot.configuration``): the loader's Newton closes the loops to 1e-12 m (its
  tolerance); quantities read off an assembled pose carry that error times the mechanism's
  conditioning (the passive closure Jacobian's condition number is ~13 at home): 1e-11 m on leg
  lengths, 1e-9 on poses found by assembling;
* URDF vs MJCF (two independent routes to one tree: Pinocchio's URDF parser, three revolutes on
  massless links for the spherical joint; MuJoCo's compiler and delta-pin's conversion, a ball
  joint): 1e-9 relative on the reduced M, C alpha_dot and G and 1e-9 on the platform pose
  (measured: up to 3e-12 and 8e-13 -- each robot assembles on its own, to Newton's 1e-12 m, and
  MuJoCo diagonalises the inertias, which moves them by round-off);
* free fall: the plant against Pinocchio's constraintDynamics integrated by SciPy (1e-9 m, the
  reason at the test);
* design I: a joint sinusoid tracked to 1e-5 m (the reason at the test).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from scipy.integrate import solve_ivp

import delta_pin as dp
from delta_pin.model.closed_chain import closure_rank
from delta_pin.model.loaders import load_robot
from tests.model.closed_chain_fixtures import pinocchio_accelerations

pytest.importorskip("mujoco")

ROOT = Path(__file__).resolve().parents[2]
ROBOTS = ROOT / "delta_pin" / "robots"

# the geometry, restated here from the Stewart platform's description (not read from the script):
# base anchors on a circle of radius 0.5 m at azimuth 120 k -/+ 15 deg, platform anchors on a
# circle of radius 0.3 m at azimuth 120 k -/+ 50 deg (k = 0, 1, 2; legs 1..6 in that order), the
# platform level with its centre 0.6 m above the base centre at home (all leg_i = 0)
BASE_RADIUS, PLATFORM_RADIUS, HEIGHT = 0.5, 0.3, 0.6
LEGS = range(1, 7)


def _azimuths(i: int) -> tuple[float, float]:
    k, sign = (i - 1) // 2, (-1.0 if i % 2 else 1.0)
    return math.radians(120 * k + sign * 15), math.radians(120 * k + sign * 50)


BASE_ANCHORS = np.array(
    [BASE_RADIUS * np.array([math.cos(b), math.sin(b), 0.0]) for b, _ in map(_azimuths, LEGS)]
)
PLATFORM_ANCHORS = np.array(  # in the platform frame (its centre, world-aligned at home)
    [PLATFORM_RADIUS * np.array([math.cos(p), math.sin(p), 0.0]) for _, p in map(_azimuths, LEGS)]
)
HOME_CENTRE = np.array([0.0, 0.0, HEIGHT])


def leg_lengths(centre: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """Closed-form inverse kinematics of a Stewart platform: |centre + R p_i - B_i| per leg [m]."""
    return np.linalg.norm(centre + PLATFORM_ANCHORS @ rotation.T - BASE_ANCHORS, axis=1)


HOME_LENGTHS = leg_lengths(HOME_CENTRE, np.eye(3))  # leg_i = 0 is this length (the file's convention)


@pytest.fixture(scope="module")
def stewart():
    return {
        "urdf": load_robot("stewart", end_effector="platform"),
        "mjcf": load_robot("stewart_mjcf", end_effector="platform"),
    }


@pytest.mark.parametrize("shape", ["urdf", "mjcf"])
def test_both_shapes_load_assemble_and_have_six_degrees_of_freedom(shape, stewart):
    robot = stewart[shape]
    assert robot.actuated_joints == tuple(f"leg_{i}" for i in LEGS)  # <transmission> / <motor>
    assert robot.dof == 6 and robot.model.nv == 21  # 6 + 5 * 3 joint velocities
    assert [c.kind for c in robot.closures] == ["3d"] * 5  # 15 closure equations
    q = robot.reference_configuration
    assert closure_rank(robot, q) == 15  # none redundant: mobility 21 - 15 = 6, the six actuators
    np.testing.assert_array_equal(robot.home, np.zeros(6))
    # the file's own home (URDF: q = 0; MJCF: qpos0) is already assembled, to round-off
    neutral = pin.neutral(robot.model)
    assert robot.closure_gap(neutral) < 1e-14
    assert robot.closure_gap(q) < 1e-12  # the loader's Newton tolerance
    home = robot.frame_placement(q, "platform")
    np.testing.assert_allclose(home.translation, HOME_CENTRE, rtol=0, atol=1e-14)
    np.testing.assert_allclose(home.rotation, np.eye(3), rtol=0, atol=1e-14)
    # the universal joints sit on the base anchors of the geometry above
    for i in LEGS:
        placement = robot.model.jointPlacements[robot.model.getJointId(f"ux_{i}")]
        np.testing.assert_allclose(placement.translation, BASE_ANCHORS[i - 1], rtol=0, atol=1e-15)
    # an assembled pose off home
    q = robot.configuration(np.array([0.03, -0.02, 0.01, 0.04, -0.03, 0.02]))
    assert robot.closure_gap(q) < 1e-12


def test_the_default_end_effector_is_a_frame_on_the_platform():
    """load_robot's default end effector is the first closure's first frame: on the platform, at
    leg 2's anchor (``end_effector="platform"`` gives the platform's centre)."""
    for name in ("stewart", "stewart_mjcf"):
        robot = load_robot(name)
        assert robot.end_effector_name == "sphere_2_1"
        platform = robot.model.frames[robot.frame_id("platform")].parentJoint
        assert robot.model.frames[robot.end_effector].parentJoint == platform
        np.testing.assert_allclose(
            robot.frame_placement(robot.reference_configuration).translation,
            HOME_CENTRE + PLATFORM_ANCHORS[1],
            rtol=0,
            atol=1e-14,
        )


def test_urdf_and_mjcf_agree(stewart):
    urdf, mjcf = stewart["urdf"], stewart["mjcf"]
    np.testing.assert_allclose(urdf.model.gravity.linear, mjcf.model.gravity.linear, rtol=0, atol=1e-15)
    rng = np.random.default_rng(7)
    for _ in range(4):
        alpha, alpha_dot = rng.uniform(-0.06, 0.06, 6), rng.uniform(-0.3, 0.3, 6)
        M_u, _C_u, G_u, c_u = urdf.reduced_terms(alpha, alpha_dot)
        M_m, _C_m, G_m, c_m = mjcf.reduced_terms(alpha, alpha_dot)
        # 1e-9 relative to each term's largest entry (measured: <= 3e-12)
        for name, mine, theirs in (("M", M_u, M_m), ("G", G_u, G_m), ("C alpha_dot", c_u, c_m)):
            np.testing.assert_allclose(mine, theirs, rtol=0, atol=1e-9 * np.abs(theirs).max(), err_msg=name)
        x_u = urdf.frame_placement(urdf.configuration(alpha), "platform")
        x_m = mjcf.frame_placement(mjcf.configuration(alpha), "platform")
        np.testing.assert_allclose(x_u.homogeneous, x_m.homogeneous, rtol=0, atol=1e-9)
    assert np.linalg.eigvalsh(M_u).min() > 0.5  # a real mass matrix [kg]: ~1.8 kg at home


@pytest.mark.parametrize("shape", ["urdf", "mjcf"])
def test_forward_kinematics_matches_the_closed_form_inverse_kinematics(shape, stewart):
    robot = stewart[shape]
    rng = np.random.default_rng(11)
    # forward: assemble actuated lengths, read the platform pose, its closed-form leg lengths are
    # the actuated ones (1e-11 m: Newton's 1e-12 m closure times the conditioning)
    for _ in range(4):
        alpha = rng.uniform(-0.08, 0.08, 6)
        q = robot.configuration(alpha, initial_guess=robot.reference_configuration)
        pose = robot.frame_placement(q, "platform")
        np.testing.assert_allclose(
            leg_lengths(pose.translation, pose.rotation), HOME_LENGTHS + alpha, rtol=0, atol=1e-11
        )
    # inverse: a platform pose gives leg lengths in closed form; assembling them gives that pose
    # back (1e-9: the assembled pose's error is the closure tolerance times the conditioning)
    for centre, rpy in (
        ([0.02, -0.03, 0.62], [0.05, -0.04, 0.1]),
        ([-0.04, 0.01, 0.55], [-0.08, 0.06, -0.15]),
        ([0.0, 0.0, 0.68], [0.0, 0.0, 0.0]),
    ):
        rotation = pin.rpy.rpyToMatrix(*rpy)
        alpha = leg_lengths(np.array(centre), rotation) - HOME_LENGTHS
        q = robot.configuration(alpha, initial_guess=robot.reference_configuration)
        pose = robot.frame_placement(q, "platform")
        np.testing.assert_allclose(pose.translation, centre, rtol=0, atol=1e-9)
        np.testing.assert_allclose(pose.rotation, rotation, rtol=0, atol=1e-9)


def _pinocchio_free_fall(robot, alpha0: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The actuated coordinates of a zero-torque fall from rest: Pinocchio's constraintDynamics on
    the tree and its closures (no Baumgarte correction, the exact KKT solve: mu = 0, the 15
    equations are independent), integrated by SciPy's DOP853 at rtol 1e-10, atol 1e-12."""
    accelerations = pinocchio_accelerations(robot, pin.ProximalSettings(1e-14, 0.0, 1))
    nv, zero = robot.model.nv, np.zeros(robot.model.nv)
    assert robot.model.nq == nv  # 1-DOF joints only: q integrates as q + v dt

    def rhs(_t, x):
        return np.concatenate([x[nv:], accelerations(x[:nv], x[nv:], zero)])

    q0, v0 = robot.state(alpha0, np.zeros(6), initial_guess=robot.reference_configuration)
    solution = solve_ivp(
        rhs, (t[0], t[-1]), np.concatenate([q0, v0]), method="DOP853", rtol=1e-10, atol=1e-12, t_eval=t
    )
    assert solution.success
    # the integrator alone keeps the loops closed to within the plant's projection tolerance
    # (1e-10 m; measured 1.6e-11 m), so the reference needs no projection of its own
    assert max(robot.closure_gap(q) for q in solution.y[:nv].T) < 1e-10
    return solution.y[robot.actuated_q_indices].T


def test_free_fall_matches_pinocchios_constraint_dynamics(stewart):
    """0.2 s of zero-torque fall from rest (the platform drops ~0.2 m and tilts; every leg stays
    within its 0.15 m stroke) with ``dp.ClosedChainPlant``: the URDF in full coordinates (RK4,
    Baumgarte, projection above 1e-10 m), the MJCF (ball joints) in full coordinates too, its
    default since the compiled plant steps it, and in active coordinates (RK4, loops assembled at
    each evaluation by the core's Newton), all at 1 ms, against the
    SciPy reference on the URDF's tree. Tolerance
    1e-9 m on the leg extensions: RK4's truncation at 1 ms is ~1e-12 m here, the full-coordinate
    projections move the state by up to the 1e-10 m projection tolerance, the
    reference is good to ~2e-11 m at rtol 1e-10 (its closure drift); 1e-9 leaves a margin of ten
    over their sum (measured: 4e-11 m full, 2e-12 m active)."""
    alpha0 = 0.08 + np.array([0.02, -0.01, 0.03, 0.0, -0.02, 0.01])
    t = np.linspace(0.0, 0.2, 201)
    reference = _pinocchio_free_fall(stewart["urdf"], alpha0, t)
    assert np.ptp(reference, axis=0).min() > 0.1  # it does fall: every leg shortens by > 0.1 m
    assert np.abs(reference).max() < 0.15  # inside the stroke (the model carries no limits)
    for shape, coordinates in (("urdf", None), ("mjcf", None), ("mjcf", "active")):
        robot = stewart[shape]
        plant = dp.ClosedChainPlant(robot, coordinates=coordinates)
        assert plant.coordinates == (coordinates or "full") and not plant.redundant
        run = dp.simulate(
            robot, lambda t, a, ad: np.zeros(6), None, plant=plant, t_end=0.2, dt=1e-3, alpha0=alpha0
        )
        np.testing.assert_allclose(run.t, t, rtol=0, atol=1e-12)
        np.testing.assert_allclose(run.alpha, reference, rtol=0, atol=1e-9, err_msg=f"{shape} {coordinates}")
        assert run.metadata["core_plant"]  # full or active, the core's plant steps it
        assert run.closure_residual.max() < 1e-9


def test_design_one_tracks_a_joint_sinusoid(stewart):
    """Design I (sampling-aware, 1 kHz) on the projected nominal model, on the constrained plant,
    for 1 s along a 1 cm, 1 Hz sinusoid of each leg about home (phases 60 deg apart: the platform
    heaves, sways and tilts), started on the reference. The nominal model is the plant's own
    dynamics, so what remains is the zero-order hold and the robust term's boundary layer: the
    legs track within 1e-5 m (1/1000 of the amplitude; measured 1.6e-7 m)."""
    robot = stewart["urdf"]
    amplitude, frequency = 0.01, 1.0
    phase = 2 * np.pi * np.arange(6) / 6
    reference = dp.JointSinusoid(center=robot.home, amplitude=amplitude, frequency=frequency, phase=phase)
    nominal = dp.ClosedChainNominalModel(robot)
    run = dp.simulate(
        robot, dp.design1(nominal, sampling_period=1e-3), reference, t_end=1.0, dt=1e-3, mode="sampled",
        alpha0=robot.home + amplitude * np.sin(phase),
        alpha_dot0=amplitude * 2 * np.pi * frequency * np.cos(phase),
    )  # fmt: skip
    assert np.isfinite(run.alpha).all() and np.isfinite(run.tau).all()
    assert np.ptp(run.alpha, axis=0).min() > 0.019  # it moves the full 2 cm
    error = np.abs(run.alpha - run.alpha_d).max()
    assert error < 1e-5, error
    assert run.closure_residual.max() < 1e-9
    assert np.abs(run.tau).max() < 100.0  # ~23 N per leg holds the platform; the motion adds little


@pytest.mark.parametrize("shape", ["urdf", "mjcf"])
def test_validate_passes_on_a_short_free_motion(shape, stewart):
    """delta-pin's own checks (G against the potential's gradient, C + C^T against dM/dt, the
    plant against the projection, energy over a free motion), each at its own tolerance. The free
    motion lasts 0.1 s, not the default 0.5 s: with zero torque the platform falls onto the base
    plane in ~0.34 s, where the legs lie flat (singular: in 0.5 s the MJCF's active coordinates no
    longer assemble and the URDF's loop gap passes the check's 1e-8 m)."""
    from delta_pin.sim.closed_chain_validation import validate_closed_chain

    report = validate_closed_chain(stewart[shape], samples=3, energy_duration=0.1)
    assert report.passed, report.table()
