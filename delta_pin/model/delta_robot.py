"""``load_delta``: the paper's Delta as one :class:`~delta_pin.model.closed_chain.ClosedChainRobot`.

One robot model for the Delta and every other closed chain (docs/architecture.md section 10):
the robot is the Pinocchio tree of the Delta's URDF closed by its three ``<constraint
type="point">`` elements, driven on ``active_1..3``, its end effector the platform; it carries
the paper's analytic model (eqs. 1-10, :class:`~delta_pin.model.robot.Delta`) as ``robot.delta``,
which the robot uses where it is exact and faster (the platform's kinematics) and which the
compiled loops, the Delta's plants and the studies run on (:func:`analytic_delta`). The
Delta-only API (``robot.params``, ``robot.jacobian(alpha)``, ``robot.pinocchio``,
``robot.analytic_dynamics`` ...) reaches ``robot.delta``.
"""

from __future__ import annotations

from pathlib import Path

from delta_pin.model.closed_chain import ClosedChainRobot
from delta_pin.model.description import GRAVITY
from delta_pin.model.robot import as_closed_chain, delta_robot, load_analytic_delta

__all__ = ["analytic_delta", "as_closed_chain", "carries_own_delta", "delta_robot", "load_delta"]


def load_delta(
    urdf: str | Path | None = None, *, g: float = GRAVITY, **xacro_args: float | str
) -> ClosedChainRobot:
    """Load a Delta robot: the closed-chain robot of its URDF, with the analytic model as
    ``robot.delta``.

    Args:
        urdf: path of a URDF (or xacro) file that follows docs/architecture.md section 3; ``None`` compiles
            the packaged ``delta.urdf.xacro`` (the paper's Table 1 robot by default).
        g: gravity acceleration [m/s^2] (9.8, the paper's, by default).
        **xacro_args: arguments of the packaged xacro, SI units: ``R, r, l_a, l_b, m_a, m_b,
            m_o`` [m, kg], ``forearm_inertia`` (``"lumped"`` or ``"rod"``), friction ``r_a, v_s,
            mu_s, mu_d, mu_v``.

    Examples:
        >>> robot = load_delta()                      # Table 1
        >>> robot = load_delta(l_a=0.25, m_o=0.5)     # swap dimensions and masses

    Raises:
        XacroArgumentError: unknown argument or invalid value.
        URDFConventionError: the URDF does not follow the convention.
        AssemblyError: the geometry cannot close its loops.
        MeshFileError: a mesh visual's file does not exist (named in the message).
    """
    return delta_robot(load_analytic_delta(urdf, g=g, **xacro_args))


def analytic_delta(robot):
    """The analytic :class:`~delta_pin.model.robot.Delta` of a robot's own URDF (the robot of
    :func:`load_delta`, or a URDF that follows the Delta convention loaded by ``load_robot``),
    else the robot itself: what the Delta's compiled loops, plants and studies take. A Delta
    recognised in another file (MJCF, a robot.yaml) keeps its own tree: its analytic model is of
    the packaged xacro at the measured numbers, not of that file."""
    return robot.delta if carries_own_delta(robot) else robot


def carries_own_delta(robot) -> bool:
    """Whether ``robot`` is a closed-chain robot whose ``robot.delta`` is built from its very URDF."""
    if not isinstance(robot, ClosedChainRobot) or robot.delta is None:
        return False
    return robot.urdf is not None and robot.delta.urdf == robot.urdf
