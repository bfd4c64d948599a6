"""The closed-chain plant, the projected nominal model and the controllers on any closed-chain
robot (a five-bar written here, and the Delta's URDF loaded as a closed-chain robot)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.cli import main
from delta_pin.errors import InvalidParameterError
from delta_pin.sim.closed_chain_validation import validate_closed_chain
from tests.model.closed_chain_fixtures import five_bar_urdf
from tests.reference.plants import ReadableClosedChainPlant

CIRCLE = dict(center=[-0.03, 0.0, -0.4], radius=0.03, period=1.0, plane="xz")  # starts at the home tip


@pytest.fixture()
def five_bar_path(tmp_path):
    path = tmp_path / "five_bar.urdf"
    path.write_text(five_bar_urdf())
    return path


@pytest.fixture()
def five_bar(five_bar_path):
    return dp.load_robot(five_bar_path, end_effector="tip")


def test_plant_accelerations_equal_the_projected_dynamics(five_bar):
    """constraintDynamics on the tree (a redundant planar closure: proximal iterations) and
    M^-1 (tau - C alpha_dot - G) by projection are independent routes: 1e-10 relative."""
    plant = ReadableClosedChainPlant(five_bar)
    assert plant.redundant
    rng = np.random.default_rng(3)
    for _ in range(3):
        alpha, alpha_dot, tau = (
            five_bar.home + rng.uniform(-0.1, 0.1, 2),
            rng.normal(size=2),
            rng.normal(size=2),
        )
        x = plant.initial_state(alpha, alpha_dot)
        plant_acceleration = plant.derivative(0.0, x, tau)[plant.nq + plant.active]
        M, _, G, coriolis = five_bar.reduced_terms(alpha, alpha_dot)
        projected = np.linalg.solve(M, tau - coriolis - G)
        np.testing.assert_allclose(
            plant_acceleration, projected, rtol=0, atol=1e-10 * np.abs(projected).max()
        )


def test_payload_and_friction_enter_the_plant_as_stated(five_bar):
    """m(t) at the tip equals the projection of the robot carrying that mass; the friction torque
    is eq. 12's Stribeck law on the actuated joints."""
    stribeck = dp.StribeckParameters(r_a=0.04, v_s=0.1, mu_s=0.2, mu_d=0.1, mu_v=2.0)
    friction = dp.Friction(stribeck=stribeck, normal_force=10.0)
    plant = ReadableClosedChainPlant(five_bar, friction, payload_mass=lambda t: 0.2 + t, payload_frame="tip")
    alpha, alpha_dot, tau = five_bar.home + 0.05, np.array([0.3, -0.6]), np.array([0.5, 0.1])
    x = plant.initial_state(alpha, alpha_dot)
    t = 0.3
    acceleration = plant.derivative(t, x, tau)[plant.nq + plant.active]
    heavier = five_bar.with_payload(0.5, "tip")
    M, _, G, coriolis = heavier.reduced_terms(alpha, alpha_dot, x[: plant.nq])
    expected = np.linalg.solve(M, tau - plant.joint_friction(alpha_dot) - coriolis - G)
    np.testing.assert_allclose(acceleration, expected, rtol=0, atol=1e-10 * np.abs(expected).max())
    stribeck_torque = (
        10.0
        * 0.04
        * (0.1 + (0.2 - 0.1) * np.exp(-((alpha_dot * 0.04 / 0.1) ** 2)))
        * np.tanh(alpha_dot / 0.01)
        + 2.0 * alpha_dot * 0.04  # mu_v alpha_dot r_a
    )
    np.testing.assert_allclose(plant.joint_friction(alpha_dot), stribeck_torque, rtol=1e-12)


def test_full_and_active_coordinates_agree(five_bar):
    """Both state forms of the plant, RK4 at 1 ms for 0.3 s under a constant torque (a 0.7 rad
    swing): 1e-8 rad -- RK4's truncation differs between the two coordinate sets (~2e-9 rad)."""
    runs = []
    for coordinates in ("full", "active"):
        plant = dp.ClosedChainPlant(five_bar, coordinates=coordinates)
        run = dp.simulate(
            five_bar,
            lambda t, a, ad: np.array([0.2, -0.1]),
            None,
            plant=plant,
            t_end=0.3,
            alpha0=five_bar.home,
        )
        runs.append(run)
    np.testing.assert_allclose(runs[0].alpha, runs[1].alpha, rtol=0, atol=1e-8)


