"""Private: the compiled layer (the C++ core, ``_core``, imported by :mod:`delta_pin.compiled.core`;
numba kernels that the Python reference loop still calls, until they go).

Nothing here is public API: ``delta_pin.sim``, ``delta_pin.control`` and ``delta_pin.model`` call
it with plain arrays and the named records of :mod:`delta_pin.compiled.layouts`, never with
delta-pin objects, so this package imports nothing from the layers above it
(docs/architecture.md sections 2 and 8). Its entry points:

* :func:`delta_pin.compiled.core.core` -- the compiled core, checked against the installed Pinocchio;
* :func:`delta_pin.compiled.adaptive_robust.adaptive_robust_kernel` -- one controller step;
* :mod:`delta_pin.compiled.delta_kernels` -- the analytic model at one state.

Each has a readable Python reference elsewhere in the package that the tests compare it with.
"""
