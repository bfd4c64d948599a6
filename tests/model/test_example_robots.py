"""The shipped closed-chain robots (delta_pin/robots/), loaded through ``load_robot``.

References and tolerances:

* the MJCF Delta and the Gepetto Delta against the xacro Delta's analytic model (eqs. 7-9, exact
  for the lumped forearm): 1e-10 on M, C alpha_dot and G. The projections agree with the analytic
  model to ~1e-13 (docs/architecture.md section 5); the MJCF Delta carries MuJoCo's inertia floor
  of 1e-12 kg m^2 (scripts/make_example_robots.py), which moves M by ~2e-12;
* free fall: 0.5 s from rest, zero torque, RK4 on the projected dynamics at 5 ms, the actuated
  angles of every shape within 1e-8 rad of the analytic model's (same integrator and step, so only
  the models differ; a 1e-12 model difference grows to ~1e-11 rad over 0.5 s);
* the 3-RRR as URDF and as MJCF (point + weld): 1e-10 on the reduced terms (two independent
  routes to the same tree: Pinocchio's URDF parser vs MuJoCo's compiler and our conversion);
* the five-bar's G against central differences of Pinocchio's potential energy on assembled
  configurations (h = 1e-6 rad: truncation ~1e-12, round-off ~1e-10 N m): 1e-7 N m;
* Pinocchio's ``constraintDynamics`` on the closures vs the projected dynamics: 1e-8 rad/s^2
  (its proximal solver is run to 1e-12).
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import delta_pin as dp
from delta_pin.errors import AssemblyError, InvalidParameterError, URDFConventionError
from delta_pin.model.loaders import load_robot
from tests.model.closed_chain_fixtures import assert_same_numbers

pytest.importorskip("mujoco")

ROOT = Path(__file__).resolve().parents[2]
ROBOTS = ROOT / "delta_pin" / "robots"
STATES = (
    (np.array([0.3, 0.45, 0.6]), np.array([0.7, -1.1, 0.4])),
    (np.array([0.1, -0.2, 0.35]), np.array([-0.5, 0.9, 1.3])),
    (np.array([0.55, 0.25, 0.05]), np.array([1.2, 0.3, -0.8])),
)
TABLE1_G = 9.8  # [m/s^2] the paper's (and the MJCF's); a URDF has none, so the Gepetto Delta is given it


@pytest.fixture(scope="module")
def xacro_delta():
    return dp.load_delta()


@pytest.fixture(scope="module")
def delta_shapes():
    return {
        "mjcf": load_robot(ROBOTS / "delta.xml"),
        "gepetto": load_robot(ROBOTS / "delta_gepetto" / "robot.urdf", g=TABLE1_G),
    }


def test_script_reproduces_every_shipped_file_number_by_number():
    """scripts/make_example_robots.py writes every file in delta_pin/robots: the same words, the
    numbers to 1e-12 relative (assert_same_numbers: not bytes, which differ across BLAS builds)."""
    spec = importlib.util.spec_from_file_location(
        "make_example_robots", ROOT / "scripts" / "make_example_robots.py"
    )
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    written = script.all_files()
    shipped = {
        str(p.relative_to(ROBOTS))
        for p in ROBOTS.rglob("*")
        if p.is_file() and p.suffix in (".urdf", ".xml", ".yaml")
    }
    assert shipped == set(written)
    for name, text in written.items():
        assert_same_numbers((ROBOTS / name).read_text(encoding="utf-8"), text, name)


@pytest.mark.parametrize("shape", ["mjcf", "gepetto"])
def test_delta_shapes_have_the_xacro_deltas_reduced_dynamics(shape, delta_shapes, xacro_delta):
    robot = delta_shapes[shape]
    assert robot.actuated_joints == ("active_1", "active_2", "active_3")
    assert [c.kind for c in robot.closures] == ["3d"] * 3
    for alpha, alpha_dot in STATES:
        M, _C, G, coriolis = robot.reduced_terms(alpha, alpha_dot)
        reference = xacro_delta.analytic_dynamics(alpha, alpha_dot)
        np.testing.assert_allclose(M, reference.M, rtol=0, atol=1e-10)
        np.testing.assert_allclose(G, reference.G, rtol=0, atol=1e-10)
        np.testing.assert_allclose(coriolis, reference.coriolis, rtol=0, atol=1e-10)
        # and the xacro Delta's own Pinocchio projection (another route)
        pinocchio = xacro_delta.pinocchio_dynamics(alpha, alpha_dot)
        np.testing.assert_allclose(M, pinocchio.M, rtol=0, atol=1e-10)


@pytest.mark.parametrize("shape", ["mjcf", "gepetto"])
def test_delta_shapes_are_recognised(shape, delta_shapes):
    delta = delta_shapes[shape].delta
    assert delta is not None
    p = delta.params
    assert (p.R, p.r, p.l_a, p.l_b, p.m_a, p.m_b, p.m_o) == pytest.approx(
        (0.15, 0.08, 0.2, 0.4, 0.2, 0.2, 0.3), abs=1e-12
    )
    assert p.g == pytest.approx(TABLE1_G, abs=1e-12)


def _free_fall(terms, alpha0: np.ndarray, duration: float = 0.5, dt: float = 5e-3) -> np.ndarray:
    """RK4 on alpha_ddot = M^-1 (-C alpha_dot - G) (zero torque); the actuated angles at each step."""

    def rhs(x):
        M, coriolis, G = terms(x[:3], x[3:])
        return np.concatenate([x[3:], np.linalg.solve(M, -coriolis - G)])

    x = np.concatenate([alpha0, np.zeros(3)])
    path = [x[:3].copy()]
    for _ in range(round(duration / dt)):
        k1 = rhs(x)
        k2 = rhs(x + dt / 2 * k1)
        k3 = rhs(x + dt / 2 * k2)
        k4 = rhs(x + dt * k3)
        x = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        path.append(x[:3].copy())
    return np.array(path)


def test_delta_shapes_fall_alike(delta_shapes, xacro_delta):
    alpha0 = np.array([0.2, -0.1, 0.35])

    def analytic(alpha, alpha_dot):
        d = xacro_delta.analytic_dynamics(alpha, alpha_dot)
        return d.M, d.coriolis, d.G

    reference = _free_fall(analytic, alpha0)
    assert np.ptp(reference, axis=0).min() > 0.1  # it does fall (the arms swing by > 0.1 rad)
    for shape, robot in delta_shapes.items():

        def projected(alpha, alpha_dot, robot=robot):
            M, _C, G, coriolis = robot.reduced_terms(alpha, alpha_dot)
            return M, coriolis, G

        path = _free_fall(projected, alpha0)
        assert np.abs(path - reference).max() < 1e-8, shape


@pytest.fixture(scope="module")
def three_rrr():
    return load_robot(ROBOTS / "three_rrr.urdf"), load_robot(ROBOTS / "three_rrr.xml")


def test_three_rrr_urdf_and_mjcf_agree(three_rrr):
    urdf, mjcf = three_rrr
    for robot in three_rrr:
        assert [c.kind for c in robot.closures] == ["3d", "6d"]
        assert robot.dof == 3 and robot.model.nv == 8
    assert urdf.model.gravity.linear == pytest.approx(mjcf.model.gravity.linear, abs=1e-15)
    for alpha, alpha_dot in (
        (np.zeros(3), np.array([0.4, -0.3, 0.2])),
        (np.array([0.1, -0.15, 0.05]), np.ones(3)),
    ):
        a, b = urdf.reduced_terms(alpha, alpha_dot), mjcf.reduced_terms(alpha, alpha_dot)
        for mine, theirs in zip(a, b):
            np.testing.assert_allclose(mine, theirs, rtol=0, atol=1e-10)
        x_urdf = urdf.frame_placement(urdf.configuration(alpha), "platform").translation
        x_mjcf = mjcf.frame_placement(mjcf.configuration(alpha), "platform").translation
        np.testing.assert_allclose(x_urdf, x_mjcf, rtol=0, atol=1e-12)


def _constraint_acceleration(robot, alpha, alpha_dot, tau):
    """alpha_ddot from Pinocchio's constraintDynamics on the closures (an independent route)."""
    q, v = robot.state(alpha, alpha_dot)
    full = np.zeros(robot.model.nv)
    full[robot.actuated_indices] = tau
    data = robot.model.createData()
    datas = pin.StdVec_RigidConstraintData()
    for constraint in robot.constraint_models:
        datas.append(constraint.createData())
    pin.initConstraintDynamics(robot.model, data, robot.constraint_models, datas)
    settings = pin.ProximalSettings(1e-13, 1e-12, 50)
    a = pin.constraintDynamics(robot.model, data, q, v, full, robot.constraint_models, datas, settings)
    return a[robot.actuated_indices]


