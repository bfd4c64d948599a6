"""The time-varying truth a plant integrates (eq. 13 of the paper), kept apart from what a
controller knows: the payload body's mass m_o(t) [kg], the normal forces F_n(t) [N] of the
actuated joints' friction and the joint disturbance F(t) [N m], from an uncertainty profile
(:mod:`delta_pin.sim.uncertainty`) or nominal. One implementation for every plant (the Delta's
analytic plant and the Pinocchio plant of any robot), tabulated once per run on the integrator's
stage grid.
"""

from __future__ import annotations

import numpy as np

__all__ = ["PlantTruth"]


class PlantTruth:
    """m_o(t), F_n(t), F(t) of a plant with ``dof`` actuated joints.

    Args:
        uncertainty: the profile (three joints: the profiles' shape), or ``None`` for the nominal
            truth (m_o = nominal_mass, F_n = nominal_normal_force, F = 0; any ``dof``).
        nominal_mass: m̄_o [kg].
        nominal_normal_force: F̄_n (dof,) [N].
    """

    def __init__(self, uncertainty, nominal_mass: float, nominal_normal_force: np.ndarray) -> None:
        self.uncertainty = uncertainty
        self.nominal_mass = float(nominal_mass)
        self.nominal_normal_force = np.asarray(nominal_normal_force, dtype=float)
        self.dof = len(self.nominal_normal_force)
        self.table = None  # (m_o (R,), F_n (R, dof), F (R, dof)) at t = k step (tabulate)
        self.step = None

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(m_o, F_n, F) at a time t [s] -- shapes (), (dof,), (dof,) -- or at an array of times
        (R,) -- shapes (R,), (R, dof), (R, dof)."""
        if self.uncertainty is not None:
            return (
                self.uncertainty.platform_mass(t, self.nominal_mass),
                self.uncertainty.normal_force(t, self.nominal_normal_force),
                self.uncertainty.disturbance(t),
            )
        shape = np.shape(t)
        return (
            np.full(shape, self.nominal_mass),
            np.broadcast_to(self.nominal_normal_force, (*shape, self.dof)).copy(),
            np.zeros((*shape, self.dof)),
        )

    def tabulate(self, step: float, count: int) -> None:
        """Tabulate the truth at t = k step [s], k < count (one vectorised call of the profile)."""
        self.step = step
        self.table = self.evaluate(np.arange(count) * step)

    def at(self, t: float) -> tuple[float, np.ndarray, np.ndarray]:
        """(m_o [kg], F_n (dof,) [N], F (dof,) [N m]) at one time t [s]: the table's row where t
        is on its grid (to 1e-9 of a step), else the profile."""
        if self.table is not None:
            k = round(t / self.step)
            if 0 <= k < len(self.table[0]) and abs(k * self.step - t) <= 1e-9 * self.step:
                return self.table[0][k], self.table[1][k], self.table[2][k]
        if self.uncertainty is None:
            return self.nominal_mass, self.nominal_normal_force, np.zeros(self.dof)
        return self.uncertainty.at(t, self.nominal_mass, self.nominal_normal_force)
