"""Time-optimal planning (delta_pin.planning.time_optimal, issue 40): the planner's dynamics against
the readable projection (tests/reference/projection.py), its time law against finite differences,
the torque of its plans checked independently at 20 kHz, its time against TOPP-RA on a fine grid,
a joint-space path of the Stewart platform, the refusals, and design I tracking the planned cycle."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.errors import InvalidParameterError, PlanningError, UnreachablePoseError
from delta_pin.planning import BlendedPath, PlannedSequence, adept_paths, plan_time_optimal
from delta_pin.planning.time_optimal import _Dynamics, path_joints
from tests.reference.projection import reduced_terms as readable_terms

ROBOTS = Path(dp.__file__).resolve().parent / "robots"
LIMIT = 20.0  # [N m] on each of the Delta's motors


@pytest.fixture(scope="module")
def delta():
    return dp.load_delta()


@pytest.fixture(scope="module")
def adept_plan(delta):
    """Half the standard Adept cycle, 100 points, |tau| <= 20 N m with the Delta's nominal friction."""
    return plan_time_optimal(delta, adept_paths(blend=0.01)[0], LIMIT, friction=True)


def _readable_torque(robot, nominal, alpha, alpha_dot, alpha_ddot) -> np.ndarray:
    """tau = M alpha_ddot + C alpha_dot + G (+ friction) of the readable projection, state by state."""
    tau = np.empty_like(alpha)
    q = None
    for i in range(len(alpha)):
        q = robot.configuration(alpha[i], initial_guess=q)
        M, _, G, c_dot = readable_terms(robot, q, alpha_dot[i])
        tau[i] = (
            M @ alpha_ddot[i]
            + c_dot
            + G
            + nominal.compensation(alpha_dot[i], nominal.friction_model is not None)
        )
    return tau


def test_the_coefficients_are_the_projected_inverse_dynamics(delta):
    """a u + b x + c (u = s_ddot, x = s_dot^2) at the path's points equals the readable projection's
    M alpha_ddot + C alpha_dot + G at alpha_dot = alpha' s_dot, alpha_ddot = alpha' u + alpha'' x, for
    random (u, x), to 1e-10 relative (round-off of two projections)."""
    path = adept_paths(blend=0.01)[0]
    s = np.linspace(0.0, path.length, 12)
    on_path = path_joints(delta, path, s)
    alpha, d1, d2 = (np.array(getattr(on_path, n)) for n in ("alpha", "alpha_dot", "alpha_ddot"))
    nominal = dp.ClosedChainNominalModel(delta)
    a, b, c0, damping = _Dynamics(delta, nominal).coefficients(alpha, d1, d2)
    rng = np.random.default_rng(3)
    u, x = rng.normal(0.0, 20.0, len(s)), rng.uniform(0.0, 4.0, len(s))
    planned = a * u[:, None] + b * x[:, None] + c0 + damping * np.sqrt(x)[:, None]
    reference = _readable_torque(
        delta, nominal, alpha, d1 * np.sqrt(x)[:, None], d1 * u[:, None] + d2 * x[:, None]
    )
    assert np.abs(planned - reference).max() <= 1e-10 * np.abs(reference).max()


def test_the_dampers_are_split_from_the_coriolis_torque(tmp_path):
    """On the MJCF Delta with a damped, sprung elbow (0.1 N m s/rad), the planner's dampers' torque
    per unit s_dot (linear in s_dot) and its quadratic Coriolis part add up to the readable C alpha_dot
    at any s_dot, to 1e-10 relative: the damper is not taken as quadratic in s_dot."""
    text = (ROBOTS / "delta.xml").read_text()
    text = text.replace(
        '<joint name="elbow_1_pitch" type="hinge" axis="0 1 0"/>',
        '<joint name="elbow_1_pitch" type="hinge" axis="0 1 0" stiffness="2" damping="0.1"/>',
    )
    (tmp_path / "sprung.xml").write_text(text)
    robot = dp.load_robot(tmp_path / "sprung.xml", recognise=False)
    alpha = np.array([[0.3, 0.4, 0.5], [0.35, 0.45, 0.4]])
    d1, d2 = np.array([[1.0, -0.5, 0.2], [0.3, 0.2, -1.0]]), np.zeros((2, 3))
    _, b, _, damping = _Dynamics(robot, dp.ClosedChainNominalModel(robot)).coefficients(alpha, d1, d2)
    assert np.abs(damping).max() > 1e-3  # the damper acts [N m per m/s of path speed]
    for s_dot in (0.5, 2.0):
        q = None
        for i in range(2):
            q = robot.configuration(alpha[i], initial_guess=q)
            c_dot = readable_terms(robot, q, d1[i] * s_dot)[3]
            planned = b[i] * s_dot**2 + damping[i] * s_dot
            assert np.allclose(planned, c_dot, rtol=1e-10, atol=1e-10 * np.abs(c_dot).max())