@pytest.mark.parametrize("name", ["three_rrr.xml", "five_bar.urdf"])
def test_projected_dynamics_match_pinocchios_constraint_dynamics(name, three_rrr):
    robot = three_rrr[1] if name == "three_rrr.xml" else load_robot(ROBOTS / name)
    rng = np.random.default_rng(3)
    for _ in range(2):
        alpha = robot.home + rng.uniform(-0.1, 0.1, robot.dof)
        alpha_dot, tau = rng.uniform(-1, 1, robot.dof), rng.uniform(-0.5, 0.5, robot.dof)
        M, _C, G, coriolis = robot.reduced_terms(alpha, alpha_dot)
        projected = np.linalg.solve(M, tau - coriolis - G)
        np.testing.assert_allclose(
            _constraint_acceleration(robot, alpha, alpha_dot, tau), projected, atol=1e-8
        )


def test_five_bar_loads_assembles_and_its_gravity_is_the_potentials_gradient():
    robot = load_robot(ROBOTS / "five_bar.urdf")
    assert robot.actuated_joints == ("active_1", "active_2")  # from the <transmission> elements
    assert robot.delta is None and robot.dof == 2
    robot.set_end_effector("tip")
    q = robot.configuration(np.zeros(2))
    assert robot.closure_gap(q) < 1e-12
    # the symmetric pose: the tip on the axis, below the elbows (0.25 + sqrt(0.3^2 - 0.1^2) m down)
    np.testing.assert_allclose(
        robot.frame_placement(q).translation, [0, 0, -0.25 - np.sqrt(0.08)], atol=1e-12
    )
    alpha = np.array([0.2, -0.1])
    _M, _C, G, _c = robot.reduced_terms(alpha, np.zeros(2))

    def potential(a):
        q = robot.configuration(a)
        return pin.computePotentialEnergy(robot.model, robot.model.createData(), q)

    h = 1e-6
    gradient = [(potential(alpha + h * e) - potential(alpha - h * e)) / (2 * h) for e in np.eye(2)]
    np.testing.assert_allclose(G, gradient, rtol=0, atol=1e-7)
    assert np.abs(G).max() > 0.05  # gravity acts in the plane of motion


