"""The compiled core's closed-chain model and plant (delta_pin/core/plant/closed_chain.cpp) against the
Python references they replace in the loops: ``ClosedChainRobot.configuration``, ``velocity_map``
and ``reduced_terms``, ``ClosedChainPlant.derivative`` under the generic RK4 step with
``finish_step``, and the Python sampled loop (tests/reference/python_loop.py).

Tolerances: the core calls the same compiled Pinocchio algorithms on the same numbers, so the
accelerations agree bit for bit; what differs is Eigen's LU against LAPACK's in the closure
solves (Newton, S, S_dot), equal to ~1e-15 relative per solve, and the order of a few sums.
1e-11 relative bounds the per-step and per-term differences (measured: up to ~1e-13); over a
closed-loop run the difference stays below 1e-9 rad (measured ~1e-16 .. 1e-13).
"""

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.compiled.core import core
from delta_pin.errors import NativeUnavailableError, SimulationError
from delta_pin.model.core_model import core_model
from delta_pin.sim.compiled_plant import build_core_plant
from delta_pin.sim.integrators import rk4_step
from tests.reference import projection as readable
from tests.reference.assembly import newton_configuration
from tests.reference.laws import called_back
from tests.reference.plants import ReadableClosedChainPlant
from tests.reference.python_loop import simulate_reference

FULLY_ACTUATED = ["five_bar", "three_rrr", "three_rrr_mjcf", "stewart"]


@pytest.fixture(scope="module", params=FULLY_ACTUATED)
def robot_name(request):
    return request.param


def _relative(a, b) -> float:
    return float(np.abs(np.asarray(a) - np.asarray(b)).max() / max(1.0, np.abs(b).max()))


def test_projected_terms_equal_the_python_projection(robot_name):
    """Assembly, S and (M, C, G, C alpha_dot) at random reachable states against the robot's own
    methods: 1e-11 relative (module docstring)."""
    robot = dp.load_robot(robot_name)
    model = core_model(robot)
    assert model is not None
    rng = np.random.default_rng(7)
    for _ in range(5):
        alpha = robot.home + rng.normal(scale=0.02, size=robot.dof)
        alpha_dot = rng.normal(size=robot.dof)
        q_python = newton_configuration(robot, alpha, robot.reference_configuration)[0]
        closed, q = model.configuration(alpha, robot.reference_configuration)
        assert closed and _relative(q, q_python) < 1e-11
        assert model.closure_gap(q) <= 1e-12
        assert _relative(model.velocity_map(q), readable.velocity_map(robot, q)) < 1e-11
        for got, expected in zip(
            model.reduced_terms(q, alpha_dot), readable.reduced_terms(robot, q, alpha_dot)
        ):
            assert _relative(got, expected) < 1e-11
            assert np.abs(expected).max() > 0.0  # a real term, not zeros on both sides


def test_rk4_steps_and_projections_equal_the_python_plant(robot_name):
    """50 RK4 steps under a held torque with friction and a payload, every step projected back
    (projection_tolerance=1e-15): the core's step against rk4_step on ClosedChainPlant.derivative
    plus finish_step, 1e-11 relative per step; the same number of projections."""
    robot = dp.load_robot(robot_name)
    friction = dp.Friction(stribeck=dp.StribeckParameters(r_a=0.05, v_s=0.1, mu_s=0.3, mu_d=0.2, mu_v=0.05))
    plant = ReadableClosedChainPlant(
        robot, friction, payload_mass=lambda t: 0.1 * (1.0 + np.sin(5.0 * t)), projection_tolerance=1e-15
    )
    h = 1e-3
    compiled = build_core_plant(plant, h / 2, 103)
    rng = np.random.default_rng(3)
    x = plant.initial_state(robot.home, rng.normal(size=robot.dof))
    x0, tau = x.copy(), rng.normal(size=robot.dof)
    for k in range(50):
        stepped = rk4_step(lambda t, y: plant.derivative(t, y, tau), k * h, x, h)
        expected = plant.finish_step(stepped, (k + 1) * h)
        got, gap = compiled.step(x, tau, k * h, h)
        assert _relative(got, expected) < 1e-11
        assert gap <= 1e-12
        x = expected
    assert np.abs(x - x0).max() > 1e-2  # it moved
    assert compiled.projections == plant.projections == 50


