"""Stribeck friction torque of the active joints (eqs. 11-12).

    M_f,i = [F_c + (F_s - F_c) exp(-(alpha_dot_i r_a / v_s)^2)] sgn(alpha_dot_i) r_a
            + mu_v alpha_dot_i r_a,               F_c = mu_d F_n,i,  F_s = mu_s F_n,i   (eq. 12)

Reading of eq. 12 (docs/architecture.md section 4, erratum 6): the exponent compares the sliding speed at the
friction arm, alpha_dot r_a [m/s], with the Stribeck velocity v_s taken in m/s (Table 1 prints
rad/s); the viscous term is mu_v alpha_dot r_a [N m] with mu_v in N s/m, as printed.

``sign_velocity_scale`` replaces sgn(v) by tanh(v / scale): 0 gives the exact (discontinuous)
sign of the paper; a plant uses a small positive scale so that the ODE stays Lipschitz.

:class:`Friction` is what a plant (the truth) or a nominal model (what a controller knows) is
given.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from delta_pin.errors import InvalidParameterError
from delta_pin.model.description import StribeckParameters

__all__ = ["Friction", "stribeck_torque"]


@dataclass(frozen=True)
class Friction:
    """Joint friction (eqs. 11-12) of a plant or of a nominal model.

    Attributes:
        stribeck: Stribeck parameters; ``None`` takes the robot's (from its URDF).
        normal_force: nominal normal force F̄_n per joint [N] (15 N in the paper); an
            uncertainty profile varies it in time.
        sign_velocity_scale: smoothing of sgn by tanh(alpha_dot / scale) [rad/s].
    """

    stribeck: StribeckParameters | None = None
    normal_force: float = 15.0
    sign_velocity_scale: float = 0.01

    def __post_init__(self) -> None:
        if not self.normal_force >= 0.0:
            raise InvalidParameterError(f"normal_force={self.normal_force} must be >= 0")
        if not self.sign_velocity_scale > 0.0:
            raise InvalidParameterError(f"sign_velocity_scale={self.sign_velocity_scale} must be > 0")

    def stribeck_for(self, robot_friction: StribeckParameters | None) -> StribeckParameters:
        """The Stribeck parameters in force: this setting's, else the robot's (from its URDF)."""
        stribeck = self.stribeck or robot_friction
        if stribeck is None:
            raise InvalidParameterError("friction requested but the robot's URDF carries no Stribeck data")
        return stribeck


def stribeck_torque(
    friction: StribeckParameters,
    alpha_dot: np.ndarray,
    normal_force: np.ndarray | float,
    sign_velocity_scale: float = 0.0,
) -> np.ndarray:
    """Friction torque M_f [N m] of eq. 12 opposing the joints' motion (it appears on the left).

    Args:
        friction: the Stribeck parameters (from the URDF).
        alpha_dot: active joint velocities [rad/s], any shape.
        normal_force: normal force F_n per joint [N], broadcast against ``alpha_dot``.
        sign_velocity_scale: smoothing scale of sgn [rad/s]; 0 for the exact sign.
    """
    alpha_dot = np.asarray(alpha_dot, dtype=float)
    normal_force = np.asarray(normal_force, dtype=float)
    coulomb = friction.mu_d * normal_force
    static = friction.mu_s * normal_force
    sliding = alpha_dot * friction.r_a / friction.v_s
    sign = np.tanh(alpha_dot / sign_velocity_scale) if sign_velocity_scale > 0.0 else np.sign(alpha_dot)
    level = coulomb + (static - coulomb) * np.exp(-(sliding**2))
    return level * sign * friction.r_a + friction.mu_v * alpha_dot * friction.r_a
