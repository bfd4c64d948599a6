"""The compiled core's loops (entered through simulate and delta_pin.sim.batch) against their
references.

* Equivalence, one parametrised test (plant x controller x substeps): in sampled mode a compiled
  run -- the compiled core's plant and law: the reduced Delta, or on the Pinocchio plant the
  axis-tree stage (equal to constraintDynamics to ~1e-13 relative per call) with its own
  projections, the law's arithmetic in C++ -- gives the arrays of the readable Python loop
  (``simulate_reference``, tests/reference/python_loop.py) to CORE_RTOL over these 0.2 s runs (on
  the analytic plant measured up to 1.5e-11 relative, in a time-delay run that leaves the path by
  2.8 rad).
* Accuracy of BDF2 (the core's, delta_pin/core/integrate/bdf2.hpp): against LSODA at rtol 1e-9 in the
  Python loop (``simulate_reference``), an independent adaptive integrator, on both plants.
* Batches: each run of a batch is the run made alone, bit for bit.
"""

from __future__ import annotations

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.control.base import Reference
from delta_pin.errors import InvalidParameterError, SimulationError
from delta_pin.sim.batch import simulate_batch
from delta_pin.sim.closed_chain_plant import PinocchioPlant
from delta_pin.studies.experiments import (
    RunSpec,
    batch_group,
    build_controller,
    build_trajectory,
    build_uncertainty,
    run_batch,
    run_spec,
)
from tests.reference.laws import readable_evaluate
from tests.reference.python_loop import simulate_reference

ALPHA0 = np.full(3, 0.3322)  # the paper's initial deviation (0.083 rad from path I's start)
RUN_ARRAYS = ("alpha", "alpha_dot", "tau", "xyz", "closure_residual")


#: the core's run against the Python loop, relative (absolute 1e-12 in SI units): the same RK4
#: steps with another evaluation of the same dynamics, projections and law
CORE_RTOL = 1e-9


def _assert_same_run(fast, reference, rtol: float = 1e-12, atol: float = 1e-14):
    """Equal to ``rtol`` relative, every array and every internal."""
    assert fast.metadata.get("core_plant") and not reference.metadata.get("core_plant")
    for name in RUN_ARRAYS:
        np.testing.assert_allclose(getattr(fast, name), getattr(reference, name), rtol=rtol, atol=atol)
    assert fast.internals.keys() == reference.internals.keys()
    for name, values in reference.internals.items():
        np.testing.assert_allclose(fast.internals[name], values, rtol=rtol, atol=atol)


PLANTS = ["analytic", "pinocchio"]


@pytest.mark.parametrize("substeps", [1, 3])
@pytest.mark.parametrize("design", ["design1", "design2"])
@pytest.mark.parametrize("plant", PLANTS)
def test_compiled_sampled_run_equals_the_python_loop(robot, plant, design, substeps):
    """Sampling-aware designs at 1 kHz along path I with the paper's friction and uncertainty. On
    the tree, a tiny projection tolerance projects (almost) every step, in the core as in Python:
    the same projections happen."""
    nominal = dp.DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))
    make = dp.design1 if design == "design1" else dp.design2
    runs = []
    for simulate in (dp.simulate, simulate_reference):
        if plant == "pinocchio":
            made = PinocchioPlant(robot, dp.Friction(), dp.PaperUncertainty(), projection_tolerance=1e-15)
        else:
            made = dp.AnalyticPlant(robot, dp.Friction(), dp.PaperUncertainty())
        runs.append(
            simulate(
                robot,
                make(nominal, sampling_period=1e-3),
                dp.PathI(),
                plant=made,
                t_end=0.2,
                substeps=substeps,
                alpha0=ALPHA0,
            )
        )
    fast, reference = runs
    tree = plant == "pinocchio"
    _assert_same_run(fast, reference, CORE_RTOL, 1e-12)
    assert np.abs(fast.tau).max() > 1.0  # the loop does real work
    if tree:
        assert fast.metadata["closure_projections"] == reference.metadata["closure_projections"] >= 5
        assert 0.0 < fast.closure_residual.max() <= 1e-9


