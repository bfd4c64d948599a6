"""The robot's Pinocchio model as the core rebuilds it (``ModelSpec``, delta_pin/core/model/
model_spec.hpp; written by ``delta_pin.model.core_model.model_spec``) against the Python model it
came from, on a tree of every joint type the core rebuilds (the corpus itself uses only six of
them), with armature, random gravity and frames of one name.

The rebuilt model is compared through what the core computes with it -- the tree's M, G and C v,
a frame's position and Jacobian -- against the same Pinocchio calls on the Python model. Hostile
ModelSpecs are in tests/sim/test_core_bounds.py.
"""

import numpy as np
import pinocchio as pin
import pytest

from delta_pin.compiled import core
from delta_pin.errors import NativeUnavailableError
from delta_pin.model.core_model import model_spec


def _unit(rng):
    axis = rng.normal(size=3)
    return axis / np.linalg.norm(axis)


def _unbounded_unaligned(axis):
    """A JointModelRevoluteUnboundedUnaligned about `axis`: Python's constructor takes no axis, so
    from a URDF continuous joint, as Pinocchio's parser makes it."""
    urdf = (
        '<robot name="r"><link name="a"/><link name="b"/><joint name="j" type="continuous">'
        f'<parent link="a"/><child link="b"/><axis xyz="{" ".join(map(repr, map(float, axis)))}"/>'
        "</joint></robot>"
    )
    return pin.buildModelFromXML(urdf).joints[1].extract()


def _every_joint(rng):
    """One of each joint type the core rebuilds, with random axes and pitches."""
    composite = pin.JointModelComposite(pin.JointModelRX())
    composite.addJoint(pin.JointModelPrismaticUnaligned(_unit(rng)), pin.SE3.Random())
    composite.addJoint(pin.JointModelSpherical(), pin.SE3.Random())
    return [
        pin.JointModelRX(),
        pin.JointModelRY(),
        pin.JointModelRZ(),
        pin.JointModelRUBX(),
        pin.JointModelRUBY(),
        pin.JointModelRUBZ(),
        pin.JointModelPX(),
        pin.JointModelPY(),
        pin.JointModelPZ(),
        pin.JointModelHX(0.3),
        pin.JointModelHY(-0.2),
        pin.JointModelHZ(0.1),
        pin.JointModelRevoluteUnaligned(_unit(rng)),
        _unbounded_unaligned(_unit(rng)),
        pin.JointModelPrismaticUnaligned(_unit(rng)),
        pin.JointModelHelicalUnaligned(_unit(rng), 0.25),
        pin.JointModelUniversal(np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])),
        pin.JointModelSpherical(),
        pin.JointModelSphericalZYX(),
        pin.JointModelTranslation(),
        pin.JointModelPlanar(),
        composite,
    ]


def _random_tree(rng):
    """A free-flying base carrying every joint type, each on a random earlier joint; random
    placements, inertias, armature and gravity; two operational frames named alike."""
    model = pin.Model()
    model.gravity.linear = rng.normal(size=3) * 5.0
    kinds = _every_joint(rng)
    joints = [pin.JointModelFreeFlyer(), *(kinds[i] for i in rng.permutation(len(kinds)))]
    for i, joint in enumerate(joints, start=1):
        parent = int(rng.integers(0, i))
        placement = pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(scale=0.3, size=3))
        index = model.addJoint(parent, joint, placement, f"joint_{i}")
        model.appendBodyToJoint(index, pin.Inertia.Random(), pin.SE3.Identity())
        model.addJointFrame(index)
    for joint in (model.njoints - 1, 3):
        model.addFrame(pin.Frame("tool", joint, 0, pin.SE3.Random(), pin.FrameType.OP_FRAME), False)
    model.armature = rng.uniform(0.0, 0.05, size=model.nv)
    return model


def _symmetric(upper):
    return np.triu(upper) + np.triu(upper, 1).T


