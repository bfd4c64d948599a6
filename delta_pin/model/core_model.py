"""A :class:`~delta_pin.model.closed_chain.ClosedChainRobot` in the compiled core: its kinematics
and projected dynamics (``ClosedChainModel`` of ``delta_pin/core/model/closed_chain.hpp``), the same
arithmetic as the robot's own Python methods (``configuration``, ``velocity_map``,
``reduced_terms``, ``project_state``), which the tests hold it to.

The core takes every robot of the one robot model: idle motions (minimum-norm Newton steps and the
map of least kinetic energy), passive joints, a free base and joint couplings (MuJoCo's
``<equality joint>``, closure rows of their own). :func:`core_model` answers ``None`` only for a
model the core refuses (its ``ValueError``); a core that cannot be imported is an error
(:class:`~delta_pin.errors.NativeUnavailableError`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["core_chain", "core_friction", "core_model"]


def core_chain(robot):
    """The core's ``ChainDescription`` of ``robot`` (closed_chain.hpp): its model as text, the
    closure frames, the joint couplings, the actuated joints' entries in q and v, the dependent
    joints' entries in v, the number of idle motions and the end-effector frame.

    Raises:
        NativeUnavailableError: the core cannot be imported here.
    """
    from delta_pin.compiled.core import core

    couplings = [  # (q1, v1, q2, v2 entries, references [rad or m], polynomial coefficients)
        (*map(int, (q1, v1, q2, v2)), c.reference1, c.reference2, np.asarray(c.coefficients, float))
        for c, q1, v1, q2, v2 in robot._couplings
    ]
    return core().ChainDescription(
        robot.model.saveToString(),
        [(int(f1), int(f2), int(size)) for f1, f2, size in robot._frames],
        couplings,
        np.asarray(robot.actuated_q_indices, dtype=np.int32),
        np.asarray(robot.actuated_indices, dtype=np.int32),
        np.asarray(robot.dependent_indices, dtype=np.int32),
        int(robot.idle_dof),
        int(robot.end_effector),
    )


def core_model(robot):
    """The core's ``ClosedChainModel`` of ``robot``, or ``None`` for a model it refuses.

    Raises:
        NativeUnavailableError: the core cannot be imported here.
    """
    from delta_pin.compiled.core import core

    module = core()
    try:
        return module.ClosedChainModel(core_chain(robot))
    except (ValueError, RuntimeError):
        return None


def core_friction(stribeck, sign_velocity_scale: float, normal_force):
    """Eq. 12's friction as the core takes it (its ``StribeckFriction``, by name): the Stribeck
    parameters (r_a [m], v_s [m/s], mu_s, mu_d, mu_v [s/m]), tanh's velocity scale [rad/s] and the
    normal force [N] of each actuated joint.

    Raises:
        NativeUnavailableError: the core cannot be imported here.
    """
    from delta_pin.compiled.core import core

    friction = core().StribeckFriction()
    friction.r_a, friction.v_s = stribeck.r_a, stribeck.v_s
    friction.mu_s, friction.mu_d, friction.mu_v = stribeck.mu_s, stribeck.mu_d, stribeck.mu_v
    friction.sign_scale = float(sign_velocity_scale)
    friction.normal_force = np.asarray(normal_force, dtype=float)
    return friction
