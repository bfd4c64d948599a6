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

Mobility. The mechanism's degrees of freedom nv - rank(J_c) are classified at load:

* the actuated joints (alpha) and the *passive* joints the user names (``passive=``: joints no
  motor drives that the closures leave free, e.g. a gripper's spring links) are the
  independent coordinates; the rest (J_p's columns, ``dependent_indices``) follow from them;
* *idle* motions are what is left: velocities the closures allow that move no independent joint
  and not the end effector's origin (a rod spinning between two ball joints, two coaxial
  revolutes welded together), ``idle_dof`` of them, the null space N of J_p. A motion that
  moves no independent joint but does move the end effector is a missing actuator (an error).

With idle motions S is not unique; the reduced model takes the map of least kinetic energy,
S = P S0 with S0 = [I; -J_p^+ J_a] and P = I - N (N^T M N)^-1 N^T M, so N^T M S = 0: at zero
idle momentum the actuated equations M_r alpha_ddot + C alpha_dot + G = tau hold exactly, and
idle motions that are dynamically decoupled (a symmetric rod's spin) never enter them. The
plant simulates the idle motions with their inertia in full coordinates; a robot with passive
joints (underactuated) has no reduced model, and controllers refuse it.

Joint couplings. A :class:`JointCoupling` (MuJoCo's ``<equality joint>``) ties one 1-DOF joint's
coordinate to another's by a polynomial, q_1 - q_1ref = sum_k c_k (q_2 - q_2ref)^k: one more
closure equation, r = q_1 - q_1ref - p(q_2 - q_2ref), with the velocity row e_1 - p'(.) e_2 and the
drift -p''(.) v_2^2. It enters the residual, J_c, its drift and derivative, the assembly and the
classification like any closure row; Pinocchio's ``constraintDynamics`` has no such constraint,
so :class:`~delta_pin.sim.closed_chain_plant.ClosedChainPlant` adds its multipliers itself.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np
import pinocchio as pin

from delta_pin.errors import AssemblyError, InvalidParameterError, UnreachablePoseError
from delta_pin.model.closures import Closure
from delta_pin.model.dynamics import ReducedDynamics

__all__ = [
    "CLOSURE_TOLERANCE",
    "ClosedChainRobot",
    "JointCoupling",
    "assembled_pose",
    "closure_rank",
    "free_motions",
    "independent_joints",
    "least_squares",
]

_WORLD = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
_RANK_TOLERANCE = 1e-9  # singular values below this fraction of the largest count as zero
CLOSURE_TOLERANCE = 1e-6  # [m or rad] the largest gap accepted in a file's loops (CAD rounding)
_EXACT_GAP = 1e-12  # [m or rad] the loops count as closed exactly (Newton's tolerance)
_NEWTON_TOL = _EXACT_GAP  # [m or rad] configuration's default tolerance
_NEWTON_STEPS = 60  # configuration's default Newton steps
# an idle spin may move a joint centre by this fraction of what the independent joints move the
# centres (a spin axis missing the joint centres by CAD offsets); more is a missing actuator
_IDLE_CENTRE_FRACTION = 1e-2


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


def _quaternion_rate(quaternion: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """d/dt of a unit quaternion (x, y, z, w) turning at omega (3,) [rad/s] in its own frame:
    0.5 quat * (omega, 0)."""
    u, w = quaternion[:3], quaternion[3]
    return 0.5 * np.concatenate([w * omega + np.cross(u, omega), [-u @ omega]])


@dataclass(frozen=True)
class JointCoupling:
    """One 1-DOF joint's coordinate tied to another's (module docstring, "Joint couplings"):
    q_1 - reference1 = sum_k coefficients[k] (q_2 - reference2)^k [rad or m], MuJoCo's
    ``<equality joint>`` with its ``polycoef`` and the joints' ``qpos0``; ``joint2`` ``None`` holds
    joint 1 at reference1 + coefficients[0]. One closure equation.

    Attributes:
        name: the coupling's name (from the file; used in every error about it).
        joint1, joint2: the joints' names (hinge or slide joints of the tree).
        coefficients: c_0 ... c_n of the polynomial.
        reference1, reference2: the coordinates the polynomial is written about.
        source: where it was read, for error messages (e.g. ``"2f85.xml line 175"``).
    """

    name: str
    joint1: str
    joint2: str | None
    coefficients: tuple[float, ...] = (0.0, 1.0)
    reference1: float = 0.0
    reference2: float = 0.0
    source: str = ""

    @property
    def where(self) -> str:
        """`` (source)`` for messages, or nothing."""
        return f" ({self.source})" if self.source else ""

    def polynomial(self, q2: float) -> tuple[float, float, float]:
        """(p, dp/dq_2, d2p/dq_2^2) at the second joint's coordinate q2 (0 without joint 2)."""
        x = 0.0 if self.joint2 is None else q2 - self.reference2
        c = self.coefficients
        value = sum(ck * x**k for k, ck in enumerate(c))
        slope = sum(k * ck * x ** (k - 1) for k, ck in enumerate(c) if k >= 1)
        curvature = sum(k * (k - 1) * ck * x ** (k - 2) for k, ck in enumerate(c) if k >= 2)
        return value, slope, curvature


def _coupling_indices(model: pin.Model, couplings: Sequence[JointCoupling], label: str = "") -> list:
    """(coupling, q index 1, v index 1, q index 2, v index 2) per coupling (-1 without joint 2).

    Raises:
        InvalidParameterError: a coupled joint the model does not have, or not of one degree of
            freedom (named).
    """
    rows = []
    for coupling in couplings:
        indices = []
        for joint in (coupling.joint1, coupling.joint2):
            if joint is None:
                indices += [-1, -1]
                continue
            jid = model.getJointId(joint) if model.existJointName(joint) else model.njoints
            if jid >= model.njoints or model.nqs[jid] != 1 or model.nvs[jid] != 1:
                what = (
                    "is not in the model" if jid >= model.njoints else "is not a 1-DOF (hinge or slide) joint"
                )
                raise InvalidParameterError(
                    f"{label}joint coupling {coupling.name!r}{coupling.where}: joint {joint!r} {what}; a "
                    "coupling ties two hinge or slide joints"
                )
            indices += [model.idx_qs[jid], model.idx_vs[jid]]
        rows.append((coupling, *indices))
    return rows


def _coupling_terms(
    indices: list, nv: int, q: np.ndarray, v: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(r, J, J_dot v, J_dot) of the joint couplings at q (and v): r = q_1 - ref_1 - p, J = e_1 - p' e_2,
    J_dot v = -p'' v_2^2, J_dot = -p'' v_2 e_2 (module docstring, "Joint couplings")."""
    k = len(indices)
    r, J, drift, J_dot = np.zeros(k), np.zeros((k, nv)), np.zeros(k), np.zeros((k, nv))
    for row, (coupling, iq1, iv1, iq2, iv2) in enumerate(indices):
        value, slope, curvature = coupling.polynomial(q[iq2] if iq2 >= 0 else 0.0)
        r[row] = q[iq1] - coupling.reference1 - value
        J[row, iv1] = 1.0
        if iv2 >= 0:
            J[row, iv2] -= slope
            if v is not None:
                drift[row] = -curvature * v[iv2] ** 2
                J_dot[row, iv2] = -curvature * v[iv2]
    return r, J, drift, J_dot


def _add_closure_frames(model: pin.Model, closures: Sequence[Closure], prefix: str = "") -> list:
    """Add each closure's two frames to ``model``: [(frame id 1, frame id 2, equations)].

    Raises:
        InvalidParameterError: a closure on a joint the model does not have.
    """
    frames = []
    for closure in closures:
        pair = []
        for tag, joint, placement in (
            ("1", closure.joint1, closure.placement1),
            ("2", closure.joint2, closure.placement2),
        ):
            if not 0 <= joint < model.njoints:
                raise InvalidParameterError(
                    f"closure {closure.name!r}{closure.where}: joint id {joint} is not in the model"
                )
            frame = pin.Frame(f"{prefix}{closure.name}_{tag}", joint, 0, placement, pin.FrameType.OP_FRAME)
            pair.append(model.addFrame(frame, False))
        frames.append((pair[0], pair[1], closure.size))
    return frames


def _closure_residual(data: pin.Data, frames: list, couplings: list, nv: int, q: np.ndarray) -> np.ndarray:
    """r(q) (module docstring) from the frame placements already in ``data`` (and q, for the joint
    couplings)."""
    parts = []
    for f1, f2, size in frames:
        M1, M2 = data.oMf[f1], data.oMf[f2]
        parts.append(M1.translation - M2.translation)
        if size == 6:
            parts.append(-M1.rotation @ pin.log3(M1.rotation.T @ M2.rotation))
    if couplings:
        parts.append(_coupling_terms(couplings, nv, q)[0])
    return np.concatenate(parts)


def _closure_rows(model: pin.Model, data: pin.Data, frames: list) -> np.ndarray:
    """J_c: the closure frames' velocity rows, J_1 - J_2 (LOCAL_WORLD_ALIGNED; linear rows only for
    a point), from the joint Jacobians and frame placements already in ``data``."""
    return np.vstack(
        [
            (pin.getFrameJacobian(model, data, f1, _WORLD) - pin.getFrameJacobian(model, data, f2, _WORLD))[
                :size
            ]
            for f1, f2, size in frames
        ]
    )


def _closure_jacobian(
    model: pin.Model, data: pin.Data, frames: list, couplings: list, q: np.ndarray
) -> np.ndarray:
    """J_c (module docstring) at q, the frame placements already in ``data``: the closure frames'
    rows and the joint couplings' rows."""
    pin.computeJointJacobians(model, data, q)
    rows = _closure_rows(model, data, frames)
    if couplings:
        rows = np.vstack([rows, _coupling_terms(couplings, model.nv, q)[1]])
    return rows


def free_motions(
    model: pin.Model,
    closures: Sequence[Closure],
    q: np.ndarray,
    held: Sequence[str] = (),
    couplings: Sequence[JointCoupling] = (),
) -> np.ndarray:
    """A basis (nv, k) of the velocities the closures (and joint couplings) allow at q with the
    joints ``held`` at rest (the null space of J_c and of those joints' velocity rows)."""
    from scipy.linalg import null_space

    model = pin.Model(model)
    frames = _add_closure_frames(model, closures, prefix="_")
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    rows = _closure_jacobian(model, data, frames, _coupling_indices(model, couplings) if couplings else [], q)
    N = null_space(rows, rcond=_RANK_TOLERANCE)
    taken = [
        model.idx_vs[model.getJointId(name)] + k
        for name in held
        for k in range(model.nvs[model.getJointId(name)])
    ]
    if taken and N.shape[1]:  # the motions left with the held joints still
        N = N @ null_space(N[taken], rcond=_RANK_TOLERANCE)
    return N


def assembled_pose(
    model: pin.Model,
    closures: Sequence[Closure],
    q: np.ndarray,
    couplings: Sequence[JointCoupling] = (),
    held: Sequence[str] = (),
) -> np.ndarray:
    """The configuration the assembly (:mod:`delta_pin.model.assembly`) closes from q, the ``held``
    joints first at their values in q, then free, as :class:`ClosedChainRobot` assembles; q itself
    where no start closes the loops (the robot's constructor then says why). For a loader that
    reads the mechanism's motions before the robot is built."""
    from delta_pin.model.assembly import assemble

    model = pin.Model(model)
    frames = _add_closure_frames(model, closures, prefix="_")
    data = model.createData()
    indices = _coupling_indices(model, couplings) if couplings else []

    def residual(x: np.ndarray) -> np.ndarray:
        pin.framesForwardKinematics(model, data, x)
        return _closure_residual(data, frames, indices, model.nv, x)

    def jacobian(x: np.ndarray) -> np.ndarray:
        pin.framesForwardKinematics(model, data, x)
        return _closure_jacobian(model, data, frames, indices, x)

    rows = [
        model.idx_vs[model.getJointId(name)] + k
        for name in held
        if model.existJointName(name)
        for k in range(model.nvs[model.getJointId(name)])
    ]
    result = assemble(model, residual, jacobian, np.asarray(q, dtype=float), held=rows)
    return result.q if result.gap <= CLOSURE_TOLERANCE else np.asarray(q, dtype=float)


def independent_joints(
    model: pin.Model,
    closures: Sequence[Closure],
    q: np.ndarray,
    exclude: Sequence[str] = (),
    couplings: Sequence[JointCoupling] = (),
) -> list[str]:
    """1-DOF joints (besides ``exclude``) whose coordinates, with those of ``exclude``, fix the
    mechanism's configuration at q: as many as its mobility leaves, chosen by column-pivoted QR
    of the closure null space (the best-conditioned set, file order breaking ties). For a
    mechanism without motors, these are the passive joints to integrate."""
    from scipy.linalg import qr

    N = free_motions(model, closures, q, exclude, couplings)
    if N.shape[1] == 0:
        return []
    candidates = [j for j in range(1, model.njoints) if model.nvs[j] == 1 and model.names[j] not in exclude]
    columns = [model.idx_vs[j] for j in candidates]
    pivots = qr(N[columns].T, pivoting=True)[2][: N.shape[1]]
    return [model.names[candidates[i]] for i in sorted(pivots)]


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
        passive: names of joints that no motor drives and that the closures do not determine
            (an underactuated mechanism: a spring link of a gripper); they are independent
            coordinates beside alpha, the plant simulates them (with ``joint_springs``) and no
            controller takes the robot (module docstring, "Mobility").
        joint_springs: joint name -> (stiffness [N m/rad or N/m], spring reference [rad or m],
            damping [N m s/rad or N s/m]); the plant applies -k (q - q_ref) - d v (a ball joint takes
            a damper only, on each of its degrees of freedom).
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
        joint_couplings: joints tied to others (:class:`JointCoupling`), closure equations of
            their own (module docstring, "Joint couplings").
        notes: lines :meth:`summary` shows about how the file was read (e.g. an actuator the file
            writes as a servo, read as a force source).
        home: the actuated coordinates alpha (``dof``,) [rad or m], or a whole configuration q
            (nq,) whose actuated coordinates are taken, at which the robot is assembled and which
            becomes its ``home`` (default: found by the global assembly from
            ``reference_configuration``, every joint free: module docstring, "Assembly").
        closure_tolerance: the largest closure gap [m or rad] accepted in the file's geometry
            (CAD exports round anchors: two ``connect`` on one hinge agree to 1e-8..1e-7 m); a
            loop consistent to this is re-anchored to close exactly where it assembles, and the
            gap is reported (``assembly_gap``, :meth:`summary`).

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
        passive: Sequence[str] = (),
        joint_springs: dict[str, tuple[float, float, float]] | None = None,
        name: str = "",
        reference_configuration: np.ndarray | None = None,
        end_effector: str | None = None,
        source: str = "",
        urdf: str | None = None,
        base_dir: str | None = None,
        visual_model: pin.GeometryModel | None = None,
        joint_couplings: Sequence[JointCoupling] = (),
        notes: Sequence[str] = (),
        home: np.ndarray | Sequence[float] | None = None,
        closure_tolerance: float = CLOSURE_TOLERANCE,
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
        self.joint_couplings = tuple(joint_couplings)
        self.notes = tuple(notes)
        self._couplings = _coupling_indices(self.model, self.joint_couplings, self._label)
        if not self.closures:
            raise InvalidParameterError(f"{self._label}has no loop closure: use a serial-robot model instead")
        self.actuated_joints = tuple(actuated)
        if not self.actuated_joints and not passive:
            raise InvalidParameterError(
                f"{self._label}names no actuated joint: name the motors (actuated=[...]), or the joints "
                "no motor drives (passive=[...]) for a mechanism without motors"
            )
        ids = [self._joint_id(joint, "actuated") for joint in self.actuated_joints]
        if len(set(ids)) != len(ids):
            raise InvalidParameterError(
                f"{self._label}an actuated joint is named twice: {list(self.actuated_joints)}"
            )
        self.passive_joints = tuple(passive)
        for joint in self.passive_joints:
            if joint in self.actuated_joints:
                raise InvalidParameterError(
                    f"{self._label}joint {joint!r} is named both actuated and passive: a joint is driven by "
                    "a motor (actuated) or by nothing (passive), not both"
                )
        passive_ids = [self._joint_id(joint, "passive", any_type=True) for joint in self.passive_joints]
        if len(set(passive_ids)) != len(passive_ids):
            raise InvalidParameterError(f"{self._label}a passive joint is named twice: {list(passive)}")
        self.dof = len(ids)
        self.actuated_indices = np.array([self.model.idx_vs[j] for j in ids], dtype=int)  # in v
        self.actuated_q_indices = np.array([self.model.idx_qs[j] for j in ids], dtype=int)  # in q
        # a passive joint may have several degrees of freedom (a free-flyer base, a ball joint)
        self.passive_joint_indices = np.array(
            [self.model.idx_vs[j] + k for j in passive_ids for k in range(self.model.nvs[j])], dtype=int
        )
        self.passive_joint_q_indices = np.array(
            [self.model.idx_qs[j] + k for j in passive_ids for k in range(self.model.nqs[j])], dtype=int
        )
        # the independent coordinates (actuated, then the named passive joints) and the ones the
        # closures determine (up to idle motions); passive_indices is the older name of the latter
        self.independent_indices = np.concatenate([self.actuated_indices, self.passive_joint_indices])
        self.dependent_indices = np.setdiff1d(np.arange(self.model.nv), self.independent_indices)
        self.passive_indices = self.dependent_indices
        self.idle_dof = None  # set by the mobility classification below
        # joint name -> (stiffness [N m/rad or N/m], spring reference [rad or m], damping
        # [N m s/rad or N s/m]): the plant applies -k (q - q_ref) - d v there (MJCF stiffness/damping);
        # a joint of several degrees of freedom (a ball) takes a damper only, on each of them
        self.joint_springs: dict[str, tuple[float, float, float]] = {}
        for joint, values in (joint_springs or {}).items():
            jid = self._joint_id(joint, "sprung", any_type=True)
            stiffness, reference, damping = (float(x) for x in values)
            if self.model.nvs[jid] != 1 and stiffness != 0.0:
                raise InvalidParameterError(
                    f"{self._label}joint_springs[{joint!r}]: a spring needs a 1-DOF joint; {joint!r} has "
                    f"{self.model.nvs[jid]} degrees of freedom and takes a damper only (stiffness 0)"
                )
            if not (np.isfinite([stiffness, reference, damping]).all() and stiffness >= 0 and damping >= 0):
                raise InvalidParameterError(
                    f"{self._label}joint_springs[{joint!r}] = {values!r} must be (stiffness >= 0, reference, "
                    "damping >= 0), finite"
                )
            self.joint_springs[joint] = (stiffness, reference, damping)
        self._rates = None  # per joint, how its configuration coefficients move (configuration_rate)
        self._set_closures(self.closures)
        q0 = (
            pin.neutral(self.model)
            if reference_configuration is None
            else np.asarray(reference_configuration, float)
        )
        if q0.shape != (self.model.nq,):
            raise InvalidParameterError(
                f"{self._label}reference_configuration has shape {q0.shape}, expected ({self.model.nq},)"
            )
        if not (isinstance(closure_tolerance, int | float) and 0.0 <= closure_tolerance < math.inf):
            raise InvalidParameterError(
                f"{self._label}closure_tolerance={closure_tolerance!r} must be a finite number >= 0 [m or "
                f"rad], e.g. {CLOSURE_TOLERANCE:g}"
            )
        self.closure_tolerance = float(closure_tolerance)
        q0 = self._home_start(q0, home)
        self.end_effector = self._frames[0][0] if end_effector is None else self.frame_id(end_effector)
        self._end_effector_given = end_effector is not None
        q0 = self._assemble_globally(q0, given_home=home is not None)
        self.home = q0[self.actuated_q_indices].copy()
        self._last_q = q0.copy()
        try:
            self.reference_configuration = self._close_while_building(q0)
        except AssemblyError:
            # a wrong actuator count is the likelier cause; the rank at a generic (perturbed)
            # configuration is the mechanism's, whatever singular pose q0 may be in
            generic = pin.integrate(self.model, q0, np.random.default_rng(0).normal(0.0, 0.1, self.model.nv))
            self._classify_mobility(generic, assembled=False)
            raise
        self._classify_mobility(self.reference_configuration)
        self._options = {
            "name": name, "source": source, "urdf": urdf, "base_dir": base_dir, "visual_model": visual_model,
            "passive": self.passive_joints, "joint_springs": self.joint_springs,
            "joint_couplings": self.joint_couplings, "notes": self.notes,
            "closure_tolerance": self.closure_tolerance,
        }  # fmt: skip

    def _set_closures(self, closures: Sequence[Closure]) -> None:
        """The closures, their frames on ``model`` (a fresh copy of the tree) and Pinocchio's
        constraint models."""
        self.closures = tuple(closures)
        self.model = pin.Model(self.tree)
        self.constraint_models = pin.StdVec_RigidConstraintModel()
        self.constraint_datas = pin.StdVec_RigidConstraintData()
        self._frames = _add_closure_frames(self.model, self.closures)  # (frame 1, frame 2, equations)
        for closure in self.closures:
            constraint = closure.constraint_model(self.model)
            self.constraint_models.append(constraint)
            self.constraint_datas.append(constraint.createData())
        self.data = self.model.createData()
        self.closure_size = sum(c.size for c in self.closures) + len(self._couplings)

    def _home_start(self, q0: np.ndarray, home) -> np.ndarray:
        """The assembly's start: ``home`` as alpha (``dof``,) puts the actuated joints there, as q
        (nq,) is the start; none: ``q0``."""
        if home is None:
            return q0
        value = np.asarray(home, dtype=float).reshape(-1)
        if value.shape == (self.dof,) and np.isfinite(value).all():
            q0 = q0.copy()
            q0[self.actuated_q_indices] = value
        elif value.shape == (self.model.nq,) and np.isfinite(value).all():
            q0 = pin.normalize(self.model, value)
        else:
            raise InvalidParameterError(
                f"{self._label}home={np.asarray(home).tolist()} must be {self.dof} finite actuated "
                f"coordinates ({', '.join(self.actuated_joints) or 'none'}) [rad or m], or a whole "
                f"configuration of {self.model.nq} numbers"
            )
        return q0

    def _assemble_globally(self, q0: np.ndarray, given_home: bool) -> np.ndarray:
        """Close the loops from ``q0`` (module docstring, "Assembly"); re-anchor a file whose loops
        are consistent only to ``closure_tolerance``. Sets ``assembly_gap``, ``assembly_starts``.

        Raises:
            AssemblyError: no start closes the loops to ``closure_tolerance`` (the worst closure
                named), at the given ``home`` or anywhere near the file's pose.
        """
        from delta_pin.model.assembly import assemble

        # the file's (or the given) actuated coordinates first, as its author drew them; then, for a
        # file whose pose is far from any assembly at those, every joint free
        result = assemble(
            self.model, self.closure_residual, self.closure_jacobian, q0, held=self.actuated_indices,
            free_fallback=not given_home,
        )  # fmt: skip
        self.assembly_starts = result.starts
        self.assembly_gap_at_start = self.closure_gap(q0)
        self.assembly_gap = result.gap
        if not result.gap <= self.closure_tolerance:
            residual = self.closure_residual(result.q)
            at = (
                f"with the actuated joints at home={np.round(q0[self.actuated_q_indices], 6).tolist()}"
                if given_home
                else "anywhere near the file's pose (every joint free)"
            )
            raise AssemblyError(
                f"{self._label}the loops do not close {at}: closure {self._worst_closure(residual)} stays "
                f"{result.gap:.3e} (m or rad) apart after a global solve from {result.starts} start(s), "
                f"beyond closure_tolerance={self.closure_tolerance:g}; give a reachable home= (CLI --home) "
                "or check the closure's frames"
            )
        if result.gap > _EXACT_GAP and not self._closes_exactly(result.q):
            self._reanchor(result.q)
        return result.q

    def _closes_exactly(self, q: np.ndarray) -> bool:
        """Whether Newton with the independent joints held at q closes the loops to ``_EXACT_GAP``."""
        from delta_pin.model.assembly import newton

        held = self.independent_indices
        gap = newton(
            self.model, self.closure_residual, self.closure_jacobian, q.copy(), held, _EXACT_GAP, 20
        )[1]
        return gap <= _EXACT_GAP

    def _close_while_building(self, q0: np.ndarray) -> np.ndarray:
        """The reference configuration: Newton from the assembled ``q0`` with the independent
        joints held (the mobility is not classified yet, so not the core's Newton, which takes
        the idle motions' count).

        Raises:
            AssemblyError: the loops do not close to 1e-12 in 60 steps; names the worst closure.
        """
        from delta_pin.model.assembly import newton

        held, tol = self.independent_indices, _NEWTON_TOL
        q, gap, _ = newton(
            self.model, self.closure_residual, self.closure_jacobian, q0.copy(), held, tol, _NEWTON_STEPS
        )
        if gap <= _NEWTON_TOL:
            return q
        raise self._not_closed(self.home, q, _NEWTON_STEPS)

    def _reanchor(self, q: np.ndarray) -> None:
        """Move each closure's second frame onto its first at q (the file's rounding), so that the
        loops close exactly there; the largest move is ``assembly_gap``."""
        import dataclasses

        pin.framesForwardKinematics(self.model, self.data, q)
        closures = []
        for closure, (f1, _, size) in zip(self.closures, self._frames, strict=True):
            joint_placement = self.data.oMi[closure.joint2]
            target = joint_placement.actInv(self.data.oMf[f1])  # frame 1 in joint 2's frame
            placement2 = pin.SE3(closure.placement2)
            placement2.translation = target.translation
            if size == 6:
                placement2.rotation = target.rotation
            closures.append(dataclasses.replace(closure, placement2=placement2))
        self._set_closures(closures)
        self.notes = (
            *self.notes,
            f"the file's loops are consistent to {self.assembly_gap:.2g} (m or rad) only (rounded anchors): "
            f"re-anchored to close exactly at home (closure_tolerance={self.closure_tolerance:g})",
        )

    def __getattr__(self, name: str):
        """The analytic Delta's attributes (``params``'s siblings: ``pinocchio``, ``description``,
        ``jacobian``, ``analytic_dynamics`` ...) where the robot carries one (``robot.delta``)."""
        delta = self.__dict__.get("delta")
        if delta is None or name.startswith("__"):
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")
        return getattr(delta, name)

    # ------------------------------------------------------------------------------ naming
    @property
    def _label(self) -> str:
        name = getattr(self, "name", "")
        source = getattr(self, "source", "")
        return f"robot {name!r}{f' ({source})' if source else ''}: " if name or source else ""

    def _joint_id(self, joint: str, role: str, any_type: bool = False) -> int:
        """Id of a joint named as ``role`` (actuated or passive): 1-DOF unless ``any_type``."""
        if not isinstance(joint, str) or not self.model.existJointName(joint):
            known = ", ".join(self.model.names[1:])
            raise InvalidParameterError(
                f"{self._label}{role} joint {joint!r} is not in the model (joints: {known})"
            )
        jid = self.model.getJointId(joint)
        if not any_type and (self.model.nqs[jid] != 1 or self.model.nvs[jid] != 1):
            what = "an actuator drives" if role == "actuated" else "a passive joint is"
            raise InvalidParameterError(
                f"{self._label}{role} joint {joint!r} has {self.model.nvs[jid]} degrees of freedom; "
                f"{what} one revolute or prismatic joint"
            )
        return jid

    def frame_id(self, frame: str) -> int:
        """Id of a named frame (a link, joint, site or closure frame).

        Raises:
            InvalidParameterError: no such frame, with the names that exist.
        """
        if not isinstance(frame, str) or not self.model.existFrame(frame):
            names = sorted({f.name for f in self.model.frames if f.name != "universe"})
            shown = ", ".join(names[:40]) + (" ..." if len(names) > 40 else "")
            raise InvalidParameterError(f"{self._label}has no frame {frame!r} (frames: {shown})")
        matches = [f for f in range(len(self.model.frames)) if self.model.frames[f].name == frame]
        # a site named like its body (MJCF): the body's own frame
        bodies = [f for f in matches if self.model.frames[f].type == pin.FrameType.BODY]
        return (bodies or matches)[0]

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
        """Make ``frame`` the one :meth:`forward_kinematics` and the runs report.

        Raises:
            InvalidParameterError: an idle motion moves the frame's origin (the actuated joints
                would not determine where it is).
        """
        previous, self.end_effector = self.end_effector, self.frame_id(frame)
        if self.idle_dof and self._idle_motions_moving_end_effector(self.reference_configuration):
            self.end_effector = previous
            idle_joints = sorted({j for motion in self.classification()["idle"] for j in motion})
            raise InvalidParameterError(
                f"{self._label}frame {frame!r} moves with the idle motions ({', '.join(idle_joints)}), so "
                "the actuated joints do not determine where it is: choose a frame the motors place"
            )

    @property
    def params(self):
        """A recognised Delta's parameters (so the Delta's task-space paths apply), else ``None``."""
        return None if self.delta is None else self.delta.params

    @property
    def closure_frames(self) -> list[tuple[int, int, int]]:
        """(frame id 1, frame id 2, equations) of each closure, in order."""
        return list(self._frames)

    @property
    def has_unactuated_motion(self) -> bool:
        """Whether the mechanism moves more than the actuated joints carry (idle motions or
        passive joints): then a plant's state must be the full (q, v), not (alpha, alpha_dot)."""
        return bool(self.idle_dof or self.passive_joints)

    @property
    def end_effector_name(self) -> str:
        return self.model.frames[self.end_effector].name

    # ------------------------------------------------------------------------------ closures
    def closure_residual(self, q: np.ndarray) -> np.ndarray:
        """Stacked closure residuals r(q) (``closure_size``,) [m, rad] (module docstring)."""
        pin.framesForwardKinematics(self.model, self.data, q)
        return self._residual(q)

    def _residual(self, q: np.ndarray) -> np.ndarray:
        """r(q) from the frame placements already in ``data`` (and q, for the joint couplings)."""
        return _closure_residual(self.data, self._frames, self._couplings, self.model.nv, q)

    def closure_gap(self, q: np.ndarray) -> float:
        """Largest closure residual max |r(q)| [m or rad] (NaN if q holds one)."""
        if not np.isfinite(q).all():
            return math.nan
        return float(np.abs(self.closure_residual(q)).max())

    def closure_jacobian(self, q: np.ndarray, kinematics_done: bool = False) -> np.ndarray:
        """J_c (``closure_size``, nv): the closures' velocity rows (module docstring)."""
        if not kinematics_done:
            pin.framesForwardKinematics(self.model, self.data, q)
        return _closure_jacobian(self.model, self.data, self._frames, self._couplings, q)

    def coupling_terms(self, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(r, J, J_dot v) of the joint couplings alone (the last rows of the closure residual, J_c
        and drift): what a plant adds to Pinocchio's constrained dynamics (``constraint_models``
        carries the frame closures only)."""
        r, J, drift, _ = _coupling_terms(self._couplings, self.model.nv, q, v)
        return r, J, drift

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
        if self._couplings:
            rows.append(_coupling_terms(self._couplings, self.model.nv, q, v)[2])
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
        if self._couplings:
            rows.append(_coupling_terms(self._couplings, self.model.nv, q, v)[3])
        return np.vstack(rows)

    # ------------------------------------------------------------------------------ assembly
    def configuration(
        self,
        alpha: np.ndarray,
        *,
        initial_guess: np.ndarray | None = None,
        tol: float = _NEWTON_TOL,
        max_iterations: int = _NEWTON_STEPS,
    ) -> np.ndarray:
        """A closure-consistent configuration q (nq,) with the actuated joints at ``alpha`` [rad or m].

        The compiled core's Newton (``ClosedChainModel.configuration``; least squares on the
        closure residual over the dependent coordinates, minimum-norm where idle motions leave a
        null space), started from ``initial_guess``, else from the last configuration assembled
        (the assembly mode the robot is in), else from the reference configuration. Steps are
        limited to 0.5 (rad or m) so that a far start does not jump to another assembly mode.
        Its readable twin is ``tests/reference/assembly.py``.

        Raises:
            AssemblyError: the loops do not close to ``tol``; names the worst closure.
        """
        alpha = self._joint_vector(alpha, "alpha")
        if not (isinstance(tol, int | float) and 0.0 < tol < math.inf):
            raise InvalidParameterError(
                f"{self._label}tol={tol!r} must be a finite number > 0 [m or rad], e.g. 1e-12"
            )
        if not (isinstance(max_iterations, int | np.integer) and max_iterations >= 1):
            raise InvalidParameterError(
                f"{self._label}max_iterations={max_iterations!r} must be an integer >= 1"
            )
        core = self._assembling_core()
        starts = [self._last_q] if initial_guess is None else [initial_guess]
        if initial_guess is None and hasattr(self, "reference_configuration"):
            starts.append(self.reference_configuration)  # the last one may be far (a diverged run)
        for start in starts:
            start = np.asarray(start, dtype=float)
            if start.shape != (self.model.nq,):
                raise InvalidParameterError(
                    f"{self._label}initial_guess has shape {start.shape}, expected ({self.model.nq},)"
                )
            closed, q = core.configuration(alpha, start, float(tol), int(max_iterations))
            if closed:
                self._last_q = q.copy()
                return q
        raise self._not_closed(alpha, q, max_iterations)

    def _not_closed(self, alpha: np.ndarray, q: np.ndarray, iterations: int) -> AssemblyError:
        """The error of a Newton that ended at q without closing the loops: its worst closure."""
        residual = self.closure_residual(q) if np.isfinite(q).all() else None
        gap = "non-finite" if residual is None else f"{np.abs(residual).max():.3e} (m or rad) apart"
        return AssemblyError(
            f"{self._label}the loops do not close at alpha={np.round(alpha, 6).tolist()}: closure "
            f"{self._worst_closure(residual)} is still {gap} after {iterations} Newton steps; "
            "start nearer (initial_guess=) or choose reachable actuated coordinates"
        )

    def _assembling_core(self):
        """The compiled model that assembles this robot.

        Raises:
            InvalidParameterError: the core refuses this model (why, in its words).
        """
        core = self.compiled_model
        if core is None:
            from delta_pin.model.core_model import core_refusal

            raise InvalidParameterError(
                f"{self._label}the compiled core cannot take this model: {core_refusal(self)}"
            )
        return core

    def actuation_conditioning(self, alpha: np.ndarray, start: np.ndarray | None = None) -> float:
        """cond(J_p) (J_p restricted to its rank) at the configuration of least closure residual
        Newton reaches at ``alpha`` from ``start`` (a configuration q; None: the last assembled
        one): large near an actuation (Type II) singularity, where the actuated joints stop
        fixing the loops; what a failed assembly during a run reports."""
        from delta_pin.model.assembly import assemble

        start = (self._last_q if start is None else np.asarray(start, dtype=float)).copy()
        start[self.actuated_q_indices] = np.asarray(alpha, dtype=float)
        q = assemble(
            self.model, self.closure_residual, self.closure_jacobian, start, held=self.independent_indices,
            free_fallback=False,
        ).q  # fmt: skip
        return self._cond_J_p(self.closure_jacobian(q))

    def _cond_J_p(self, J: np.ndarray) -> float:
        """cond(J_p) of J_c's dependent columns restricted to their rank (less the idle motions)."""
        singular = np.linalg.svd(J[:, self.dependent_indices], compute_uv=False)
        rank = len(self.dependent_indices) - (self.idle_dof or 0)
        if not rank:
            return 1.0
        return float(singular[0] / singular[rank - 1]) if singular[rank - 1] > 0 else math.inf

    def _worst_closure(self, residual: np.ndarray | None) -> str:
        if residual is None or not np.isfinite(residual).all():
            return "(non-finite state)"
        start, worst, largest = 0, self.closures[0], -1.0
        for closure in self.closures:
            value = np.abs(residual[start : start + closure.size]).max()
            if value > largest:
                worst, largest = closure, value
            start += closure.size
        for coupling in self.joint_couplings:  # the last rows, one each
            if abs(residual[start]) > largest:
                worst, largest = coupling, abs(residual[start])
            start += 1
        return f"{worst.name!r}{worst.where}"

    # ------------------------------------------------------------------------------ mobility
    def _classify_mobility(self, q: np.ndarray, assembled: bool = True) -> None:
        """Split the mechanism's mobility nv - rank(J_c) into the actuated joints, the named
        passive joints and the idle motions (module docstring, "Mobility"); sets ``idle_dof``.

        Raises:
            AssemblyError: the actuated and passive joints are not independent (a redundant or
                singular actuation), or motions that move none of them move the end effector
                (a missing actuator), each named.
        """
        J = self.closure_jacobian(q)
        rank = _rank(J)
        mobility = self.model.nv - rank
        named = len(self.independent_indices)
        counts = (
            f"({self.model.nv} joint velocities, {rank} independent closure equations"
            + "".join(f", joint coupling {c.name!r}{c.where} among them" for c in self.joint_couplings)
            + f") but {self.dof} "
            f"actuator(s) ({', '.join(self.actuated_joints) or 'none'})"
            + (f" and {len(self.passive_joints)} passive joint(s)" if self.passive_joints else "")
        )
        where = f"at its reference configuration{'' if assembled else ' (a generic pose near it)'}"
        if not assembled:
            if mobility < named:
                raise AssemblyError(
                    f"{self._label}the mechanism has {mobility} degree(s) of freedom {where} {counts}: "
                    "name one actuator per degree of freedom"
                )
            return
        dependent = J[:, self.dependent_indices]
        dependent_rank = _rank(dependent)
        if dependent_rank != rank or mobility < named:
            raise AssemblyError(
                f"{self._label}the mechanism has {mobility} degree(s) of freedom {where} {counts}: the "
                "actuated joints do not move independently (a singular or redundant actuation); drop an "
                "actuator or start from another configuration"
                if self.actuated_joints
                else f"{self._label}a mechanism without motors with {mobility} degree(s) of freedom {where} "
                f"{counts}: its free motion is not the motion of whole joints delta-pin could pick as its "
                "coordinates; name the joints whose coordinates fix its configuration (passive=[...], CLI "
                "--passive)"
            )
        self.idle_dof = len(self.dependent_indices) - dependent_rank
        if self.idle_dof:
            if not self._end_effector_given:
                self._missing_actuator_check(q, where, counts)
                self._choose_end_effector(q)
            moving = self._idle_motions_moving_end_effector(q)
            if moving:
                raise AssemblyError(
                    f"{self._label}the mechanism has {mobility} degree(s) of freedom {where} {counts}; "
                    f"{len(moving)} of the {self.idle_dof} motion(s) that move none of them move the end "
                    f"effector {self.end_effector_name!r} (joints {', '.join(moving[0])}): a missing "
                    "actuator: name one more actuated (actuated=) or passive (passive=) joint per motion, "
                    "or choose another end effector (end_effector=)"
                )

    def _missing_actuator_check(self, q: np.ndarray, where: str, counts: str) -> None:
        """Refuse motions that move no independent joint but carry joint centres along: an idle
        motion spins bodies about axes through their joints' centres (a rod between two ball
        joints), a missing actuator moves the linkage. A centre moved by less than
        ``_IDLE_CENTRE_FRACTION`` of what the independent joints move the centres counts as on
        the axis (CAD offsets of a fraction of a millimetre on a spinning rod).

        Raises:
            AssemblyError: a motion that moves joint centres (its joints named).
        """
        basis = self.idle_motions(q)
        S = self._velocity_map(self.closure_jacobian(q), q)
        pin.computeJointJacobians(self.model, self.data, q)
        centres = np.vstack(
            [pin.getJointJacobian(self.model, self.data, j, _WORLD)[:3] for j in range(1, self.model.njoints)]
        )
        scale = float(np.abs(centres @ S).max(initial=0.0))
        moved = np.abs(centres @ basis).max(axis=0, initial=0.0)
        for column in np.flatnonzero(moved > _IDLE_CENTRE_FRACTION * scale):
            joints = self._joints_of_motion(basis[:, column])
            raise AssemblyError(
                f"{self._label}the mechanism has {self.model.nv - _rank(self.closure_jacobian(q))} degree(s) "
                f"of freedom {where} {counts}; a motion that moves none of them moves the linkage (joints "
                f"{', '.join(joints)}): a missing actuator: name one more actuated (actuated=) or passive "
                "(passive=) joint per motion"
            )

    def _choose_end_effector(self, q: np.ndarray) -> None:
        """The default end effector where idle motions move the first closure's first frame (a
        frame on a rod that spins between two joints): the first closure frame, else the first
        frame of a leaf body of the tree (a foot, a platform), that no idle motion moves. None
        such: the first closure frame stays, and the classification names the missing actuator."""
        leaves = set(range(1, self.model.njoints)) - {
            self.model.parents[j] for j in range(1, self.model.njoints)
        }
        candidates = [f for pair in self._frames for f in pair[:2]] + [
            f
            for f, frame in enumerate(self.model.frames)
            if frame.parentJoint in leaves and frame.type == pin.FrameType.BODY
        ]
        first = self.end_effector
        for frame in candidates:
            self.end_effector = frame
            if not self._idle_motions_moving_end_effector(q):
                return
        self.end_effector = first

    def _idle_motions_moving_end_effector(self, q: np.ndarray) -> list[list[str]]:
        """The joints of each motion that moves no independent joint but moves the end effector's
        origin (an empty list where every such motion is idle)."""
        basis = self.idle_motions(q)
        pin.computeJointJacobians(self.model, self.data, q)
        pin.updateFramePlacements(self.model, self.data)
        J_ee = pin.getFrameJacobian(self.model, self.data, self.end_effector, _WORLD)[:3]
        scale = max(1.0, float(np.abs(J_ee).max()))
        moved = J_ee @ basis
        _, singular, vt = np.linalg.svd(moved)
        offending = vt[: int((singular > 1e-8 * scale).sum())]
        return [self._joints_of_motion(basis @ direction) for direction in offending]

    def _joints_of_motion(self, v: np.ndarray) -> list[str]:
        """Names of the joints a velocity (nv,) moves (components above 1e-6 of the largest)."""
        largest = np.abs(v).max()
        return [
            self.model.names[j]
            for j in range(1, self.model.njoints)
            if self.model.nvs[j]
            and np.abs(v[self.model.idx_vs[j] : self.model.idx_vs[j] + self.model.nvs[j]]).max()
            > 1e-6 * largest
        ]

    def _pseudo_inverse(self, A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(A^+, N): the pseudo-inverse of the dependent columns A of J_c and an orthonormal basis
        N (columns) of their null space, of dimension ``idle_dof`` (by numeric rank until the
        classification has set it)."""
        U, singular, Vt = np.linalg.svd(A, full_matrices=True)
        if self.idle_dof is None:
            rank = int((singular > _RANK_TOLERANCE * max(singular[0] if singular.size else 0.0, 1.0)).sum())
        else:
            rank = A.shape[1] - self.idle_dof
        return (Vt[:rank].T / singular[:rank]) @ U[:, :rank].T, Vt[rank:].T

    def idle_motions(self, q: np.ndarray) -> np.ndarray:
        """The idle motions at q (nv, ``idle_dof``): velocities the closures allow that move no
        actuated or passive joint, one column each, localised (each column is 1 at a joint of
        its own and 0 at the others' ones, so independent spins come apart)."""
        from scipy.linalg import qr

        _, N_dependent = self._pseudo_inverse(self.closure_jacobian(q)[:, self.dependent_indices])
        basis = np.zeros((self.model.nv, N_dependent.shape[1]))
        if N_dependent.shape[1]:
            pivots = qr(N_dependent.T, pivoting=True)[2][: N_dependent.shape[1]]
            N_dependent = N_dependent @ np.linalg.inv(N_dependent[pivots])
            basis[self.dependent_indices] = N_dependent
        return basis

    # ------------------------------------------------------------------------------ velocities
    def configuration_rate(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """dq/dt (nq,) of the configuration's coefficients for the velocity v (nv,): the
        identity on 1-DOF axis joints, 0.5 quat * (omega, 0) on a ball joint's quaternion
        (x, y, z, w; omega in the joint's frame), R v_linear and the quaternion rate on a free
        joint, the unit-complex rate of a continuous (RUBX) or planar joint. With it, a
        configuration with quaternions integrates as a plain ODE; renormalise after each step
        (``pin.normalize``).

        Raises:
            InvalidParameterError: a joint type without such a rate (named).
        """
        if self._rates is None:
            self._rates = [self._joint_rate_kind(j) for j in range(1, self.model.njoints)]
        q_dot = np.empty(self.model.nq)
        for j, kind in enumerate(self._rates, 1):
            iq, iv, nq = self.model.idx_qs[j], self.model.idx_vs[j], self.model.nqs[j]
            if kind == "axis":
                q_dot[iq : iq + nq] = v[iv : iv + nq]
            elif kind == "ball":
                q_dot[iq : iq + 4] = _quaternion_rate(q[iq : iq + 4], v[iv : iv + 3])
            elif kind == "free":
                quaternion = q[iq + 3 : iq + 7]
                q_dot[iq : iq + 3] = pin.Quaternion(quaternion).matrix() @ v[iv : iv + 3]
                q_dot[iq + 3 : iq + 7] = _quaternion_rate(quaternion, v[iv + 3 : iv + 6])
            elif kind == "unit_complex":
                c, s = q[iq], q[iq + 1]
                q_dot[iq : iq + 2] = (-s * v[iv], c * v[iv])
            else:  # planar: x, y, cos, sin; v = (vx, vy) in the joint frame, omega
                c, s = q[iq + 2], q[iq + 3]
                vx, vy, w = v[iv : iv + 3]
                q_dot[iq : iq + 4] = (c * vx - s * vy, s * vx + c * vy, -s * w, c * w)
        return q_dot

    def _joint_rate_kind(self, j: int) -> str:
        name = self.model.joints[j].shortname()
        if self.model.nqs[j] == self.model.nvs[j] and (
            (name.startswith(("JointModelR", "JointModelP")) and not name.startswith("JointModelPlanar"))
            or name == "JointModelTranslation"
        ):
            return "axis"
        kinds = {
            "JointModelSpherical": "ball",
            "JointModelFreeFlyer": "free",
            "JointModelRUBX": "unit_complex",
            "JointModelRUBY": "unit_complex",
            "JointModelRUBZ": "unit_complex",
            "JointModelRevoluteUnboundedUnaligned": "unit_complex",
            "JointModelPlanar": "planar",
        }
        if name not in kinds:
            raise InvalidParameterError(
                f"{self._label}joint {self.model.names[j]!r} ({name}) has no configuration rate here: full "
                "coordinates take axis, ball, free, continuous and planar joints (use coordinates='active')"
            )
        return kinds[name]

    def velocity_map(self, q: np.ndarray) -> np.ndarray:
        """S = dq/dalpha (nv, dof) at a closed q: v = S alpha_dot satisfies the closures' velocity
        constraint (named passive joints at rest; with idle motions, the one of least kinetic
        energy: module docstring, "Mobility"). The compiled core's (its readable twin:
        ``tests/reference/projection.py``)."""
        return self._assembling_core().velocity_map(self._configuration_vector(q))

    def _configuration_vector(self, q) -> np.ndarray:
        value = np.asarray(q, dtype=float)
        if value.shape != (self.model.nq,) or not np.isfinite(value).all():
            raise InvalidParameterError(
                f"{self._label}q has shape {value.shape} or a non-finite entry; expected {self.model.nq} "
                "finite numbers (a configuration)"
            )
        return value

    def _velocity_map(self, J: np.ndarray, q: np.ndarray) -> np.ndarray:
        """S (nv, independent coordinates) from J_c at q."""
        count = len(self.independent_indices)
        S = np.zeros((self.model.nv, count))
        S[self.independent_indices] = np.eye(count)
        A, B = J[:, self.dependent_indices], J[:, self.independent_indices]
        if self.idle_dof == 0:
            S[self.dependent_indices] = -least_squares(A, B)
            return S
        A_pinv, N_dependent = self._pseudo_inverse(A)
        S[self.dependent_indices] = -A_pinv @ B
        M = self.mass_matrix(q)
        N = np.zeros((self.model.nv, self.idle_dof))
        N[self.dependent_indices] = N_dependent
        return S - N @ np.linalg.solve(N.T @ M @ N, N.T @ M @ S)

    def project_state(self, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The nearest closure-consistent (q, v) keeping the actuated and passive joints' values
        and the idle motions' state: Newton from q over the dependent coordinates (minimum-norm
        steps), then v's dependent part corrected by the minimum-norm velocity that closes the
        loops. The compiled core's (its readable twin: ``tests/reference/projection.py``).

        Raises:
            AssemblyError: the loops do not close at q's actuated coordinates; names the worst closure.
        """
        q = self._configuration_vector(q)
        v = np.asarray(v, dtype=float)
        closed, q_out, v_out = self._assembling_core().project_state(q, v)
        if not closed:
            raise self._not_closed(q[self.actuated_q_indices], q_out, _NEWTON_STEPS)
        return q_out, v_out

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
        -> (3,), or (N, dof) -> (N, 3), assembling each state (warm-started); a Delta's
        platform by the analytic model (eqs. 1-5)."""
        if frame is None and self.delta is not None:
            return self.delta.forward_kinematics(alpha)
        alpha = np.asarray(alpha, dtype=float)
        if alpha.ndim == 2:
            if frame is None or self._frame(frame) == self.end_effector:
                core = self.compiled_model
                if core is not None:  # the same assembly and placement, in the compiled core
                    return self._core_forward_kinematics(core, alpha)
            return np.array([self.forward_kinematics(row, frame) for row in alpha])
        return self.frame_placement(self.configuration(alpha), frame).translation.copy()

    @property
    def compiled_model(self):
        """This robot in the compiled core (``ClosedChainModel``,
        :func:`~delta_pin.model.core_model.core_model`): built once per end effector and shared by
        everything that assembles, projects or differentiates this robot (its plant, nominal
        model, frame paths, regressor, validation); ``None`` for a model the core refuses. It
        holds a copy of ``model``: after changing that in place, call :meth:`model_changed`.

        Raises:
            NativeUnavailableError: the core cannot be imported here.
        """
        cached = self.__dict__.get("_core")
        if cached is None or cached[0] != self.end_effector:  # the core holds its end effector
            from delta_pin.model.core_model import core_model

            cached = self._core = (self.end_effector, core_model(self))
        return cached[1]

    def model_changed(self) -> None:
        """Say that ``model`` was changed in place (its gravity, inertias or armature): the compiled
        model, built from it at first use, is rebuilt at the next, and ``data`` is made afresh.
        (Changing a Pinocchio model's inertias in place is what identification does.)"""
        self.data = self.model.createData()
        self.__dict__.pop("_core", None)

    def _core_forward_kinematics(self, core, alpha: np.ndarray) -> np.ndarray:
        """The end effector's positions (N, 3) at the rows of alpha (N, dof), each assembled by
        the core's Newton warm-started from the one before (a row it does not close: the robot's
        own :meth:`configuration`, which names the worst closure)."""
        out = np.empty((len(alpha), 3))
        q, start = self._last_q, 0
        while start < len(alpha):
            failed, q, out[start:] = core.end_effector_positions(np.ascontiguousarray(alpha[start:]), q)
            if failed < 0:
                break
            k = start + failed  # Newton did not close it from the row before: the robot's own
            q = self.configuration(alpha[k], initial_guess=q)
            out[k] = core.end_effector_position(q)
            start = k + 1
        self._last_q = q.copy()
        return out

    def frame_jacobian(self, q: np.ndarray, frame: str | int | None = None) -> np.ndarray:
        """Closed-loop Jacobian (6, dof) of a frame at a closed q: its [linear; angular] velocity
        (LOCAL_WORLD_ALIGNED) per actuated velocity, J_frame S. The compiled core's."""
        return self._assembling_core().frame_jacobian(self._configuration_vector(q), self._frame(frame))

    def frame_acceleration_drift(
        self, q: np.ndarray, alpha_dot: np.ndarray, frame: str | int | None = None
    ) -> np.ndarray:
        """The frame's classical linear acceleration (3,) [m/s^2] at zero actuated acceleration:
        x_ddot = J_x alpha_ddot + this (the J_dot alpha_dot of a task-space reference). The
        compiled core's."""
        alpha_dot = self._joint_vector(alpha_dot, "alpha_dot")
        return self._assembling_core().frame_acceleration_drift(
            self._configuration_vector(q), alpha_dot, self._frame(frame)
        )

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
        task coordinates than actuators), each iterate assembled from the previous one, in the
        compiled core (its readable twin: ``tests/reference/kinematics.py``); a Delta's platform
        (the default frame, ``axes="xyz"``) in closed form, elbow-out.

        Args:
            position: target world position (3,) [m]; only the ``axes`` components count.
            frame: the frame (the end effector by default).
            axes: the controlled coordinates, e.g. ``"xy"`` for a planar robot.
            initial_guess: start alpha (default: the last assembled configuration's).

        Raises:
            UnreachablePoseError: Newton does not reach the target to ``tol`` [m].
            AssemblyError: an iterate's loops do not close (the worst closure named).
        """
        if self.delta is not None and frame is None and axes == "xyz" and initial_guess is None:
            return self.delta.inverse_kinematics(position)
        rows = [" xyz".index(a) - 1 for a in axes] if axes and set(axes) <= set("xyz") else None
        if rows is None or len(set(rows)) != len(rows):
            raise InvalidParameterError(f"axes={axes!r} must be distinct letters of 'xyz'")
        target = np.asarray(position, dtype=float).reshape(3)
        if not np.isfinite(target).all():
            raise InvalidParameterError(f"{self._label}position={target.tolist()} must be finite [m]")
        fid = self._frame(frame)
        start = self._last_q.copy()
        alpha = (
            start[self.actuated_q_indices]
            if initial_guess is None
            else self._joint_vector(initial_guess, "initial_guess")
        )
        core = self._assembling_core()
        reached, alpha, q = core.inverse_kinematics(
            target, int(fid), np.asarray(rows, dtype=np.int32), alpha, start, float(tol), int(max_iterations)
        )
        if reached:
            self._last_q = q
            return alpha
        if not np.all(np.isfinite(alpha)):  # a singular step: the frame does not move along these axes
            raise UnreachablePoseError(
                f"{self._label}frame {self.model.frames[fid].name!r} cannot be placed along {axes!r} at "
                f"{target.tolist()} m: it does not move along all of {axes!r} there (a singular Jacobian); "
                "give the coordinates it moves along (axes=)"
            )
        q = self.configuration(alpha, initial_guess=q)  # where the loops do not close: AssemblyError, named
        self._last_q = start  # a failed search leaves the assembly mode where it was
        pin.framesForwardKinematics(self.model, self.data, q)
        error = (self.data.oMf[fid].translation - target)[rows]
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
        The file's joint springs are in G (with gravity) and its dampers in C
        (:meth:`joint_spring_forces`), as the plant applies them. The compiled core's (its
        readable twin: ``tests/reference/projection.py``).

        Args:
            q: the closure-consistent configuration of ``alpha`` if already known.
        """
        alpha_dot = self._joint_vector(alpha_dot, "alpha_dot")
        self.require_full_actuation()
        q = self.configuration(alpha) if q is None else self._configuration_vector(q)
        return self._assembling_core().reduced_terms(q, alpha_dot)

    def joint_spring_forces(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The joint springs and dampers (``joint_springs``) as generalized forces the model must
        overcome: (k (q - q_ref) per sprung joint (nv,) [N m or N], the damping matrix D (nv, nv)
        [N m s/rad or N s/m]); the plant applies -k (q - q_ref) - D v. In the reduced model the
        first adds to G, S^T D S to C (so C + C^T = M_dot + 2 S^T D S)."""
        stiffness, damping = np.zeros(self.model.nv), np.zeros(self.model.nv)
        for joint, (k, reference, d) in self.joint_springs.items():
            jid = self.model.getJointId(joint)
            iv, iq, nv = self.model.idx_vs[jid], self.model.idx_qs[jid], self.model.nvs[jid]
            if k:
                stiffness[iv] = k * (q[iq] - reference)
            damping[iv : iv + nv] = d
        return stiffness, np.diag(damping)

    def potential_energy(self, q: np.ndarray) -> float:
        """Gravity's and the joint springs' potential energy at q [J]."""
        springs = sum(
            0.5 * k * (q[self.model.idx_qs[self.model.getJointId(joint)]] - reference) ** 2
            for joint, (k, reference, _) in self.joint_springs.items()
            if k
        )
        return float(pin.computePotentialEnergy(self.model, self.data, q)) + springs

    def require_full_actuation(self) -> None:
        """Raise unless the actuated joints determine the motion (up to idle motions): what every
        controller's reduced model needs.

        Raises:
            InvalidParameterError: passive joints (an underactuated robot, or a free base), named.
        """
        if self.passive_joints:
            free = [
                j
                for j in self.passive_joints
                if self.model.joints[self.model.getJointId(j)].shortname() == "JointModelFreeFlyer"
            ]
            what = f"its base is free ({', '.join(free)})" if free else "it is underactuated"
            raise InvalidParameterError(
                f"{self._label}{what}: passive joint(s) {', '.join(self.passive_joints)} are driven by no "
                "motor, so the actuated joints do not determine its motion and it has no reduced model "
                "for a controller (underactuated); simulate it with a plant and torques of your own, or "
                "name those joints actuated"
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
            "closures": [self._closure_record(c) for c in self.closures],
            "end_effector": self.end_effector_name,
            "passive_joints": list(self.passive_joints),
            "joint_springs": {name: list(values) for name, values in self.joint_springs.items()},
            "idle_dof": self.idle_dof,
            "joint_couplings": [asdict(c) for c in self.joint_couplings],
            "notes": list(self.notes),
        }

    def _closure_record(self, closure: Closure) -> dict:
        """A closure as JSON: enough to rebuild it on the same tree (joint names, placements)."""
        return {
            "name": closure.name,
            "kind": closure.kind,
            "source": closure.source,
            "joint1": self.model.names[closure.joint1],
            "placement1": closure.placement1.homogeneous.tolist(),
            "joint2": self.model.names[closure.joint2],
            "placement2": closure.placement2.homogeneous.tolist(),
        }

    def classification(self, q: np.ndarray | None = None) -> dict:
        """The mobility classification (module docstring, "Mobility") at q (default: the
        reference configuration): joint counts, closure equations and their rank, the actuated
        and passive joints, each idle motion's joints, and cond(J_p) (J_p restricted to its rank)."""
        q = self.reference_configuration if q is None else np.asarray(q, dtype=float)
        J = self.closure_jacobian(q)
        return {
            "joint_velocities": self.model.nv,
            "closure_equations": self.closure_size,
            "independent_closure_equations": _rank(J),
            "mobility": self.model.nv - _rank(J),
            "actuated": list(self.actuated_joints),
            "passive": list(self.passive_joints),
            "idle": [self._joints_of_motion(column) for column in self.idle_motions(q).T],
            "fully_actuated": not self.passive_joints,
            "cond_J_p": self._cond_J_p(J),
        }

    def summary(self, q: np.ndarray | None = None) -> str:
        """A few lines a person reads: the robot, its closures and its mobility classification."""
        c = self.classification(q)
        kinds = ", ".join(
            [
                f"{sum(x.kind == k for x in self.closures)} {'point' if k == '3d' else 'weld'}"
                for k in ("3d", "6d")
                if any(x.kind == k for x in self.closures)
            ]
            + ([f"{len(self.joint_couplings)} joint coupling"] if self.joint_couplings else [])
        )
        idle = "; ".join(" + ".join(joints) for joints in c["idle"]) or "none"
        lines = [
            f"robot {self.name!r}{f' ({self.source})' if self.source else ''}",
            f"  joints: {c['joint_velocities']} velocities; closures: {kinds} "
            f"({c['closure_equations']} equations, {c['independent_closure_equations']} independent)",
            f"  mobility: {c['mobility']} = {self.dof} actuated + {len(self.passive_joint_indices)} "
            f"passive + {self.idle_dof} idle",
            f"  actuated: {', '.join(self.actuated_joints) or 'none'}",
            f"  passive: {', '.join(self.passive_joints) or 'none'}"
            + ("" if c["fully_actuated"] else " (underactuated: no controller takes it)"),
            f"  idle motions: {idle}",
            f"  end effector: {self.end_effector_name}; cond(J_p) = {c['cond_J_p']:.3g} here",
        ]
        lines += [
            f"  coupled: {c.joint1} follows {c.joint2 or 'nothing (held)'} "
            f"(joint coupling {c.name!r}{c.where})"
            for c in self.joint_couplings
        ]
        if self.assembly_gap_at_start > _EXACT_GAP:
            lines.append(
                f"  assembly: the file's pose leaves the loops {self.assembly_gap_at_start:.3g} (m or rad) "
                f"open; closed by the global solve ({self.assembly_starts} start(s)), home = "
                f"{np.round(self.home, 6).tolist()}"
            )
        lines += [f"  note: {note}" for note in self.notes]
        return "\n".join(lines)

    def __repr__(self) -> str:
        kinds = ", ".join(
            [
                f"{sum(c.kind == k for c in self.closures)} {k}"
                for k in ("3d", "6d")
                if any(c.kind == k for c in self.closures)
            ]
            + ([f"{len(self.joint_couplings)} joint"] if self.joint_couplings else [])
        )
        extra = (f", {len(self.passive_joints)} passive" if self.passive_joints else "") + (
            f", {self.idle_dof} idle" if self.idle_dof else ""
        )
        return (
            f"ClosedChainRobot({self.name!r}: {self.model.nv} joints, {self.dof} actuated "
            f"[{', '.join(self.actuated_joints)}]{extra}, closures: {kinds})"
        )
