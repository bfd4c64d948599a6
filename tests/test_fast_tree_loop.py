"""Compiled closed loops on the Pinocchio plant through the native library.

Sampled mode (delta_pin/fast_tree_loop.py) against simulate()'s Python loop, which stays the
reference (``compiled=False``); continuous mode (BDF2 in active coordinates,
delta_pin/fast_closed_loop.py) against LSODA on the same plant and against the analytic plant."""

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.compiled import native
from delta_pin.errors import InvalidParameterError, SimulationError
from delta_pin.model.friction import Friction
from delta_pin.sim.batch import batchable, simulate_batch
from delta_pin.sim.plants import PinocchioPlant
from delta_pin.studies.experiments import (
    RunSpec,
    batch_group,
    build_controller,
    build_uncertainty,
    run_batch,
    run_spec,
)

pytestmark = pytest.mark.skipif(
    native.load() is None, reason=f"native library unavailable: {native._loaded.get('reason')}"
)

RUN_ARRAYS = ("alpha", "alpha_dot", "tau", "xyz", "closure_residual")


def _assert_same_run(fast, reference):
    """Equal to 1e-12 relative (they are equal bit for bit on this machine: the same compiled
    kernels and the same Pinocchio function in the same order)."""
    assert fast.metadata["compiled"] and not reference.metadata.get("compiled")
    for name in RUN_ARRAYS:
        np.testing.assert_allclose(getattr(fast, name), getattr(reference, name), rtol=1e-12, atol=1e-300)
    assert fast.internals.keys() == reference.internals.keys()
    for name, values in reference.internals.items():
        np.testing.assert_allclose(fast.internals[name], values, rtol=1e-12, atol=1e-300)


@pytest.mark.parametrize("controller", ["design1", "design2"])
def test_compiled_pinocchio_run_equals_the_python_loop(robot, controller):
    spec = RunSpec(controller=controller, plant="pinocchio", mode="sampled", sampling_aware=True, t_end=0.4)
    fast, reference = run_spec(spec, robot), run_spec(spec, robot, compiled=False)
    _assert_same_run(fast, reference)
    assert 0.0 < fast.closure_residual.max() <= 1e-9
    assert np.abs(fast.tau).max() > 1.0  # the loop does real work
    assert fast.metadata["rhs_evaluations"] == 4 * 400  # four tree evaluations per 1 ms sample


@pytest.mark.parametrize("substeps", [1, 3])
def test_projections_and_substeps_resume_where_the_python_loop_projects(robot, substeps):
    """A tiny projection tolerance projects (almost) every step: the compiled loop stops, the
    plant projects in Python, the loop resumes mid-sample; the same projections happen."""
    nominal = dp.DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))
    runs = []
    for compiled in (None, False):
        plant = PinocchioPlant(robot, Friction(), dp.PaperUncertainty(), projection_tolerance=1e-15)
        runs.append(
            dp.simulate(
                robot,
                dp.design1(nominal, sampling_period=1e-3),
                dp.PathI(),
                plant=plant,
                t_end=0.1,
                substeps=substeps,
                alpha0=np.full(3, 0.3322),
                compiled=compiled,
            )
        )
    fast, reference = runs
    _assert_same_run(fast, reference)
    assert fast.metadata["closure_projections"] == reference.metadata["closure_projections"] >= 5


def test_a_failing_run_fails_as_the_python_loop_does(robot):
    """The paper's gains sampled at 1 kHz destabilise the loop; the closure gap explodes at the
    same step with the same message."""
    spec = RunSpec(controller="design1", plant="pinocchio", mode="sampled", t_end=0.3)
    errors = []
    for compiled in (None, False):
        with pytest.raises(SimulationError) as caught:
            run_spec(spec, robot, compiled=compiled)
        errors.append(caught.value)
    assert str(errors[0]) == str(errors[1])
    assert errors[0].time == errors[1].time == pytest.approx(0.11)


def test_what_the_tree_loops_cannot_run_is_refused(robot):
    nominal = dp.DeltaNominalModel(robot)
    active = PinocchioPlant(robot, coordinates="active")
    assert batchable(dp.design1(nominal), "pinocchio", mode="sampled")
    assert batchable(dp.design1(nominal), active, mode="continuous")
    assert not batchable(dp.design1(nominal), active, mode="sampled")
    assert not batchable(dp.ComputedTorque(nominal), "pinocchio", mode="sampled")
    with pytest.raises(InvalidParameterError, match="sampled mode"):
        simulate_batch(robot, [dp.design1(nominal)], dp.PathI(), plant=active, mode="sampled", t_end=0.1)
    with pytest.raises(InvalidParameterError, match="compiled=False"):
        dp.simulate(robot, dp.ComputedTorque(nominal), dp.PathI(), t_end=0.1, compiled=True)


