"""The compiled single-state kernels against the readable model they mirror, and the named
records they read.

References: :mod:`delta_pin.model.kinematics` and :mod:`delta_pin.model.dynamics` (numpy,
broadcasting; independently tested against Pinocchio and finite differences in tests/model),
:func:`delta_pin.model.friction.stribeck_torque`, and the robot's parameters for the records.
Tolerance 1e-12 relative: the same formulas in a different order of operations.
"""

import numpy as np
import pytest

from delta_pin.compiled.delta_kernels import delta_terms, friction_torque
from delta_pin.compiled.layouts import CONTROLLER, GEOMETRY, record, records
from delta_pin.compiled.rk4 import combine, stage_point, within_limits
from delta_pin.errors import ForwardKinematicsError
from delta_pin.model import kinematics
from delta_pin.model.dynamics import analytic_dynamics, kernel_geometry
from delta_pin.model.friction import Friction, kernel_friction, stribeck_torque
from delta_pin.model.validation import sample_states
from delta_pin.sim.integrators import rk4_step


def test_kernel_geometry_names_the_robot_parameters(robot):
    p = robot.params
    geometry = kernel_geometry(p)
    assert geometry.dtype == GEOMETRY
    assert (geometry.R, geometry.r, geometry.l_a, geometry.l_b, geometry.g) == (p.R, p.r, p.l_a, p.l_b, p.g)
    assert geometry.arm_inertia == pytest.approx((p.m_a / 3 + p.m_b / 2) * p.l_a**2, rel=1e-15)
    assert geometry.arm_gravity == pytest.approx((p.m_a + p.m_b) * p.g * p.l_a / 2, rel=1e-15)