def test_the_rebuilt_model_computes_what_the_python_model_computes(rng):
    """On every joint type, at random states: the core's M, G and C v (ClosedChainModel.reduced_terms
    with every joint actuated and no closure: the tree's own) against pin.crba,
    pin.computeGeneralizedGravity and pin.computeCoriolisMatrix; a frame's
    position and Jacobian against Pinocchio's, for each of two frames named alike (addFrame would
    merge them; both keep their indices). 1e-12 relative to each quantity's largest entry: the same
    library arithmetic on a model rebuilt from the same numbers (measured ~1e-15, the rotations'
    round trip through 12 floats). The armature is the core's too: without it M differs."""
    try:
        module = core.core()
    except NativeUnavailableError as exc:
        pytest.skip(str(exc))
    for trial in range(3):
        model = _random_tree(rng)
        assert {j.shortname() for j in model.joints} >= {
            "JointModelComposite",
            "JointModelUniversal",
            "JointModelHelicalUnaligned",
            "JointModelRevoluteUnboundedUnaligned",
        }
        data = model.createData()
        bare = model.copy()
        bare.armature[:] = 0.0
        everything = np.arange(model.nv, dtype=np.int32)
        for tool in (model.nframes - 2, model.nframes - 1):
            chain = module.ChainDescription(
                model_spec(model), [], [], everything, everything, np.zeros(0, np.int32), 0, tool
            )
            rebuilt = module.ClosedChainModel(chain)
            for _ in range(3):
                q = pin.integrate(model, pin.neutral(model), rng.normal(size=model.nv))
                v = rng.normal(size=model.nv)
                M, _, G, Cv = rebuilt.reduced_terms(q, v)
                expected_M = _symmetric(pin.crba(model, data, q))
                expected_G = pin.computeGeneralizedGravity(model, data, q).copy()
                # Pinocchio 4.1's computeCoriolisMatrix gives a C v that differs from
                # rnea(q, v, 0) - G on joints whose motion subspace turns with q (Universal,
                # SphericalZYX, Composite: ~1 N m measured), so for such a tree the core takes its
                # C alpha_dot from the RNEA: compared with nle - G
                expected_Cv = pin.nonLinearEffects(model, data, q, v) - expected_G
                for got, expected, name in (
                    (M, expected_M, "M"),
                    (G, expected_G, "G"),
                    (Cv, expected_Cv, "C v"),
                ):
                    scale = np.abs(expected).max()
                    np.testing.assert_allclose(
                        got, expected, rtol=0, atol=1e-12 * scale, err_msg=f"{name}, trial {trial}"
                    )
                without = _symmetric(pin.crba(bare, bare.createData(), q))
                assert np.abs(M - without).max() > 1e-3 * np.abs(model.armature).max()
                pin.computeJointJacobians(model, data, q)
                pin.framesForwardKinematics(model, data, q)
                np.testing.assert_allclose(
                    rebuilt.end_effector_position(q), data.oMf[tool].translation, rtol=0, atol=1e-12
                )
                J = pin.getFrameJacobian(model, data, tool, pin.LOCAL_WORLD_ALIGNED)
                np.testing.assert_allclose(
                    rebuilt.frame_jacobian(q, tool), J, rtol=0, atol=1e-12 * np.abs(J).max()
                )


def test_the_core_plant_takes_a_joint_without_a_configuration_rate(rng):
    """A free base carrying a universal joint, ZYX Euler angles and a revolute: the universal and
    ZYX joints have no configuration rate the core writes, and the compiled plant is built all the
    same (it steps such a chain in active coordinates). Its accelerations on Pinocchio's
    constraintDynamics without a closure equal pin.aba to 1e-10 relative (the same library's
    dynamics with no constraint row; measured ~1e-15), and a derivative of the whole state, which
    would need those rates, is refused in one line naming the joint. (The tree of every joint type
    above is not used: on it Pinocchio 4.1's aba and crba disagree by ~10 m/s^2 themselves.)"""
    try:
        module = core.core()
    except NativeUnavailableError as exc:
        pytest.skip(str(exc))
    model = pin.Model()
    joints = [
        pin.JointModelFreeFlyer(),
        pin.JointModelUniversal(np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])),
        pin.JointModelSphericalZYX(),
        pin.JointModelRX(),
    ]
    for i, joint in enumerate(joints, start=1):
        placement = pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(scale=0.3, size=3))
        index = model.addJoint(i - 1, joint, placement, f"joint_{i}")
        model.appendBodyToJoint(index, pin.Inertia.Random(), pin.SE3.Identity())
        model.addJointFrame(index)
    everything = np.arange(model.nv, dtype=np.int32)
    chain = module.ChainDescription(
        model_spec(model), [], [], everything, everything, np.zeros(0, np.int32), 0, model.nframes - 1
    )
    plant = module.ClosedChainPlant(chain, [], 400.0, 40.0, 1e-12, 0.0, 100, 1e-10)
    plant.use_axis_tree(False)
    q = pin.integrate(model, pin.neutral(model), rng.normal(size=model.nv))
    v, tau = rng.normal(size=model.nv), rng.normal(size=model.nv)
    expected = pin.aba(model, model.createData(), q, v, tau)
    got = plant.accelerations(q, v, tau, 0.0)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-10 * np.abs(expected).max())
    with pytest.raises(ValueError, match=r"joint joint_2 \(JointModelUniversal\) has no configuration rate"):
        plant.derivative(np.concatenate([q, v]), tau, 0.0)