def test_the_sampled_loop_equals_the_python_loop_with_any_controller():
    """Design I on the five-bar along a circle of its tip with an unknown payload, and a user's
    own function as a controller: the compiled plant and loop (dp.simulate) against the Python
    reference loop (simulate_reference), 1e-9 rad and 1e-9 relative in torque over 0.3 s."""
    robot = dp.load_robot("five_bar", end_effector="tip")
    home = robot.frame_placement(robot.reference_configuration).translation
    above = home + np.array([0.0, 0.0, 0.03])
    circle = dp.FramePath(dp.Circle(center=above, radius=0.03, period=2.0, plane="xz", phase=-np.pi / 2))
    nominal = dp.ClosedChainNominalModel(robot)

    def user_law(t, alpha, alpha_dot):
        return -5.0 * (alpha - robot.home) - 0.5 * alpha_dot

    for controller, path in ((dp.design1(nominal, sampling_period=1e-3), circle), (user_law, None)):
        runs = []
        for simulate in (simulate_reference, dp.simulate):
            plant = dp.ClosedChainPlant(robot, payload_mass=lambda t: 0.2 * (1 + np.sin(np.pi * t)))
            options = {"t_end": 0.3, "mode": "sampled", "alpha0": robot.home}
            runs.append(simulate(robot, controller, path, plant=plant, **options))
        python, compiled = runs
        assert compiled.q is not None and compiled.q.shape == python.q.shape
        assert np.abs(compiled.alpha - python.alpha).max() < 1e-9
        assert _relative(compiled.tau, python.tau) < 1e-9
        assert np.abs(compiled.xyz - python.xyz).max() < 1e-9
        assert np.abs(compiled.closure_residual).max() < 1e-9
        for name, values in python.internals.items():
            assert _relative(compiled.internals[name], values) < 1e-9
        assert np.abs(python.alpha - robot.home).max() > 1e-3  # the runs moved


def test_a_controller_that_fails_inside_the_compiled_loop_is_named():
    robot = dp.load_robot("five_bar")
    calls = []

    def law(t, alpha, alpha_dot):
        calls.append(t)
        return np.full(robot.dof, np.nan) if t >= 0.005 else np.zeros(robot.dof)

    with pytest.raises(SimulationError, match=r"non-finite torque.*t=0\.005"):
        dp.simulate(robot, law, None, t_end=0.02, mode="sampled", alpha0=robot.home)
    assert len(calls) == 6  # it stopped at the bad sample

    def wrong_shape(t, alpha, alpha_dot):
        return np.zeros(robot.dof + 1)

    with pytest.raises(SimulationError, match="shape"):
        dp.simulate(robot, wrong_shape, None, t_end=0.02, mode="sampled", alpha0=robot.home)


def test_a_core_that_cannot_be_imported_names_the_rebuild_command(monkeypatch):
    """Every robot has a compiled plant (the ball-ball Delta's idle rod spins included) and every
    run goes through the core: a core that cannot be imported stops the run in one line naming
    the command that rebuilds it (NativeUnavailableError), never a slower path."""
    import sys

    import delta_pin.compiled
    from delta_pin.compiled import core as core_module

    robot = dp.load_robot("delta_ballrods")
    assert robot.idle_dof > 0
    options = {"t_end": 0.01, "mode": "sampled", "alpha0": robot.home}
    assert dp.simulate(robot, lambda t, a, ad: np.zeros(3), None, **options).metadata["core_plant"]
    monkeypatch.setitem(sys.modules, "delta_pin.compiled._core", None)  # import then raises ImportError
    monkeypatch.delattr(delta_pin.compiled, "_core")  # else `from delta_pin.compiled import _core` finds it
    core_module.core.cache_clear()  # the core is looked up once per process
    try:
        with pytest.raises(NativeUnavailableError, match=r"cannot be imported.*pip install") as info:
            dp.simulate(robot, lambda t, a, ad: np.zeros(3), None, **options)
        assert "\n" not in str(info.value)
    finally:
        monkeypatch.undo()
        core_module.core.cache_clear()
    assert dp.simulate(robot, lambda t, a, ad: np.zeros(3), None, **options).metadata["core_plant"]


