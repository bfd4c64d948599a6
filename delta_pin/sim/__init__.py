"""Simulation: plants, uncertainty, the loops of the compiled core and their Python side,
:func:`~delta_pin.sim.runner.simulate`, :class:`~delta_pin.sim.run.Run` and
:func:`~delta_pin.sim.batch.simulate_batch`. Imports ``control`` and ``model`` (docs/architecture.md
section 2)."""