@pytest.mark.parametrize("substeps", [1, 2])
@pytest.mark.parametrize("law", ["tdc", "digital-robust", "design1"])
@pytest.mark.parametrize("plant", PLANTS)
def test_compiled_digital_drive_run_equals_the_python_loop(robot, plant, law, substeps):
    """The digital laws, and design I (sampling-aware, its rho_hat advanced once per sample), on a
    digital drive (17-bit encoders with seeded noise, one sample of delay, a torque limit that
    binds): the compiled digital loop (analytic plant) or the core's plant, law and drive
    (Pinocchio plant, with projections at almost every step, as above) against the Python loop."""
    from delta_pin.sim.drive import Encoder

    nominal = dp.DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))
    runs = []
    for simulate in (dp.simulate, simulate_reference):
        if plant == "pinocchio":
            made = PinocchioPlant(robot, dp.Friction(), dp.PaperUncertainty(), projection_tolerance=1e-15)
        else:
            made = dp.AnalyticPlant(robot, dp.Friction(), dp.PaperUncertainty())
        controller = {
            "tdc": lambda: dp.tdc(nominal, 1e-3, delay=1, pairing="mean"),
            "digital-robust": lambda: dp.digital_robust(nominal, 1e-3, delay=1, torque_limit=4.0),
            "design1": lambda: dp.design1(nominal, sampling_period=1e-3),
        }[law]()
        runs.append(
            simulate(
                robot,
                controller,
                dp.PathI(),
                plant=made,
                t_end=0.2,
                substeps=substeps,
                alpha0=ALPHA0,
                sensor=Encoder(bits=17, noise=1e-5, seed=11),
                delay=1,
                torque_limit=4.0,
            )
        )
    fast, reference = runs
    tree = plant == "pinocchio"
    _assert_same_run(fast, reference, CORE_RTOL, 1e-12)
    assert fast.metadata["torque_limit_hits"] == reference.metadata["torque_limit_hits"] > 0
    assert fast.metadata["sensor"] == reference.metadata["sensor"]
    if tree:
        assert fast.metadata["closure_projections"] == reference.metadata["closure_projections"] >= 5


def test_a_diverging_digital_run_fails_when_the_python_loop_does(robot):
    """Time-delay control at 20 times its bandwidth: the error dynamics' poles leave the unit
    circle; both loops stop at the same sample."""
    nominal = dp.DeltaNominalModel(robot, nominal_disturbance=(2, 4, 6))
    times = []
    for simulate in (dp.simulate, simulate_reference):
        with pytest.raises(SimulationError) as failure:
            simulate(
                robot, dp.tdc(nominal, 1e-3, bandwidth=1600.0), dp.PathI(), plant="analytic", t_end=1.0,
                alpha0=ALPHA0,
            )  # fmt: skip
        times.append(failure.value.time)
    assert times[0] == pytest.approx(times[1], abs=1e-12) and times[0] < 1.0


def _run_spec_reference(spec: RunSpec, robot):
    """:func:`run_spec`'s run of ``spec`` in the readable Python loop."""
    trajectory = build_trajectory(spec.path)
    return simulate_reference(
        robot, build_controller(spec, robot, trajectory), trajectory, plant=spec.plant, t_end=spec.duration,
        dt=spec.dt, mode=spec.mode, integrator=None if spec.integrator == "auto" else spec.integrator,
        alpha0=None if spec.alpha0 is None else np.full(3, spec.alpha0),
        friction=dp.Friction() if spec.friction else None, uncertainty=build_uncertainty(spec),
        sensor=spec.sensor(), delay=spec.delay, torque_limit=spec.torque_limit,
    )  # fmt: skip


