"""``ClosedChainRobot.configuration`` is the compiled core's Newton; its readable twin
(``tests/reference/assembly.py``) is the oracle, on models it was not built around: Gepetto's
and MuJoCo Menagerie's files as shipped (idle motions, ball joints, passive joints) and the
paper's Delta.

Tolerance: both Newtons stop at a closure gap of 1e-12 (m or rad) from the same start with the
same capped steps; where idle motions leave a null space each takes the minimum-norm step, so the
two configurations may differ along those motions by what the last steps leave, far below 1e-9."""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

import delta_pin as dp
from delta_pin.errors import AssemblyError
from tests.model.corpus_models import corpus_model
from tests.reference.assembly import newton_configuration

AGREE = 1e-9  # [rad or m] the module docstring's bound

MODELS = [
    "gepetto/5bar_linkage",  # an idle motion
    "gepetto/robot_delta",  # three idle spins
    "gepetto/cassie_like",  # two idle motions, 6D closures
    "gepetto/battobot_6d",  # ball joints (quaternions), 12 motors
    "menagerie/robotiq_2f85",  # two named passive joints, MJCF
]


def _robot(model_id: str) -> dp.ClosedChainRobot:
    model = corpus_model(model_id)
    if model.file.suffix == ".xml":
        pytest.importorskip("mujoco")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the warnings a file earns are test_corpus's business
        return dp.load_robot(model.file, **model.kwargs)


def _robots():
    yield "paper Delta", dp.load_delta
    for model_id in MODELS:
        yield model_id, lambda model_id=model_id: _robot(model_id)


@pytest.mark.parametrize(("name", "load"), list(_robots()), ids=[n for n, _ in _robots()])
def test_the_core_assembles_as_its_readable_twin(name, load):
    robot = load()
    rng = np.random.default_rng(7)
    q_home = robot.reference_configuration
    closed = 0
    for _ in range(5):
        alpha = robot.home + rng.uniform(-0.05, 0.05, robot.dof)
        # a start off the loops: every coordinate moved by up to 0.05 (rad or m)
        start = pin.integrate(robot.model, q_home, rng.uniform(-0.05, 0.05, robot.model.nv))
        expected, _, _ = newton_configuration(robot, alpha, start)
        try:
            q = robot.configuration(alpha, initial_guess=start)
        except AssemblyError:
            assert expected is None, "the readable Newton closes where the core's does not"
            continue
        assert expected is not None, "the core's Newton closes where the readable one does not"
        closed += 1
        assert robot.closure_gap(q) <= 1e-12
        np.testing.assert_allclose(q[robot.actuated_q_indices], alpha, atol=0.0)
        assert np.abs(pin.difference(robot.model, expected, q)).max() < AGREE
    assert closed >= 4, f"{name}: only {closed} of 5 small moves assembled"


def test_a_failed_assembly_names_its_worst_closure_as_the_twin_finds_it():
    robot = _robot("gepetto/5bar_linkage")
    alpha = robot.home + np.array([1.5, -1.5])  # the cranks turned apart by 3 rad: the loop cannot close
    q, residual, _ = newton_configuration(robot, alpha, robot.reference_configuration)
    assert q is None and np.abs(residual).max() > 0.1  # 0.31 m apart (measured)
    with pytest.raises(
        AssemblyError, match=r"the loops do not close at alpha=\[1\.5, -1\.5\]: closure '\w+'.* is still "
    ) as caught:
        robot.configuration(alpha, initial_guess=robot.reference_configuration)
    # the gap it reports is the one the readable Newton is left with, to 1 % (the same steps)
    reported = float(str(caught.value).split("is still ")[1].split(" ")[0])
    assert reported == pytest.approx(np.abs(residual).max(), rel=1e-2)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"tol": 0.0}, r"tol=0\.0 must be a finite number > 0"),
        ({"tol": float("nan")}, r"tol=nan must be a finite number > 0"),
        ({"max_iterations": 0}, r"max_iterations=0 must be an integer >= 1"),
        ({"initial_guess": np.zeros(2)}, r"initial_guess has shape \(2,\), expected"),
    ],
)
def test_bad_newton_options_are_one_line(options, message):
    robot = dp.load_delta()
    with pytest.raises(dp.InvalidParameterError, match=message):
        robot.configuration(robot.home, **options)