def test_wrong_sizes_are_refused_by_the_core_not_read_past():
    robot = dp.load_robot("five_bar")
    model = core_model(robot)
    with pytest.raises(ValueError, match="alpha has 5 entries, expected 2"):
        model.configuration(np.zeros(5), robot.reference_configuration)
    with pytest.raises(ValueError, match="alpha_dot has 1 entries"):
        model.reduced_terms(robot.reference_configuration, np.zeros(1))
    plant = build_core_plant(dp.ClosedChainPlant(robot))
    with pytest.raises(ValueError, match="tau has 3 entries"):
        plant.step(np.zeros(plant.nq + plant.nv), np.zeros(3), 0.0, 1e-3)
    assert isinstance(core().pinocchio_version, str)


def test_a_frame_path_becomes_the_same_joint_reference_in_the_core():
    """FramePath.joint_reference through the core's loop against the Python loop it replaces
    (the same Newton iterations; 1e-12 rad, rad/s, rad/s^2 and m over 1.5 s at 1 kHz), and a
    circle that leaves the workspace still named by the Python loop with its time."""
    from delta_pin.model import frame_path

    robot = dp.load_robot("five_bar", end_effector="tip")
    home = robot.frame_placement(robot.reference_configuration).translation
    circle = dp.Circle(center=home + np.array([0.0, 0.0, 0.03]), radius=0.03, period=2.0, plane="xz")
    path = dp.FramePath(circle)
    t = np.arange(1501) * 1e-3
    robot._last_q = robot.reference_configuration.copy()
    compiled = path.joint_reference(robot, t)
    robot._last_q = robot.reference_configuration.copy()
    original = frame_path.FramePath.__dict__["_compiled_reference"]
    try:
        frame_path.FramePath._compiled_reference = staticmethod(lambda *arguments: None)
        python = path.joint_reference(robot, t)
    finally:
        frame_path.FramePath._compiled_reference = original
    for name in ("alpha", "alpha_dot", "alpha_ddot", "xyz"):
        assert np.abs(getattr(compiled, name) - getattr(python, name)).max() < 1e-12, name
    assert np.abs(compiled.alpha_dot).max() > 0.1  # a moving reference
    too_far = dp.FramePath(
        dp.Circle(center=home + np.array([0.0, 0.0, 0.03]), radius=5.0, period=2.0, plane="xz")
    )
    with pytest.raises(dp.UnreachablePoseError, match=r"t=0 s"):
        too_far.joint_reference(robot, t[:10])


@pytest.mark.parametrize(
    "options",
    [
        {"design": "I", "sampling_period": 1e-3},
        {"design": "II", "sampling_period": 1e-3},
        {"design": "I", "vector_rho": True, "friction_compensation": True, "sampling_period": 1e-3},
    ],
    ids=["I-sampling-aware", "II", "I-vector-rho-friction"],
)
def test_designs_in_the_core_equal_the_readable_law_in_the_loop(options):
    """Designs I/II compiled with the plant (no Python during the run) against the same
    controller's readable law called back from the compiled plant (sampled_core_law turned off):
    every array within 1e-10 (rad, N m, internals) over 0.5 s of the five-bar's circle with an
    unknown payload and a nominal friction the controller compensates."""
    robot = dp.load_robot("five_bar", end_effector="tip")
    home = robot.frame_placement(robot.reference_configuration).translation
    above = home + np.array([0.0, 0.0, 0.03])
    circle = dp.FramePath(dp.Circle(center=above, radius=0.03, period=2.0, plane="xz", phase=-np.pi / 2))
    stribeck = dp.StribeckParameters(r_a=0.05, v_s=0.1, mu_s=0.3, mu_d=0.2, mu_v=0.05)
    nominal = dp.ClosedChainNominalModel(
        robot, nominal_disturbance=[0.01, -0.02], friction=dp.Friction(stribeck=stribeck)
    )
    design = options.pop("design")
    runs = []
    for compiled_law in (True, False):
        controller = dp.design1(nominal, **options) if design == "I" else dp.design2(nominal, **options)
        assert controller.sampled_core_law() is not None
        if not compiled_law:
            controller = called_back(controller)
        plant = dp.ClosedChainPlant(robot, dp.Friction(stribeck=stribeck), payload_mass=0.1)
        runs.append(
            dp.simulate(robot, controller, circle, plant=plant, t_end=0.5, mode="sampled", alpha0=robot.home)
        )
    core, python = runs
    for name in ("alpha", "alpha_dot", "tau", "xyz", "q", "v"):
        assert np.abs(getattr(core, name) - getattr(python, name)).max() < 1e-10, name
    assert sorted(core.internals) == sorted(python.internals)
    for name, values in python.internals.items():
        assert np.abs(core.internals[name] - values).max() < 1e-10, name
    assert np.abs(python.internals["rho_hat"] - python.internals["rho_hat"][0]).max() > 1e-6  # it adapted