def test_the_time_law_and_its_joint_rates_agree_with_finite_differences(delta, adept_plan):
    """alpha_dot and alpha_ddot of the plan's joint reference against central differences of alpha
    and alpha_dot (h = 1e-6 s) away from the grid's switching times: 1e-5 of their scale (O(h^2)
    with alpha''' ~ 1e5 rad/s^3)."""
    t = np.linspace(0.01, adept_plan.duration - 0.01, 37)
    h = 1e-6
    k = np.searchsorted(adept_plan.times, t)
    t = t[np.minimum(np.abs(adept_plan.times[k] - t), np.abs(adept_plan.times[k - 1] - t)) > 3 * h]
    ref, before, after = (adept_plan.joint_reference(delta, t + d) for d in (0.0, -h, h))
    velocity = (np.array(after.alpha) - np.array(before.alpha)) / (2 * h)
    acceleration = (np.array(after.alpha_dot) - np.array(before.alpha_dot)) / (2 * h)
    assert np.abs(velocity - ref.alpha_dot).max() <= 1e-5 * np.abs(ref.alpha_dot).max()
    assert np.abs(acceleration - ref.alpha_ddot).max() <= 1e-4 * np.abs(ref.alpha_ddot).max()
    s, s_dot, _ = adept_plan.path_state([0.0, adept_plan.duration])
    assert s[0] == 0.0 and s[1] == adept_plan.s[-1] and s_dot[0] == 0.0 and s_dot[1] == 0.0  # rest to rest


def test_the_plan_holds_the_limit_on_an_independent_check(delta, adept_plan):
    """The planner's own check: max |tau| / limit <= 1 at 10 kHz (the issue's target), the limit
    reached (a time-optimal law rides it: >= 0.999). Independently, at 20 kHz (samples between the
    planner's) with the readable projection and eq. 12's friction: within 1e-3 of the limit (the
    torque moves by < 1e-4 of it in the 50 us between two checked samples; measured 1.00004)."""
    check = adept_plan.verification
    assert check.rate == 1e4 and 0.999 <= check.torque_ratio <= 1.0 and check.feasible
    t = np.append(np.arange(0.0, adept_plan.duration, 5e-5), adept_plan.duration)
    ref = adept_plan.joint_reference(delta, t)
    nominal = dp.ClosedChainNominalModel(delta, friction=True)
    tau = _readable_torque(
        delta, nominal, np.array(ref.alpha), np.array(ref.alpha_dot), np.array(ref.alpha_ddot)
    )
    assert np.abs(tau).max() / LIMIT <= 1.0 + 1e-3
    assert np.all(adept_plan.singularity > 0.03)  # the standard cycle at z = -0.40 m is far from both kinds


