"""Blended pick-and-place paths (delta_pin.planning.paths): their derivatives against finite
differences, C^2 continuity at the blends' ends, and hostile corners refused in one line."""

from __future__ import annotations

import numpy as np
import pytest

from delta_pin.errors import InvalidParameterError
from delta_pin.model.trajectory import AdeptCycle
from delta_pin.planning import BlendedPath, adept_paths


def _inside_pieces(path: BlendedPath, count: int, seed: int = 0) -> np.ndarray:
    """Random s inside the pieces, 1e-4 m clear of their ends (where x''' jumps)."""
    rng = np.random.default_rng(seed)
    starts, ends = path._starts[:-1], path._starts[1:]
    k = rng.integers(0, len(starts), count)
    return starts[k] + 1e-4 + rng.random(count) * (ends[k] - starts[k] - 2e-4)


@pytest.mark.parametrize("space", ["task", "joints"])
def test_derivatives_match_central_differences_within_their_error_estimate(space):
    """x'(s) and x''(s) against central differences at h and h/2: the difference is held to 10x the
    Richardson estimate |D_h - D_{h/2}| (the O(h^2) error of D_{h/2} is ~1/3 of it) plus round-off
    (1e-7 of the value: eps / h^2 with h = 1e-4 for the second derivative)."""
    if space == "task":
        path = adept_paths(blend=0.01)[0]
    else:
        corners = [[0.0, 0.0, 0.1, 0.0], [0.2, 0.1, 0.0, 0.0], [0.3, -0.1, 0.2, 0.1], [0.1, 0.0, 0.0, 0.3]]
        path = BlendedPath(corners, 0.03, space="joints")
    s = _inside_pieces(path, 200)
    for order, (f, df) in enumerate(((path.position, path.velocity), (path.velocity, path.acceleration)), 1):
        exact = df(s)
        estimates = []
        for h in (1e-4, 5e-5):
            estimates.append((f(s + h) - f(s - h)) / (2 * h))
        error = np.abs(estimates[1] - exact)
        bound = 10 * np.abs(estimates[0] - estimates[1]) + 1e-7 * (1 + np.abs(exact))
        assert np.all(error <= bound), (
            f"order {order}: worst {error.max():.3g} against {bound[np.argmax(error / bound)]:.3g}"
        )


def test_the_path_is_c2_and_unit_speed_where_a_blend_meets_a_line():
    """At each piece boundary x, x' and x'' are continuous: their values 1e-12 m either side agree
    to 1e-9 (x'' to 1e-6: it moves by x''' ~ 1e5 1/m^2 times 1e-12 m inside a 10 mm blend), and
    |x'| = 1 there (s is the arc length on the lines)."""
    path = adept_paths(blend=0.01)[0]
    for boundary in path._starts[1:-1]:
        left, right = boundary - 1e-12, boundary + 1e-12
        for f, atol in ((path.position, 1e-9), (path.velocity, 1e-9), (path.acceleration, 1e-6)):
            assert np.allclose(f(left), f(right), atol=atol), (boundary, f.__name__)
        assert abs(np.linalg.norm(path.velocity(boundary)) - 1.0) < 1e-9
    assert np.allclose(path.position(0.0), AdeptCycle().pick_point) and np.allclose(
        path.position(path.length), AdeptCycle().place_point
    )
    assert np.allclose(path.velocity(0.0), [0.0, 0.0, 1.0])  # straight up from the pick point


@pytest.mark.parametrize(
    ("corners", "blend", "space", "named"),
    [
        ([[0.0, 0.0, 0.0]], 0.01, "task", "corners must be"),
        ([[0.0, 0.0, 0.0], [np.nan, 0.0, 0.0]], 0.01, "task", "non-finite"),
        ([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], 0.01, "task", "coincide"),
        ([[0.0, 0.0, 0.0], [0.0, 0.0, 0.02], [0.3, 0.0, 0.02]], 0.01, "task", "too long"),
        ([[0.0, 0.0, 0.0], [0.0, 0.0, 0.1], [0.0, 0.0, 0.0]], 0.01, "task", "turns back"),
        ([[0.0, 0.0], [1.0, 0.0]], 0.01, "task", "corners must be"),
        ([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], -0.01, "task", "blend=-0.01"),
        ([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], 0.01, "cartesian", "space='cartesian'"),
    ],
)
def test_bad_corners_are_one_line_naming_the_value(corners, blend, space, named):
    with pytest.raises(InvalidParameterError) as error:
        BlendedPath(corners, blend, space=space)
    assert named in str(error.value) and "\n" not in str(error.value)