def test_a_compiled_law_that_diverges_stops_at_the_sample_with_its_time():
    robot = dp.load_robot("five_bar")
    nominal = dp.ClosedChainNominalModel(robot)
    controller = dp.design1(nominal, T_p=1e9, T_v=1e9)  # far beyond what 1 ms sampling holds
    with pytest.raises(
        SimulationError, match=r"(non-finite|diverged|cannot close|cannot be re-assembled).*at t=0\.0[0-9]+ s"
    ):
        dp.simulate(robot, controller, None, t_end=0.2, mode="sampled", alpha0=robot.home + 0.05)


def test_the_delta_from_either_loader_takes_the_core_with_a_projected_nominal_model(tmp_path):
    """load_delta's robot and the same URDF through load_robot: with designs I/II on the projected
    nominal model both take the compiled closed-chain plant and law (one engine; the same run
    within 1e-7 rad: the two robots' closure frames are built by different loaders), and so do
    the Delta's own analytic nominal model and the paper's uncertainty profile on the Pinocchio
    plant; the run is described as the Delta's (its parameters in the metadata)."""
    delta = dp.load_delta()
    urdf = tmp_path / "delta.urdf"
    urdf.write_text(delta.delta.description.urdf)
    loaded = dp.load_robot(str(urdf))
    runs = []
    for robot in (delta, loaded):
        controller = dp.design1(dp.ClosedChainNominalModel(robot), sampling_period=1e-3)
        runs.append(dp.simulate(robot, controller, dp.PathI(), t_end=0.3, mode="sampled"))
        assert runs[-1].metadata["plant"] == "pinocchio" and runs[-1].metadata["core_plant"]
    assert np.abs(runs[0].alpha - runs[1].alpha).max() < 1e-7
    for nominal in (dp.DeltaNominalModel(delta), dp.ClosedChainNominalModel(delta)):
        run = dp.simulate(
            delta, dp.design1(nominal, sampling_period=1e-3), dp.PathI(), t_end=0.01, mode="sampled",
            uncertainty=dp.PaperUncertainty(), friction=True,
        )  # fmt: skip
        assert run.metadata["plant"] == "pinocchio" and run.metadata["core_plant"]
        assert run.metadata["robot"]["m_o"] == delta.params.m_o  # the Delta's description
        assert run.metadata["uncertainty"]["kind"] != "none"


@pytest.mark.parametrize("kind", ["ctc", "pd"])
def test_computed_torque_and_pd_in_the_core_equal_their_readable_laws(kind):
    """ComputedTorque and PDGravity compiled with the plant against the same controllers called
    back from the compiled plant: every array within 1e-10 over 0.5 s of the 3-RRR holding a
    point against gravity with an unknown payload, friction compensated."""
    robot = dp.load_robot("three_rrr")
    stribeck = dp.StribeckParameters(r_a=0.05, v_s=0.1, mu_s=0.3, mu_d=0.2, mu_v=0.05)
    nominal = dp.ClosedChainNominalModel(
        robot, nominal_disturbance=[0.01, -0.02, 0.005], friction=dp.Friction(stribeck=stribeck)
    )
    runs = []
    for compiled_law in (True, False):
        controller = dp.ComputedTorque(nominal) if kind == "ctc" else dp.PDGravity(nominal, K_p=20.0, K_d=2.0)
        assert controller.sampled_core_law() is not None
        if not compiled_law:
            controller = called_back(controller)
        plant = dp.ClosedChainPlant(robot, dp.Friction(stribeck=stribeck), payload_mass=0.05)
        options = {"t_end": 0.5, "mode": "sampled", "alpha0": robot.home + 0.02}
        runs.append(dp.simulate(robot, controller, None, plant=plant, **options))
    core, python = runs
    for name in ("alpha", "alpha_dot", "tau", "xyz", "q", "v"):
        assert np.abs(getattr(core, name) - getattr(python, name)).max() < 1e-10, name
    assert core.internals == {} == python.internals
    assert np.abs(python.alpha - python.alpha[0]).max() > 1e-3  # it moved