def test_the_plan_is_as_fast_as_toppra_on_a_fine_grid(delta):
    """Without friction, the 100-point plan against TOPP-RA as a user wires it (a cubic spline through
    the path's joints at 1000 points, collocation): TOPP-RA's time there is near the continuous
    optimum but violates the limit between its points (measured 1.14x); ours is within 3 % of it
    (measured +0.8 %; +1.4 % on the uniform grid, switch_refinements=0) and never faster by more
    than 1 % (it cannot beat the optimum)."""
    import toppra
    import toppra.algorithm
    import toppra.constraint

    path = adept_paths(blend=0.01)[0]
    plan = plan_time_optimal(delta, path, LIMIT)
    s = np.linspace(0.0, path.length, 1000)
    spline = toppra.SplineInterpolator(s, np.array(path_joints(delta, path, s).alpha))
    q = [delta.reference_configuration.copy()]

    def inverse_dynamics(a, a_dot, a_ddot):
        q[0] = delta.configuration(a, initial_guess=q[0])
        M, _, G, c_dot = delta.reduced_terms(a, a_dot, q[0])
        return M @ a_ddot + c_dot + G

    limits = np.column_stack([-np.full(3, LIMIT), np.full(3, LIMIT)])
    constraint = toppra.constraint.JointTorqueConstraint(inverse_dynamics, limits, np.zeros(3))
    _, s_dot, _ = toppra.algorithm.TOPPRA(
        [constraint], spline, gridpoints=s, solver_wrapper="seidel"
    ).compute_parameterization(0.0, 0.0)
    theirs = float(np.sum(2 * np.diff(s) / (s_dot[:-1] + s_dot[1:])))
    assert 0.99 * theirs <= plan.duration <= 1.03 * theirs


def test_the_grid_around_the_switches_approaches_the_dense_grid_time(delta):
    """Half the Adept cycle without friction: the verified plan on 1600 uniform points estimates the
    feasible optimum; the default plan (100 points and two rounds around the law's switches) must
    close at least 30 % of the 100-point uniform grid's gap to it (measured: the gap 1.24 % -> 0.61 %,
    +46 points), stay within the limit, and never beat it by more than 0.1 % (a finer grid's law
    is the better estimate of the optimum, not a bound)."""
    path = adept_paths(blend=0.01)[0]
    adapted = plan_time_optimal(delta, path, LIMIT)
    uniform = plan_time_optimal(delta, path, LIMIT, switch_refinements=0)
    dense = plan_time_optimal(delta, path, LIMIT, points=1600, switch_refinements=0)
    assert 0 < adapted.switch_points <= 100 and uniform.switch_points == 0
    assert adapted.verification.torque_ratio <= 1.0
    gap, uniform_gap = adapted.duration / dense.duration - 1.0, uniform.duration / dense.duration - 1.0
    assert -1e-3 <= gap <= 0.7 * uniform_gap, (gap, uniform_gap)


def test_a_joint_space_path_of_the_stewart_platform():
    """Six prismatic legs along a blended joint path, |f| <= 100 N: verified at 10 kHz, the legs'
    forces at the limit, and the path's own joint values at the grid (a joint path is alpha(s))."""
    robot = dp.load_robot("stewart")
    h = robot.home
    d1, d2 = np.full(6, 0.02), np.array([0.03, 0.01, 0.03, 0.01, 0.03, 0.01])
    path = BlendedPath([h, h + d1, h + d1 + d2, h + d2], 0.003, space="joints")
    plan = plan_time_optimal(robot, path, 100.0)
    assert 0.999 <= plan.verification.torque_ratio <= 1.0
    ref = plan.joint_reference(robot, [0.0, plan.duration])
    assert np.allclose(ref.alpha[0], h, atol=1e-12) and np.allclose(ref.alpha[1], h + d2, atol=1e-12)


