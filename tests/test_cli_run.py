"""``delta-pin run``: files written, summary consistent with the saved run, bad input."""

import json

import numpy as np
import pytest

from delta_pin.cli import main
from delta_pin.sim.run import load_run
from delta_pin.studies.experiments import CONTROLLERS
from delta_pin.studies.metrics import compute_metrics

FAST = ["--plant", "analytic", "--mode", "sampled", "--sampling-aware"]  # a sub-second run


def test_run_writes_a_loadable_run_and_a_consistent_summary(tmp_path, capsys):
    out = tmp_path / "design1"
    code = main(
        [
            "run",
            "--controller",
            "design1",
            "--plant",
            "analytic",
            "--mode",
            "sampled",
            "--sampling-aware",
            "--t-end",
            "0.5",
            "--out",
            str(out),
        ]
    )
    assert code == 0
    assert "max_task_error_mm" in capsys.readouterr().out
    run = load_run(out / "run.npz")
    summary = json.loads((out / "summary.json").read_text())
    recomputed = compute_metrics(run).as_dict()
    for name, value in summary["metrics"].items():
        expected = recomputed[name]
        if expected is not None and np.isnan(expected):  # a "last 5 s" index of a 0.5 s run
            assert value is None and name.endswith("_last_5s"), name
            continue
        assert value == (None if expected is None else pytest.approx(expected, rel=1e-12)), name
    assert summary["spec"]["controller"] == "design1" and summary["spec"]["sampling_aware"] is True
    assert run.metadata["controller"]["sampling_period"] == 1e-3
    np.testing.assert_allclose(run.alpha[0], np.full(3, 0.3322))  # the paper's initial deviation
    assert run.metadata["uncertainty"] == {
        "kind": "paper",
        "delta_m": 0.3,
        "delta_fc": 0.3,
        "delta_f": 0.3,
        "nominal_disturbance": [2.0, 4.0, 6.0],
    }


@pytest.mark.parametrize("controller", ["lqr", "ctc", "pd", "design2"])
def test_every_controller_runs_on_both_paths(tmp_path, controller):
    for path in ("I", "II"):
        out = tmp_path / f"{controller}_{path}"
        assert (
            main(
                [
                    "run",
                    "--controller",
                    controller,
                    "--path",
                    path,
                    *(FAST if controller == "design2" else FAST[:-1]),  # --sampling-aware: designs only
                    "--t-end",
                    "0.2",
                    "--no-friction-compensation",
                    "--out",
                    str(out),
                ]
            )
            == 0
        )
        summary = json.loads((out / "summary.json").read_text())
        assert summary["spec"]["friction_compensation"] is False


def test_seeded_uncertainty_is_reproducible(tmp_path):
    for name in ("a", "b"):
        main(
            [
                "run",
                *FAST,
                "--t-end",
                "0.2",
                "--seed",
                "7",
                "--out",
                str(tmp_path / name),
            ]
        )
    a, b = load_run(tmp_path / "a" / "run.npz"), load_run(tmp_path / "b" / "run.npz")
    np.testing.assert_array_equal(a.alpha, b.alpha)
    assert a.metadata["uncertainty"]["kind"] == "random" and a.metadata["uncertainty"]["seed"] == 7


def test_bad_input_is_a_clear_error(tmp_path, capsys):
    assert main(["run", "--dt", "-1", "--plant", "analytic", "--out", str(tmp_path)]) == 2
    assert "--dt: -1 must be a finite number of seconds > 0" in capsys.readouterr().err
    assert main(["run", "--uncertainty", "1.5", "--plant", "analytic", "--out", str(tmp_path)]) == 2
    assert "delta_m" in capsys.readouterr().err
    assert not (tmp_path / "run.npz").exists()


def test_unknown_gain_is_refused_with_its_name():
    from delta_pin.errors import InvalidParameterError
    from delta_pin.studies.experiments import RunSpec, run_spec

    with pytest.raises(InvalidParameterError, match="kappa"):
        run_spec(RunSpec(plant="analytic", gains={"kappa": 1.0}, t_end=0.1))