@pytest.mark.parametrize("plant", ["analytic", "pinocchio"])
def test_a_failing_run_fails_as_the_python_loop_does(robot, plant):
    """The paper's gains sampled at 1 kHz destabilise the loop (docs/architecture.md section 6):
    the compiled run stops at the sample where the Python loop stops."""
    spec = RunSpec(controller="design1", plant=plant, mode="sampled", t_end=0.3)
    errors = []
    for run in (run_spec, _run_spec_reference):
        with pytest.raises(SimulationError) as caught:
            run(spec, robot)
        errors.append(caught.value)
    assert errors[0].time == pytest.approx(errors[1].time) == pytest.approx(0.11, abs=0.003)


def _continuous(robot, plant, t_end, simulate=dp.simulate, **options):
    """Design I, paper gains and scenario (friction, Delta = 0.3), continuous mode, by ``simulate``
    (the package's, or ``simulate_reference``: the Python loop's LSODA)."""
    spec = RunSpec(controller="design1", t_end=t_end)
    trajectory = dp.PathI()
    return simulate(
        robot, build_controller(spec, robot, trajectory), trajectory, plant=plant, t_end=t_end,
        mode="continuous", alpha0=ALPHA0, friction=dp.Friction(), uncertainty=build_uncertainty(spec),
        **options,
    )  # fmt: skip


@pytest.fixture(scope="module")
def paper_runs(robot):
    """Design I, paper scenario, 2 s, analytic plant: LSODA (rtol 1e-9) and BDF2 with 1 ms and
    0.25 ms steps."""
    return (
        _continuous(robot, "analytic", 2.0, simulate_reference, integrator="lsoda", rtol=1e-9, atol=1e-11),
        _continuous(robot, "analytic", 2.0, integrator="bdf2"),
        _continuous(robot, "analytic", 2.0, integrator="bdf2", substeps=4),
    )


def test_bdf2_converges_to_lsoda_at_second_order(paper_runs):
    lsoda, coarse, fine = paper_runs
    late = lsoda.t >= 1.0
    coarse_error = np.abs(coarse.alpha - lsoda.alpha).max(axis=1)
    fine_error = np.abs(fine.alpha - lsoda.alpha).max(axis=1)
    # after the reaching phase both are far inside the tracking error (~1e-4 rad at 1 s)
    assert coarse_error[late].max() < 2e-6  # measured 3e-7 rad
    assert fine_error[late].max() < 1e-7  # measured 2e-8 rad
    # 4x smaller steps: the worst error (in the reaching phase) drops by > 8 (order > 1.5)
    assert fine_error.max() < coarse_error.max() / 8.0
    # rho_hat integrates ||s||: the reaching-phase error leaves it 1e-3 off (relative) at 1 ms
    rho = lsoda.internals["rho_hat"]
    coarse_rho = np.abs(coarse.internals["rho_hat"] - rho).max() / rho.max()
    fine_rho = np.abs(fine.internals["rho_hat"] - rho).max() / rho.max()
    # measured 9.9e-4 and 1.7e-4: about first order, the reaching phase is not smooth
    assert coarse_rho < 2e-3 and fine_rho < coarse_rho / 4.0
    assert coarse.metadata["integrator"] == "bdf2" and coarse.metadata["rhs_evaluations"] > 0
    assert coarse.metadata["core_plant"] and coarse.metadata["bdf2_steps"] == 2000


def test_recorded_outputs_are_the_readable_law_at_the_recorded_states(robot, paper_runs):
    _, run, _ = paper_runs
    controller = build_controller(RunSpec(controller="design1"), robot)
    for k in (0, 7, 500, 1999):
        # alpha_ddot_d is not stored in a Run: take it from the path
        reference = Reference(
            run.alpha_d[k], run.alpha_dot_d[k], dp.PathI().joint_reference(robot, run.t[k]).alpha_ddot[0]
        )
        out = readable_evaluate(controller)(
            run.t[k], run.alpha[k], run.alpha_dot[k], reference, run.internals["rho_hat"][k]
        )
        np.testing.assert_allclose(run.tau[k], out.tau, rtol=1e-9, atol=1e-9)
        assert run.internals["Lambda"][k] == pytest.approx(out.internals["Lambda"], rel=1e-12)
        np.testing.assert_allclose(run.xyz[k], robot.forward_kinematics(run.alpha[k]), atol=1e-12)