def test_refusals_are_one_line(delta):
    path = adept_paths(blend=0.01)[0]
    cases = [
        (lambda: plan_time_optimal(delta, path, 0.5), PlanningError, "actuated joint"),
        (lambda: plan_time_optimal(delta, path, [20.0, 20.0]), InvalidParameterError, "torque_limit"),
        (lambda: plan_time_optimal(delta, path, -1.0), InvalidParameterError, "torque_limit"),
        (lambda: plan_time_optimal(delta, path, 20.0, points=2), InvalidParameterError, "points=2"),
        (
            lambda: plan_time_optimal(delta, path, 20.0, velocity_limit=np.nan),
            InvalidParameterError,
            "velocity_limit",
        ),
        (
            lambda: plan_time_optimal(delta, path, 20.0, switch_refinements=-1),
            InvalidParameterError,
            "switch_refinements=-1",
        ),
        (
            lambda: plan_time_optimal(delta, path, 20.0, singularity_margin=2.0),
            InvalidParameterError,
            "margin",
        ),
        (  # down the axis to 0.9 mm from the stretched-leg locus z* = -0.5959 m (measure 3.1e-3)
            lambda: plan_time_optimal(delta, BlendedPath([[0, 0, -0.5], [0, 0, -0.595]], 0.0), 20.0),
            PlanningError,
            "Type I singularity",
        ),
        (
            lambda: plan_time_optimal(delta, adept_paths(dp.AdeptCycle(z=-0.65))[0], 20.0),
            UnreachablePoseError,
            "s=0 m of the path",
        ),
    ]
    for call, kind, named in cases:
        with pytest.raises(kind) as error:
            call()
        assert named in str(error.value) and "\n" not in str(error.value), str(error.value)


def test_a_velocity_limit_slows_the_plan(delta):
    """|alpha_dot| <= 5 rad/s: the verified peak rate is within it (to the 10 kHz sampling) and the
    plan takes longer than without the limit."""
    path = adept_paths(blend=0.01)[0]
    free = plan_time_optimal(delta, path, LIMIT, verify=False)
    slow = plan_time_optimal(delta, path, LIMIT, velocity_limit=5.0)
    assert slow.verification.velocity_ratio <= 1.0 + 1e-6
    assert slow.duration > 1.05 * free.duration


def test_design_one_tracks_the_planned_cycle(delta):
    """The whole cycle (there and back) planned with the nominal friction, run on the constrained
    Pinocchio plant with friction: design I in continuous time within 1e-4 rad (measured 5.0e-5;
    Radau at rtol 1e-6, whose error is of that order: 5.8e-5 before a rounding-level change of the
    plant's arithmetic),
    and sampled at 1 kHz with the sampling-aware gain cap within the issue's 1e-3 rad (measured
    6.6e-4; 1.29e-3 on the uniform grid, switch_refinements=0, whose s_ddot jumps more at the
    switches)."""
    plans = [plan_time_optimal(delta, p, LIMIT, friction=True) for p in adept_paths(blend=0.01)]
    cycle = PlannedSequence(plans, "Adept cycle")
    nominal = dp.ClosedChainNominalModel(delta, friction=True)
    t_end = round(cycle.duration + 0.02, 3)
    continuous = dp.simulate(
        delta, dp.design1(nominal), cycle, t_end=t_end, dt=1e-3, friction=True, mode="continuous"
    )
    assert np.abs(continuous.alpha - continuous.alpha_d).max() <= 1e-4
    sampled = dp.simulate(
        delta, dp.design1(nominal, sampling_period=1e-3), cycle, t_end=t_end, dt=1e-3, friction=True
    )
    assert np.abs(sampled.alpha - sampled.alpha_d).max() <= 1e-3


def test_a_planar_robot_plans_in_the_plane_it_moves_in():
    """The five-bar moves its tip in xz: without axes the planner takes those (task_axes, the frame
    Jacobian's largest rows), and the plan equals the one given axes="xz" (1e-12 s)."""
    from delta_pin.planning.time_optimal import task_axes

    robot = dp.load_robot("five_bar", end_effector="tip")
    assert task_axes(robot) == "xz" and task_axes(dp.load_delta()) == "xyz"
    A, B, up = np.array([-0.02, 0.0, -0.53]), np.array([0.02, 0.0, -0.53]), np.array([0.0, 0.0, 0.01])
    path = BlendedPath([A, A + up, B + up, B], 0.003)
    found = plan_time_optimal(robot, path, 1.0, verify=False)
    given = plan_time_optimal(robot, path, 1.0, axes="xz", verify=False)
    assert found.axes == "xz" and abs(found.duration - given.duration) <= 1e-12