@pytest.mark.parametrize(("name", "axes"), [("paper Delta", "xyz"), ("gepetto/5bar_linkage", None)])
def test_inverse_kinematics_is_the_twins(name, axes):
    """The core's inverse kinematics (ClosedChainRobot.inverse_kinematics with a frame named, so
    not the Delta's closed form) against tests/reference/kinematics.py from the same start: both
    stop at 1e-12 m, so the actuated coordinates agree to 1e-9 (cond J of the task rows < 1e2
    here); a target off the workspace is refused in one line by both."""
    from tests.reference.kinematics import inverse_kinematics

    robot = dp.load_delta() if name == "paper Delta" else _robot(name)
    frame = robot.end_effector_name
    fid = robot.frame_id(frame)
    pin.framesForwardKinematics(robot.model, robot.data, robot.reference_configuration)
    home = robot.data.oMf[fid].translation.copy()
    if axes is None:  # a planar robot: the two task coordinates its motors move most
        J = robot.frame_jacobian(robot.reference_configuration, fid)[:3]
        axes = "".join(sorted("xyz"[i] for i in np.argsort(-np.linalg.norm(J, axis=1))[: robot.dof]))
    rows = ["xyz".index(a) for a in axes]
    rng = np.random.default_rng(3)
    for _ in range(4):
        target = home.copy()
        target[rows] += rng.uniform(-0.01, 0.01, len(rows))
        start = robot.reference_configuration
        expected = inverse_kinematics(robot, target, fid, rows, robot.home, start)
        robot._last_q = start.copy()
        got = robot.inverse_kinematics(target, frame, axes=axes, initial_guess=robot.home)
        assert expected is not None
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9)
    far = home.copy()
    far[rows[0]] += 10.0  # 10 m away
    assert inverse_kinematics(robot, far, fid, rows, robot.home, robot.reference_configuration) is None
    with pytest.raises((dp.UnreachablePoseError, AssemblyError)) as caught:
        robot.inverse_kinematics(far, frame, axes=axes, initial_guess=robot.home)
    assert "\n" not in str(caught.value)


def test_inverse_kinematics_stops_at_the_closure_floor():
    """A Delta target where the platform's position cannot get within 1e-13 m: the loops' closure is
    solved to its own tolerance, and the frame's position there sits ~3.8e-13 m off (measured; a
    10x-refined Adept path of the time-optimal planner failed on it with 1e-12 m: "1.034e-12 m off
    after 60 Newton steps"). Asked for 1e-13 m, the core and the readable twin stop where Newton
    stops gaining, within 1000x the tolerance, and agree; a target out of reach is still refused."""
    from tests.reference.kinematics import inverse_kinematics

    robot = dp.load_delta()
    fid = robot.end_effector
    target = np.array([5.367171220252431e-05, 0.0, -0.375])
    alpha = robot.inverse_kinematics(target, fid, axes="xyz", initial_guess=robot.home, tol=1e-13)
    reached = robot.frame_placement(robot.configuration(alpha), fid).translation
    assert np.abs(reached - target).max() <= 1e-10
    twin = inverse_kinematics(
        robot, target, fid, [0, 1, 2], robot.home, robot.reference_configuration, tol=1e-13
    )
    assert twin is not None and np.abs(twin - alpha).max() <= AGREE
    with pytest.raises(dp.errors.UnreachablePoseError):
        robot.inverse_kinematics(
            np.array([0.0, 0.0, -0.7]), fid, axes="xyz", initial_guess=robot.home, tol=1e-13
        )
