"""Simulation: plants, uncertainty, integrators, the Python loop, :func:`~delta_pin.sim.runner.simulate`,
:class:`~delta_pin.sim.run.Run` and :func:`~delta_pin.sim.batch.simulate_batch` (the entry to the
compiled loops). Imports ``control`` and ``model`` (docs/architecture.md section 2)."""
