"""``delta-pin validate --robot PATH``: check a closed-chain robot's projected model where no
analytic model exists to compare with.

Five checks, each against an independent reference (docs/architecture.md section 10):

1. **closure** -- the largest closure residual of the assembled random states [m or rad];
2. **plant** -- the projected alpha_ddot = M^-1 (tau - C alpha_dot - G) against the plant's
   ``pin.constraintDynamics`` (a KKT solve on the whole tree) under random torques (relative);
3. **gravity** -- G against central differences of the potential energy V(q(alpha)) (relative);
4. **Coriolis** -- C + C^T against central differences of M along alpha_dot (M_dot = C + C^T, the
   skew-symmetry the designs rely on) (relative);
5. **energy** -- free motion (zero torque, no friction) for ``energy_duration`` on the plant
   with RK4 at 0.1 ms (full coordinates, Baumgarte-stabilised): the drift of kinetic + potential
   energy relative to the largest kinetic energy, and the closure gap along it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from delta_pin.errors import AssemblyError, InvalidParameterError
from delta_pin.model.closed_chain import ClosedChainRobot
from delta_pin.sim.closed_chain_plant import ClosedChainPlant
from delta_pin.sim.integrators import rk4_step

__all__ = ["ClosedChainValidation", "validate_closed_chain"]

DIFFERENCE_STEP = 1e-6  # [rad or m] central differences: truncation ~1e-12, rounding ~1e-10 relative


@dataclass
class ClosedChainValidation:
    """The checks' results: name -> (measured, tolerance, what it measures)."""

    robot: str
    states: int
    checks: dict[str, tuple[float, float, str]] = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        return all(value <= tol for value, tol, _ in self.checks.values())

    def table(self) -> str:
        lines = [
            f"{self.robot}: {self.states} assembled random states",
            f"{'check':<10} {'measured':>11}  {'tol':>8}  ",
        ]
        for name, (value, tol, what) in self.checks.items():
            verdict = "ok" if value <= tol else "FAILED"
            lines.append(f"{name:<10} {value:>11.3e}  {tol:>8.0e}  {verdict:<6} {what}")
        lines.append("all checks passed" if self.passed else "some checks FAILED")
        return "\n".join(lines)


def _potential(robot: ClosedChainRobot, alpha: np.ndarray, q_guess: np.ndarray) -> float:
    q = robot.configuration(alpha, initial_guess=q_guess)
    return float(pin.computePotentialEnergy(robot.model, robot.data, q))


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1e-9))


