"""Geometric paths of a frame for time-optimal planning: a polyline whose corners are blended.

A planner needs the path without its timing: x(s) with its derivatives x'(s) = dx/ds and
x''(s) = d^2x/ds^2 along a parameter s [m]. :class:`BlendedPath` is the pick-and-place path of
industrial controllers: straight segments between corner points, every interior corner replaced
by a quintic blend that leaves the incoming segment and joins the outgoing one with the same
position, tangent and zero curvature (the path is C^2: x'' is continuous, so the torque a
time-optimal law needs has no step at a blend's ends). On the segments s is the arc length; on a
blend it is the blend's chord parameter (|x'| = 1 at its ends, up to ~1.26 inside a 90 degree
blend).

It is a :class:`~delta_pin.model.trajectory.Trajectory` whose "time" is s: ``position(s)``,
``velocity(s)`` = x'(s), ``acceleration(s)`` = x''(s), so that a
:class:`~delta_pin.model.frame_path.FramePath` maps it to the actuated joints of any closed chain
(alpha(s), alpha'(s), alpha''(s) by the core's closed-loop inverse kinematics).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from delta_pin.errors import InvalidParameterError
from delta_pin.model.trajectory import AdeptCycle, Trajectory, _vectorised

__all__ = ["BlendedPath", "adept_paths"]


def _quintic_blend(u: np.ndarray) -> tuple[np.ndarray, ...]:
    """The quintic Hermite basis on u in [0, 1] for end values, end first derivatives and zero
    end second derivatives: (h0, h1, g0, g1) and their first and second derivatives in u, with
    p(u) = h0 p0 + h1 p1 + g0 v0 + g1 v1 (v: dp/du at the ends)."""
    u2, u3, u4, u5 = u * u, u**3, u**4, u**5
    h1 = 10 * u3 - 15 * u4 + 6 * u5
    h0 = 1 - h1
    g0 = u - 6 * u3 + 8 * u4 - 3 * u5
    g1 = -4 * u3 + 7 * u4 - 3 * u5
    dh1 = 30 * u2 - 60 * u3 + 30 * u4
    dg0 = 1 - 18 * u2 + 32 * u3 - 15 * u4
    dg1 = -12 * u2 + 28 * u3 - 15 * u4
    ddh1 = 60 * u - 180 * u2 + 120 * u3
    ddg0 = -36 * u + 96 * u2 - 60 * u3
    ddg1 = -24 * u + 84 * u2 - 60 * u3
    return (h0, h1, g0, g1), (-dh1, dh1, dg0, dg1), (-ddh1, ddh1, ddg0, ddg1)


class BlendedPath(Trajectory):
    """Straight segments through ``corners`` (K, D), each interior corner blended over ``blend``
    on either side (at most 0.45 of the shorter adjacent segment): the path from the first corner
    to the last, parametrised by s in [0, :attr:`length`] (module docstring). ``space``:
    ``"task"`` -- corners are a frame's positions (D = 3) [m] --, or ``"joints"`` -- corners are
    the actuated joints' values (D = the robot's actuators) [rad or m], a path the planner takes
    as alpha(s) itself.

    Raises:
        InvalidParameterError: fewer than 2 corners, a non-finite one, two equal consecutive
            corners, a blend < 0 or too long for its segments, a path that turns back on itself
            (a corner of 180 degrees: a blend cannot turn there).
    """

    name = "blended path"

    def __init__(self, corners: Sequence[Sequence[float]], blend: float = 0.01, space: str = "task") -> None:
        if space not in ("task", "joints"):
            raise InvalidParameterError(f"space={space!r} must be 'task' or 'joints'")
        points = np.asarray(corners, dtype=float)
        width = 3 if space == "task" else (points.shape[1] if points.ndim == 2 else -1)
        if points.ndim != 2 or points.shape[1] != width or len(points) < 2 or width < 1:
            expected = "(K >= 2, 3) positions [m]" if space == "task" else "(K >= 2, actuators) joint values"
            raise InvalidParameterError(f"corners must be {expected}, got shape {points.shape}")
        self.space = space
        if not np.all(np.isfinite(points)):
            raise InvalidParameterError(f"corners hold a non-finite number: {points.tolist()}")
        if not (math.isfinite(blend) and blend >= 0.0):
            raise InvalidParameterError(f"blend={blend!r} must be a finite distance >= 0 [m]")
        moves = np.diff(points, axis=0)
        lengths = np.linalg.norm(moves, axis=1)
        if np.any(lengths <= 1e-12):
            k = int(np.argmax(lengths <= 1e-12))
            raise InvalidParameterError(f"corners {k} and {k + 1} coincide at {points[k].tolist()}")
        directions = moves / lengths[:, None]
        for k in range(1, len(points) - 1):
            if blend > 0.45 * min(lengths[k - 1], lengths[k]):
                raise InvalidParameterError(
                    f"blend={blend:g} m is too long for corner {k}: at most 0.45 of its shorter segment, "
                    f"{0.45 * min(lengths[k - 1], lengths[k]):.4g} m"
                )
            if blend > 0.0 and float(directions[k - 1] @ directions[k]) < -1.0 + 1e-9:
                raise InvalidParameterError(
                    f"the path turns back on itself at corner {k}: no blend can turn there"
                )
        self.corners, self.blend = points, float(blend)
        # the pieces in order: ("line", start, direction, length) or ("blend", p0, p1, v0, v1, length)
        pieces: list[tuple] = []
        start = points[0]
        for k in range(len(points) - 1):
            end = points[k + 1] - (blend * directions[k] if k + 1 < len(points) - 1 else 0.0)
            span = float(np.linalg.norm(end - start))
            if span > 0.0:
                pieces.append(("line", start, directions[k], span))
            if k + 1 < len(points) - 1 and blend > 0.0:
                after = points[k + 1] + blend * directions[k + 1]
                chord = float(np.linalg.norm(after - end))
                # unit speed at both ends: dp/du = chord * direction
                pieces.append(("blend", end, after, chord * directions[k], chord * directions[k + 1], chord))
                start = after
            else:
                start = end
        self._pieces = pieces
        self._starts = np.concatenate([[0.0], np.cumsum([p[-1] for p in pieces])])
        self.length = float(self._starts[-1])  # [m] of s
        self.duration = self.length  # the "time" of a Trajectory is s here

    def _evaluate(self, s: np.ndarray, order: int) -> np.ndarray:
        s = np.clip(s, 0.0, self.length)
        k = np.clip(np.searchsorted(self._starts, s, side="right") - 1, 0, len(self._pieces) - 1)
        out = np.zeros((len(s), self.corners.shape[1]))
        for index in np.unique(k):
            rows = k == index
            piece = self._pieces[index]
            local = s[rows] - self._starts[index]
            if piece[0] == "line":
                _, start, direction, _ = piece
                out[rows] = (
                    start + local[:, None] * direction if order == 0 else direction if order == 1 else 0.0
                )
                continue
            _, p0, p1, v0, v1, chord = piece
            basis = _quintic_blend(local / chord)[order]
            scale = chord**-order  # d/ds = (1 / chord) d/du
            out[rows] = scale * (
                basis[0][:, None] * p0
                + basis[1][:, None] * p1
                + basis[2][:, None] * v0
                + basis[3][:, None] * v1
            )
        return out

    @_vectorised
    def position(self, s: np.ndarray) -> np.ndarray:
        return self._evaluate(s, 0)

    @_vectorised
    def velocity(self, s: np.ndarray) -> np.ndarray:
        """x'(s) = dx/ds (dimensionless)."""
        return self._evaluate(s, 1)

    @_vectorised
    def acceleration(self, s: np.ndarray) -> np.ndarray:
        """x''(s) = d^2x/ds^2 [1/m]."""
        return self._evaluate(s, 2)

    def metadata(self) -> dict[str, Any]:
        return {
            **super().metadata(), "corners": self.corners.tolist(), "blend": self.blend,
            "length": self.length, "space": self.space,
        }  # fmt: skip


def adept_paths(cycle: AdeptCycle | None = None, blend: float = 0.01) -> tuple[BlendedPath, BlendedPath]:
    """The two halves of an Adept cycle (``cycle``: its pick and place points, height; the
    standard 25 mm up, 305 mm across at z = -0.40 m by default) as blended paths, A -> B and
    B -> A, each from rest to rest at a pick or place point; ``blend`` [m] at the four top
    corners of each half (the vertical moves are 25 mm long, so at most 11 mm)."""
    cycle = AdeptCycle() if cycle is None else cycle
    up = np.array([0.0, 0.0, cycle.height])
    A, B = cycle.pick_point, cycle.place_point
    there = BlendedPath([A, A + up, B + up, B], blend)
    back = BlendedPath([B, B + up, A + up, A], blend)
    there.name, back.name = "Adept cycle A -> B", "Adept cycle B -> A"
    return there, back
