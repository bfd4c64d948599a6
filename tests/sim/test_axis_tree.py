"""The core's own recursive stage for trees of axis joints (delta_pin/core/model/axis_tree.hpp, the
accelerations of ``ClosedChainPlant`` where it applies) against Pinocchio's constraintDynamics on
random trees, and the core's import checks.

The Delta's case (its projections, friction, truth) is in tests/sim/test_core_plant.py; here the
stage meets trees the Delta does not exercise: every axis joint type, branches, a closure between
branches with a common ancestor and one to the world, random gravity and Baumgarte gains.
"""

import numpy as np
import pinocchio as pin
import pytest

from delta_pin.compiled import core
from delta_pin.errors import NativeUnavailableError
from delta_pin.model.core_model import model_spec

# joints 1-5: a chain; 6-9: a second chain off joint 1; 10: a side branch off joint 6 (depth-first
# order, as Pinocchio's algorithms need it)
RANDOM_TREE_PARENTS = (0, 1, 2, 3, 4, 1, 6, 7, 8, 6)


def _random_axis_tree(rng):
    """A tree of the six axis joint types (each used, in random order) with random placements,
    inertias and gravity, closed by two point closures (6 rows on 10 DOF)."""
    model = pin.Model()
    model.gravity.linear = rng.normal(size=3) * 5.0
    kinds = [
        pin.JointModelRX,
        pin.JointModelRY,
        pin.JointModelRZ,
        pin.JointModelPX,
        pin.JointModelPY,
        pin.JointModelPZ,
    ]
    order = rng.permutation(len(RANDOM_TREE_PARENTS)) % len(kinds)
    for i, parent in enumerate(RANDOM_TREE_PARENTS, start=1):
        placement = pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(scale=0.3, size=3))
        joint = model.addJoint(parent, kinds[order[i - 1]](), placement, f"joint_{i}")
        inertia = pin.Inertia.Random()
        inertia.mass = rng.uniform(0.1, 2.0)
        model.appendBodyToJoint(joint, inertia, pin.SE3.Identity())
    anchors = [pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(scale=0.2, size=3)) for _ in range(4)]
    closures = [(5, anchors[0], 9, anchors[1]), (4, anchors[2], 0, anchors[3])]
    return model, closures


def _core_plant(module, model, closures, gains):
    """The core's ClosedChainPlant of a bare tree: every joint actuated (the kinematic index sets
    serve no purpose here), the exact KKT solution asked for (proximal mu = 0)."""
    everything = np.arange(model.nv, dtype=np.int32)
    constraints = [
        (3, j1, p1.homogeneous, j2, p2.homogeneous, int(pin.ReferenceFrame.LOCAL))
        for j1, p1, j2, p2 in closures
    ]
    chain = module.ChainDescription(
        model_spec(model), [], [], everything, everything, np.zeros(0, dtype=np.int32), 0, 0
    )
    return module.ClosedChainPlant(chain, constraints, *gains, 1e-12, 0.0, 1, 1.0)


def test_the_axis_tree_stage_on_random_trees_of_every_axis_joint(rng):
    """At random (unclosed) states and torques, against pin.constraintDynamics called from Python:
    1e-10 relative (measured up to ~1e-13; random inertias and placements make M and the Delassus
    matrix less well conditioned than the Delta's, hence the bound looser than its 1e-12). The
    core's own constraintDynamics (use_axis_tree(False)) is the same library call: 1e-12."""
    try:
        module = core.core()
    except NativeUnavailableError as exc:
        pytest.skip(str(exc))
    worst = 0.0
    for trial in range(8):
        model, closures = _random_axis_tree(rng)
        gains = (rng.uniform(0.0, 500.0), rng.uniform(0.0, 50.0))
        models, datas = pin.StdVec_RigidConstraintModel(), pin.StdVec_RigidConstraintData()
        for j1, p1, j2, p2 in closures:
            closure = pin.RigidConstraintModel(
                pin.ContactType.CONTACT_3D, model, j1, p1, j2, p2, pin.ReferenceFrame.LOCAL
            )
            closure.setBaumgarteCorrectorParameters(pin.BaumgarteCorrectorParameters(*gains))
            models.append(closure)
            datas.append(closure.createData())
        data = model.createData()
        pin.initConstraintDynamics(model, data, models, datas)
        axis, library = (
            _core_plant(module, model, closures, gains),
            _core_plant(module, model, closures, gains),
        )
        library.use_axis_tree(False)
        assert (axis.stage, library.stage) == ("axis_tree", "constraint_dynamics")
        for _ in range(5):
            q, v = rng.normal(size=model.nq), 2.0 * rng.normal(size=model.nv)
            tau = 3.0 * rng.normal(size=model.nv)
            expected = pin.constraintDynamics(
                model, data, q, v, tau, models, datas, pin.ProximalSettings(1e-12, 0.0, 1)
            ).copy()
            scale = np.abs(expected).max()
            got = axis.accelerations(q, v, tau, 0.0)
            np.testing.assert_allclose(
                got, expected, rtol=1e-10, atol=1e-10 * scale, err_msg=f"trial {trial}"
            )
            np.testing.assert_allclose(
                library.accelerations(q, v, tau, 0.0), expected, rtol=1e-12, atol=1e-12 * scale
            )
            worst = max(worst, np.abs(got - expected).max() / scale)
    assert worst > 0.0  # a different implementation: not the same arithmetic


def test_a_core_built_against_another_pinocchio_is_refused_in_one_line(monkeypatch):
    """The core links the libpinocchio_default it was compiled against: another installed
    Pinocchio is named with the rebuild command, not left to crash later."""
    try:
        from delta_pin.compiled import _core
    except ImportError as exc:
        pytest.skip(f"the compiled core is not built here: {exc}")
    core.core.cache_clear()
    monkeypatch.setattr(_core, "pinocchio_version", "0.0.1")
    try:
        with pytest.raises(NativeUnavailableError) as error:
            core.core()
        message = str(error.value)
        assert "Pinocchio 0.0.1" in message and pin.__version__ in message and "pip install" in message
        assert "\n" not in message
    finally:
        core.core.cache_clear()
