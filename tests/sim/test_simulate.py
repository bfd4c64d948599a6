"""The closed-loop runner: timing modes, recorded data, saving, and bad input."""

import json

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.control import ComputedTorque, DeltaNominalModel
from delta_pin.model.friction import Friction
from delta_pin.model.trajectory import PathI, SplinePath
from delta_pin.sim.run import load_run
from delta_pin.sim.runner import simulate
from delta_pin.sim.uncertainty import PaperUncertainty

START = np.array([0.0, 0.0, -0.35])


def _hold(robot):
    alpha0 = robot.inverse_kinematics(START)
    G0 = robot.analytic_dynamics(alpha0, np.zeros(3)).G
    return alpha0, lambda t, a, ad: G0 + 2.0 * (alpha0 - a) - 0.1 * ad


def test_pinocchio_closure_stays_below_1e9_over_15s_of_path_i(robot):
    controller = ComputedTorque(DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6)))
    run = simulate(
        robot,
        controller,
        PathI(),
        plant="pinocchio",
        t_end=15.0,
        alpha0=np.full(3, 0.3322),
        friction=Friction(),
        uncertainty=PaperUncertainty(),
    )
    assert run.closure_residual.max() <= 1e-9  # [m]
    assert run.t[-1] == pytest.approx(15.0)
    np.testing.assert_allclose(run.xyz_d, PathI().position(run.t), atol=1e-15)
    # the platform really follows the spiral (C1 + C2 alone converge slowly: ~7 mm at 5 s, ~3 mm later)
    assert np.linalg.norm(run.xyz - run.xyz_d, axis=1)[run.t > 10].max() < 5e-3


def test_sampled_mode_holds_the_torque_over_each_period(robot):
    alpha0, hold = _hold(robot)
    seen = []

    def controller(t, a, ad):
        seen.append(t)
        return hold(t, a, ad) + 0.01 * np.sin(7.0 * t)

    run = simulate(robot, controller, alpha0=alpha0, plant="analytic", t_end=0.05, dt=1e-3, substeps=4)
    np.testing.assert_allclose(seen, run.t, atol=1e-15)  # evaluated exactly once per sample
    assert len(run) == 51


def test_continuous_and_fast_sampled_runs_agree(robot):
    """A smooth controller sampled at 10 kHz approaches the continuous loop (ZOH error ~ dt)."""
    controller = ComputedTorque(DeltaNominalModel(robot))
    runs = [
        simulate(
            robot,
            controller,
            PathI(),
            plant="analytic",
            t_end=1.0,
            dt=dt,
            mode=mode,
            alpha0=np.full(3, 0.3322),
        )
        for dt, mode in ((1e-3, "continuous"), (1e-4, "sampled"))
    ]
    sampled = runs[1].alpha[::10]
    assert np.abs(sampled - runs[0].alpha).max() < 1e-4  # [rad]
    assert np.abs(runs[0].alpha - runs[0].alpha_d).max() > 0.05  # the loop does real work


def test_alpha0_defaults_to_the_path_start_and_to_home_without_one(robot):
    run = simulate(robot, ComputedTorque(DeltaNominalModel(robot)), PathI(), plant="analytic", t_end=0.01)
    np.testing.assert_allclose(run.alpha[0], robot.inverse_kinematics(START), atol=1e-12)
    # no path: a hold of the robot's assembled home (exactly: the run starts there)
    held = simulate(robot, lambda t, a, ad: np.zeros(3), t_end=0.01)
    np.testing.assert_array_equal(held.alpha[0], robot.home)


def test_run_round_trips_through_an_atomic_save(robot, tmp_path):
    controller = ComputedTorque(DeltaNominalModel(robot))
    run = simulate(
        robot,
        controller,
        PathI(),
        plant="analytic",
        t_end=0.05,
        uncertainty=PaperUncertainty(),
        friction=True,
    )
    path = run.save(tmp_path / "deep" / "run.npz")
    assert sorted(p.name for p in path.parent.iterdir()) == ["run.npz"]  # no temporary file left
    again = load_run(path)
    for name in (
        "t",
        "alpha",
        "alpha_dot",
        "alpha_d",
        "alpha_dot_d",
        "xyz",
        "xyz_d",
        "tau",
        "closure_residual",
    ):
        np.testing.assert_array_equal(getattr(again, name), getattr(run, name))
    assert json.loads(json.dumps(run.metadata, default=list))["mode"] == again.metadata["mode"] == "sampled"
    assert again.metadata["uncertainty"]["kind"] == "paper"
    assert again.metadata["robot"]["l_a"] == 0.2


