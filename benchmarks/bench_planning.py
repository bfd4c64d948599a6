"""Time-optimal planning (issue 40): delta-pin's planner against TOPP-RA wired by hand, same path,
same limits, same grid, measured in one run.

Run: ``python benchmarks/bench_planning.py [--repeats 3] [--points 100]``

Three cases: the Delta's Adept cycle (25 mm up, 305 mm across at z = -0.40 m, 10 mm blends, both
halves, |tau| <= 20 N m), a pick-and-place of the five-bar's tip (|tau| <= 1 N m) and a joint-space
path of the Stewart platform's legs (|f| <= 100 N). The reference is what a user of ``toppra``
writes for a closed chain: a cubic spline through the actuated joints' values at the grid points
(``SplineInterpolator``), ``JointTorqueConstraint`` on the projected inverse dynamics, the
default collocation discretisation and the Seidel solver. Both time laws are then checked on the
exact model (the path's own inverse kinematics at each sample, not the spline) at 10 kHz: the
largest |tau_j| / limit_j. delta-pin's planner is :func:`delta_pin.planning.plan_time_optimal`
(the same solver, its coefficients from the exact path derivatives, the interpolation
discretisation, then the verification and its repairs). Without friction in both, so that the
two plan the same dynamics. Then each case again under joint jerk limits of 1e6, 1e5 and 1e4
(rad/s^3, or m/s^3 for the Stewart platform's legs): its time against the unlimited plan's, and
its check.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from common import machine_info, measure, print_table, report_target

import delta_pin as dp
from delta_pin.planning import BlendedPath, adept_paths, plan_time_optimal
from delta_pin.planning.time_optimal import (
    TimeOptimalPlan,
    _Dynamics,
    _times,
    _verify,
    branch_configuration,
    path_joints,
)


def _cases():
    delta = dp.load_delta()
    there, back = adept_paths(blend=0.01)
    yield "Delta, Adept cycle A -> B", delta, there, 20.0, {}
    yield "Delta, Adept cycle B -> A", delta, back, 20.0, {}
    five_bar = dp.load_robot("five_bar", end_effector="tip")
    A, B, up = np.array([-0.02, 0.0, -0.53]), np.array([0.02, 0.0, -0.53]), np.array([0.0, 0.0, 0.01])
    yield (
        "five-bar, pick and place of its tip",
        five_bar,
        BlendedPath([A, A + up, B + up, B], 0.003),
        1.0,
        {"axes": "xz"},
    )
    stewart = dp.load_robot("stewart")
    h = stewart.home
    d1, d2 = np.full(6, 0.02), np.array([0.03, 0.01, 0.03, 0.01, 0.03, 0.01])
    legs = BlendedPath([h, h + d1, h + d1 + d2, h + d2], 0.003, space="joints")
    yield "Stewart platform, a path of its legs", stewart, legs, 100.0, {}


def _toppra_by_hand(robot, path, limit: float, points: int, options: dict):
    """TOPP-RA as a user wires it: (s, s_dot) of a spline through the grid's joint values."""
    import toppra
    import toppra.algorithm
    import toppra.constraint as constraint

    s = np.linspace(0.0, path.length, points)
    alpha = np.array(path_joints(robot, path, s, axes=options.get("axes")).alpha)
    spline = toppra.SplineInterpolator(s, alpha)
    q = [robot.reference_configuration.copy()]

    def inverse_dynamics(a, a_dot, a_ddot):
        q[0] = robot.configuration(a, initial_guess=q[0])
        M, _, G, c_dot = robot.reduced_terms(a, a_dot, q[0])
        return M @ a_ddot + c_dot + G

    limits = np.column_stack([-np.full(robot.dof, limit), np.full(robot.dof, limit)])
    torque = constraint.JointTorqueConstraint(inverse_dynamics, limits, np.zeros(robot.dof))
    solver = toppra.algorithm.TOPPRA([torque], spline, gridpoints=s, solver_wrapper="seidel")
    _, s_dot, _ = solver.compute_parameterization(0.0, 0.0)
    return s, s_dot


