"""The compiled tree dynamics (delta_pin/core/tree_dynamics.cpp) against Pinocchio's Python binding, and its
graceful absence."""

import numpy as np
import pinocchio as pin
import pytest

from delta_pin.compiled import native
from delta_pin.sim.closed_chain_plant import PinocchioPlant

pytestmark = pytest.mark.skipif(
    native.load() is None, reason=f"native library unavailable: {native._loaded.get('reason')}"
)


def test_tree_dynamics_equal_pin_constraint_dynamics(robot, rng):
    """The same compiled constraintDynamics behind both calls: equal bit for bit, at random
    closed states, torques and platform masses (the inertia rewrite included)."""
    plant = PinocchioPlant(robot)
    tree = plant.native_tree()
    for mass in (plant.nominal_platform_mass, 0.7, 1.3, 0.7):
        alpha = rng.uniform(-0.3, 0.6, 3)
        x = plant.initial_state(alpha, rng.normal(size=3))
        q, v = x[: plant.nq], x[plant.nq :]
        tau = rng.normal(size=plant.model.nv)
        plant._tau[:] = tau
        expected = plant._tree_dynamics(q, v, mass).copy()
        got = tree.dynamics(q, v, tau, mass, plant.rotational_inertia(mass))
        np.testing.assert_array_equal(got, expected)
        assert np.abs(got).max() > 1.0  # a real acceleration, not zeros


def test_closure_gap_equals_the_python_gap(robot, rng):
    plant = PinocchioPlant(robot)
    tree = plant.native_tree()
    q = plant.initial_state(np.array([0.1, 0.2, 0.3]), np.zeros(3))[: plant.nq]
    assert tree.closure_gap(q) == robot.pinocchio.closure_gap(q) <= 1e-13
    moved = q + rng.normal(scale=1e-3, size=q.shape)
    assert tree.closure_gap(moved) == pytest.approx(robot.pinocchio.closure_gap(moved), rel=1e-14)
    assert tree.closure_gap(moved) > 1e-4
    moved[3] = np.nan
    assert np.isnan(tree.closure_gap(moved))


def test_joints_beyond_the_axis_joints_are_refused():
    model = pin.buildSampleModelHumanoidRandom()  # a free flyer and spherical joints
    with pytest.raises(native.NativeUnavailableError, match="JointModelFreeFlyer"):
        native.TreeDynamics(native.load(), model, [], (0.0, 0.0), 1)


def test_a_core_built_against_another_pinocchio_is_refused_in_one_line(monkeypatch):
    """The core links the libpinocchio_default it was compiled against: another installed
    Pinocchio is named with the rebuild command, not left to crash later."""
    from delta_pin.compiled import _core, core

    core.core.cache_clear()
    monkeypatch.setattr(_core, "pinocchio_version", "0.0.1")
    try:
        with pytest.raises(native.NativeUnavailableError) as error:
            core.core()
        message = str(error.value)
        assert "Pinocchio 0.0.1" in message and pin.__version__ in message and "pip install" in message
        assert "\n" not in message
    finally:
        core.core.cache_clear()


def test_the_native_path_can_be_turned_off(monkeypatch):
    monkeypatch.setenv("DELTA_PIN_NATIVE", "0")
    assert native.load() is None
    with pytest.raises(native.NativeUnavailableError, match="DELTA_PIN_NATIVE=0"):
        native.load(strict=True)


def test_the_axis_tree_stage_equals_pin_constraint_dynamics(robot, rng):
    """dpn_dynamics_axis (delta-pin's own recursive algorithms, axis_tree.hpp) against
    pin.constraintDynamics (through the Python plant, the reference) at random states on and off
    the closure manifold (off it the Baumgarte terms act), random torques and platform masses:
    1e-12 relative (measured: up to ~2e-15; the bound leaves room for other compilers and
    libms). Its Jacobian and right-hand side are checked through the accelerations: a wrong sign,
    frame or Coriolis term would be off by O(1)."""
    plant = PinocchioPlant(robot)
    tree = plant.native_tree()
    worst = 0.0
    for k in range(60):
        mass = (plant.nominal_platform_mass, 0.7, 1.3)[k % 3]
        x = plant.initial_state(rng.uniform(-0.3, 0.6, 3), 3.0 * rng.normal(size=3))
        q, v = x[: plant.nq].copy(), x[plant.nq :].copy()
        if k % 2:
            q += rng.normal(scale=1e-4, size=q.shape)
            v += rng.normal(scale=1e-2, size=v.shape)
        tau = 5.0 * rng.normal(size=plant.model.nv)
        plant._tau[:] = tau
        expected = plant._tree_dynamics(q, v, mass).copy()
        got = tree.dynamics(q, v, tau, mass, plant.rotational_inertia(mass), stage="axis_tree")
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-12 * np.abs(expected).max())
        worst = max(worst, np.abs(got - expected).max() / np.abs(expected).max())
    assert worst > 0.0  # a different implementation: not the same arithmetic


# joints 1-5: a chain; 6-9: a second chain off joint 1; 10: a side branch off joint 6 (depth-first
# order, as Pinocchio's algorithms need it)
RANDOM_TREE_PARENTS = (0, 1, 2, 3, 4, 1, 6, 7, 8, 6)