def test_design_one_tracks_a_circle_of_the_five_bar_tip(five_bar):
    """Continuous design I with the projected nominal model on the constrained plant carrying an
    unmodelled, time-varying payload: the tip stays within 0.05 mm of the circle after 0.5 s."""
    nominal = dp.ClosedChainNominalModel(five_bar)
    payload = lambda t: 0.1 * (1.0 + np.sin(2 * np.pi * t))  # noqa: E731
    plant = dp.ClosedChainPlant(five_bar, payload_mass=payload, coordinates="active")  # q, v completed
    run = dp.simulate(
        five_bar, dp.design1(nominal), dp.FramePath(dp.Circle(**CIRCLE)), plant=plant, t_end=1.0,
        mode="continuous", alpha0=five_bar.home,
    )  # fmt: skip
    late = run.t >= 0.5
    task_error = np.linalg.norm(run.xyz - run.xyz_d, axis=1)[late].max()
    assert task_error < 5e-5, task_error
    assert run.closure_residual.max() < 1e-10
    # the payload's m(t) tabulated on the reference's grid: the core's Radau runs it
    assert run.metadata["integrator"] == "radau" and run.metadata["core_plant"]


@pytest.mark.parametrize("controller", ["design2", "ctc", "pd", "lqr", "tdc", "digital-robust"])
def test_every_controller_runs_on_a_closed_chain_robot(five_bar, controller):
    from delta_pin.studies.closed_chain_run import run_closed_chain

    aware = controller == "design2"  # the one switch it has: sampled at 1 kHz it needs the cap
    run, description = run_closed_chain(
        five_bar, controller=controller, frame="tip", mode="sampled", t_end=0.3, sampling_aware=aware
    )
    assert description["plane"] == "xz"  # the five-bar moves in the vertical plane
    assert np.isfinite(run.alpha).all() and run.closure_residual.max() < 1e-9
    assert np.abs(run.xyz[0] - run.xyz_d[0]).max() < 1e-9  # the circle starts at home
    assert np.abs(run.alpha - run.alpha_d).max() < 0.05


def test_the_core_runs_closed_chains_and_other_integrators_are_refused_by_name(five_bar):
    nominal = dp.ClosedChainNominalModel(five_bar)

    payload = dp.ClosedChainPlant(five_bar, payload_mass=lambda t: 0.1, coordinates="active")
    run = dp.simulate(
        five_bar, dp.PDGravity(nominal), None, plant=payload, t_end=0.1, alpha0=five_bar.home,
        mode="continuous",
    )  # fmt: skip
    assert run.metadata["core_plant"] and run.metadata["integrator"] == "radau"  # a payload runs compiled
    for mode in ("sampled", "continuous"):
        run = dp.simulate(five_bar, dp.PDGravity(nominal), None, t_end=0.01, alpha0=five_bar.home, mode=mode)
        assert run.q is not None and run.metadata["core_plant"]  # the full configuration, from the core
    run = dp.simulate(  # the core's BDF2 takes any closed chain
        five_bar, dp.PDGravity(nominal), None, t_end=0.1, alpha0=five_bar.home, mode="continuous",
        integrator="bdf2",
    )  # fmt: skip
    assert run.metadata["core_plant"] and run.metadata["integrator"] == "bdf2"
    for integrator in ("rk4", "lsoda"):  # continuous RK4 and LSODA left with the Python loop
        refused = rf"integrator='{integrator}' does not run mode='continuous'"
        with pytest.raises(InvalidParameterError, match=refused):
            dp.simulate(
                five_bar, dp.PDGravity(nominal), None, t_end=0.1, alpha0=five_bar.home, mode="continuous",
                integrator=integrator,
            )  # fmt: skip
    with pytest.raises(InvalidParameterError, match="not a recognised Delta"):
        dp.simulate(five_bar, dp.PDGravity(nominal), None, t_end=0.1, alpha0=five_bar.home, plant="analytic")
    with pytest.raises(InvalidParameterError, match="FramePath"):
        dp.simulate(five_bar, dp.PDGravity(nominal), dp.PathI(), t_end=0.1)


