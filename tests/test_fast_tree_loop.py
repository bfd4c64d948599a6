"""The compiled sampled loop on the Pinocchio plant (delta_pin/fast_tree_loop.py) against
simulate()'s Python loop, which stays the reference (``compiled=False``)."""

import numpy as np
import pytest

import delta_pin as dp
from delta_pin import native
from delta_pin.batch import batchable, simulate_batch
from delta_pin.errors import InvalidParameterError, SimulationError
from delta_pin.experiments import RunSpec, run_spec
from delta_pin.plant import Friction, PinocchioPlant

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


def test_what_the_tree_loop_cannot_run_is_refused(robot):
    nominal = dp.DeltaNominalModel(robot)
    assert batchable(dp.design1(nominal), "pinocchio", mode="sampled")
    assert not batchable(dp.design1(nominal), "pinocchio", mode="continuous")
    assert not batchable(dp.ComputedTorque(nominal), "pinocchio", mode="sampled")
    with pytest.raises(InvalidParameterError, match="continuous mode"):
        simulate_batch(robot, [dp.design1(nominal)], dp.PathI(), plant="pinocchio", t_end=0.1)
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
