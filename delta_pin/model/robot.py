"""The paper's analytic Delta model: :class:`Delta` and :func:`load_analytic_delta`.

Users get it as ``robot.delta`` of the :class:`~delta_pin.model.closed_chain.ClosedChainRobot`
that :func:`delta_pin.load_delta` returns (:mod:`delta_pin.model.delta_robot`): one robot
model for every closed chain, the analytic one an accelerator where the robot is a Delta."""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

import numpy as np
import pinocchio as pin

from delta_pin.errors import AssemblyError, DeltaPinError, ForwardKinematicsError, URDFConventionError
from delta_pin.model import kinematics
from delta_pin.model.closed_chain import ClosedChainRobot
from delta_pin.model.closures import read_urdf_constraints
from delta_pin.model.description import (
    GRAVITY,
    DeltaDescription,
    compile_urdf,
    default_xacro_path,
    expand_xacro,
    read_description,
)
from delta_pin.model.dynamics import ReducedDynamics, analytic_dynamics
from delta_pin.model.friction import stribeck_torque
from delta_pin.model.urdf_tree import build_urdf_tree
from delta_pin.model.visuals import check_mesh_files

__all__ = ["Delta", "as_closed_chain", "delta_robot", "load_analytic_delta"]

# common active angles tried to show that a geometry can close its loops at all [rad]
ASSEMBLY_PROBES = np.linspace(-1.2, 1.4, 27)