def _five_bar_with(tmp_path: Path, old: str, new: str) -> Path:
    text = (ROBOTS / "five_bar.urdf").read_text()
    assert old in text
    path = tmp_path / "five_bar.urdf"
    path.write_text(text.replace(old, new))
    return path


def test_five_bar_with_one_actuator_is_a_mobility_error():
    with pytest.raises(AssemblyError, match=r"2 degree\(s\) of freedom .* but 1 actuator\(s\) \(active_1\)"):
        load_robot(ROBOTS / "five_bar.urdf", actuated=["active_1"])


def test_five_bar_with_three_actuators_is_a_mobility_error():
    # a third actuator (passive_1) pins a joint the loop needs: the loop cannot close at the
    # reference, and the error says why -- 2 degrees of freedom, 3 actuators
    with pytest.raises(AssemblyError, match=r"has 2 degree\(s\) of freedom .* but 3 actuator\(s\)"):
        load_robot(ROBOTS / "five_bar.urdf", actuated=["active_1", "active_2", "passive_1"])


def test_five_bar_closure_to_a_missing_link_is_named_with_its_line(tmp_path):
    path = _five_bar_with(
        tmp_path, '<child link="distal_2"/>\n    <child_origin', '<child link="distal_9"/>\n    <child_origin'
    )
    with pytest.raises(
        URDFConventionError,
        match=r"constraint 'distal_tips' \(five_bar.urdf line \d+\) names link 'distal_9'",
    ):
        load_robot(path)


def test_five_bar_that_cannot_assemble_names_the_closure(tmp_path):
    # distal links 0.05 m long cannot bridge the 0.2 m between the elbows at alpha = 0 ...
    path = _five_bar_with(tmp_path, '<parent_origin xyz="0 0 -0.3"/>', '<parent_origin xyz="0 0 -0.05"/>')
    text = path.read_text().replace('<child_origin xyz="0 0 -0.3"/>', '<child_origin xyz="0 0 -0.05"/>')
    path.write_text(text)
    with pytest.raises(
        AssemblyError,
        match=r"loops do not close with the actuated joints at home=\[0.0, 0.0\]: closure 'distal_tips' "
        r"\(five_bar.urdf line \d+\) stays .* give a reachable home= \(CLI --home\)",
    ):
        load_robot(path, home=[0.0, 0.0])
    # ... but the global assembly (every joint free) swings the proximal links together: the
    # loops then close exactly (Newton's 1e-12) and home is where they do
    robot = load_robot(path)
    assert robot.closure_gap(robot.reference_configuration) <= 1e-12
    assert np.abs(robot.home).max() > 0.1
    assert "the file's pose leaves the loops" in robot.summary()


def test_five_bar_actuator_on_an_unknown_joint():
    with pytest.raises(InvalidParameterError, match=r"actuated joint 'motor_9' is not in the model"):
        load_robot(ROBOTS / "five_bar.urdf", actuated=["active_1", "motor_9"])