def test_run_on_a_digital_drive_reports_roughness_and_limit_hits(tmp_path):
    """The README's digital-drive command (shortened): an encoder, a delay, a torque limit and the
    time-delay controller; summary.json carries the drive's metrics, recomputed from run.npz."""
    out = tmp_path / "tdc"
    code = main(
        ["run", "--controller", "tdc", "--plant", "analytic", "--mode", "sampled", "--t-end", "5",
         "--encoder-bits", "17", "--velocity", "difference", "--delay", "1", "--torque-limit", "20",
         "--out", str(out)]
    )  # fmt: skip
    assert code == 0
    summary = json.loads((out / "summary.json").read_text())
    run = load_run(out / "run.npz")
    increments = np.linalg.norm(np.diff(run.tau, axis=0), axis=1)
    assert summary["metrics"]["torque_increment_rms_last_5s"] == pytest.approx(
        np.sqrt(np.mean(increments**2))
    )
    assert summary["metrics"]["torque_limit_hits"] == run.metadata["torque_limit_hits"] >= 0
    assert summary["spec"]["encoder_bits"] == 17 and run.metadata["sensor"]["bits"] == 17
    assert run.metadata["delay"] == 1 and run.metadata["controller"]["delay"] == 1


def test_a_rough_sampled_run_on_the_pinocchio_plant_completes_and_counts_its_projections(tmp_path, capsys):
    """TDC on 11-bit encoders drifts the loops by up to 1.7e-6 m in one 1 ms step: before issue 15
    `run` stopped at t = 1.323 s ("the loop-closure gap exploded to 1.060e-06 m", exit 1); the
    plant now projects such steps back, and summary.json says how many it projected."""
    out = tmp_path / "rough"
    code = main(
        ["run", "--controller", "tdc", "--mode", "sampled", "--t-end", "3", "--encoder-bits", "11",
         "--delay", "1", "--out", str(out)]
    )  # fmt: skip
    assert code == 0, capsys.readouterr().err
    summary = json.loads((out / "summary.json").read_text())
    run = load_run(out / "run.npz")
    assert summary["closure_projections"] == run.metadata["closure_projections"] > 1000
    # the core keeps the largest gap it projected back: above the projection tolerance, below
    # one step's drift (1.7e-6 m)
    assert run.metadata["core_plant"] and 1e-10 < summary["closure_gap_projected_max"] < 1e-5
    assert summary["closure_residual_max"] <= 1e-10  # [m] after the projections
    largest = f"{summary['closure_gap_projected_max']:.3g}"
    assert (
        f"{summary['closure_projections']} (largest gap projected back: {largest})" in capsys.readouterr().out
    )


def test_a_run_that_saturates_most_of_the_time_says_so(tmp_path, capsys):
    """digital-robust with a 5 N m limit (the paper's disturbance F̄ = [2, 4, 6] N m alone exceeds
    it on joint 3): the limit binds at most samples, and summary.json and the terminal both say so,
    with the count from run.npz."""
    out = tmp_path / "saturated"
    code = main(
        ["run", "--controller", "digital-robust", "--plant", "analytic", "--mode", "sampled",
         "--t-end", "0.2", "--encoder-bits", "17", "--delay", "1", "--torque-limit", "5", "--out", str(out)]
    )  # fmt: skip
    assert code == 0
    summary = json.loads((out / "summary.json").read_text())
    hits = load_run(out / "run.npz").metadata["torque_limit_hits"]
    assert hits > 0.5 * 201
    assert summary["warnings"] == [
        f"the drive saturates most of the time: the torque limit bound at {hits} of 201 samples"
    ]
    assert "warning: the drive saturates most of the time" in capsys.readouterr().out


def _discrete(controller: str) -> bool:
    """Whether the named controller is a discrete-time law (runs only in sampled mode)."""
    from delta_pin.model.delta_robot import load_delta
    from delta_pin.studies.experiments import RunSpec, build_controller

    return build_controller(RunSpec(controller=controller, path="adept"), load_delta()).dt is not None


@pytest.mark.parametrize("controller", CONTROLLERS)
def test_every_controller_runs_the_adept_cycle(tmp_path, controller):
    """Issue 15: design I stopped at once on the Adept cycle ("Unexpected istate in LSODA"): its
    87 rad/s^2 make Lambda ~240 and the robust term's layer ~4e-6 rad/s thin, finer than LSODA's
    rtol 1e-6 resolved. Continuous mode (the core's Radau IIA) for every continuous-time law,
    sampled for the discrete-time ones; from the paper's alpha_0 (0.72 rad off the cycle's start)."""
    mode = "sampled" if _discrete(controller) else "continuous"
    out = tmp_path / controller
    argv = ["run", "--controller", controller, "--path", "adept", "--plant", "analytic"]
    assert main([*argv, "--mode", mode, "--t-end", "0.3", "--out", str(out)]) == 0
    run = load_run(out / "run.npz")
    assert run.t[-1] == pytest.approx(0.3) and np.isfinite(run.alpha).all()
    if controller in ("design1", "design2"):
        assert run.metadata["integrator"] == "radau"  # the compiled default resolves the layer itself
        assert np.linalg.norm(run.error[-1]) < np.linalg.norm(run.error[0])  # it is converging