class Delta:
    """A Delta robot: parameters read from its URDF, analytic and Pinocchio models.

    Build one with :func:`load_delta`. All methods take and return SI units.
    """

    def __init__(self, description: DeltaDescription, xacro_args: dict | None = None) -> None:
        self.description = description
        self.xacro_args = dict(xacro_args or {})
        self._check_assembly()

    @property
    def params(self):
        """The :class:`~delta_pin.model.description.DeltaParameters` read from the URDF."""
        return self.description.params

    @property
    def urdf(self) -> str:
        """The URDF text every model of this robot is built from."""
        return self.description.urdf

    @property
    def pinocchio(self):
        """The constrained Pinocchio model of this robot: the
        :class:`~delta_pin.model.closed_chain.ClosedChainRobot` of its URDF (the one robot model,
        built on first use), which carries this analytic model as ``.delta``."""
        return as_closed_chain(self)

    def closed_form_configuration(
        self, model: pin.Model, closures, alpha: np.ndarray, xyz: np.ndarray | None = None
    ) -> np.ndarray:
        """q (nq,) of this Delta's tree ``model`` (built from its URDF) with the active joints at
        alpha [rad], the platform slides at the analytic FK (eqs. 1-5) and each forearm pointing
        from its elbow to its platform anchor C_i: the configuration the Newton assembly of the
        closures starts from (the analytic FK closes them exactly up to the forearm direction).

        Args:
            model: the tree (``pin.Model``), its joints named as docs/architecture.md section 3.
            closures: its loop closures (:class:`~delta_pin.model.closures.Closure`), one per
                forearm: a forearm's tip on one side, the platform on the other.
            alpha: active angles [rad].
            xyz: their platform position [m] if already known (saves an FK).
        """
        alpha = kinematics.as_vector3(alpha, "alpha")
        return self.closed_form_configurations(model, closures, alpha[None], None if xyz is None else [xyz])[
            0
        ]

    def closed_form_configurations(
        self, model: pin.Model, closures, alpha: np.ndarray, xyz: np.ndarray | None = None
    ) -> np.ndarray:
        """:meth:`closed_form_configuration` of many states (n, 3) at once: (n, nq). One
        Pinocchio forward-kinematics pass per state gives the elbows' parent placements and the
        platform anchors; the forearm angles follow for all states together."""
        description = self.description
        alpha = np.atleast_2d(np.asarray(alpha, dtype=float))
        xyz = kinematics.forward_kinematics(self.params, alpha) if xyz is None else np.atleast_2d(xyz)
        q = np.tile(pin.neutral(model), (len(alpha), 1))
        for names, values in ((description.active_joints, alpha), (description.platform_joints, xyz)):
            q[:, [model.idx_qs[model.getJointId(name)] for name in names]] = values
        platform = model.getJointId(description.platform_joints[-1])
        rolls, pitches, anchor_joints, anchors = [], [], [], []
        for closure in closures:
            ends = ((closure.joint1, closure.placement1), (closure.joint2, closure.placement2))
            (roll, _), (joint, placement) = ends if closure.joint2 == platform else ends[::-1]
            rolls.append(roll)
            pitches.append(model.parents[roll])  # elbow_i_pitch, then elbow_i_roll on the forearm
            anchor_joints.append(joint)
            anchors.append(placement.homogeneous)
        joints = [model.parents[pitch] for pitch in pitches] + anchor_joints
        unique = sorted(set(joints))
        read = np.empty((len(q), len(unique), 4, 4))  # oMi of those joints per state
        data = model.createData()
        oMi = data.oMi  # a reference to the placements, updated by every kinematics pass
        for k, q_k in enumerate(q):
            pin.forwardKinematics(model, data, q_k)
            for j, joint in enumerate(unique):
                read[k, j] = oMi[joint].homogeneous
        placements = read[:, [unique.index(joint) for joint in joints]]
        n = len(pitches)
        elbow = np.array([model.jointPlacements[pitch].homogeneous for pitch in pitches])
        parent = placements[:, :n] @ elbow  # (states, closures, 4, 4): the pitch joints' frames
        target = (placements[:, n:] @ np.array(anchors))[..., :3, 3] - parent[..., :3, 3]
        target /= np.linalg.norm(target, axis=-1, keepdims=True)
        d = np.einsum("...ji,...j->...i", parent[..., :3, :3], target)  # R^T target
        for i, (pitch, roll) in enumerate(zip(pitches, rolls)):
            # forearm direction R_y(pitch) R_x(roll) [0, 0, -1] (docs/architecture.md section 3)
            q[:, model.idx_qs[roll]] = np.arcsin(np.clip(d[:, i, 1], -1.0, 1.0))
            q[:, model.idx_qs[pitch]] = np.arctan2(-d[:, i, 0], -d[:, i, 2])
        return q

    def reference_configuration(self, model: pin.Model, closures) -> np.ndarray:
        """:meth:`closed_form_configuration` at alpha = 0, or at the first common arm angle of
        :data:`ASSEMBLY_PROBES` where the analytic FK exists (short forearms may not close at 0)."""
        for angle in (0.0, *ASSEMBLY_PROBES):
            try:
                return self.closed_form_configuration(model, closures, np.full(3, angle))
            except ForwardKinematicsError:
                continue
        raise AssemblyError(
            f"the loops of {self!r} close at no common arm angle"
        )  # _check_assembly found one

    def assembled_configuration(self) -> np.ndarray:
        """The assembled q (nq,) of :attr:`pinocchio` (its reference configuration)."""
        return self.pinocchio.reference_configuration.copy()

    def _check_assembly(self) -> None:
        for angle in ASSEMBLY_PROBES:
            try:
                kinematics.forward_kinematics(self.params, np.full(3, angle))
                return
            except ForwardKinematicsError:
                continue
        p = self.params
        raise AssemblyError(
            f"the geometry R={p.R}, r={p.r}, l_a={p.l_a}, l_b={p.l_b} m cannot close its loops for "
            f"any common arm angle in [{ASSEMBLY_PROBES[0]}, {ASSEMBLY_PROBES[-1]}] rad "
            "(forearms too short or too long for the platforms?)"
        )

    # -------------------------------------------------------------------- kinematics (eqs. 1-5, 10)
    def inverse_kinematics(self, xyz: np.ndarray) -> np.ndarray:
        """Active angles alpha (3,) [rad] of the elbow-out branch for platform position xyz [m]."""
        return kinematics.inverse_kinematics(self.params, xyz)

    def forward_kinematics(self, alpha: np.ndarray) -> np.ndarray:
        """Platform position xyz (3,) [m] below the base for active angles alpha [rad]."""
        return kinematics.forward_kinematics(self.params, alpha)

    def jacobian(self, alpha: np.ndarray) -> np.ndarray:
        """J (3, 3) [m/rad] with xyz_dot = J alpha_dot (eq. 10)."""
        return kinematics.jacobian(self.params, kinematics.as_vector3(alpha, "alpha"))

    def jacobian_derivative_times_velocity(self, alpha: np.ndarray, alpha_dot: np.ndarray) -> np.ndarray:
        """J_dot alpha_dot (3,) [m/s^2]: platform acceleration at zero joint acceleration."""
        return kinematics.jacobian_derivative_times_velocity(
            self.params, kinematics.as_vector3(alpha, "alpha"), kinematics.as_vector3(alpha_dot, "alpha_dot")
        )

    # -------------------------------------------------------------------- dynamics (eqs. 7-9, 12)
    def analytic_dynamics(
        self, alpha: np.ndarray, alpha_dot: np.ndarray, platform_mass: float | None = None
    ) -> ReducedDynamics:
        """The paper's M, C, G (eqs. 7-9, G with the corrected sign); ``.coriolis = C @ alpha_dot``."""
        return analytic_dynamics(self.params, alpha, alpha_dot, platform_mass)

    def pinocchio_dynamics(self, alpha: np.ndarray, alpha_dot: np.ndarray) -> ReducedDynamics:
        """M, C alpha_dot, G of the constrained Pinocchio model projected on the active joints
        (:meth:`~delta_pin.model.closed_chain.ClosedChainRobot.reduced_dynamics`), assembled by
        Newton from :meth:`closed_form_configuration`."""
        closed = self.pinocchio
        start = self.closed_form_configuration(closed.model, closed.closures, alpha)
        return closed.reduced_dynamics(alpha, alpha_dot, closed.configuration(alpha, initial_guess=start))

    def friction_torque(
        self, alpha_dot: np.ndarray, normal_force: np.ndarray | float, sign_velocity_scale: float = 0.0
    ) -> np.ndarray:
        """Stribeck friction torque M_f (3,) [N m] of eq. 12 for normal forces F_n [N]."""
        if self.params.friction is None:
            raise DeltaPinError("this URDF carries no <delta_pin_friction> element")
        return stribeck_torque(self.params.friction, alpha_dot, normal_force, sign_velocity_scale)

    def metadata(self) -> dict:
        """JSON-serialisable parameters (stored with every run)."""
        return {**asdict(self.params), "xacro_args": self.xacro_args}

    def __repr__(self) -> str:
        p = self.params
        return (
            f"Delta(R={p.R:g}, r={p.r:g}, l_a={p.l_a:g}, l_b={p.l_b:g}, m_a={p.m_a:g}, "
            f"m_b={p.m_b:g}, m_o={p.m_o:g}, forearm_inertia={p.forearm_inertia!r})"
        )