def test_continuous_pinocchio_bdf2_equals_the_analytic_bdf2_on_the_lumped_robot(robot):
    """On the Table 1 robot the two plants agree to ~1e-13 (tests/model/test_validation.py), so
    the same integrator gives the same run: the tree is completed and solved at every evaluation."""
    tree = _continuous(robot, "pinocchio", 0.5, integrator="bdf2")
    analytic = _continuous(robot, "analytic", 0.5, integrator="bdf2")
    np.testing.assert_allclose(tree.alpha, analytic.alpha, rtol=0, atol=1e-11)  # measured 0
    np.testing.assert_allclose(tree.internals["rho_hat"], analytic.internals["rho_hat"], rtol=1e-11)
    np.testing.assert_allclose(tree.xyz, analytic.xyz, rtol=0, atol=1e-12)  # Pinocchio's q vs the FK
    assert (
        tree.closure_residual.max() <= 1e-12
    )  # the core completion's tolerance (ClosedChainModel::configuration)
    assert tree.metadata["plant"] == "pinocchio" and tree.metadata["integrator"] == "bdf2"


def test_continuous_pinocchio_bdf2_follows_lsoda_on_the_same_plant():
    """Forearms as uniform rods: a plant the analytic model does not describe. BDF2 at 1 ms
    against LSODA (rtol 1e-9) on the Pinocchio plant: the bounds of the analytic plant's test
    above, and 1e-5 rad away from the analytic plant's run."""
    rod_robot = dp.load_delta(forearm_inertia="rod")
    t_end = 1.2
    lsoda = _continuous(
        rod_robot, "pinocchio", t_end, simulate_reference, integrator="lsoda", rtol=1e-9, atol=1e-11
    )
    bdf2 = _continuous(rod_robot, "pinocchio", t_end, integrator="bdf2")
    analytic = _continuous(rod_robot, "analytic", t_end, integrator="bdf2")
    error = np.abs(bdf2.alpha - lsoda.alpha).max(axis=1)
    assert error[lsoda.t >= 1.0].max() < 2e-6  # after the reaching phase
    assert error.max() < 1e-3  # the reaching phase (measured 4.2e-4 rad)
    rho = lsoda.internals["rho_hat"]
    assert np.abs(bdf2.internals["rho_hat"] - rho).max() < 2e-3 * rho.max()
    assert np.abs(analytic.alpha - lsoda.alpha).max() > 5e-6  # the rods matter (measured 1.4e-5)
    assert bdf2.closure_residual.max() <= 1e-12  # the core completion's tolerance


@pytest.mark.parametrize(
    ("plant", "mode"),
    [
        ("analytic", "continuous"),
        ("analytic", "sampled"),
        ("pinocchio", "continuous"),
    ],
)
def test_a_batch_equals_its_runs_made_alone(robot, plant, mode):
    """Runs of one batch group (different designs, gains, uncertainty, seeds): each is the run made
    alone, bit for bit, and the runs really differ from each other."""
    options = {"integrator": "bdf2"} if mode == "continuous" else {"sampling_aware": True}
    specs = [
        RunSpec(controller="design1", plant=plant, mode=mode, t_end=0.3, delta_m=0.0, **options),
        RunSpec(controller="design2", plant=plant, mode=mode, t_end=0.3, gains={"xi": 0.01}, **options),
        RunSpec(controller="design1", plant=plant, mode=mode, t_end=0.3, delta_f=0.9, seed=3, **options),
    ]
    assert len({batch_group(s) for s in specs}) == 1 and batch_group(specs[0]) is not None
    together = run_batch(specs, robot)
    for spec, run in zip(specs, together):
        alone = run_spec(spec, robot)
        for name in RUN_ARRAYS:
            np.testing.assert_array_equal(getattr(run, name), getattr(alone, name))
        np.testing.assert_array_equal(run.internals["rho_hat"], alone.internals["rho_hat"])
        assert run.metadata["spec"] == spec.as_dict()
    assert np.abs(together[0].alpha - together[2].alpha).max() > 1e-5