def test_delta_terms_equal_the_readable_model(robot):
    geometry, (cos_phi, sin_phi) = kernel_geometry(robot.params), kinematics.chain_trigonometry()
    m_eq = robot.params.platform_equivalent_mass
    alphas, alpha_dots = sample_states(robot, 50, seed=3)
    for alpha, alpha_dot in zip(alphas, alpha_dots):
        ok, xyz, J, J_dot, M, C, G = delta_terms(geometry, cos_phi, sin_phi, m_eq, alpha, alpha_dot)
        reference = analytic_dynamics(robot.params, alpha, alpha_dot)
        assert ok
        np.testing.assert_allclose(xyz, kinematics.forward_kinematics(robot.params, alpha), rtol=1e-12)
        np.testing.assert_allclose(J, kinematics.jacobian(robot.params, alpha), rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(
            J_dot, kinematics.jacobian_derivative(robot.params, alpha, alpha_dot), rtol=1e-12, atol=1e-13
        )
        for name, value in (("M", M), ("C", C), ("G", G)):
            expected = getattr(reference, name)
            np.testing.assert_allclose(value, expected, rtol=1e-12, atol=1e-12 * np.abs(expected).max())


def test_delta_terms_report_a_pose_without_forward_kinematics(robot):
    geometry, (cos_phi, sin_phi) = kernel_geometry(robot.params), kinematics.chain_trigonometry()
    alpha = np.array([3.0, 0.0, 0.0])  # arm 1 folded up: the forearms cannot meet
    with pytest.raises(ForwardKinematicsError):
        kinematics.forward_kinematics(robot.params, alpha)
    ok, *_ = delta_terms(geometry, cos_phi, sin_phi, 1.0, alpha, np.zeros(3))
    assert not ok


def test_friction_record_gives_eq12(robot, rng):
    friction = Friction()
    stribeck = friction.stribeck_for(robot.params.friction)
    parameters = kernel_friction(stribeck, friction.sign_velocity_scale)
    assert parameters.on and not kernel_friction(None).on
    alpha_dot, normal = rng.normal(size=3), rng.uniform(5.0, 20.0, 3)
    np.testing.assert_allclose(
        friction_torque(parameters, alpha_dot, normal),
        stribeck_torque(stribeck, alpha_dot, normal, friction.sign_velocity_scale),
        rtol=1e-14,
    )


def test_the_compiled_rk4_arithmetic_is_rk4_step_bit_for_bit(rng):
    """stage_point and combine in the order of rk4_step, on y' = A y + sin(t) b."""
    A, b = rng.normal(size=(5, 5)), rng.normal(size=5)

    def f(t, y):
        return A @ y + np.sin(t) * b

    y, t, h = rng.normal(size=5), 0.3, 1e-2
    k1 = f(t, y)
    y2 = np.empty(5)
    stage_point(y2, y, k1, 0.5 * h)
    k2 = f(t + 0.5 * h, y2)
    y3 = np.empty(5)
    stage_point(y3, y, k2, 0.5 * h)
    k3 = f(t + 0.5 * h, y3)
    y4 = np.empty(5)
    stage_point(y4, y, k3, h)
    k4 = f(t + h, y4)
    out = np.empty(5)
    combine(y, k1, k2, k3, k4, h / 6.0, out)
    np.testing.assert_array_equal(out, rk4_step(f, t, y, h))


def test_the_divergence_check():
    x, z = np.zeros(6), np.ones(1)
    assert within_limits(x, z, np.array([1e3, -1e3, 0.0]), 1e3)
    assert not within_limits(x, z, np.array([0.0, -1e3 - 1e-9, 0.0]), 1e3)
    assert not within_limits(np.array([np.nan]), z, np.zeros(3), 1e3)
    assert not within_limits(x, np.array([np.inf]), np.zeros(3), 1e3)


def test_records_read_by_name_in_python_too():
    """The records that the kernels read are np.record/np.recarray: fields as attributes in plain
    Python (the fallback without numba) as in compiled code."""
    controller = record(CONTROLLER, xi=0.5, D=(1.0, 2.0, 3.0))
    assert controller.xi == 0.5 and controller.D[2] == 3.0 and controller.geometry.R == 0.0
    table = records(CONTROLLER, 2)
    table[1].xi = 2.0
    assert table.xi.tolist() == [0.0, 2.0]
    with pytest.raises(ValueError):
        record(CONTROLLER, no_such_field=1.0)


def test_smallest_eigenvalue_in_closed_form_is_lapacks():
    """Smith's closed form against LAPACK's eigvalsh on random symmetric positive matrices (the
    nominal inertias it serves are SPD with condition numbers below ~100), a diagonal matrix and
    one with a double eigenvalue: within 1e-13 of the largest eigenvalue (rounding of acos near
    its ends; measured 8e-15 worst over 2000 draws)."""
    from delta_pin.compiled.digital_laws import smallest_eigenvalue

    rng = np.random.default_rng(7)
    matrices = [np.diag([3.0, 1.0, 2.0]), np.diag([2.0, 2.0, 5.0]) + 0.0]
    for _ in range(500):
        b = rng.normal(size=(3, 3))
        matrices.append(b @ b.T + rng.uniform(0.0, 0.1) * np.eye(3))
    rotation = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    matrices.append(rotation @ np.diag([1.0, 1.0, 4.0]) @ rotation.T)  # a double smallest eigenvalue
    for matrix in matrices:
        values = np.linalg.eigvalsh(matrix)
        assert abs(smallest_eigenvalue(matrix) - values[0]) <= 1e-13 * abs(values[-1])


def test_numba_caches_are_dropped_when_any_source_of_the_package_changes(tmp_path):
    """numba checks a cached function against its own file only; a changed callee or record layout
    in another file must drop every cache (a stale caller crashed the digital loop once)."""
    from delta_pin.compiled.jit import invalidate_stale_caches

    (tmp_path / "kernels.py").write_text("def f():\n    return 1\n")
    (tmp_path / "layouts.py").write_text("A = 1\n")
    cache = tmp_path / "__pycache__"
    cache.mkdir()
    (cache / "kernels.f-1.py311.nbi").write_bytes(b"index")
    assert invalidate_stale_caches(tmp_path)  # no stamp yet: the caches' sources are unknown
    assert not (cache / "kernels.f-1.py311.nbi").exists()
    (cache / "kernels.f-1.py311.nbc").write_bytes(b"code")  # compiled against these sources
    assert not invalidate_stale_caches(tmp_path)
    assert (cache / "kernels.f-1.py311.nbc").exists()
    (tmp_path / "layouts.py").write_text("A = 2\n")  # another file than the cached function's
    assert invalidate_stale_caches(tmp_path)
    assert not (cache / "kernels.f-1.py311.nbc").exists()
