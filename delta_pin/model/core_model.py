"""A :class:`~delta_pin.model.closed_chain.ClosedChainRobot` in the compiled core: its kinematics
and projected dynamics (``ClosedChainModel`` of ``delta_pin/core/closed_chain.hpp``), the same
arithmetic as the robot's own Python methods (``configuration``, ``velocity_map``,
``reduced_terms``), which the tests hold it to.

The core takes robots whose actuated joints carry the whole motion (no idle motions, no passive
joints, no joint couplings); :func:`core_model` answers ``None`` for the others, and where the
core is turned off (``DELTA_PIN_NATIVE=0``) or cannot be imported.
"""

from __future__ import annotations

import numpy as np

from delta_pin.errors import NativeUnavailableError

__all__ = ["core_arguments", "core_model", "core_supports"]


def core_supports(robot) -> bool:
    """Whether the core's closed-chain model applies to ``robot``: its actuated joints carry the
    whole motion, no joint couplings (whether the core is on here: :func:`~delta_pin.compiled.core.core`)."""
    return not robot.has_unactuated_motion and not getattr(robot, "_couplings", None)


def core_arguments(robot) -> tuple:
    """(model text, closure frames, actuated q, actuated v, dependent v) of ``robot`` as the core
    reads them."""
    return (
        robot.model.saveToString(),
        [(int(f1), int(f2), int(size)) for f1, f2, size in robot._frames],
        np.asarray(robot.actuated_q_indices, dtype=np.int32),
        np.asarray(robot.actuated_indices, dtype=np.int32),
        np.asarray(robot.dependent_indices, dtype=np.int32),
    )


def core_model(robot):
    """The core's ``ClosedChainModel`` of ``robot``, or ``None`` where it does not apply
    (:func:`core_supports`) or the core cannot be imported here."""
    if not core_supports(robot):
        return None
    from delta_pin.compiled.core import core

    try:
        return core().ClosedChainModel(*core_arguments(robot), int(robot.end_effector))
    except (NativeUnavailableError, ValueError, RuntimeError):
        return None