def test_failed_save_leaves_nothing(robot, tmp_path):
    alpha0, hold = _hold(robot)
    run = simulate(robot, hold, alpha0=alpha0, plant="analytic", t_end=0.01)
    run.metadata["bad"] = object()
    with pytest.raises(TypeError):
        run.save(tmp_path / "run.npz")
    assert list(tmp_path.iterdir()) == []


def test_missing_run_file_is_a_clear_error(tmp_path):
    with pytest.raises(dp.DeltaPinError, match="does not exist"):
        load_run(tmp_path / "nope.npz")


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"dt": 0.0}, "dt=0.0"),
        ({"dt": -1e-3}, "dt=-0.001"),
        ({"t_end": 0.0}, "t_end=0.0"),
        ({"mode": "discrete"}, "mode='discrete'"),
        ({"plant": "mujoco"}, "plant='mujoco'"),
        ({"substeps": 0}, "substeps=0"),
        ({"integrator": "lsoda"}, "integrator='lsoda'"),
        # LSODA and continuous RK4 left the package with the Python loop (tests/reference)
        ({"integrator": "lsoda", "mode": "continuous"}, "integrator='lsoda' does not run mode='continuous'"),
        ({"integrator": "rk4", "mode": "continuous"}, "integrator='rk4' does not run mode='continuous'"),
    ],
)
def test_bad_arguments_are_refused(robot, kwargs, message):
    alpha0, hold = _hold(robot)
    with pytest.raises(dp.InvalidParameterError, match=message):
        simulate(robot, hold, alpha0=alpha0, **{"t_end": 0.1, **kwargs})


def test_non_finite_torque_names_the_time(robot):
    alpha0, hold = _hold(robot)

    def broken(t, a, ad):
        return hold(t, a, ad) * (np.nan if t >= 0.0125 else 1.0)

    with pytest.raises(dp.SimulationError, match=r"non-finite torque.*t=0\.013 s"):
        simulate(robot, broken, alpha0=alpha0, plant="analytic", t_end=0.1)


def test_wrong_torque_shape_names_the_time(robot):
    alpha0, _ = _hold(robot)
    with pytest.raises(dp.SimulationError, match=r"shape \(2,\).*t=0 s"):
        simulate(robot, lambda t, a, ad: np.zeros(2), alpha0=alpha0, t_end=0.1)


@pytest.mark.parametrize("plant", ["analytic", "pinocchio"])
def test_divergence_names_the_time(robot, plant):
    alpha0, _ = _hold(robot)
    with pytest.raises(dp.SimulationError, match=r"t=\d"):
        simulate(
            robot,
            lambda t, a, ad: np.full(3, 50.0) if t > 0.02 else np.zeros(3),
            alpha0=alpha0,
            plant=plant,
            t_end=2.0,
        )


def test_path_outside_the_workspace_fails_before_the_run(robot, tmp_path):
    dive = SplinePath([0.0, 1.0], [[0.0, 0.0, -0.35], [0.0, 0.0, -0.9]])
    calls = []
    with pytest.raises(dp.UnreachablePoseError, match=r"t=0\.\d+ s: xyz="):
        simulate(robot, lambda t, a, ad: calls.append(t) or np.zeros(3), dive, t_end=1.0)
    assert calls == []  # the controller never ran


def test_progress_is_shown_only_when_asked(robot, capsys):
    alpha0, hold = _hold(robot)
    simulate(robot, hold, alpha0=alpha0, plant="analytic", t_end=0.2)
    assert capsys.readouterr().err == ""  # library default: quiet
    simulate(robot, hold, alpha0=alpha0, plant="analytic", t_end=0.2, progress=True)
    err = capsys.readouterr().err
    assert "simulate: " in err and "(100%)" not in err.splitlines()[0]


def test_a_run_prints_as_one_line(robot):
    """repr(run) used to print every array and the whole URDF (~17 kB for 10 samples; issue 15)."""
    run = simulate(robot, lambda t, a, ad: np.zeros(3), alpha0=np.full(3, 0.3), plant="analytic", t_end=0.01)
    text = repr(run)
    assert "\n" not in text and len(text) < 200
    assert "11 samples" in text and "plant='analytic'" in text and "mode='sampled'" in text
