"""Private: the compiled layer (the C++ core, and the numba BDF2 loop that is moving into it).

Nothing here is public API: ``delta_pin.sim``, ``delta_pin.control`` and ``delta_pin.model`` call
it with plain numbers and arrays (and, for the numba loop only, the named records of
:mod:`delta_pin.compiled.layouts`), never with delta-pin objects, so this package imports nothing
from the layers above it (docs/architecture.md sections 2 and 8). Its entry points:

* :mod:`delta_pin.compiled.core` -- the compiled core (``delta_pin/core/``, nanobind): the plants,
  the sampled and continuous loops and the compiled laws;
* :func:`delta_pin.compiled.closed_loop.run_closed_loop` -- the numba BDF2 loop of designs I/II
  and the LQR on either plant (:mod:`delta_pin.sim.compiled_batch`), with its kernels
  (:mod:`~delta_pin.compiled.delta_kernels`, :mod:`~delta_pin.compiled.adaptive_robust`,
  :mod:`~delta_pin.compiled.lqr`, :mod:`~delta_pin.compiled.rk4`, :mod:`~delta_pin.compiled.jit`);
  nothing else imports them;
* :mod:`delta_pin.compiled.native` -- Pinocchio's tree for that loop, from the core.

Each compiled computation has a readable Python reference elsewhere in the package (the model,
the controllers' ``evaluate``, the plants' ``derivative``) that the tests hold it to.
"""
