"""Closed-chain dynamic identification (docs/identification.md): from measured joint data to the
nominal model the controllers use.

* :mod:`~delta_pin.identification.regressor` -- tau_act = Y(alpha, alpha_dot, alpha_ddot) theta,
  Pinocchio's joint-torque regressor projected through the closures, with friction, rotor
  inertia and offset columns;
* :mod:`~delta_pin.identification.base` -- base parameters by QR with column pivoting;
* :mod:`~delta_pin.identification.excitation` -- optimised finite Fourier excitation;
* :mod:`~delta_pin.identification.log` -- the CSV log (read with one-line errors, written atomically);
* :mod:`~delta_pin.identification.estimation` -- filtering, differentiation, OLS and WLS;
* :mod:`~delta_pin.identification.consistent` -- the physically consistent estimate (log-Cholesky);
* :mod:`~delta_pin.identification.workflow` -- ``dp.identify``, simulated logs, validation;
* :mod:`~delta_pin.identification.report` -- parameters.json, report.md and figures.
"""

from delta_pin.identification.workflow import IdentificationResult, identified_robot, identify, validate

__all__ = ["IdentificationResult", "identified_robot", "identify", "validate"]
