"""The Delta as a Pinocchio model: the kinematic tree plus one point constraint per loop.

The tree (12 joints: 3 active, 3 x 2 elbow, 3 platform slides) comes from the same URDF as the
analytic model; each ``<constraint>`` becomes a ``pin.RigidConstraintModel`` (CONTACT_3D). This
module gives the closure-consistent configuration q(alpha) and velocity v(alpha, alpha_dot), and
the reduced dynamics obtained by projecting the tree's dynamics onto the active joints:

    S = dq/dalpha (constraint null space, active rows = I),
    M_red = S^T M S,   G_red = S^T g(q),   C alpha_dot_red = S^T (nle(q, v) - g(q)) + S^T M S_dot alpha_dot,

which is an independent route to the paper's eqs. 7-9 (docs/architecture.md section 5).
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pinocchio as pin

from delta_pin.errors import AssemblyError
from delta_pin.model.description import DeltaDescription
from delta_pin.model.dynamics import ReducedDynamics
from delta_pin.model.kinematics import as_vector3, forward_kinematics

__all__ = ["DeltaPinocchioModel"]

_WORLD = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED


@functools.cache
def _largest_gap_kernel():
    """The compiled closure-gap reduction, imported on first use (numba stays unloaded for
    ``delta-pin validate``)."""
    from delta_pin.compiled.tree_kernels import largest_gap

    return largest_gap


class DeltaPinocchioModel:
    """Pinocchio model, data and loop-closure constraints of a Delta description.

    Attributes:
        model: the ``pin.Model`` of the tree, gravity set to [0, 0, -g].
        data: its ``pin.Data``.
        constraint_models: ``StdVec_RigidConstraintModel``, one CONTACT_3D per closure (LOCAL).
        constraint_datas: matching ``StdVec_RigidConstraintData``.
        active_indices: indices of alpha_1..3 in q and v (all joints are 1-DOF: nq = nv).
        passive_indices: indices of the elbow and platform coordinates.
        platform_indices: indices of the platform's x, y, z slides in q.
    """

    def __init__(self, description: DeltaDescription) -> None:
        self.description = description
        params = description.params
        model = pin.buildModelFromXML(description.urdf)
        model.gravity.linear = np.array([0.0, 0.0, -params.g])
        if model.nq != model.nv:
            raise AssemblyError("delta-pin expects 1-DOF joints only (nq == nv)")
        self.active_indices = np.array(
            [model.idx_vs[model.getJointId(name)] for name in description.active_joints]
        )
        self.platform_indices = np.array(
            [model.idx_vs[model.getJointId(name)] for name in description.platform_joints]
        )
        self.passive_indices = np.setdiff1d(np.arange(model.nv), self.active_indices)
        self.platform_joint = model.getJointId(description.platform_joints[-1])
        self._elbow_joints = [
            (model.getJointId(f"elbow_{i}_pitch"), model.getJointId(f"elbow_{i}_roll")) for i in range(1, 4)
        ]
        self._constraint_models = []
        self._closure_frames = []
        for closure in description.closures:
            anchors = []
            for link, origin, tag in (
                (closure.parent_link, closure.parent_origin, "parent"),
                (closure.child_link, closure.child_origin, "child"),
            ):
                body = model.frames[model.getFrameId(link, pin.FrameType.BODY)]
                placement = body.placement * pin.SE3(np.eye(3), np.asarray(origin, dtype=float))
                frame = pin.Frame(
                    f"{closure.name}_{tag}",
                    body.parentJoint,
                    model.getFrameId(link, pin.FrameType.BODY),
                    placement,
                    pin.FrameType.OP_FRAME,
                )
                anchors.append((body.parentJoint, placement, model.addFrame(frame)))
            (j1, P1, f1), (j2, P2, f2) = anchors
            constraint = pin.RigidConstraintModel(
                pin.ContactType.CONTACT_3D, model, j1, P1, j2, P2, pin.ReferenceFrame.LOCAL
            )
            constraint.name = closure.name
            self._constraint_models.append(constraint)
            self._closure_frames.append((f1, f2))
        self.model = model
        self.data = model.createData()
        self._gap_data = model.createData()  # closure_gap's own
        # the closure anchors [parent_1, child_1, parent_2, ...] for the batched routines: the joints
        # they ride on (each read once per state), their position in that joint's frame, and the
        # velocity coordinates that move them (the joint's support)
        anchor_frames = [model.frames[f] for pair in self._closure_frames for f in pair]
        self._anchor_joints = sorted({frame.parentJoint for frame in anchor_frames})
        self._anchor_slots = np.array(
            [self._anchor_joints.index(frame.parentJoint) for frame in anchor_frames]
        )
        self._anchor_offsets = np.array([[*frame.placement.translation, 1.0] for frame in anchor_frames])
        self._anchor_supports = np.zeros((len(anchor_frames), model.nv))
        for a, frame in enumerate(anchor_frames):
            for joint in model.supports[frame.parentJoint][1:]:  # [0] is the universe
                self._anchor_supports[a, model.idx_vs[joint]] = 1.0
        self.constraint_models = pin.StdVec_RigidConstraintModel()
        self.constraint_datas = pin.StdVec_RigidConstraintData()
        for cm in self._constraint_models:
            self.constraint_models.append(cm)
            self.constraint_datas.append(cm.createData())

    # ----------------------------------------------------------------------------- kinematics
    def closure_residual(self, q: np.ndarray) -> np.ndarray:
        """Stacked world-frame gaps p_parent - p_child of the closures at q [m] (3 n_closures,)."""
        pin.framesForwardKinematics(self.model, self.data, q)
        return np.concatenate(
            [self.data.oMf[f1].translation - self.data.oMf[f2].translation for f1, f2 in self._closure_frames]
        )

    def closure_gap(self, q: np.ndarray) -> float:
        """Largest loop-closure gap max |closure_residual(q)| [m] (NaN if q holds one), cheaply.

        The same number as ``np.abs(closure_residual(q)).max()``, bit for bit (the same frame
        placements oMi * placement, subtracted the same way), for the simulation's per-step check:
        joint kinematics plus the six anchor frames only, on a ``data`` of its own (the shared one
        is left as it was).
        """
        largest_gap = _largest_gap_kernel()
        model, data, place = self.model, self._gap_data, pin.updateFramePlacement
        pin.forwardKinematics(model, data, q)
        gap, nan = 0.0, False
        for f1, f2 in self._closure_frames:
            gap, nan = largest_gap(
                gap, nan, place(model, data, f1).translation, place(model, data, f2).translation
            )
        return math.nan if nan else gap

    def _closure_jacobian(self, q: np.ndarray) -> np.ndarray:
        """d(closure_residual)/dq (3 n_closures, nv); needs kinematics at q already computed."""
        pin.computeJointJacobians(self.model, self.data, q)
        return np.vstack(
            [
                pin.getFrameJacobian(self.model, self.data, f1, _WORLD)[:3]
                - pin.getFrameJacobian(self.model, self.data, f2, _WORLD)[:3]
                for f1, f2 in self._closure_frames
            ]
        )

    def analytic_configuration(self, alpha: np.ndarray, xyz: np.ndarray | None = None) -> np.ndarray:
        """q with the analytic FK for the platform and each forearm pointing from B_i to C_i.

        Its closure residual measures how well the analytic FK closes Pinocchio's loops.

        Args:
            alpha: active angles [rad].
            xyz: their platform position [m] if already known (saves an FK).
        """
        q = pin.neutral(self.model)
        q[self.active_indices] = alpha
        q[self.platform_indices] = forward_kinematics(self.description.params, alpha) if xyz is None else xyz
        pin.framesForwardKinematics(self.model, self.data, q)
        for (pitch, roll), (_f1, f2) in zip(self._elbow_joints, self._closure_frames):
            parent = self.data.oMi[self.model.parents[pitch]] * self.model.jointPlacements[pitch]
            target = self.data.oMf[f2].translation - parent.translation
            d = parent.rotation.T @ (target / np.linalg.norm(target))
            # forearm direction R_y(pitch) R_x(roll) [0, 0, -1] (docs/architecture.md section 3)
            q[self.model.idx_qs[roll]] = math.asin(float(np.clip(d[1], -1.0, 1.0)))
            q[self.model.idx_qs[pitch]] = math.atan2(-d[0], -d[2])
        return q

    def analytic_configurations(self, alpha: np.ndarray, xyz: np.ndarray | None = None) -> np.ndarray:
        """:meth:`analytic_configuration` of many states at once (n, nq).

        One Pinocchio forward-kinematics pass per state gives the elbows' parent placements and
        the platform anchors; the forearm angles are then computed for all states together.

        Args:
            alpha: active angles [rad] (n, 3).
            xyz: their platform positions [m] (n, 3) if already known.
        """
        alpha = np.atleast_2d(np.asarray(alpha, dtype=float))
        xyz = forward_kinematics(self.description.params, alpha) if xyz is None else np.atleast_2d(xyz)
        model, data = self.model, self.data
        q = np.tile(pin.neutral(model), (len(alpha), 1))
        q[:, self.active_indices] = alpha
        q[:, self.platform_indices] = xyz
        parents = [model.parents[pitch] for pitch, _roll in self._elbow_joints]
        anchors = [model.frames[f2] for _f1, f2 in self._closure_frames]
        joints = parents + [frame.parentJoint for frame in anchors]
        unique = sorted(set(joints))
        read = np.empty((len(q), len(unique), 4, 4))  # oMi of those joints per state
        oMi = data.oMi  # a reference to the placements, updated by every kinematics pass
        for k, q_k in enumerate(q):
            pin.forwardKinematics(model, data, q_k)
            for j, joint in enumerate(unique):
                read[k, j] = oMi[joint].homogeneous
        placements = read[:, [unique.index(joint) for joint in joints]]
        n = len(parents)
        elbow = np.array([model.jointPlacements[pitch].homogeneous for pitch, _roll in self._elbow_joints])
        anchor = np.array([frame.placement.homogeneous for frame in anchors])
        parent = placements[:, :n] @ elbow  # (states, closures, 4, 4): joint frames of the pitches
        anchor_position = (placements[:, n:] @ anchor)[..., :3, 3]
        target = anchor_position - parent[..., :3, 3]
        target /= np.linalg.norm(target, axis=-1, keepdims=True)
        d = np.einsum("...ji,...j->...i", parent[..., :3, :3], target)  # R^T target
        for i, (pitch, roll) in enumerate(self._elbow_joints):
            # forearm direction R_y(pitch) R_x(roll) [0, 0, -1] (docs/architecture.md section 3)
            q[:, model.idx_qs[roll]] = np.arcsin(np.clip(d[:, i, 1], -1.0, 1.0))
            q[:, model.idx_qs[pitch]] = np.arctan2(-d[:, i, 0], -d[:, i, 2])
        return q

    def closure_residuals(self, q: np.ndarray) -> np.ndarray:
        """:meth:`closure_residual` of many configurations (n, nq) -> (n, 3 n_closures) [m]."""
        q = np.atleast_2d(q)
        model, data = self.model, self.data
        placements = np.empty((len(q), len(self._anchor_joints), 4, 4))
        oMi = data.oMi  # a reference to the placements, updated by every kinematics pass
        for k, q_k in enumerate(q):
            pin.forwardKinematics(model, data, q_k)
            for j, joint in enumerate(self._anchor_joints):
                placements[k, j] = oMi[joint].homogeneous
        return self._anchor_gaps(self._anchor_positions(placements))

    def _anchor_positions(self, placements: np.ndarray) -> np.ndarray:
        """World positions (n, anchors, 3) of the closure anchors from the oMi (n, joints, 4, 4)
        of ``_anchor_joints``."""
        return (placements[:, self._anchor_slots] @ self._anchor_offsets[:, :, None])[..., :3, 0]

    @staticmethod
    def _anchor_gaps(anchor_values: np.ndarray) -> np.ndarray:
        """Parent minus child value of each closure, stacked: (n, anchors, ...) -> (n, 3 n_closures, ...)."""
        gaps = anchor_values[:, 0::2] - anchor_values[:, 1::2]
        return gaps.reshape(len(gaps), -1, *gaps.shape[3:])

    def configuration(
        self,
        alpha: np.ndarray,
        tol: float = 1e-13,
        max_iterations: int = 30,
        initial_guess: np.ndarray | None = None,
    ) -> np.ndarray:
        """Closure-consistent configuration q(alpha) (nq,) with the active joints at ``alpha``.

        Newton iterations on the closure residual over the passive coordinates, started from
        ``initial_guess`` (a nearby configuration, e.g. the previous step's) or else from the
        analytic FK with each forearm pointing from B_i towards C_i.

        Raises:
            AssemblyError: no configuration closes the loops to ``tol`` [m].
        """
        alpha = as_vector3(alpha, "alpha")
        if initial_guess is None:
            q = self.analytic_configuration(alpha)
        else:
            q = np.array(initial_guess, dtype=float)
            q[self.active_indices] = alpha
        for _ in range(max_iterations):
            residual = self.closure_residual(q)
            if np.abs(residual).max() <= tol:
                return q
            jacobian = self._closure_jacobian(q)[:, self.passive_indices]
            q[self.passive_indices] -= np.linalg.solve(jacobian, residual)
        raise AssemblyError(
            f"the loops do not close at alpha={alpha.tolist()} rad: residual "
            f"{np.abs(residual).max():.3e} m after {max_iterations} Newton steps"
        )

    def velocity_map(self, q: np.ndarray) -> np.ndarray:
        """S = dq/dalpha (nv, 3): v = S alpha_dot satisfies the closures' velocity constraint."""
        pin.framesForwardKinematics(self.model, self.data, q)
        jacobian = self._closure_jacobian(q)
        S = np.zeros((self.model.nv, 3))
        S[self.active_indices] = np.eye(3)
        S[self.passive_indices] = -np.linalg.solve(
            jacobian[:, self.passive_indices], jacobian[:, self.active_indices]
        )
        return S

    def _closure_drift(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """J_c_dot v: the gap between the closure points' classical accelerations at zero joint
        acceleration (J_c v_dot + J_c_dot v = 0 on the constraint manifold)."""
        pin.forwardKinematics(self.model, self.data, q, v, np.zeros(self.model.nv))
        return np.concatenate(
            [
                pin.getFrameClassicalAcceleration(self.model, self.data, f1, _WORLD).linear
                - pin.getFrameClassicalAcceleration(self.model, self.data, f2, _WORLD).linear
                for f1, f2 in self._closure_frames
            ]
        )

    def state(self, alpha: np.ndarray, alpha_dot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Closure-consistent (q, v) for active angles [rad] and velocities [rad/s]."""
        q = self.configuration(alpha)
        return q, self.velocity_map(q) @ as_vector3(alpha_dot, "alpha_dot")

    def platform_position(self, q: np.ndarray) -> np.ndarray:
        """Platform position xyz [m] read from the slides of q."""
        return np.asarray(q)[self.platform_indices].copy()

    # ----------------------------------------------------------------------------- dynamics
    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """Full symmetric joint-space inertia matrix of the tree (nv, nv) [SI]."""
        M = pin.crba(self.model, self.data, q).copy()
        lower = np.tril_indices(self.model.nv, -1)
        M[lower] = M.T[lower]  # CRBA's upper triangle is the reference
        return M

    def reduced_dynamics(
        self, alpha: np.ndarray, alpha_dot: np.ndarray, q: np.ndarray | None = None
    ) -> ReducedDynamics:
        """M_red, C alpha_dot_red, G_red on the active joints by projection (see module doc).

        Args:
            q: the closure-consistent configuration of ``alpha`` if already known.
        """
        q = self.configuration(alpha) if q is None else q
        pin.framesForwardKinematics(self.model, self.data, q)
        jacobian = self._closure_jacobian(q)
        passive = jacobian[:, self.passive_indices]
        S = np.zeros((self.model.nv, 3))
        S[self.active_indices] = np.eye(3)
        S[self.passive_indices] = -np.linalg.solve(passive, jacobian[:, self.active_indices])
        v = S @ as_vector3(alpha_dot, "alpha_dot")
        rate = np.zeros(self.model.nv)  # S_dot alpha_dot: the passive acceleration at alpha_ddot = 0
        rate[self.passive_indices] = -np.linalg.solve(passive, self._closure_drift(q, v))
        M = self.mass_matrix(q)
        gravity = pin.computeGeneralizedGravity(self.model, self.data, q).copy()
        nle = pin.nonLinearEffects(self.model, self.data, q, v).copy()
        return ReducedDynamics(
            M=S.T @ M @ S,
            G=S.T @ gravity,
            coriolis=S.T @ (nle - gravity) + S.T @ (M @ rate),
        )

    def reduced_dynamics_batch(
        self, alpha: np.ndarray, alpha_dot: np.ndarray, q: np.ndarray | None = None
    ) -> ReducedDynamics:
        """:meth:`reduced_dynamics` of many states at once: M (n, 3, 3), G and coriolis (n, 3).

        Same projection, arranged for speed. Per state, two short passes of Pinocchio calls: the
        joint Jacobians (``computeJointJacobians``), the anchor joints' placements, CRBA and
        gravity at q; then the Jacobians' time variation (``computeJointJacobiansTimeVariation``)
        and the nonlinear effects at (q, v). The closure Jacobian and its drift J_c_dot v follow
        for all states together from rigid-body point kinematics of the anchors (a point p on a
        body with world spatial velocity (v_O, w) at the origin moves at v_O + w x p); the
        closure solves and projections are batched too.

        Args:
            alpha: active angles [rad] (n, 3).
            alpha_dot: active velocities [rad/s] (n, 3).
            q: their closure-consistent configurations (n, nq) if already known; otherwise
                Newton from :meth:`analytic_configurations` (``configuration``'s tolerance).
        """
        alpha = np.atleast_2d(np.asarray(alpha, dtype=float))
        alpha_dot = np.atleast_2d(np.asarray(alpha_dot, dtype=float))
        if q is None:
            q = self.analytic_configurations(alpha)
            gaps = np.abs(self.closure_residuals(q)).max(axis=1)
            for k in np.flatnonzero(gaps > 1e-13):
                q[k] = self.configuration(alpha[k], initial_guess=q[k])
        q = np.atleast_2d(q)
        model, data, nv, n = self.model, self.data, self.model.nv, len(q)
        J = np.empty((n, 6, nv))  # joint Jacobians, world frame (linear part at the origin)
        placements = np.empty((n, len(self._anchor_joints), 4, 4))
        M = np.empty((n, nv, nv))
        gravity = np.empty((n, nv))
        oMi = data.oMi  # a reference to the placements, updated by every kinematics pass
        for k, q_k in enumerate(q):
            pin.computeJointJacobians(model, data, q_k)
            J[k] = data.J
            for j, joint in enumerate(self._anchor_joints):
                placements[k, j] = oMi[joint].homogeneous
            M[k] = pin.crba(model, data, q_k)
            gravity[k] = pin.computeGeneralizedGravity(model, data, q_k)
        M = np.triu(M) + np.swapaxes(np.triu(M, 1), 1, 2)  # CRBA's upper triangle is the reference
        p = self._anchor_positions(placements)[..., None]  # (n, anchors, 3, 1)
        support = self._anchor_supports[None, :, None, :]  # (1, anchors, 1, nv)
        J_lin, J_ang = J[:, None, :3] * support, J[:, None, 3:] * support
        jacobian = self._anchor_gaps(J_lin + np.cross(J_ang, p, axis=2))  # d(p_parent - p_child)/dq
        passive = jacobian[:, :, self.passive_indices]
        S = np.zeros((n, nv, 3))
        S[:, self.active_indices] = np.eye(3)
        S[:, self.passive_indices] = -np.linalg.solve(passive, jacobian[:, :, self.active_indices])
        v = (S @ alpha_dot[:, :, None])[..., 0]
        J_dot = np.empty((n, 6, nv))
        nle = np.empty((n, nv))
        for k, (q_k, v_k) in enumerate(zip(q, v)):
            pin.computeJointJacobiansTimeVariation(model, data, q_k, v_k)
            J_dot[k] = data.dJ
            nle[k] = pin.nonLinearEffects(model, data, q_k, v_k)
        # J_c_dot v = the gap between the anchors' classical accelerations at zero joint
        # acceleration: a_O + w_dot x p + w x p_dot, with (a_O, w_dot) = J_dot v on the anchor's body
        v_body = v[:, None, :] * self._anchor_supports[None]  # (n, anchors, nv)
        velocity = np.einsum("kij,kaj->kai", J, v_body)
        acceleration = np.einsum("kij,kaj->kai", J_dot, v_body)
        p = p[..., 0]
        p_dot = velocity[..., :3] + np.cross(velocity[..., 3:], p)
        drift = self._anchor_gaps(
            acceleration[..., :3] + np.cross(acceleration[..., 3:], p) + np.cross(velocity[..., 3:], p_dot)
        )
        rate = np.zeros((n, nv))  # S_dot alpha_dot
        rate[:, self.passive_indices] = -np.linalg.solve(passive, drift[:, :, None])[..., 0]
        S_T = np.swapaxes(S, 1, 2)
        return ReducedDynamics(
            M=S_T @ M @ S,
            G=(S_T @ gravity[:, :, None])[..., 0],
            coriolis=(S_T @ ((nle - gravity) + (M @ rate[:, :, None])[..., 0])[:, :, None])[..., 0],
        )
