"""The names a user chooses among (controllers, paths, modes, integrators, encoder velocities):
one home, importing nothing, so that ``delta-pin ... --help`` lists them without loading SciPy
or Pinocchio. The modules that implement each choice import their tuple from here."""

from __future__ import annotations

__all__ = [
    "CONTROLLERS",
    "INTEGRATORS",
    "INTEGRATOR_CHOICES",
    "MODES",
    "PATHS",
    "SHIPPED_ROBOT_NAMES",
    "VELOCITIES",
]

CONTROLLERS = ("design1", "design2", "lqr", "ctc", "pd", "tdc", "digital-robust", "pid")  # control.registry
PATHS = ("I", "II", "adept")  # path I (eq. 66), path II (eq. 69), the Adept pick-and-place cycle
MODES = ("sampled", "continuous")  # sim.arguments
INTEGRATORS = ("rk4", "bdf2", "radau")  # the compiled core's: rk4 sampled, bdf2 and radau continuous
INTEGRATOR_CHOICES = ("auto", *INTEGRATORS)  # what RunSpec and the CLI accept
VELOCITIES = ("difference", "none", "exact")  # what an encoder gives as velocity (sim.drive)
SHIPPED_ROBOT_NAMES = (
    "five_bar",
    "three_rrr",
    "three_rrr_mjcf",
    "delta_mjcf",
    "delta_gepetto",
    "stewart",
    "stewart_mjcf",
    "delta_ballrods",
)  # model.loaders