def test_active_coordinate_completions_and_end_effector_paths_in_the_core(robot_name):
    """The active-coordinate plant completes q(alpha), v = S alpha_dot in the core, and a robot's
    end-effector positions along many actuated states are assembled there: both equal the
    readable Newton and null space (tests/reference) to 1e-11 (two Newton runs to the same 1e-12
    closure tolerance from the same start; the closure Jacobian's conditioning amplifies the rest)."""
    robot = dp.load_robot(robot_name)
    rng = np.random.default_rng(5)
    alphas = robot.home + rng.uniform(-0.05, 0.05, (8, robot.dof))
    plant = dp.ClosedChainPlant(robot, coordinates="active")
    for alpha in alphas:
        alpha_dot = rng.normal(0.0, 0.5, robot.dof)
        start = plant._last_q.copy()
        q, v = plant.complete(alpha, alpha_dot, 0.0)
        expected = newton_configuration(robot, alpha, start)[0]
        np.testing.assert_allclose(q, expected, rtol=0, atol=1e-11)
        np.testing.assert_allclose(
            v, readable.velocity_map(robot, expected) @ alpha_dot, rtol=1e-9, atol=1e-11
        )
    frame = robot.end_effector_name
    reference = np.array([robot.frame_placement(robot.configuration(a), frame).translation for a in alphas])
    np.testing.assert_allclose(robot.forward_kinematics(alphas, frame), reference, rtol=0, atol=1e-11)


@pytest.mark.parametrize("name", ["five_bar", "stewart"])
def test_an_active_coordinate_plant_runs_sampled_in_the_core(name):
    """coordinates="active" in sampled mode: the core's RK4 integrates (alpha, alpha_dot), (q, v)
    completed by its Newton at every stage, and equals the readable loop on the Python plant's
    active derivative (tests/reference/python_loop.py) to 1e-9 rad (the module docstring's bound
    for a closed-loop run; each completion agrees to the 1e-12 Newton tolerance); friction, a
    time-varying payload and the drive's torque limit act in both. The run records the completed
    (q, v), on the loops to 1e-11."""
    robot = dp.load_robot(name)
    nominal = dp.ClosedChainNominalModel(robot)
    stribeck = dp.StribeckParameters(r_a=0.02, v_s=0.05, mu_s=0.3, mu_d=0.2, mu_v=0.0)
    options = {
        "friction": dp.Friction(stribeck=stribeck),
        "payload_mass": lambda t: 0.05 * (1.0 + np.sin(4.0 * t)),
        "coordinates": "active",
    }
    limit = np.full(robot.dof, 2.0)
    runs = []
    start = {"alpha0": robot.home + 0.02, "alpha_dot0": np.full(robot.dof, 3.0), "torque_limit": limit}
    for simulate in (dp.simulate, simulate_reference):
        plant = dp.ClosedChainPlant(robot, **options)
        controller = dp.PDGravity(nominal, K_p=20.0, K_d=2.0)
        runs.append(simulate(robot, controller, None, plant=plant, t_end=0.3, **start))
    core, python = runs
    assert core.metadata["core_plant"] and core.metadata["coordinates"] == "active"
    for field in ("alpha", "alpha_dot", "tau", "xyz", "q", "v"):
        got, expected = getattr(core, field), getattr(python, field)
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9, err_msg=field)
    assert core.closure_residual.max() < 1e-11
    assert np.abs(core.alpha - core.alpha[0]).max() > 1e-2  # it moved


