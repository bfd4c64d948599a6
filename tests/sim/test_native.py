"""The native tree dynamics (delta_pin/native) against Pinocchio's Python binding, and its
graceful absence."""

import numpy as np
import pinocchio as pin
import pytest

from delta_pin.compiled import native
from delta_pin.sim.plants import PinocchioPlant

pytestmark = pytest.mark.skipif(
    native.load() is None, reason=f"native library unavailable: {native._loaded.get('reason')}"
)


def test_tree_dynamics_equal_pin_constraint_dynamics(robot, rng):
    """The same compiled constraintDynamics behind both calls: equal bit for bit, at random
    closed states, torques and platform masses (the inertia rewrite included)."""
    plant = PinocchioPlant(robot)
    tree = plant.native_tree()
    for mass in (plant._mass, 0.7, 1.3, 0.7):
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


def test_a_missing_compiler_is_named(monkeypatch, tmp_path):
    monkeypatch.setattr(native, "PREBUILT", tmp_path / "no-prebuilt")  # the build-on-first-use path
    monkeypatch.setenv("DELTA_PIN_CACHE", str(tmp_path))
    monkeypatch.setenv("CXX", "no-such-c++")
    with pytest.raises(native.NativeUnavailableError, match="no-such-c\\+\\+"):
        native.build()
    assert list(tmp_path.iterdir()) == []  # nothing half-written left behind


def test_the_prebuilt_library_serves_only_the_pinocchio_and_source_it_was_built_from(monkeypatch, tmp_path):
    """setup.py builds the library at install time with a stamp; a stamp that does not match (a
    different ``pin``, an edited source) sends build() to the first-use path instead."""
    (tmp_path / "prebuilt").mkdir()
    (tmp_path / "prebuilt" / "tree_dynamics.so").write_bytes(b"not a library")
    (tmp_path / "prebuilt" / "stamp.txt").write_text(native._stamp() + "\n")
    monkeypatch.setattr(native, "PREBUILT", tmp_path / "prebuilt")
    assert native.build() == tmp_path / "prebuilt" / "tree_dynamics.so"
    (tmp_path / "prebuilt" / "stamp.txt").write_text("built against another Pinocchio\n")
    monkeypatch.setenv("DELTA_PIN_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("CXX", "no-such-c++")  # the fallback is a build: here it fails at once, by name
    with pytest.raises(native.NativeUnavailableError, match="no-such-c"):
        native.build()


def test_the_native_path_can_be_turned_off(monkeypatch):
    monkeypatch.setenv("DELTA_PIN_NATIVE", "0")
    assert native.load() is None
    with pytest.raises(native.NativeUnavailableError, match="DELTA_PIN_NATIVE=0"):
        native.load(strict=True)


def test_the_schur_stage_equals_pin_constraint_dynamics(robot, rng):
    """dpn_dynamics_schur (the KKT system by its Schur complement) against pin.constraintDynamics
    (through the Python plant, the reference) at random states on and off the closure manifold
    (off it the Baumgarte terms act), random torques and platform masses: 1e-12 relative
    (measured: up to ~8e-14). Its Jacobian and right-hand side are checked against Pinocchio's own
    through the accelerations: a wrong sign or frame would be off by O(1)."""
    plant = PinocchioPlant(robot)
    tree = plant.native_tree()
    worst = 0.0
    for k in range(60):
        mass = (plant._mass, 0.7, 1.3)[k % 3]
        x = plant.initial_state(rng.uniform(-0.3, 0.6, 3), 3.0 * rng.normal(size=3))
        q, v = x[: plant.nq].copy(), x[plant.nq :].copy()
        if k % 2:
            q += rng.normal(scale=1e-4, size=q.shape)
            v += rng.normal(scale=1e-2, size=v.shape)
        tau = 5.0 * rng.normal(size=plant.model.nv)
        plant._tau[:] = tau
        expected = plant._tree_dynamics(q, v, mass).copy()
        got = tree.dynamics(q, v, tau, mass, plant.rotational_inertia(mass), schur=True)
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-12 * np.abs(expected).max())
        worst = max(worst, np.abs(got - expected).max() / np.abs(expected).max())
    assert worst > 0.0  # a different solve: not the same arithmetic
