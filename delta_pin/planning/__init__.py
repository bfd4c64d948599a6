"""Time-optimal, torque-feasible paths for any fully actuated closed chain (docs/planning.md).

- :mod:`~delta_pin.planning.paths`: geometric paths of a frame (:class:`BlendedPath`, the Adept
  cycle's halves :func:`adept_paths`);
- :mod:`~delta_pin.planning.time_optimal`: the time-optimal law under torque and joint velocity
  limits on the projected dynamics, verified on the exact model (:func:`plan_time_optimal`);
- :mod:`~delta_pin.planning.singularity`: the distance to Type I and Type II singularities along
  a path.
"""

from delta_pin.planning.paths import BlendedPath, adept_paths
from delta_pin.planning.time_optimal import PlannedSequence, TimeOptimalPlan, Verification, plan_time_optimal

__all__ = [
    "BlendedPath",
    "PlannedSequence",
    "TimeOptimalPlan",
    "Verification",
    "adept_paths",
    "plan_time_optimal",
]