def test_the_axis_tree_stage_equals_constraint_dynamics_on_the_delta():
    """The Delta's tree (RX..PZ joints, LOCAL point closures, the exact KKT solution) takes the
    core's axis-tree stage (delta_pin/core/model/axis_tree.hpp); 50 RK4 steps with friction and a
    varying payload on its platform body equal the same steps through Pinocchio's
    constraintDynamics and the Python plant's to 1e-12 relative (the two stages' arithmetic
    differs in its order only: measured ~1e-15 per evaluation). Robots it does not hold keep
    Pinocchio's."""
    robot = dp.load_delta()
    plant = ReadableClosedChainPlant(
        robot, dp.Friction(), payload_mass=lambda t: 0.2 * (1.0 + np.sin(5.0 * t)), projection_tolerance=1e-15
    )
    h = 1e-3
    axis, pinocchio = build_core_plant(plant, h / 2, 103), build_core_plant(plant, h / 2, 103)
    pinocchio.use_axis_tree(False)
    assert (axis.stage, pinocchio.stage) == ("axis_tree", "constraint_dynamics")
    rng = np.random.default_rng(4)
    x = plant.initial_state(robot.home + 0.05, rng.normal(size=3))
    x0, tau = x.copy(), rng.normal(size=3)
    for k in range(50):
        stepped = rk4_step(lambda t, y: plant.derivative(t, y, tau), k * h, x, h)
        expected = plant.finish_step(stepped, (k + 1) * h)
        got_axis, _ = axis.step(x, tau, k * h, h)
        got_pinocchio, _ = pinocchio.step(x, tau, k * h, h)
        assert _relative(got_axis, got_pinocchio) < 1e-12
        assert _relative(got_axis, expected) < 1e-12
        x = expected
    assert np.abs(x - x0).max() > 1e-2  # it moved
    for name in ("five_bar", "three_rrr", "stewart"):  # redundant closures, a weld, ball joints
        assert build_core_plant(dp.ClosedChainPlant(dp.load_robot(name))).stage == "constraint_dynamics"


def test_the_axis_tree_gives_the_chains_closure_gap():
    """After each RK4 step the axis-tree stage measures the closure gap from its own placements
    (AxisTree::closureGap) instead of the chain's Pinocchio pass: the two agree to 1e-15 m (a few
    ulps of the anchors' ~0.3 m coordinates; measured equal to the bit) from a closed state and
    from states 1e-6 and 1e-4 rad off the loops. The gap before the projection is the plant's
    largest_projected_gap (projection_tolerance 1e-15: every step projects)."""
    robot = dp.load_delta()
    plant = ReadableClosedChainPlant(robot, dp.Friction(), projection_tolerance=1e-15)
    h = 1e-3
    rng = np.random.default_rng(5)
    x = plant.initial_state(robot.home + 0.05, rng.normal(size=3))
    tau = rng.normal(size=3)
    for offset, at_least in ((0.0, 0.0), (1e-6, 1e-8), (1e-4, 1e-6)):
        axis, pinocchio = build_core_plant(plant, h / 2, 5), build_core_plant(plant, h / 2, 5)
        pinocchio.use_axis_tree(False)
        assert (axis.stage, pinocchio.stage) == ("axis_tree", "constraint_dynamics")
        y = x.copy()
        y[1] += offset  # a passive joint of the first arm: the loop opens
        axis.step(y, tau, 0.0, h)
        pinocchio.step(y, tau, 0.0, h)
        assert axis.largest_projected_gap >= at_least
        assert abs(axis.largest_projected_gap - pinocchio.largest_projected_gap) <= 1e-15


def test_an_uncertainty_profile_is_the_core_plants_truth_too():
    """The paper's time-varying truth (m_o(t) of the payload body with its rotational inertia
    scaled, F_n(t) of the friction, F(t) on the joints: PaperUncertainty) tabulated into the core's
    plant: design I (sampling-aware) on a Delta written in MJCF, sampled at 1 kHz over 0.5 s of
    path I with the paper's friction, equals the Python loop on the Python plant
    (simulate_reference) within 1e-10
    (rad, N m); a profile the core held wrongly (no disturbance, say) would move it by far more:
    the run without the profile differs by > 1e-4 rad."""
    robot = dp.load_robot("delta_mjcf")
    nominal = dp.ClosedChainNominalModel(robot)

    def design():
        return dp.design1(nominal, sampling_period=1e-3)

    options = {"t_end": 0.5, "mode": "sampled", "friction": True}
    runs = [
        simulate(robot, design(), dp.PathI(), uncertainty=uncertainty, **options)
        for uncertainty, simulate in (
            (dp.PaperUncertainty(), dp.simulate),
            (dp.PaperUncertainty(), simulate_reference),
            (None, dp.simulate),
        )
    ]
    core, python, nominal_truth = runs
    assert core.metadata.get("core_plant") and not python.metadata.get("core_plant")
    assert core.metadata["uncertainty"] == python.metadata["uncertainty"] is not None
    for name in ("alpha", "alpha_dot", "tau", "xyz"):
        assert np.abs(getattr(core, name) - getattr(python, name)).max() < 1e-10, name
    assert np.abs(core.alpha - nominal_truth.alpha).max() > 1e-4
