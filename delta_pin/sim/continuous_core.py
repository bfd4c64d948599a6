"""The continuous mode in the compiled core (docs/architecture.md section 7), for a closed chain's
plant or the Delta's reduced one.

The plant (:func:`~delta_pin.sim.compiled_plant.build_core_plant`,
:func:`~delta_pin.sim.compiled_plant.build_core_analytic_plant`) and a controller's compiled law
(:meth:`Controller.sampled_core_law <delta_pin.control.base.Controller.sampled_core_law>`) are
integrated as one ODE by the core's Radau IIA of order 5 with error control
(``delta_pin/core/integrate/radau.hpp``; the core's one run, ``delta_pin/core/run/run.hpp``), in
active coordinates

    y = [alpha, alpha_dot, z],   y' = [alpha_dot, alpha_ddot(q(alpha), S alpha_dot, tau, t), z_dot]:

every evaluation assembles q(alpha) by Newton, v = S alpha_dot (a closed chain's), the law's
torque and state rate at the reference of that time, and the plant's dynamics with its truth
(uncertainty profile, payload) interpolated linearly between the rows of a table on the
reference's grid -- the arithmetic of the Python plant in active coordinates, which the tests
hold it to (``tests/reference/python_loop.py``, with LSODA). A closed chain with idle motions or
passive joints is integrated in its whole state instead, y = [q, v, z] with the constrained
dynamics (Baumgarte-stabilised) and the configuration coefficients' rates, projected back onto
the loops every :data:`~delta_pin.sim.integrators.PROJECTION_CHUNK` samples. The samples
t_k = k dt are read from the collocation polynomial of the step that covers them. Python is not
called during the run unless the controller is a Python one.
"""

from __future__ import annotations

import numpy as np

from delta_pin.compiled.core import core
from delta_pin.control.base import Reference
from delta_pin.sim.compiled_plant import keep_core_projections, run_core, set_core_truth
from delta_pin.sim.integrators import MAX_JOINT_SPEED, PROJECTION_CHUNK
from delta_pin.sim.loop import ControlLoop, LoopRecord

__all__ = ["RADAU_FIRST_STEP", "RADAU_MAX_STEP", "PythonLaw", "continuous_core", "run_core_continuous"]

RADAU_FIRST_STEP = 1e-5  # [s]: a run starts in the reaching phase, off the path
RADAU_MAX_STEP = 1e-2  # [s]


class PythonLaw:
    """A controller's own :meth:`~delta_pin.control.base.Controller.evaluate` called from the
    core's continuous loop once per evaluation (with the checks of the sampled loop's
    :class:`~delta_pin.sim.loop.ControlLoop`: a torque of the wrong shape or not finite is a
    :class:`~delta_pin.errors.SimulationError` naming the controller and the time), and its
    internals recorded at the samples."""

    def __init__(self, controller, plant) -> None:
        self.controller = controller
        self._loop = ControlLoop(controller, plant)
        self._last = None
        self.internals: dict[str, list] = {}

    def evaluate(self, t, q, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, z):
        reference = Reference(ref_alpha, ref_alpha_dot, ref_alpha_ddot)
        tau, z_dot, self._last = self._loop.control(t, None, reference, z, (alpha, alpha_dot))
        return tau, z_dot

    def keep(self, k, tau, z) -> None:
        for name, value in self._last.internals.items():
            self.internals.setdefault(name, []).append(np.asarray(value, dtype=float))


def continuous_core(plant, controller) -> tuple[object, object] | None:
    """(the core's plant, the law) for a continuous run of ``plant`` in the core -- the
    controller's compiled law (:meth:`Controller.sampled_core_law
    <delta_pin.control.base.Controller.sampled_core_law>`) or, for any other continuous-time
    controller (a user's own), a :class:`PythonLaw` around it --, or ``None`` where the plant has
    no compiled copy (:meth:`Plant.core_plant <delta_pin.sim.plants.Plant.core_plant>`: a
    plant of the user's, a joint without a configuration rate), the controller is a
    discrete-time law or the plant has no actuated joint. The plant's truth is tabulated when
    the run starts (:func:`run_core_continuous`)."""
    if getattr(controller, "dt", None) is not None:  # a discrete-time law: sampled mode only
        return None
    if plant.dof == 0:  # a mechanism without motors: the core's continuous loop takes dof >= 1
        return None
    compiled_plant = plant.core_plant()  # its truth on the reference's grid, when the run starts
    if compiled_plant is None:
        return None
    make_law = getattr(controller, "sampled_core_law", None)
    law = make_law() if make_law is not None else None
    return compiled_plant, PythonLaw(controller, plant) if law is None else law