def load_analytic_delta(
    urdf: str | Path | None = None, *, g: float = GRAVITY, **xacro_args: float | str
) -> Delta:
    """The analytic Delta model of a URDF: what :func:`delta_pin.load_delta` (the same arguments
    and errors) carries as ``robot.delta``.
    """
    if urdf is None:
        text = compile_urdf(**xacro_args)
        base_dir = default_xacro_path().parent
    else:
        if xacro_args:
            raise URDFConventionError(
                f"xacro arguments {sorted(xacro_args)} apply to the packaged xacro only, not to urdf={urdf!s}"
            )
        path = Path(urdf)
        if not path.is_file():
            raise URDFConventionError(f"URDF file {str(path)!r} does not exist")
        try:
            text = path.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            raise URDFConventionError(
                f"URDF file {str(path)!r} is not text (a binary file?); give a URDF or xacro (XML) file"
            ) from None
        if path.suffix == ".xacro":
            text = expand_xacro(path)
        base_dir = path.resolve().parent
        try:
            description = read_description(text, g=g, base_dir=base_dir)
        except URDFConventionError as exc:  # name the file
            raise URDFConventionError(f"URDF file {str(path)!r}: {exc}") from None
        check_mesh_files(text, base_dir)  # MeshFileError names the mesh and its full path
        return Delta(description, xacro_args)
    check_mesh_files(text, base_dir)
    return Delta(read_description(text, g=g, base_dir=base_dir), xacro_args)


def delta_robot(delta: Delta) -> ClosedChainRobot:
    """The closed-chain robot of an analytic Delta's URDF, carrying it as ``robot.delta``."""
    description = delta.description
    source = "delta.urdf" if description.base_dir is None else f"{Path(description.base_dir).name}/delta.urdf"
    model = build_urdf_tree(delta.urdf, source)
    model.gravity.linear = np.array([0.0, 0.0, -delta.params.g])
    closures = read_urdf_constraints(delta.urdf, model, source)
    robot = ClosedChainRobot(
        model, closures, description.active_joints,
        name=model.name or "delta", source=source, urdf=delta.urdf,
        base_dir=None if description.base_dir is None else str(description.base_dir),
        reference_configuration=delta.reference_configuration(model, closures),
    )  # fmt: skip
    robot.delta = delta
    robot.set_end_effector(robot.joint_frame(description.platform_joints[-1]))
    if getattr(delta, "_closed_chain", None) is None:
        delta._closed_chain = robot  # as_closed_chain's: the first closed-chain robot of this model
    return robot


def as_closed_chain(robot) -> ClosedChainRobot:
    """The closed-chain robot of ``robot``: itself, or for an analytic
    :class:`~delta_pin.model.robot.Delta` the robot of its URDF carrying it (built once)."""
    if isinstance(robot, Delta):
        closed = getattr(robot, "_closed_chain", None)
        return closed if closed is not None else delta_robot(robot)
    return robot