def test_validate_passes_on_the_five_bar_and_catches_a_wrong_model(five_bar):
    report = validate_closed_chain(five_bar, samples=4, energy_duration=0.1)
    assert report.passed, report.table()
    assert report.checks["plant"][0] < 1e-10
    # a plant whose gravity differs from the model's: the plant check must fail
    five_bar.model.gravity.linear = np.array([0.0, 0.0, -9.0])  # the robot's own model, not the plant's copy
    five_bar.model_changed()  # its compiled copy (G) follows
    broken = validate_closed_chain(five_bar, samples=2, energy_duration=0.01)
    assert broken.checks["gravity"][0] < 1e-6  # G and V use the same (changed) model
    assert not broken.passed or broken.checks["plant"][0] < 1e-8


def test_cli_run_and_validate_on_a_robot_file(five_bar_path, tmp_path, capsys):
    out = tmp_path / "run"
    arguments = ["run", "--robot", str(five_bar_path), "--frame", "tip", "--mode", "sampled"]
    assert main([*arguments, "--sampling-aware", "--t-end", "0.3", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["run"]["reference"] == "circle" and summary["robot"]["dof"] == 2
    assert summary["closure_residual_max"] < 1e-9
    run = dp.load_run(out / "run.npz")
    assert run.alpha.shape == (301, 2)
    assert main(["validate", "--robot", str(five_bar_path), "--samples", "3"]) == 0
    assert "all checks passed" in capsys.readouterr().out
    assert main(["run", "--robot", str(five_bar_path), "--frame", "hand", "--out", str(out)]) == 2
    assert "has no frame 'hand'" in capsys.readouterr().err
    assert main(["run", "--frame", "tip", "--out", str(out)]) == 2
    assert main(["validate", "--robot", str(tmp_path / "none.urdf")]) == 2


def test_the_delta_from_each_file_shape_runs_design_one_alike():
    """The Table 1 Delta from its xacro URDF, from MJCF and from URDF + robot.yaml: design I on the
    projected nominal model, each on its own constrained plant, along path I (the recognised
    Delta's task-space path) for 0.3 s at 1 kHz. The three robots are one robot, so the runs
    agree to 1e-8 rad (the MJCF's inertias carry MuJoCo's 1e-12 kg m^2 floor: ~1e-10 relative)."""
    pytest.importorskip("mujoco")
    runs = {}
    for name in ("xacro", "delta_mjcf", "delta_gepetto"):
        source = dp.model.description.default_xacro_path().parent / "delta.urdf" if name == "xacro" else name
        robot = dp.load_robot(source, g=9.8)
        assert robot.delta is not None
        nominal = dp.ClosedChainNominalModel(robot)
        runs[name] = dp.simulate(
            robot, dp.design1(nominal, sampling_period=1e-3), dp.PathI(), t_end=0.3, mode="sampled"
        )
        assert runs[name].closure_residual.max() < 1e-9
    for name in ("delta_mjcf", "delta_gepetto"):
        np.testing.assert_allclose(runs[name].alpha, runs["xacro"].alpha, rtol=0, atol=1e-8)
    assert np.abs(runs["xacro"].alpha - runs["xacro"].alpha_d).max() < 1e-3


def test_a_path_the_frame_cannot_follow_names_the_time(five_bar):
    """A 0.5 m circle leaves the five-bar's reach (0.55 m links from a 0.2 m base): the error
    names the first sample the tip cannot reach."""
    path = dp.FramePath(dp.Circle(center=[0.0, 0.0, -0.4], radius=0.5, period=1.0, plane="xz"), frame="tip")
    with pytest.raises(dp.UnreachablePoseError, match=r"^t=0 s: .*frame 'tip' cannot reach"):
        path.joint_reference(five_bar, np.linspace(0.0, 1.0, 11))