def test_an_axis_the_frame_does_not_move_along_is_one_line():
    """Inverse kinematics of the five-bar's tip along xy (it cannot move in y): before, a NaN step
    surfaced as "alpha=[nan, nan] must be 2 finite numbers"; now the frame and the axes are named."""
    robot = dp.load_robot("five_bar", end_effector="tip")
    with pytest.raises(UnreachablePoseError) as error:
        robot.inverse_kinematics([0.01, 0.0, -0.53], axes="xy")
    assert "does not move along all of 'xy'" in str(error.value) and "\n" not in str(error.value)


@pytest.fixture(scope="module")
def jerk_plan(delta):
    """Half the Adept cycle under 20 N m and |alpha_dddot| <= 1e5 rad/s^3 (with friction): a limit
    that the path's blends (their curvature at speed), not only the law's switches, make bind."""
    return plan_time_optimal(delta, adept_paths(blend=0.01)[0], LIMIT, friction=True, jerk_limit=1e5)


def test_the_moving_average_is_the_grid_laws_mean_over_its_window(jerk_plan):
    """s(t) of a smoothed plan against the trapezoidal mean of the grid's own law over [t - w, t]
    (4001 points: error ~ w^2 max|s_ddot| / 4001^2, < 1e-9 m here), its s_dot and s_ddot against
    central differences of s and s_dot (h = 1e-6 s: O(h^2) s_dddot', < 1e-6 of their scale); rest to
    rest, and the duration is the grid law's plus the window."""
    w = jerk_plan.smoothing
    assert w > 0.0 and jerk_plan.duration == pytest.approx(jerk_plan.times[-1] + w, abs=1e-15)
    t = np.linspace(0.0, jerk_plan.duration, 23)[1:-1]
    s, s_dot, s_ddot = jerk_plan.path_state(t)
    for ti, si in zip(t, s):
        window = np.linspace(ti - w, ti, 4001)
        mean = np.trapezoid(jerk_plan._grid_state(window)[0], window) / w
        assert abs(si - mean) <= 1e-9
    h = 1e-6
    (before, before_dot, _), (after, after_dot, _) = (jerk_plan.path_state(t + d) for d in (-h, h))
    assert np.abs((after - before) / (2 * h) - s_dot).max() <= 1e-6 * np.abs(s_dot).max()
    assert np.abs((after_dot - before_dot) / (2 * h) - s_ddot).max() <= 1e-6 * np.abs(s_ddot).max()
    ends = jerk_plan.path_state([0.0, jerk_plan.duration])
    assert ends[0][0] == 0.0 and ends[0][1] == jerk_plan.s[-1] and ends[1][0] == 0.0 and ends[1][1] == 0.0


def test_a_jerk_limit_holds_on_an_independent_check(delta, jerk_plan):
    """The planner's check holds (torque <= 1 and jerk <= 1 at 10 kHz: the jerk there is the mean
    over each 0.1 ms between samples). Independently at 20 kHz, the jerk by central differences of
    the exact alpha_ddot (also a 0.1 ms mean, centred between the planner's samples) stays within
    1 % of the limit (measured 0.968: s_dddot is piecewise constant, and a piece shorter than a
    sample's 0.1 ms is averaged by both checks), and the torque of the readable projection within
    1e-3 of its limit. Without the jerk limit the same path's law has a jerk hundreds of times over (its
    switches), and runs faster."""
    check = jerk_plan.verification
    assert check.feasible and check.torque_ratio <= 1.0 and check.jerk_ratio <= 1.0
    t = np.append(np.arange(0.0, jerk_plan.duration, 5e-5), jerk_plan.duration)
    ref = jerk_plan.joint_reference(delta, t)
    alpha_ddot = np.array(ref.alpha_ddot)
    jerk = (alpha_ddot[2:] - alpha_ddot[:-2]) / (t[2:] - t[:-2])[:, None]
    assert np.abs(jerk).max() / 1e5 <= 1.01
    nominal = dp.ClosedChainNominalModel(delta, friction=True)
    tau = _readable_torque(delta, nominal, np.array(ref.alpha), np.array(ref.alpha_dot), alpha_ddot)
    assert np.abs(tau).max() / LIMIT <= 1.0 + 1e-3
    free = plan_time_optimal(delta, adept_paths(blend=0.01)[0], LIMIT, friction=True)
    t = np.append(np.arange(0.0, free.duration, 1e-4), free.duration)
    free_ddot = np.array(free.joint_reference(delta, t).alpha_ddot)
    assert np.abs(np.diff(free_ddot, axis=0) / 1e-4).max() > 100 * 1e5
    assert free.duration < jerk_plan.duration
    meta = jerk_plan.metadata()
    assert meta["jerk_limit"] == [1e5] * 3 and meta["smoothing"] == jerk_plan.smoothing
    assert meta["jerk_ratio"] == check.jerk_ratio


