"""Any closed-chain robot: a Pinocchio tree, its loop closures and its actuated joints.

:class:`ClosedChainRobot` is what :func:`~delta_pin.model.loaders.load_robot` returns for a URDF
with ``<constraint>`` elements, a URDF with a Gepetto ``robot.yaml`` sidecar, or an MJCF file. It
knows nothing of the Delta; the Delta's own class (:class:`~delta_pin.model.robot.Delta`) adds the
paper's analytic model on top of the same ideas (docs/architecture.md section 10).

Coordinates: alpha (``dof``,) are the actuated joints (1-DOF joints, one per actuator); q (nq,)
and v (nv,) the whole tree. Every closure k gives residual rows r_k(q):

* point (``"3d"``): r = p_1 - p_2, the world positions of the two frames' origins [m];
* weld (``"6d"``): r = [p_1 - p_2, -R_1 log3(R_1^T R_2)] [m, rad],

and velocity rows J_c v with J_c = J_1 - J_2 (LOCAL_WORLD_ALIGNED frame Jacobians; linear rows
only for a point). With the actuated coordinates fixed, Newton on r over the passive coordinates
assembles the mechanism; the constraint null space with actuated rows = I is

    S = dq/dalpha:  S_actuated = I,  S_passive = -J_p^+ J_a   (J_c = [J_a J_p] by columns),

and the actuated-joint dynamics follow by projection (an independent route to eqs. 7-9 on the
Delta, docs/architecture.md section 5):

    M = S^T M_tree S,  G = S^T g(q),  C alpha_dot = S^T (nle(q, v) - g(q)) + S^T M_tree S_dot alpha_dot,
    C (the matrix) = S^T C_tree(q, v) S + S^T M_tree S_dot,  S_dot_passive = -J_p^+ J_c_dot S,

with v = S alpha_dot. C so built keeps M_dot - 2 C skew-symmetric (the property designs I/II
rely on). Redundant closure equations (a planar loop closed by a point or a weld) are allowed:
J_p^+ is the least-squares solve of a consistent system.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from delta_pin.errors import AssemblyError, InvalidParameterError, UnreachablePoseError
from delta_pin.model.closures import Closure
from delta_pin.model.dynamics import ReducedDynamics

__all__ = ["ClosedChainRobot", "closure_rank", "least_squares"]

_WORLD = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
_RANK_TOLERANCE = 1e-9  # singular values below this fraction of the largest count as zero


def _rank(matrix: np.ndarray) -> int:
    if matrix.size == 0:
        return 0
    singular = np.linalg.svd(matrix, compute_uv=False)
    return int((singular > _RANK_TOLERANCE * max(singular[0], 1.0)).sum())


def least_squares(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """x minimising |A x - b| for A of full column rank (a consistent system for the closures):
    ``solve`` when A is square, the normal equations when it is tall (cond(A)^2 stays far below
    1/eps away from singular configurations; 5-10 us instead of LAPACK's lstsq 40 us), lstsq
    where those are singular."""
    try:
        if A.shape[0] == A.shape[1]:
            return np.linalg.solve(A, b)
        return np.linalg.solve(A.T @ A, A.T @ b)
    except np.linalg.LinAlgError:
        return np.linalg.lstsq(A, b, rcond=None)[0]


def closure_rank(robot: ClosedChainRobot, q: np.ndarray) -> int:
    """Number of independent closure equations at q (``robot.closure_size`` when none is redundant)."""
    return _rank(robot.closure_jacobian(q))


class ClosedChainRobot:
    """A kinematic tree closed by :class:`~delta_pin.model.closures.Closure` constraints and
    driven on its actuated joints.

    Args:
        model: the tree (a ``pin.Model``, gravity included; copied).
        closures: its loop closures.
        actuated: names of the actuated joints, in the order of alpha (1-DOF joints).
        name: the robot's name.
        reference_configuration: a configuration q (nq,) near an assembled one; its actuated
            coordinates are the robot's ``home`` and it starts the first assembly (default: the
            model's neutral configuration).
        end_effector: the frame whose position :meth:`forward_kinematics` returns and the runs
            record (default: the first closure's first frame; change with :meth:`set_end_effector`).
        source: the file the robot came from (for messages and metadata).
        urdf: the URDF text, where there is one (drawing, metadata).
        base_dir: folder for the URDF's relative mesh paths.
        visual_model: the robot's visual geometry on ``model`` (drawing); ``None``: read from
            ``urdf`` where there is one.

    Raises:
        InvalidParameterError: an unknown or multi-DOF actuated joint, or no closure.
        AssemblyError: the loops do not close near ``reference_configuration``, or the mechanism
            has more or fewer degrees of freedom than actuators there.
    """

    def __init__(
        self,
        model: pin.Model,
        closures: Sequence[Closure],
        actuated: Sequence[str],
        *,
        name: str = "",
        reference_configuration: np.ndarray | None = None,
        end_effector: str | None = None,
        source: str = "",
        urdf: str | None = None,
        base_dir: str | None = None,
        visual_model: pin.GeometryModel | None = None,
    ) -> None:
        self.tree = pin.Model(model)  # as given, without the closure frames (for variants)
        self.model = pin.Model(model)
        self.data = self.model.createData()
        self.name = name or model.name or "robot"
        self.source = source
        self.urdf = urdf
        self.base_dir = base_dir
        self.visual_model = visual_model
        self.delta = None  # the analytic Delta model, where load_robot recognises one
        self.closures = tuple(closures)
        if not self.closures:
            raise InvalidParameterError(f"{self._label}has no loop closure: use a serial-robot model instead")
        self.actuated_joints = tuple(actuated)
        if not self.actuated_joints:
            raise InvalidParameterError(f"{self._label}names no actuated joint")
        ids = []
        for joint in self.actuated_joints:
            if not self.model.existJointName(joint):
                known = ", ".join(self.model.names[1:])
                raise InvalidParameterError(
                    f"{self._label}actuated joint {joint!r} is not in the model (joints: {known})"
                )
            jid = self.model.getJointId(joint)
            if self.model.nqs[jid] != 1 or self.model.nvs[jid] != 1:
                raise InvalidParameterError(
                    f"{self._label}actuated joint {joint!r} has {self.model.nvs[jid]} degrees of freedom; "
                    "an actuator "
                    "drives one revolute or prismatic joint"
                )
            ids.append(jid)
        if len(set(ids)) != len(ids):
            raise InvalidParameterError(
                f"{self._label}an actuated joint is named twice: {list(self.actuated_joints)}"
            )
        self.dof = len(ids)
        self.actuated_indices = np.array([self.model.idx_vs[j] for j in ids])  # in v
        self.actuated_q_indices = np.array([self.model.idx_qs[j] for j in ids])  # in q
        self.passive_indices = np.setdiff1d(np.arange(self.model.nv), self.actuated_indices)
        self.constraint_models = pin.StdVec_RigidConstraintModel()
        self.constraint_datas = pin.StdVec_RigidConstraintData()
        self._frames = []  # (frame id 1, frame id 2, kind) per closure
        for closure in self.closures:
            pair = []
            for tag, joint, placement in (
                ("1", closure.joint1, closure.placement1),
                ("2", closure.joint2, closure.placement2),
            ):
                if not 0 < joint < self.model.njoints:
                    raise InvalidParameterError(
                        f"closure {closure.name!r}{closure.where}: joint id {joint} is not in the model"
                    )
                frame = pin.Frame(f"{closure.name}_{tag}", joint, 0, placement, pin.FrameType.OP_FRAME)
                pair.append(self.model.addFrame(frame, False))
            self._frames.append((pair[0], pair[1], closure.size))
            constraint = closure.constraint_model(self.model)
            self.constraint_models.append(constraint)
            self.constraint_datas.append(constraint.createData())
        self.data = self.model.createData()
        self.closure_size = sum(c.size for c in self.closures)
        q0 = (
            pin.neutral(self.model)
            if reference_configuration is None
            else np.asarray(reference_configuration, float)
        )
        if q0.shape != (self.model.nq,):
            raise InvalidParameterError(
                f"{self._label}reference_configuration has shape {q0.shape}, expected ({self.model.nq},)"
            )
        self.home = q0[self.actuated_q_indices].copy()
        self._last_q = q0.copy()
        try:
            self.reference_configuration = self.configuration(self.home, initial_guess=q0)
        except AssemblyError:
            # a wrong actuator count is the likelier cause; the rank at a generic (perturbed)
            # configuration is the mechanism's, whatever singular pose q0 may be in
            generic = pin.integrate(self.model, q0, np.random.default_rng(0).normal(0.0, 0.1, self.model.nv))
            self._check_mobility(generic, assembled=False)
            raise
        self._check_mobility(self.reference_configuration)
        self.end_effector = self._frames[0][0] if end_effector is None else self.frame_id(end_effector)
        self._options = {
            "name": name, "source": source, "urdf": urdf, "base_dir": base_dir, "visual_model": visual_model,
        }  # fmt: skip

    # ------------------------------------------------------------------------------ naming
    @property
    def _label(self) -> str:
        name = getattr(self, "name", "")
        source = getattr(self, "source", "")
        return f"robot {name!r}{f' ({source})' if source else ''}: " if name or source else ""

    def frame_id(self, frame: str) -> int:
        """Id of a named frame (a link, joint, site or closure frame).

        Raises:
            InvalidParameterError: no such frame, with the names that exist.
        """
        if not isinstance(frame, str) or not self.model.existFrame(frame):
            names = sorted({f.name for f in self.model.frames if f.name != "universe"})
            shown = ", ".join(names[:40]) + (" ..." if len(names) > 40 else "")
            raise InvalidParameterError(f"{self._label}has no frame {frame!r} (frames: {shown})")
        return self.model.getFrameId(frame)

    def _frame(self, frame: str | int | None) -> int:
        """A frame id from a name, an id, or ``None`` (the end effector)."""
        if frame is None:
            return self.end_effector
        if isinstance(frame, (int, np.integer)) and 0 <= frame < len(self.model.frames):
            return int(frame)
        return self.frame_id(frame)

    def joint_frame(self, joint: str) -> str:
        """Name of a frame sitting exactly on a joint (its origin and axes), added as
        ``<joint>_frame`` if the model has none (MJCF models carry body frames only)."""
        jid = self.model.getJointId(joint) if self.model.existJointName(joint) else None
        if jid is None:
            raise InvalidParameterError(f"{self._label}has no joint {joint!r}")
        for frame in self.model.frames:
            if frame.parentJoint == jid and np.allclose(frame.placement.homogeneous, np.eye(4), atol=1e-15):
                return frame.name
        name = f"{joint}_frame"
        for model in (self.model, self.tree):  # the tree too: variants (with_payload) keep it
            model.addFrame(pin.Frame(name, jid, pin.SE3.Identity(), pin.FrameType.OP_FRAME), False)
        self.data = self.model.createData()
        return name

    def set_end_effector(self, frame: str) -> None:
        """Make ``frame`` the one :meth:`forward_kinematics` and the runs report."""
        self.end_effector = self.frame_id(frame)

    @property
    def params(self):
        """A recognised Delta's parameters (so the Delta's task-space paths apply), else ``None``."""
        return None if self.delta is None else self.delta.params

    @property
    def closure_frames(self) -> list[tuple[int, int, int]]:
        """(frame id 1, frame id 2, equations) of each closure, in order."""
        return list(self._frames)

    @property
    def end_effector_name(self) -> str:
        return self.model.frames[self.end_effector].name

    # ------------------------------------------------------------------------------ closures
    def closure_residual(self, q: np.ndarray) -> np.ndarray:
        """Stacked closure residuals r(q) (``closure_size``,) [m, rad] (module docstring)."""
        pin.framesForwardKinematics(self.model, self.data, q)
        return self._residual()

    def _residual(self) -> np.ndarray:
        parts = []
        for f1, f2, size in self._frames:
            M1, M2 = self.data.oMf[f1], self.data.oMf[f2]
            parts.append(M1.translation - M2.translation)
            if size == 6:
                parts.append(-M1.rotation @ pin.log3(M1.rotation.T @ M2.rotation))
        return np.concatenate(parts)

    def closure_gap(self, q: np.ndarray) -> float:
        """Largest closure residual max |r(q)| [m or rad] (NaN if q holds one)."""
        if not np.isfinite(q).all():
            return math.nan
        return float(np.abs(self.closure_residual(q)).max())

    def closure_jacobian(self, q: np.ndarray, kinematics_done: bool = False) -> np.ndarray:
        """J_c (``closure_size``, nv): the closures' velocity rows (module docstring)."""
        if not kinematics_done:
            pin.framesForwardKinematics(self.model, self.data, q)
        pin.computeJointJacobians(self.model, self.data, q)
        rows = []
        for f1, f2, size in self._frames:
            J = pin.getFrameJacobian(self.model, self.data, f1, _WORLD) - pin.getFrameJacobian(
                self.model, self.data, f2, _WORLD
            )
            rows.append(J[:size])
        return np.vstack(rows)

    def closure_drift(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """J_c_dot v: the closures' relative (classical) accelerations at zero joint acceleration."""
        pin.forwardKinematics(self.model, self.data, q, v, np.zeros(self.model.nv))
        rows = []
        for f1, f2, size in self._frames:
            a1 = pin.getFrameClassicalAcceleration(self.model, self.data, f1, _WORLD)
            a2 = pin.getFrameClassicalAcceleration(self.model, self.data, f2, _WORLD)
            rows.append(a1.linear - a2.linear)
            if size == 6:
                rows.append(a1.angular - a2.angular)
        return np.concatenate(rows)

    def closure_jacobian_derivative(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """J_c_dot (``closure_size``, nv) at (q, v): J_c_dot v equals :meth:`closure_drift`."""
        pin.computeJointJacobiansTimeVariation(self.model, self.data, q, v)
        pin.updateFramePlacements(self.model, self.data)
        rows = []
        for f1, f2, size in self._frames:
            # Pinocchio 4.1's LOCAL_WORLD_ALIGNED dJ is the true time derivative of J (checked
            # against finite differences in the tests), so dJ v is the classical acceleration
            dJ = pin.getFrameJacobianTimeVariation(self.model, self.data, f1, _WORLD) - (
                pin.getFrameJacobianTimeVariation(self.model, self.data, f2, _WORLD)
            )
            rows.append(dJ[:size])
        return np.vstack(rows)

    # ------------------------------------------------------------------------------ assembly
    def configuration(
        self,
        alpha: np.ndarray,
        *,
        initial_guess: np.ndarray | None = None,
        tol: float = 1e-12,
        max_iterations: int = 60,
    ) -> np.ndarray:
        """A closure-consistent configuration q (nq,) with the actuated joints at ``alpha`` [rad or m].

        Newton (least squares) on the closure residual over the passive coordinates, started
        from ``initial_guess``, else from the last configuration assembled (the assembly mode
        the robot is in), else from the reference configuration. Steps are limited to 0.5 (rad
        or m) so that a far start does not jump to another assembly mode.

        Raises:
            AssemblyError: the loops do not close to ``tol``; names the worst closure.
        """
        alpha = self._joint_vector(alpha, "alpha")
        q = np.array(self._last_q if initial_guess is None else initial_guess, dtype=float)
        q[self.actuated_q_indices] = alpha
        model, data = self.model, self.data
        residual = None
        for _ in range(max_iterations):
            pin.framesForwardKinematics(model, data, q)
            residual = self._residual()
            if np.abs(residual).max() <= tol:
                self._last_q = q.copy()
                return q
            J = self.closure_jacobian(q, kinematics_done=True)[:, self.passive_indices]
            step = least_squares(J, residual)
            largest = np.abs(step).max()
            if largest > 0.5:
                step *= 0.5 / largest
            dv = np.zeros(model.nv)
            dv[self.passive_indices] = -step
            q = pin.integrate(model, q, dv)
            if not np.isfinite(q).all():
                break
        worst = self._worst_closure(residual)
        raise AssemblyError(
            f"{self._label}the loops do not close at alpha={np.round(alpha, 6).tolist()}: closure {worst} "
            f"is still {np.abs(residual).max():.3e} (m or rad) apart after {max_iterations} Newton steps; "
            "start nearer (initial_guess=) or choose reachable actuated coordinates"
        )

    def _worst_closure(self, residual: np.ndarray | None) -> str:
        if residual is None or not np.isfinite(residual).all():
            return "(non-finite state)"
        start, worst, largest = 0, self.closures[0], -1.0
        for closure in self.closures:
            value = np.abs(residual[start : start + closure.size]).max()
            if value > largest:
                worst, largest = closure, value
            start += closure.size
        return f"{worst.name!r}{worst.where}"

    def _check_mobility(self, q: np.ndarray, assembled: bool = True) -> None:
        J = self.closure_jacobian(q)
        rank = _rank(J)
        mobility = self.model.nv - rank
        if mobility != self.dof:
            raise AssemblyError(
                f"{self._label}the mechanism has {mobility} degree(s) of freedom at its reference "
                f"configuration{'' if assembled else ' (a generic pose near it)'} "
                f"({self.model.nv} joint velocities, {rank} independent closure equations) but {self.dof} "
                f"actuator(s) ({', '.join(self.actuated_joints)}): name one actuator per degree of freedom"
            )
        if assembled and _rank(J[:, self.passive_indices]) != len(self.passive_indices):
            raise AssemblyError(
                f"{self._label}the actuated joints ({', '.join(self.actuated_joints)}) do not determine "
                "the passive "
                "joints at the reference configuration (a singular or redundant actuation)"
            )

    def velocity_map(self, q: np.ndarray) -> np.ndarray:
        """S = dq/dalpha (nv, dof): v = S alpha_dot satisfies the closures' velocity constraint."""
        return self._velocity_map(self.closure_jacobian(q))

    def _velocity_map(self, J: np.ndarray) -> np.ndarray:
        S = np.zeros((self.model.nv, self.dof))
        S[self.actuated_indices] = np.eye(self.dof)
        S[self.passive_indices] = -least_squares(J[:, self.passive_indices], J[:, self.actuated_indices])
        return S

    def state(self, alpha: np.ndarray, alpha_dot: np.ndarray, **options) -> tuple[np.ndarray, np.ndarray]:
        """Closure-consistent (q, v) for actuated positions and velocities; ``options`` as
        :meth:`configuration`."""
        q = self.configuration(alpha, **options)
        return q, self.velocity_map(q) @ self._joint_vector(alpha_dot, "alpha_dot")

    def _joint_vector(self, value, name: str) -> np.ndarray:
        vector = np.asarray(value, dtype=float).reshape(-1)
        if vector.shape != (self.dof,) or not np.isfinite(vector).all():
            raise InvalidParameterError(
                f"{name}={np.asarray(value).tolist()} must be {self.dof} finite numbers "
                f"(one per actuated joint: "
                f"{', '.join(self.actuated_joints)})"
            )
        return vector

    # ------------------------------------------------------------------------------ frames
    def frame_placement(self, q: np.ndarray, frame: str | int | None = None) -> pin.SE3:
        """World placement of a frame (name or id; the end effector by default) at configuration q."""
        fid = self._frame(frame)
        pin.framesForwardKinematics(self.model, self.data, q)
        return pin.SE3(self.data.oMf[fid])

    def forward_kinematics(self, alpha: np.ndarray, frame: str | None = None) -> np.ndarray:
        """Position [m] of a frame (the end effector by default) for actuated coordinates (dof,)
        -> (3,), or (N, dof) -> (N, 3), assembling each state (warm-started)."""
        alpha = np.asarray(alpha, dtype=float)
        if alpha.ndim == 2:
            return np.array([self.forward_kinematics(row, frame) for row in alpha])
        return self.frame_placement(self.configuration(alpha), frame).translation.copy()

    def frame_jacobian(self, q: np.ndarray, frame: str | int | None = None) -> np.ndarray:
        """Closed-loop Jacobian (6, dof) of a frame: its [linear; angular] velocity
        (LOCAL_WORLD_ALIGNED) per actuated velocity, J_frame S."""
        fid = self._frame(frame)
        S = self.velocity_map(q)  # leaves the joint Jacobians computed at q
        return pin.getFrameJacobian(self.model, self.data, fid, _WORLD) @ S

    def frame_acceleration_drift(
        self, q: np.ndarray, alpha_dot: np.ndarray, frame: str | int | None = None
    ) -> np.ndarray:
        """The frame's classical linear acceleration (3,) [m/s^2] at zero actuated acceleration:
        x_ddot = J_x alpha_ddot + this (the J_dot alpha_dot of a task-space reference)."""
        fid = self._frame(frame)
        J = self.closure_jacobian(q)
        v = self._velocity_map(J) @ alpha_dot
        rate = np.zeros(self.model.nv)  # S_dot alpha_dot
        rate[self.passive_indices] = -least_squares(J[:, self.passive_indices], self.closure_drift(q, v))
        pin.forwardKinematics(self.model, self.data, q, v, rate)
        return pin.getFrameClassicalAcceleration(self.model, self.data, fid, _WORLD).linear.copy()

    def inverse_kinematics(
        self,
        position: np.ndarray,
        frame: str | None = None,
        *,
        axes: str = "xyz",
        initial_guess: np.ndarray | None = None,
        tol: float = 1e-12,
        max_iterations: int = 60,
    ) -> np.ndarray:
        """Actuated coordinates alpha that put a frame's origin at ``position`` [m] along ``axes``.

        Newton on alpha with the closed-loop Jacobian (least squares where the frame has fewer
        task coordinates than actuators), each iterate assembled from the previous one.

        Args:
            position: target world position (3,) [m]; only the ``axes`` components count.
            frame: the frame (the end effector by default).
            axes: the controlled coordinates, e.g. ``"xy"`` for a planar robot.
            initial_guess: start alpha (default: the last assembled configuration's).

        Raises:
            UnreachablePoseError: Newton does not reach the target to ``tol`` [m].
        """
        rows = [" xyz".index(a) - 1 for a in axes] if axes and set(axes) <= set("xyz") else None
        if rows is None or len(set(rows)) != len(rows):
            raise InvalidParameterError(f"axes={axes!r} must be distinct letters of 'xyz'")
        target = np.asarray(position, dtype=float).reshape(3)
        fid = self._frame(frame)
        q = start = self._last_q.copy()
        alpha = (
            q[self.actuated_q_indices]
            if initial_guess is None
            else self._joint_vector(initial_guess, "initial_guess")
        )
        error = None
        for _ in range(max_iterations):
            q = self.configuration(alpha, initial_guess=q)
            pin.framesForwardKinematics(self.model, self.data, q)
            error = (self.data.oMf[fid].translation - target)[rows]
            if np.abs(error).max() <= tol:
                return alpha
            J = self.frame_jacobian(q, fid)[:3][rows]
            step = least_squares(J, error)
            largest = np.abs(step).max()
            if largest > 0.2:
                step *= 0.2 / largest
            alpha = alpha - step
        self._last_q = start  # a failed search leaves the assembly mode where it was
        raise UnreachablePoseError(
            f"{self._label}frame {self.model.frames[fid].name!r} cannot reach {target.tolist()} m "
            f"along {axes!r}: "
            f"{np.abs(error).max():.3e} m off after {max_iterations} Newton steps"
        )

    # ------------------------------------------------------------------------------ dynamics
    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """Symmetric joint-space inertia matrix of the tree (nv, nv) [SI]."""
        M = pin.crba(self.model, self.data, q).copy()
        return np.triu(M) + np.triu(M, 1).T

    def reduced_terms(
        self, alpha: np.ndarray, alpha_dot: np.ndarray, q: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(M, C, G, C alpha_dot) on the actuated joints by projection (module docstring):
        inertia (dof, dof), Coriolis matrix (dof, dof), gravity (dof,), Coriolis torque (dof,).

        Args:
            q: the closure-consistent configuration of ``alpha`` if already known.
        """
        alpha_dot = self._joint_vector(alpha_dot, "alpha_dot")
        q = self.configuration(alpha) if q is None else q
        pin.framesForwardKinematics(self.model, self.data, q)
        J = self.closure_jacobian(q, kinematics_done=True)
        S = self._velocity_map(J)
        v = S @ alpha_dot
        passive = J[:, self.passive_indices]
        S_dot = np.zeros_like(S)
        S_dot[self.passive_indices] = -least_squares(passive, self.closure_jacobian_derivative(q, v) @ S)
        M = self.mass_matrix(q)
        gravity = pin.computeGeneralizedGravity(self.model, self.data, q).copy()
        C_tree = pin.computeCoriolisMatrix(self.model, self.data, q, v).copy()
        rate = np.zeros(self.model.nv)  # S_dot alpha_dot, from the drift (exact classical accelerations)
        rate[self.passive_indices] = -least_squares(passive, self.closure_drift(q, v))
        nle = pin.nonLinearEffects(self.model, self.data, q, v)
        M_red = S.T @ M @ S
        return (
            0.5 * (M_red + M_red.T),
            S.T @ C_tree @ S + S.T @ M @ S_dot,
            S.T @ gravity,
            S.T @ (nle - gravity) + S.T @ (M @ rate),
        )

    def reduced_dynamics(
        self, alpha: np.ndarray, alpha_dot: np.ndarray, q: np.ndarray | None = None
    ) -> ReducedDynamics:
        """M, C alpha_dot and G on the actuated joints by projection (``ReducedDynamics``)."""
        M, _C, G, coriolis = self.reduced_terms(alpha, alpha_dot, q)
        return ReducedDynamics(M=M, G=G, coriolis=coriolis)

    # ------------------------------------------------------------------------------ payload
    def with_payload(self, mass: float, frame: str | int | None = None) -> ClosedChainRobot:
        """The same robot carrying a point mass [kg] at a frame's origin (the end effector by
        default): e.g. a controller's nominal model with a nominal payload."""
        fid = self._frame(frame)
        tree = pin.Model(self.tree)
        placement, joint = self.model.frames[fid].placement, self.model.frames[fid].parentJoint
        tree.inertias[joint] = tree.inertias[joint] + pin.Inertia(
            float(mass), placement.translation, np.zeros((3, 3))
        )
        robot = ClosedChainRobot(
            tree, self.closures, self.actuated_joints, reference_configuration=self.reference_configuration,
            end_effector=self.model.frames[self.end_effector].name, **self._options,
        )  # fmt: skip
        robot.delta = self.delta
        return robot

    def metadata(self) -> dict:
        return {
            "kind": "closed_chain",
            "name": self.name,
            "source": self.source,
            "dof": self.dof,
            "actuated_joints": list(self.actuated_joints),
            "closures": [{"name": c.name, "kind": c.kind} for c in self.closures],
            "end_effector": self.end_effector_name,
        }

    def __repr__(self) -> str:
        kinds = ", ".join(
            f"{sum(c.kind == k for c in self.closures)} {k}"
            for k in ("3d", "6d")
            if any(c.kind == k for c in self.closures)
        )
        return (
            f"ClosedChainRobot({self.name!r}: {self.model.nv} joints, {self.dof} actuated "
            f"[{', '.join(self.actuated_joints)}], closures: {kinds})"
        )
