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

__all__ = ["core_chain", "core_friction", "core_model", "core_refusal", "core_springs", "model_spec"]


def _placements(placements) -> np.ndarray:
    """(n, 12): each placement's rotation by rows, then its translation [m]."""
    rows = [np.concatenate([p.rotation.reshape(9), p.translation]) for p in placements]
    return np.asarray(rows, dtype=float).reshape(len(rows), 12)


def _joint_spec(module, joint):
    """The core's ``JointSpec`` of one Pinocchio joint model (its type, axes, pitch, parts)."""
    concrete = joint.extract() if hasattr(joint, "extract") else joint
    spec = module.JointSpec()
    spec.type = concrete.shortname()
    for field, attribute in (("axis", "axis"), ("axis", "axis1"), ("axis2", "axis2"), ("pitch", "pitch")):
        if hasattr(concrete, attribute):
            setattr(spec, field, getattr(concrete, attribute))
    if spec.type == "JointModelRevoluteUnboundedUnaligned":  # Python exposes no axis: S's angular part
        data, q = concrete.createData(), np.zeros(concrete.idx_q + 2)
        q[concrete.idx_q] = 1.0
        concrete.calc(data, q)
        spec.axis = np.asarray(data.S).reshape(6)[3:]
    if spec.type == "JointModelComposite":
        spec.parts = [_joint_spec(module, part) for part in concrete.joints]
        spec.part_placements = _placements(concrete.jointPlacements)
    return spec


def model_spec(model):
    """The core's ``ModelSpec`` of a Pinocchio model (model_spec.hpp): what the core's algorithms
    read of it -- joints, parents, placements, inertias, frames, gravity, armature -- rebuilt there
    with ``Model::addJoint``.

    Raises:
        NativeUnavailableError: the core cannot be imported here.
    """
    from delta_pin.compiled.core import core

    module = core()
    spec = module.ModelSpec()
    spec.joints = [_joint_spec(module, model.joints[j]) for j in range(1, model.njoints)]
    spec.joint_names = list(model.names)[1:]
    spec.parents = np.asarray(model.parents[1:], dtype=np.int32)
    spec.placements = _placements(model.jointPlacements[1:])
    spec.inertias = np.asarray(
        [[i.mass, *i.lever, *np.asarray(i.inertia).reshape(9)] for i in model.inertias], dtype=float
    ).reshape(model.njoints, 13)
    frames = list(model.frames)[1:]
    spec.frame_names = [f.name for f in frames]
    spec.frame_joints = np.asarray([f.parentJoint for f in frames], dtype=np.int32)
    spec.frame_parents = np.asarray([f.parentFrame for f in frames], dtype=np.int32)
    spec.frame_types = np.asarray([int(f.type) for f in frames], dtype=np.int32)
    spec.frame_placements = _placements(f.placement for f in frames)
    spec.gravity = np.asarray(model.gravity.vector, dtype=float)
    spec.armature = np.asarray(model.armature, dtype=float)
    return spec


def core_springs(robot, damping: bool = True):
    """The core's ``JointSprings`` of ``robot.joint_springs``: springs (and their dampers) on
    1-DOF joints, dampers alone on the others' every entry of v (``damping=False``: the dampers'
    coefficients 0, the springs kept).

    Raises:
        NativeUnavailableError: the core cannot be imported here.
    """
    from delta_pin.compiled.core import core

    model = robot.model
    springs = [(model.getJointId(n), k, ref, d) for n, (k, ref, d) in robot.joint_springs.items()]
    one = [spring for spring in springs if model.nvs[spring[0]] == 1]
    many = [(j, d) for j, _, _, d in springs if model.nvs[j] != 1]
    out = core().JointSprings()
    out.q_index = np.array([model.idx_qs[j] for j, *_ in one], dtype=np.int32)
    out.v_index = np.array([model.idx_vs[j] for j, *_ in one], dtype=np.int32)
    out.k = np.array([k for _, k, _, _ in one], dtype=float)
    out.ref = np.array([r for _, _, r, _ in one], dtype=float)
    out.d = np.array([d if damping else 0.0 for *_, d in one], dtype=float)
    out.damper_v = np.array(
        [model.idx_vs[j] + k for j, _ in many for k in range(model.nvs[j])], dtype=np.int32
    )
    out.damper_d = np.array(
        [d if damping else 0.0 for j, d in many for _ in range(model.nvs[j])], dtype=float
    )
    return out


def core_chain(robot, springs=None):
    """The core's ``ChainDescription`` of ``robot`` (closed_chain.hpp): its model (:func:`model_spec`), the
    closure frames, the joint couplings, the actuated joints' entries in q and v, the dependent
    joints' entries in v, the number of idle motions, the end-effector frame and the joint springs
    (``springs``: a ``JointSprings``; default :func:`core_springs` of the robot).

    Raises:
        NativeUnavailableError: the core cannot be imported here.
    """
    from delta_pin.compiled.core import core

    couplings = [  # (q1, v1, q2, v2 entries, references [rad or m], polynomial coefficients)
        (*map(int, (q1, v1, q2, v2)), c.reference1, c.reference2, np.asarray(c.coefficients, float))
        for c, q1, v1, q2, v2 in robot._couplings
    ]
    return core().ChainDescription(
        model_spec(robot.model),
        [(int(f1), int(f2), int(size)) for f1, f2, size in robot._frames],
        couplings,
        np.asarray(robot.actuated_q_indices, dtype=np.int32),
        np.asarray(robot.actuated_indices, dtype=np.int32),
        np.asarray(robot.dependent_indices, dtype=np.int32),
        int(robot.idle_dof),
        int(robot.end_effector),
        core_springs(robot) if springs is None else springs,
    )


def core_model(robot):
    """The core's ``ClosedChainModel`` of ``robot``, or ``None`` for a model it refuses
    (:func:`core_refusal` says why).

    Raises:
        NativeUnavailableError: the core cannot be imported here.
    """
    from delta_pin.compiled.core import core

    module = core()
    try:
        return module.ClosedChainModel(core_chain(robot))
    except (ValueError, RuntimeError):
        return None


def core_refusal(robot) -> str:
    """Why the core refuses ``robot``'s model, in its one line (``""`` where it takes it).

    Raises:
        NativeUnavailableError: the core cannot be imported here.
    """
    from delta_pin.compiled.core import core

    try:
        core().ClosedChainModel(core_chain(robot))
    except (ValueError, RuntimeError) as exc:
        return str(exc)
    return ""


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