def _checked(robot, path, limit: float, points: int, options: dict):
    """TOPP-RA by hand's law on ``points`` points as a plan along the exact path, and its check on
    the exact model at 10 kHz."""
    s, s_dot = _toppra_by_hand(robot, path, limit, points, options)
    x = s_dot * s_dot
    law = TimeOptimalPlan(
        path, None, options.get("axes"), s, s_dot, (x[1:] - x[:-1]) / (2 * np.diff(s)), _times(s, s_dot),
        np.full(robot.dof, limit), None,
    )  # fmt: skip
    start = branch_configuration(
        robot, np.array(path_joints(robot, path, [0.0], axes=options.get("axes")).alpha[0])
    )
    check, _, _, _ = _verify(law, robot, _Dynamics(robot, dp.ClosedChainNominalModel(robot), start), 1e4)
    return law, check


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--points", type=int, default=100)
    args = parser.parse_args()
    print(
        f"machine: {machine_info()}; {args.points} grid points; torque checked at 10 kHz on the exact model"
    )
    rows = []
    for name, robot, path, limit, options in _cases():
        plan = plan_time_optimal(robot, path, limit, points=args.points, **options)
        ours = measure(
            f"{name}: delta-pin plan_time_optimal, without the verification",
            lambda robot=robot, path=path, limit=limit, options=options: plan_time_optimal(
                robot, path, limit, points=args.points, verify=False, **options
            ),
            args.repeats,
        )
        verified = measure(
            f"{name}: delta-pin plan_time_optimal, verified and repaired",
            lambda robot=robot, path=path, limit=limit, options=options: plan_time_optimal(
                robot, path, limit, points=args.points, **options
            ),
            args.repeats,
        )
        uniform_plan = plan_time_optimal(
            robot, path, limit, points=args.points, switch_refinements=0, **options
        )
        uniform = measure(
            f"{name}: the same on the uniform grid (switch_refinements=0), verified and repaired",
            lambda robot=robot, path=path, limit=limit, options=options: plan_time_optimal(
                robot, path, limit, points=args.points, switch_refinements=0, **options
            ),
            args.repeats,
        )
        # the feasible optimum's estimate: a verified plan on 16 times the points
        dense = plan_time_optimal(robot, path, limit, points=16 * args.points, **options)
        reference = measure(
            f"{name}: TOPP-RA by hand (spline, collocation)",
            lambda robot=robot, path=path, limit=limit, options=options: _toppra_by_hand(
                robot, path, limit, args.points, options
            ),
            args.repeats,
        )
        theirs, check = _checked(robot, path, limit, args.points, options)
        fine, fine_check = _checked(robot, path, limit, 10 * args.points, options)
        print_table(name, [ours, verified, uniform, reference], reference)
        print(
            f"\n{name}: time {plan.duration * 1e3:.2f} ms (delta-pin, {plan.switch_points} points added "
            f"around the switches, {plan.repairs} repairs, {len(plan.s)} points at the end; on the uniform "
            f"grid {uniform_plan.duration * 1e3:.2f} ms, {len(uniform_plan.s)} points; on "
            f"{16 * args.points} points {dense.duration * 1e3:.2f} ms, verified) against "
            f"{theirs.duration * 1e3:.2f} ms (TOPP-RA by hand), "
            f"{100 * (plan.duration / theirs.duration - 1):+.2f} %; largest |tau| / limit at 10 kHz: "
            f"{plan.verification.torque_ratio:.4f} against {check.torque_ratio:.4f}; TOPP-RA by hand on "
            f"{10 * args.points} points: {fine.duration * 1e3:.2f} ms "
            f"({fine_check.torque_ratio:.4f} of the limit)"
        )
        rows.append((name, plan, theirs, check, ours, verified, fine, uniform_plan, dense))
    for name, plan, theirs, check, ours, verified, fine, uniform_plan, dense in rows:
        report_target(f"{name}: time / TOPP-RA's - 1", plan.duration / theirs.duration - 1.0, 0.01, "x")
        report_target(
            f"{name}: the uniform grid's time / TOPP-RA's - 1", uniform_plan.duration / theirs.duration - 1.0,
            None, "x",
        )  # fmt: skip
        report_target(
            f"{name}: time / delta-pin's verified plan on {16 * args.points} points - 1",
            plan.duration / dense.duration - 1.0, None, "x",
        )  # fmt: skip
        report_target(
            f"{name}: time / TOPP-RA's on {10 * args.points} points - 1",
            plan.duration / fine.duration - 1.0,
            None,
            "x",
        )
        report_target(f"{name}: largest |tau| / limit at 10 kHz", plan.verification.torque_ratio, 1.0, "x")
        report_target(f"{name}: TOPP-RA by hand's |tau| / limit at 10 kHz", check.torque_ratio, None, "x")
        report_target(
            f"{name}: planning, {args.points} points (and those added around the switches)", ours.median, 5e-3
        )
        report_target(f"{name}: planning with the verification", verified.median, 50e-3)
    # jerk limits on every case: the time they cost, each plan's check at 10 kHz, the planning time
    for (name, robot, path, limit, options), row in zip(_cases(), rows):
        plan = row[1]
        print(
            f"\n{name} under jerk limits (the law averaged over a moving window, slowed where the path's "
            "jerk binds):"
        )
        for jerk in (1e6, 1e5, 1e4):
            start = time.perf_counter()
            smooth = plan_time_optimal(robot, path, limit, points=args.points, jerk_limit=jerk, **options)
            took = time.perf_counter() - start
            check = smooth.verification
            print(
                f"  |alpha_dddot| <= {jerk:.0e}: {smooth.duration * 1e3:.2f} ms "
                f"({100 * (smooth.duration / plan.duration - 1):+.1f} % on the unlimited "
                f"{plan.duration * 1e3:.2f} ms), window {smooth.smoothing * 1e3:.2f} ms; at 10 kHz "
                f"|tau| / limit {check.torque_ratio:.4f}, jerk / limit {check.jerk_ratio:.4f}; "
                f"planned in {took:.2f} s"
            )
            label = f"{name}, jerk <= {jerk:.0e}"
            report_target(f"{label}: time / the unlimited plan's", smooth.duration / plan.duration, None, "x")
            report_target(f"{label}: largest |tau| / limit at 10 kHz", check.torque_ratio, 1.0, "x")
            report_target(f"{label}: largest jerk / limit at 10 kHz", check.jerk_ratio, 1.0, "x")


if __name__ == "__main__":
    main()
