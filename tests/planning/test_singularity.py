"""Singularity measures (delta_pin.planning.singularity) against the known singular configurations:
the Delta's leg stretched with its arm in line with its forearm (Type I) at the closed-form height
z* = -sqrt((l_a + l_b)^2 - (R - r)^2), and the five-bar's distal links in line (Type II). Each
root is found by minimising the measure along a one-parameter family of actuated values and then
checked geometrically on the configuration, independently of the measure."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.optimize import minimize_scalar

import delta_pin as dp
from delta_pin.errors import InvalidParameterError
from delta_pin.planning.singularity import singularity_measure, workspace_map


def _position(robot, q, frame: str) -> np.ndarray:
    pin.framesForwardKinematics(robot.model, robot.data, q)
    return robot.data.oMf[robot.model.getFrameId(frame)].translation.copy()


def _sine(u: np.ndarray, v: np.ndarray) -> float:
    return float(np.linalg.norm(np.cross(u, v)) / (np.linalg.norm(u) * np.linalg.norm(v)))


def _singular_point(robot, alpha_of, start: float, bracket: tuple[float, float], kind: int):
    """(theta, measure, q) minimising the Type ``kind`` measure over theta in ``bracket``, on the
    assembly branch reached by continuation from theta = ``start``."""
    q = robot.configuration(alpha_of(start), initial_guess=robot.reference_configuration)
    for theta in np.linspace(start, 0.5 * sum(bracket), 40):
        q = robot.configuration(alpha_of(theta), initial_guess=q)
    anchor = q

    def measure(theta: float) -> float:
        m = singularity_measure(robot, robot.configuration(alpha_of(theta), initial_guess=anchor))
        return m.type_one if kind == 1 else m.type_two

    found = minimize_scalar(measure, bounds=bracket, method="bounded", options={"xatol": 1e-12})
    return found.x, found.fun, robot.configuration(alpha_of(found.x), initial_guess=anchor)


def test_the_delta_type_one_locus_is_a_stretched_leg():
    """Along alpha = (t, t, t) the Type I measure vanishes (< 1e-8) where arm and forearm are in line
    (sin of their angle <= 1e-6) and the platform is at the closed-form z* to 1e-6 m."""
    robot = dp.load_delta()
    p = robot.params
    _, value, q = _singular_point(robot, lambda t: np.full(3, t), 0.0, (1.5, 1.9), kind=1)
    assert value < 1e-8
    for leg in (1, 2, 3):
        arm = _position(robot, q, f"elbow_{leg}") - _position(robot, q, f"active_{leg}")
        forearm = _position(robot, q, f"closure_{leg}_1") - _position(robot, q, f"elbow_{leg}")
        assert _sine(arm, forearm) <= 1e-6
    z_star = -np.sqrt((p.l_a + p.l_b) ** 2 - (p.R - p.r) ** 2)
    assert abs(_position(robot, q, "platform")[2] - z_star) <= 1e-6
    assert singularity_measure(robot, q).type_two > 0.01  # a Type I point, not a Type II one


def test_the_five_bar_type_two_locus_has_its_distal_links_in_line():
    """Along alpha = (t, -t) the Type II measure vanishes (< 1e-8) where the two distal links are
    collinear (sin of their angle <= 1e-6): the tip can move with both motors held."""
    robot = dp.load_robot("five_bar", end_effector="tip")
    _, value, q = _singular_point(robot, lambda t: np.array([t, -t]), 0.0, (-0.6, -0.25), kind=2)
    assert value < 1e-8
    d1 = _position(robot, q, "distal_tips_1") - _position(robot, q, "passive_1")
    d2 = _position(robot, q, "distal_tips_2") - _position(robot, q, "passive_2")
    assert _sine(d1, d2) <= 1e-6
    assert singularity_measure(robot, q, axes="xz").type_one > 0.01


def test_a_workspace_map_marks_the_unreachable_and_the_near_singular():
    """The Delta's map at z = -0.55 m: NaN beyond the reachable disc, the measure in (0, 1] inside,
    smallest towards the rim (the legs stretch)."""
    robot = dp.load_delta()
    xs = np.linspace(-0.3, 0.3, 9)
    values = workspace_map(robot, xs, np.array([0.0]), -0.55)[0]
    assert np.isnan(values[0]) and np.isnan(values[-1])
    inside = values[~np.isnan(values)]
    assert inside.size >= 3 and np.all((inside > 0.0) & (inside <= 1.0))
    assert values[4] > np.nanmin(values)  # the centre is farther from a singularity than the rim


def test_bad_axes_are_refused():
    robot = dp.load_delta()
    with pytest.raises(InvalidParameterError, match="axes='xy'"):
        singularity_measure(robot, robot.reference_configuration, axes="xy")