def test_without_the_native_library_simulate_falls_back_to_python(robot, monkeypatch):
    monkeypatch.setitem(native._loaded, "library", None)
    monkeypatch.setitem(native._loaded, "reason", "test: no compiler")
    spec = RunSpec(controller="design1", plant="pinocchio", mode="sampled", sampling_aware=True, t_end=0.05)
    run = run_spec(spec, robot)
    assert not run.metadata.get("compiled")
    with pytest.raises(InvalidParameterError, match="native library"):
        run_spec(spec, robot, compiled=True)


ALPHA0 = np.full(3, 0.3322)  # the paper's initial deviation (0.083 rad from path I's start)


def _continuous(robot, plant, t_end, **options):
    """Design I, paper gains and scenario (friction, Delta = 0.3), continuous mode."""
    spec = RunSpec(controller="design1", t_end=t_end)
    trajectory = dp.PathI()
    return dp.simulate(
        robot,
        build_controller(spec, robot, trajectory),
        trajectory,
        plant=plant,
        t_end=t_end,
        mode="continuous",
        alpha0=ALPHA0,
        friction=dp.Friction(),
        uncertainty=build_uncertainty(spec),
        **options,
    )


def test_continuous_pinocchio_bdf2_equals_the_analytic_bdf2_on_the_lumped_robot(robot):
    """On the Table 1 robot the two plants agree to ~1e-13 (tests/test_validation.py), so the
    same integrator gives the same run: the tree is completed and solved at every evaluation."""
    tree = _continuous(robot, "pinocchio", 0.5, integrator="bdf2")
    analytic = _continuous(robot, "analytic", 0.5, integrator="bdf2")
    np.testing.assert_allclose(tree.alpha, analytic.alpha, rtol=0, atol=1e-11)  # measured 0
    np.testing.assert_allclose(tree.internals["rho_hat"], analytic.internals["rho_hat"], rtol=1e-11)
    np.testing.assert_allclose(tree.xyz, analytic.xyz, rtol=0, atol=1e-12)  # Pinocchio's q vs the FK
    assert tree.closure_residual.max() <= 1e-13  # the completion's tolerance
    assert tree.metadata["plant"] == "pinocchio" and tree.metadata["integrator"] == "bdf2"


@pytest.fixture(scope="module")
def rod_robot():
    return dp.load_delta(forearm_inertia="rod")


def test_continuous_pinocchio_bdf2_follows_lsoda_on_the_same_plant(rod_robot):
    """Forearms as uniform rods: a plant the analytic model does not describe. BDF2 at 1 ms
    against LSODA (rtol 1e-9) on the Pinocchio plant: the bounds of the analytic plant's test
    (tests/test_batch.py), and 1e-5 rad away from the analytic plant's run."""
    t_end = 1.2
    lsoda = _continuous(rod_robot, "pinocchio", t_end, integrator="lsoda", rtol=1e-9, atol=1e-11)
    bdf2 = _continuous(rod_robot, "pinocchio", t_end, integrator="bdf2")
    analytic = _continuous(rod_robot, "analytic", t_end, integrator="bdf2")
    error = np.abs(bdf2.alpha - lsoda.alpha).max(axis=1)
    assert error[lsoda.t >= 1.0].max() < 2e-6  # after the reaching phase
    assert error.max() < 1e-3  # the reaching phase (measured 4.2e-4 rad)
    rho = lsoda.internals["rho_hat"]
    assert np.abs(bdf2.internals["rho_hat"] - rho).max() < 2e-3 * rho.max()
    assert np.abs(analytic.alpha - lsoda.alpha).max() > 5e-6  # the rods matter (measured 1.4e-5)
    assert bdf2.closure_residual.max() <= 1e-13


@pytest.mark.parametrize("mode", ["sampled", "continuous"])
def test_pinocchio_batches_equal_runs_made_alone(robot, mode):
    """A sweep's batch on the Pinocchio plant (one compiled loop per run, one task): each run is
    the run made alone, bit for bit (each starts its own completion and truth)."""
    options = {"integrator": "bdf2"} if mode == "continuous" else {"sampling_aware": True}
    specs = [
        RunSpec(controller="design1", plant="pinocchio", mode=mode, t_end=0.2, **options),
        RunSpec(controller="design2", plant="pinocchio", mode=mode, t_end=0.2, seed=3, **options),
    ]
    assert batch_group(specs[0]) == batch_group(specs[1]) is not None
    for together, spec in zip(run_batch(specs, robot), specs):
        alone = run_spec(spec, robot)
        for name in RUN_ARRAYS:
            np.testing.assert_array_equal(getattr(together, name), getattr(alone, name))
        np.testing.assert_array_equal(together.internals["rho_hat"], alone.internals["rho_hat"])
