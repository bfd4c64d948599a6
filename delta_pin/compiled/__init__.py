"""Private: the compiled layer (numba kernels and the native C++ library).

Nothing here is public API: ``delta_pin.sim``, ``delta_pin.control`` and ``delta_pin.model`` call
it with plain arrays and the named records of :mod:`delta_pin.compiled.layouts`, never with
delta-pin objects, so this package imports nothing from the layers above it
(docs/architecture.md sections 2 and 8). Its entry points:

* :func:`delta_pin.compiled.closed_loop.run_closed_loop` -- one run of design I or II on the
  analytic plant (BDF2, or sampled RK4) or on Pinocchio's tree in active coordinates (BDF2);
* :func:`delta_pin.compiled.adaptive_robust.adaptive_robust_kernel` -- one controller step;
* :func:`delta_pin.compiled.lqr.lqr_law_into` -- the LQR baseline's law in those closed loops;
* :mod:`delta_pin.compiled.delta_kernels` -- the analytic model at one state;
* :mod:`delta_pin.compiled.native` -- the native library (built on first use).

Each has a readable Python reference elsewhere in the package that the tests compare it with.
"""