def validate_closed_chain(
    robot: ClosedChainRobot,
    samples: int = 20,
    seed: int = 0,
    spread: float = 0.1,
    energy_duration: float = 0.5,
) -> ClosedChainValidation:
    """Run the five checks (module docstring) at ``samples`` random states alpha = home +
    U(-spread, spread) [rad or m], alpha_dot ~ N(0, 0.5^2).

    Raises:
        InvalidParameterError: bad ``samples``, ``spread`` or ``energy_duration``.
        AssemblyError: no random state assembles (the home configuration is at the workspace edge).
    """
    if samples < 1:
        raise InvalidParameterError(f"samples={samples} must be >= 1")
    if not spread > 0.0 or not energy_duration > 0.0:
        raise InvalidParameterError(f"spread={spread} and energy_duration={energy_duration} must be > 0")
    rng = np.random.default_rng(seed)
    plant = ClosedChainPlant(robot, coordinates="active")
    report = ClosedChainValidation(robot.name, 0)
    gaps, plant_errors, gravity_errors, coriolis_errors = [], [], [], []
    h = DIFFERENCE_STEP
    for _ in range(samples):
        alpha = robot.home + rng.uniform(-spread, spread, robot.dof)
        alpha_dot = rng.normal(0.0, 0.5, robot.dof)
        try:
            q = robot.configuration(alpha, initial_guess=robot.reference_configuration)
        except AssemblyError:
            continue
        report.states += 1
        gaps.append(robot.closure_gap(q))
        M, C, G, coriolis = robot.reduced_terms(alpha, alpha_dot, q)
        tau = rng.normal(0.0, 1.0, robot.dof)
        v = robot.velocity_map(q) @ alpha_dot
        plant_alpha_ddot = plant.accelerations(0.0, q, v, tau)[robot.actuated_indices]
        plant_errors.append(_relative(np.linalg.solve(M, tau - coriolis - G), plant_alpha_ddot))
        eye = np.eye(robot.dof)
        G_fd = np.array(
            [
                (_potential(robot, alpha + h * e, q) - _potential(robot, alpha - h * e, q)) / (2 * h)
                for e in eye
            ]
        )
        gravity_errors.append(_relative(G, G_fd) if np.abs(G_fd).max() > 1e-9 else float(np.abs(G).max()))
        M_plus = robot.reduced_terms(
            alpha + h * alpha_dot, alpha_dot, robot.configuration(alpha + h * alpha_dot, initial_guess=q)
        )[0]
        M_minus = robot.reduced_terms(
            alpha - h * alpha_dot, alpha_dot, robot.configuration(alpha - h * alpha_dot, initial_guess=q)
        )[0]
        coriolis_errors.append(_relative(C + C.T, (M_plus - M_minus) / (2 * h)))
        robot.configuration(alpha, initial_guess=q)  # leave the warm start here
    if report.states == 0:
        raise AssemblyError(
            f"{robot.name!r}: none of {samples} random states within {spread} of home={robot.home.tolist()} "
            "assembles; lower --spread"
        )
    report.checks["closure"] = (max(gaps), 1e-10, "largest closure residual of the states [m or rad]")
    report.checks["plant"] = (
        max(plant_errors),
        1e-8,
        "projected alpha_ddot vs constraintDynamics (relative)",
    )
    report.checks["gravity"] = (max(gravity_errors), 1e-6, "G vs dV/dalpha by central differences (relative)")
    report.checks["coriolis"] = (
        max(coriolis_errors),
        1e-6,
        "C + C^T vs dM/dt by central differences (relative)",
    )
    drift, gap = _energy_drift(robot, energy_duration, rng)
    report.checks["energy"] = (
        drift,
        1e-6,
        f"energy drift over {energy_duration:g} s of free motion (relative)",
    )
    report.checks["loop gap"] = (gap, 1e-8, "largest closure gap along the free motion [m or rad]")
    return report


def _energy(robot: ClosedChainRobot, q: np.ndarray, v: np.ndarray) -> tuple[float, float]:
    kinetic = pin.computeKineticEnergy(robot.model, robot.data, q, v)
    return kinetic + pin.computePotentialEnergy(robot.model, robot.data, q), kinetic


def _energy_drift(robot: ClosedChainRobot, duration: float, rng) -> tuple[float, float]:
    """Free motion from home with a random velocity, RK4 at 0.1 ms on the plant in full
    coordinates where the joints allow (a passive mechanism may swing through a configuration
    where the actuated coordinates do not determine the rest), else in active coordinates:
    (largest |E(t) - E(0)| / max kinetic energy, largest closure gap)."""
    full = robot.model.nq == robot.model.nv
    plant = ClosedChainPlant(robot, coordinates="full" if full else "active")
    h = 1e-4
    x = plant.initial_state(robot.home, rng.normal(0.0, 0.5, robot.dof))
    nq, n = robot.model.nq, robot.dof

    def point(x: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        return (x[:nq], x[nq:]) if full else plant.complete(x[:n], x[n:], t)

    q, v = point(x, 0.0)
    energy0, kinetic = _energy(robot, q, v)
    largest_kinetic, drift, gap = kinetic, 0.0, 0.0
    zero = np.zeros(n)
    for k in range(round(duration / h)):
        x = rk4_step(lambda t, y: plant.derivative(t, y, zero), k * h, x, h)
        q, v = point(x, (k + 1) * h)
        energy, kinetic = _energy(robot, q, v)
        largest_kinetic = max(largest_kinetic, kinetic)
        drift = max(drift, abs(energy - energy0))
        gap = max(gap, robot.closure_gap(q))
    return drift / max(largest_kinetic, 1e-12), gap