def _random_axis_tree(rng):
    """A tree of the six axis joint types (each used, in random order) with random placements,
    inertias and gravity, closed by two point closures: between the tips of two chains that share
    an ancestor, and from a body to the world (6 rows on 10 DOF, independent at generic states)."""
    model = pin.Model()
    model.gravity.linear = rng.normal(size=3) * 5.0
    kinds = [
        pin.JointModelRX,
        pin.JointModelRY,
        pin.JointModelRZ,
        pin.JointModelPX,
        pin.JointModelPY,
        pin.JointModelPZ,
    ]
    order = rng.permutation(len(RANDOM_TREE_PARENTS)) % len(kinds)
    for i, parent in enumerate(RANDOM_TREE_PARENTS, start=1):
        placement = pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(scale=0.3, size=3))
        joint = model.addJoint(parent, kinds[order[i - 1]](), placement, f"joint_{i}")
        inertia = pin.Inertia.Random()
        inertia.mass = rng.uniform(0.1, 2.0)
        model.appendBodyToJoint(joint, inertia, pin.SE3.Identity())
    anchors = [pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(scale=0.2, size=3)) for _ in range(4)]
    closures = [
        pin.RigidConstraintModel(pin.ContactType.CONTACT_3D, model, 5, anchors[0], 9, anchors[1],
                                 pin.ReferenceFrame.LOCAL),
        pin.RigidConstraintModel(pin.ContactType.CONTACT_3D, model, 4, anchors[2], 0, anchors[3],
                                 pin.ReferenceFrame.LOCAL),
    ]  # fmt: skip
    return model, closures


def test_the_axis_tree_stage_on_random_trees_of_every_axis_joint(rng):
    """Beyond the Delta: random trees mixing RX..PZ joints, branches, a closure between branches
    with common ancestors and one to the world, random gravity and Baumgarte gains, at random
    (unclosed) states, against pin.constraintDynamics called directly: 1e-10 relative (measured: up to
    1e-13 over 40 random trees; random inertias and placements make M and the Delassus matrix less
    well conditioned than the Delta's, hence the looser bound)."""
    worst = 0.0
    for trial in range(8):
        model, closures = _random_axis_tree(rng)
        gains = (rng.uniform(0.0, 500.0), rng.uniform(0.0, 50.0))
        models, datas = pin.StdVec_RigidConstraintModel(), pin.StdVec_RigidConstraintData()
        for closure in closures:
            closure.setBaumgarteCorrectorParameters(pin.BaumgarteCorrectorParameters(*gains))
            models.append(closure)
            datas.append(closure.createData())
        data = model.createData()
        pin.initConstraintDynamics(model, data, models, datas)
        platform = int(rng.integers(1, model.njoints))
        tree = native.TreeDynamics(native.load(), model, models, gains, platform)
        inertia = model.inertias[platform]
        for _ in range(5):
            q, v = rng.normal(size=model.nq), 2.0 * rng.normal(size=model.nv)
            tau = 3.0 * rng.normal(size=model.nv)
            expected = pin.constraintDynamics(
                model, data, q, v, tau, models, datas, pin.ProximalSettings(1e-12, 0.0, 1)
            ).copy()
            got = tree.dynamics(q, v, tau, inertia.mass, inertia.inertia, stage="axis_tree")
            scale = np.abs(expected).max()
            np.testing.assert_allclose(
                got, expected, rtol=1e-10, atol=1e-10 * scale, err_msg=f"trial {trial}"
            )
            worst = max(worst, np.abs(got - expected).max() / scale)
    assert worst > 0.0  # a different implementation: not the same arithmetic


def test_an_unknown_stage_is_named(robot):
    tree = PinocchioPlant(robot).native_tree()
    with pytest.raises(ValueError, match="stage='schur' must be one of constraint_dynamics, axis_tree"):
        tree.dynamics(np.zeros(tree.nv), np.zeros(tree.nv), np.zeros(tree.nv), 1.0, np.eye(3), stage="schur")


def test_active_dynamics_equal_the_python_active_plant(robot, rng):
    """dpn_active_dynamics (Newton completion of q(alpha), v = S alpha_dot, then the axis_tree
    stage) against PinocchioPlant(coordinates="active").derivative (Python completion, then
    pin.constraintDynamics): alpha_ddot to 1e-12 relative (measured ~8e-15: both completions run
    the same Newton iteration to 1e-13 m, and the stages agree to ~2e-15), and the platform
    position and closure gap of the completed configuration."""
    plant = PinocchioPlant(robot, coordinates="active")
    tree = plant.native_tree()
    alpha = np.array([0.33, 0.2, 0.45])
    x0 = PinocchioPlant(robot).initial_state(alpha, np.zeros(3))
    tree.set_active(plant.active, plant.platform_q_indices, x0[: plant.nq])
    worst = 0.0
    for _ in range(30):
        alpha = alpha + rng.normal(scale=0.02, size=3)  # a walk: the completions warm-start
        alpha_dot = 3.0 * rng.normal(size=3)
        torque = 5.0 * rng.normal(size=3)
        expected = plant.derivative(0.0, np.concatenate([alpha, alpha_dot]), torque)[3:]  # no friction
        got, xyz, gap = tree.active_dynamics(
            alpha, alpha_dot, torque, plant.nominal_platform_mass, plant.nominal_platform_rotational
        )
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-12 * np.abs(expected).max())
        np.testing.assert_allclose(xyz, robot.forward_kinematics(alpha), atol=1e-12)
        assert gap <= 1e-13
        worst = max(worst, np.abs(got - expected).max() / np.abs(expected).max())
    assert worst > 0.0