def test_a_bad_jerk_limit_is_one_line(delta):
    path = adept_paths(blend=0.01)[0]
    for call, named in (
        (lambda: plan_time_optimal(delta, path, LIMIT, jerk_limit=0.0), "jerk_limit=0.0"),
        (lambda: plan_time_optimal(delta, path, LIMIT, jerk_limit=[1e5, 1e5]), "jerk_limit"),
        (lambda: plan_time_optimal(delta, path, LIMIT, jerk_limit=1e5, verify=False), "verify=True"),
    ):
        with pytest.raises(InvalidParameterError) as error:
            call()
        assert named in str(error.value) and "\n" not in str(error.value), str(error.value)


@pytest.mark.parametrize("jerk", [1e6, 1e5, 1e4])
def test_jerk_limits_on_the_five_bar(jerk):
    """Any closed chain: the five-bar's pick and place of its tip (|tau| <= 1 N m) under jerk limits
    from barely binding to 18x slower than its law's switches allow: each plan's check holds (torque
    and jerk <= 1 at 10 kHz) and it takes longer as the limit falls (measured 185.1, 197.9, 347.2 ms
    against 184.8 ms unlimited; at 1e5 the local rounds trade overshoots and the whole law is run
    slower, the fallback)."""
    robot = dp.load_robot("five_bar", end_effector="tip")
    A, B, up = np.array([-0.02, 0.0, -0.53]), np.array([0.02, 0.0, -0.53]), np.array([0.0, 0.0, 0.01])
    path = BlendedPath([A, A + up, B + up, B], 0.003)
    free = plan_time_optimal(robot, path, 1.0)
    plan = plan_time_optimal(robot, path, 1.0, jerk_limit=jerk)
    check = plan.verification
    assert check.feasible and check.torque_ratio <= 1.0 and check.jerk_ratio <= 1.0
    assert free.duration < plan.duration < {1e6: 1.01, 1e5: 1.2, 1e4: 2.5}[jerk] * free.duration


def test_design_one_tracks_a_jerk_limited_cycle_closer(delta):
    """The same cycle under |alpha_dddot| <= 1e6 rad/s^3 (+1.7 % of cycle time): no jump of the
    reference's acceleration for the loop to chase, so design I follows it closer -- sampled at
    1 kHz within 5e-4 rad (measured 4.0e-4 against the unlimited cycle's 6.6e-4), in continuous
    time within 1e-5 rad (measured 1.6e-6 against 5.0e-5), asking for at most 30 N m (measured
    28.3 against 38.1)."""
    plans = [
        plan_time_optimal(delta, p, LIMIT, friction=True, jerk_limit=1e6) for p in adept_paths(blend=0.01)
    ]
    cycle = PlannedSequence(plans, "Adept cycle, jerk-limited")
    nominal = dp.ClosedChainNominalModel(delta, friction=True)
    t_end = round(cycle.duration + 0.02, 3)
    sampled = dp.simulate(
        delta, dp.design1(nominal, sampling_period=1e-3), cycle, t_end=t_end, dt=1e-3, friction=True
    )
    assert np.abs(sampled.alpha - sampled.alpha_d).max() <= 5e-4
    assert np.abs(sampled.tau).max() <= 30.0
    continuous = dp.simulate(
        delta, dp.design1(nominal), cycle, t_end=t_end, dt=1e-3, friction=True, mode="continuous"
    )
    assert np.abs(continuous.alpha - continuous.alpha_d).max() <= 1e-5