@pytest.mark.parametrize("controller", ["design1", "design2"])
def test_the_default_continuous_run_follows_the_adept_cycle_at_the_documented_tolerance(tmp_path, controller):
    """LSODA (gone from the package; `--integrator lsoda` is refused: tests/test_cli_errors.py)
    needed its rtol tightened to the robust term's ~4e-6 rad/s layer to run the Adept cycle; the
    default continuous integrator, the core's Radau IIA, runs it at rtol 1e-6 as given and follows
    the path once the 0.72 rad reaching phase is over: over 0.7-1 s at most 2e-3 rad per joint and
    0.5 mm at the platform (measured 1.19e-3 rad, 0.29 mm for designs I and II)."""
    out = tmp_path / controller
    argv = ["run", "--controller", controller, "--path", "adept", "--plant", "analytic"]
    assert main([*argv, "--t-end", "1", "--out", str(out)]) == 0
    run = load_run(out / "run.npz")
    assert run.metadata["integrator"] == "radau" and run.metadata["rtol"] == 1e-6  # not tightened
    assert run.t[-1] == pytest.approx(1.0)
    late = run.t >= 0.7
    assert np.abs(run.error[late]).max() < 2e-3  # [rad]
    assert np.linalg.norm(run.xyz - run.xyz_d, axis=1)[late].max() < 5e-4  # [m]
    assert np.linalg.norm(run.error[0]) > 0.7  # [rad] from the paper's alpha_0, off the cycle


def test_design1_runs_the_adept_cycle_on_the_pinocchio_plant(tmp_path):
    """The same on the Pinocchio plant (it stopped at t = 0.013 s of a 1 s run)."""
    out = tmp_path / "pin"
    argv = ["run", "--path", "adept", "--plant", "pinocchio", "--t-end", "1", "--out", str(out)]
    assert main(argv) == 0
    assert np.isfinite(load_run(out / "run.npz").alpha).all()


def test_the_reference_lsoda_keeps_paths_i_and_ii_at_the_documented_tolerance():
    """The reference LSODA's tightening (tests/reference/python_loop.py, the oracle of the
    continuous runs) leaves paths I and II at rtol 1e-6 and tightens the Adept cycle."""
    from delta_pin.model.delta_robot import load_delta
    from delta_pin.sim.reference import tabulate_reference
    from delta_pin.studies.experiments import RunSpec, build_controller, build_trajectory
    from tests.reference.python_loop import layer_resolving_rtol

    robot = load_delta()
    for path, expected in (("I", 1e-6), ("II", 1e-6), ("adept", 1.78e-7)):
        spec = RunSpec(path=path)
        trajectory = build_trajectory(path)
        table, _, _ = tabulate_reference(robot, trajectory, None, 3, round(spec.duration / 1e-3), 1e-3, 4)
        rtol = layer_resolving_rtol(build_controller(spec, robot, trajectory), table, 1e-6)
        assert rtol == pytest.approx(expected, rel=1e-2), path


def test_bdf2_on_the_adept_cycle_fails_in_one_line_naming_what_can_run_it(tmp_path, capsys):
    """Issue 15: the Adept cycle's reaching phase (Lambda ~240, a damper gain ~5e7 N m s/rad) defeats
    the fixed-step BDF2's Newton iteration even on 1024 sub-steps; the run fails with one line and
    exit 1 naming the integrators that run it, and the default (Radau) does run it."""
    argv = ["run", "--path", "adept", "--plant", "analytic", "--t-end", "0.3"]
    assert main([*argv, "--integrator", "bdf2", "--out", str(tmp_path / "bdf2")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "integrator='radau' (the default)" in err[0] and "t=0.003 s" in err[0]
    assert main([*argv, "--out", str(tmp_path / "radau")]) == 0
    assert load_run(tmp_path / "radau" / "run.npz").metadata["integrator"] == "radau"