def test_a_batch_returns_a_failing_run_in_its_place(robot):
    specs = [
        RunSpec(controller="design1", plant="analytic", mode="sampled", sampling_aware=True, t_end=0.3),
        RunSpec(controller="design1", plant="analytic", mode="sampled", t_end=0.3),  # diverges at 0.112 s
    ]
    ok, failed = run_batch(specs, robot)
    assert isinstance(ok, dp.Run) and isinstance(failed, dp.SimulationError)
    assert failed.time == pytest.approx(0.112)


def test_what_the_compiled_loops_cannot_run_is_refused(robot):
    """Every controller runs in the core's loops (computed torque with BDF2 too); what is refused
    is named in one line: BDF2 in sampled mode, LSODA (gone with the Python loop; Radau or BDF2
    run continuous mode), a batch without controllers or with a profile count that does not
    match."""
    nominal = dp.DeltaNominalModel(robot)
    ctc = dp.simulate(
        robot, dp.ComputedTorque(nominal), dp.PathI(), t_end=0.1, mode="continuous", integrator="bdf2"
    )
    assert ctc.metadata["core_plant"] and ctc.metadata["integrator"] == "bdf2"
    with pytest.raises(InvalidParameterError, match="integrator='bdf2' does not run mode='sampled'"):
        dp.simulate(robot, dp.design1(nominal), dp.PathI(), t_end=0.1, mode="sampled", integrator="bdf2")
    # computed torque runs in the core on the reduced Delta, sampled as continuous
    ctc = dp.simulate(robot, dp.ComputedTorque(nominal), dp.PathI(), plant="analytic", t_end=0.1)
    assert ctc.metadata["core_plant"]
    with pytest.raises(
        InvalidParameterError,
        match=r"integrator='lsoda' does not run mode='continuous': .*'radau' or 'bdf2' continuous mode",
    ) as info:
        dp.simulate(
            robot, dp.ComputedTorque(nominal), dp.PathI(), plant="analytic", t_end=0.1, mode="continuous",
            integrator="lsoda",
        )  # fmt: skip
    assert "\n" not in str(info.value)
    with pytest.raises(InvalidParameterError, match="at least one controller"):
        simulate_batch(robot, [], dp.PathI(), t_end=0.1)
    with pytest.raises(InvalidParameterError, match="uncertainties has 1 entries for 2 controllers"):
        simulate_batch(robot, [dp.design1(nominal)] * 2, dp.PathI(), t_end=0.1, uncertainties=[None])
    with pytest.raises(InvalidParameterError, match="integrator='euler'"):
        RunSpec(integrator="euler")
    with pytest.raises(InvalidParameterError, match="batch group"):
        run_batch([RunSpec(plant="analytic", integrator="bdf2"), RunSpec(plant="analytic")], robot)


def test_bdf2_crosses_a_sweep_point_that_needs_split_steps(robot):
    """A point of reproduce --full's surface grid (design II, Delta_m 0.3, Delta_f = Delta_fc =
    0.09) where Newton fails on whole 1 ms steps in the sliding phase: the split steps, with the
    reference and the truth read linearly inside the step (as the former numba BDF2 read them),
    cross it. Read by cubic Hermite interpolation instead, the split steps failed at t = 12.975 s."""
    spec = RunSpec(
        controller="design2", plant="analytic", integrator="bdf2", t_end=15.0, gains={"rho0": 0.02},
        delta_f=0.09, delta_fc=0.09, delta_m=0.3,
    )  # fmt: skip
    run = run_spec(spec, robot)
    assert run.metadata["split_steps"] > 0
    assert np.abs(run.alpha - run.alpha_d)[-1000:].max() < 1e-3  # tracking in the last second