def run_core_continuous(
    compiled: tuple[object, object],
    controller,
    plant,
    table,
    alpha0: np.ndarray,
    alpha_dot0: np.ndarray,
    t: np.ndarray,
    rtol: float,
    atol: float,
    bdf2_substeps: int = 0,
) -> tuple[LoopRecord, dict]:
    """Run the compiled plant and law of :func:`continuous_core` from (alpha0 [rad], alpha_dot0
    [rad/s]) over the sample times t [s] by Radau IIA (rtol, atol) or, with ``bdf2_substeps`` > 0,
    by BDF2 with fixed steps dt / bdf2_substeps (``delta_pin/core/integrate/bdf2.hpp``); ``table``: the
    reference with its jerk (cubic Hermite between its rows, as LSODA's; for BDF2 on the step
    grid). Returns the record and the integrator's counters.

    Raises:
        SimulationError: the loops cannot be closed, the state or the torque became non-finite,
            |alpha_dot| exceeded the divergence limit or the step size collapsed (at the time it
            happened).
    """
    core_plant, law = compiled
    module = core()
    controller.reset()
    if isinstance(law, PythonLaw):
        law.internals = {}
    set_core_truth(core_plant, plant, table.step, len(table.alpha))
    reference = module.HermiteReference()
    reference.step = table.step
    reference.alpha, reference.alpha_dot, reference.alpha_ddot, reference.alpha_dddot = (
        np.ascontiguousarray(a) for a in (table.alpha, table.alpha_dot, table.alpha_ddot, table.alpha_dddot)
    )
    settings = module.RunSettings()
    settings.integrator = "bdf2" if bdf2_substeps > 0 else "radau"
    settings.dt, settings.samples = float(t[1] - t[0]), len(t)
    settings.rtol, settings.atol = rtol, atol
    settings.first_step, settings.max_step = RADAU_FIRST_STEP, RADAU_MAX_STEP
    settings.max_joint_speed = MAX_JOINT_SPEED
    settings.substeps, settings.projection_interval = max(bdf2_substeps, 1), PROJECTION_CHUNK
    x0 = plant.initial_state(np.asarray(alpha0, float), np.asarray(alpha_dot0, float))
    if core_plant.has_configuration:  # the core's plant steps the multibody's [q, v]
        x0 = np.concatenate(plant.configuration_state(x0))
    z0 = np.asarray(controller.initial_state(), dtype=float)
    run = run_core(core_plant, law, settings, x0, plant, z0, reference)
    record = LoopRecord(
        alpha=run.alpha, alpha_dot=run.alpha_dot, tau=run.tau, xyz=run.xyz, closure_residual=run.gap
    )
    record.q, record.v = run.q, run.v
    if isinstance(law, PythonLaw):
        record.internals = {name: np.array(values) for name, values in law.internals.items()}
    else:
        record.internals = controller.core_law_internals(law)
    keep_core_projections(plant, core_plant)
    if bdf2_substeps > 0:
        steps, evaluations, split_steps, jacobians = run.bdf2_counters
        counters = {
            "bdf2_steps": int(steps), "rhs_evaluations": int(evaluations), "split_steps": int(split_steps),
            "jacobians": int(jacobians),
        }  # fmt: skip
    else:
        steps, rejected, evaluations, jacobians, factorizations = run.radau_counters
        counters = {
            "radau_steps": int(steps), "radau_rejected": int(rejected), "rhs_evaluations": int(evaluations),
            "jacobians": int(jacobians), "factorizations": int(factorizations),
        }  # fmt: skip
    return record, counters
