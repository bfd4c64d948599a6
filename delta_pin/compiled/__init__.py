"""Private: the compiled layer -- the C++ core (``delta_pin/core/``, nanobind), imported once and
checked against the installed Pinocchio by :func:`delta_pin.compiled.core.core`: the plants, the
sampled and continuous loops and the compiled laws.

Nothing here is public API: ``delta_pin.sim``, ``delta_pin.control`` and ``delta_pin.model`` call
it with plain numbers and arrays, never with delta-pin objects, so this package imports nothing
from the layers above it (docs/architecture.md sections 2 and 8). Each compiled computation has a
readable Python reference elsewhere in the package (the model, the controllers' ``evaluate``, the
plants' ``derivative``) that the tests hold it to.
"""
