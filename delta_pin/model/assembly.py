"""Global assembly of a closed chain: closing the loops from a start that may be far from closed.

Files people publish often store a pose whose loops are open: Gepetto's exported legs are saved
with every joint at zero, and MuJoCo users write a ``qpos0`` that MuJoCo's soft constraints pull
shut at the first steps. Newton with the actuated joints held (minimum-norm steps, capped) only
converges from nearby; where it does not, the loops are closed by a global solve, first with the
actuated joints held at the file's values, then with every joint free:

    min_dv  1/2 |r(q0 (+) dv)|^2 + 1/2 w^2 |dv|^2      over the velocity coordinates not held,

by SciPy's trust-region reflective least squares (``scipy.optimize.least_squares``, method
``"trf"``: damped Gauss-Newton steps inside a trust region, i.e. Levenberg-Marquardt with a step
control), with the Jacobian J_c(q) dIntegrate/dv. ``(+)`` is ``pin.integrate``, so ball and free
joints stay on their manifolds. The small pull w |dv| (first round only) keeps what the loops
leave free (idle spins, the freed actuated joints) near the file's pose, instead of wherever the
trust region wanders; the problem is then re-linearised without it and polished by Newton, a few
times (exponential coordinates stay small). A stalled start (a local minimum of |r|, e.g. a leg
folded the other way) is followed by a few deterministic restarts: the start moved by seeded
random steps of growing size. The solution closest in the least-squares sense to the file's pose
is the one found first, so the assembly mode the author drew is kept where one exists.

Units: r in m (points) and rad (weld orientations); q, v as Pinocchio's.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

__all__ = ["AssemblyResult", "assemble", "newton"]

ASSEMBLY_TOLERANCE = 1e-10  # [m or rad] a global solve stops once the loops close this well
RESTART_SCALES = (0.0, 0.3, 0.3, 1.0, 1.0, 2.0)  # [rad or m] the restarts' random step sizes
_ROUNDS = 3  # re-linearisations per start
_EVALUATIONS = 60  # residual evaluations per round
_NEWTON_STEPS = 60  # Newton steps from the given start
_POLISH_STEPS = 15  # Newton steps after each round of the global solve
_BUDGET = 3000  # residual evaluations in all: past them no further start is tried (a bounded wait)
_PULL = 1e-2  # weight of the first round's pull towards its start [residual units per rad or m]


@dataclass(frozen=True)
class AssemblyResult:
    """What :func:`assemble` found.

    Attributes:
        q: the configuration of least closure residual found (nq,).
        gap: its largest closure residual max |r| [m or rad].
        starts: how many starts were tried (1: the given one sufficed).
        evaluations: residual evaluations in all.
    """

    q: np.ndarray
    gap: float
    starts: int
    evaluations: int


def assemble(
    model: pin.Model,
    residual: Callable[[np.ndarray], np.ndarray],
    jacobian: Callable[[np.ndarray], np.ndarray],
    q0: np.ndarray,
    *,
    held: Sequence[int] = (),
    free_fallback: bool = True,
    tolerance: float = ASSEMBLY_TOLERANCE,
) -> AssemblyResult:
    """Close the loops from ``q0`` (module docstring): Newton with the ``held`` coordinates fixed,
    then the global solve with them fixed, then (``free_fallback``) with every coordinate free;
    the first that closes to ``tolerance`` wins, else the smallest gap found.

    Args:
        model: the tree (for ``pin.integrate`` and ``pin.dIntegrate``).
        residual: r(q) (m,) [m, rad].
        jacobian: dr/dv (m, nv) at q (J_c).
        q0: the start (nq,), e.g. the file's pose.
        held: velocity indices kept at their value in ``q0`` (the actuated joints).
        free_fallback: free the held coordinates where holding them closes no loop.
        tolerance: stop once max |r| is at most this [m or rad].

    Returns:
        The best configuration found (its ``gap`` may exceed ``tolerance``: the caller decides).
    """
    q0 = np.asarray(q0, dtype=float)
    held = np.asarray(held, dtype=int)
    q, gap, evaluations = newton(model, residual, jacobian, q0, held, tolerance)
    best = AssemblyResult(q, gap, 1, evaluations)
    stages = [held] + ([np.zeros(0, dtype=int)] if free_fallback and held.size else [])
    for fixed in stages:
        if best.gap <= tolerance:
            break
        found = _global(model, residual, jacobian, q0, fixed, tolerance)
        evaluations += found.evaluations
        if found.gap < best.gap:
            best = found
        best = AssemblyResult(best.q, best.gap, found.starts, evaluations)
    return best


def newton(
    model, residual, jacobian, q: np.ndarray, held: np.ndarray, tolerance: float, steps: int = _NEWTON_STEPS
):
    """Newton from q over the coordinates not held, minimum-norm steps (LAPACK's least squares at
    numeric rank, so idle motions stay where they are) capped at 0.5 (rad or m) so that a far start
    does not jump to another assembly mode: (q, gap, evaluations) of the smallest gap met.

    Once a robot is built and its mobility classified, the compiled core's Newton assembles it
    (``ClosedChainRobot.configuration``); this one closes the loops while it is being built."""
    free = np.setdiff1d(np.arange(model.nv), held)
    best_q, best_gap = q, _gap(residual(q))
    for k in range(steps):
        r = residual(q)
        gap = _gap(r)
        if gap < best_gap:
            best_q, best_gap = q, gap
        if gap <= tolerance or not np.isfinite(gap):
            return best_q, best_gap, k + 1
        step = np.linalg.lstsq(jacobian(q)[:, free], r, rcond=None)[0]
        largest = np.abs(step).max(initial=0.0)
        if largest > 0.5:
            step *= 0.5 / largest
        dv = np.zeros(model.nv)
        dv[free] = -step
        q = pin.integrate(model, q, dv)
    return best_q, best_gap, steps


def _global(model, residual, jacobian, q0: np.ndarray, held: np.ndarray, tolerance: float) -> AssemblyResult:
    """The damped least-squares solve with restarts (module docstring)."""
    from scipy.optimize import least_squares

    free = np.setdiff1d(np.arange(model.nv), held)
    rng = np.random.default_rng(0)
    best_q, best_gap = q0.copy(), _gap(residual(q0))
    evaluations, starts = 1, 0
    for scale in RESTART_SCALES:
        if best_gap <= tolerance or evaluations > _BUDGET:
            break
        starts += 1
        dv = np.zeros(model.nv)
        if scale:
            dv[free] = rng.uniform(-scale, scale, free.size)
        q = pin.integrate(model, q0, dv)
        for round_ in range(_ROUNDS):
            base = q.copy()
            # the first round also pulls towards its start (weight _PULL), so that motions the
            # loops leave free (idle spins, or the actuated joints when freed) stay where they were
            pull = _PULL if round_ == 0 else 0.0

            def step(x: np.ndarray, base: np.ndarray = base) -> np.ndarray:
                delta = np.zeros(model.nv)
                delta[free] = x
                return pin.integrate(model, base, delta)

            def fun(x: np.ndarray, pull: float = pull) -> np.ndarray:
                return np.concatenate([residual(step(x)), pull * x])

            def jac(x: np.ndarray, base: np.ndarray = base, pull: float = pull) -> np.ndarray:
                delta = np.zeros(model.nv)
                delta[free] = x
                dq_dv = pin.dIntegrate(model, base, delta, pin.ArgumentPosition.ARG1)
                return np.vstack([(jacobian(step(x)) @ dq_dv)[:, free], pull * np.eye(free.size)])

            solution = least_squares(
                fun, np.zeros(free.size), jac=jac, method="trf", x_scale=1.0,
                ftol=1e-15, xtol=1e-15, gtol=1e-15, max_nfev=_EVALUATIONS,
            )  # fmt: skip
            evaluations += int(solution.nfev)
            q = step(solution.x)
            q, gap, count = newton(model, residual, jacobian, q, held, tolerance, _POLISH_STEPS)
            evaluations += count
            if gap < best_gap:
                best_q, best_gap = q, gap
            if gap <= tolerance or not np.isfinite(gap):
                break
    return AssemblyResult(best_q, best_gap, starts, evaluations)


def _gap(r: np.ndarray) -> float:
    return float(np.abs(r).max()) if np.isfinite(r).all() else np.inf
