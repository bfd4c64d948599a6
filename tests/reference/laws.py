"""The readable laws in the compiled loops: a controller whose compiled law is hidden, so the core
calls its Python ``evaluate`` back (once per sample, or per evaluation in continuous mode) -- the
reference a compiled law is tested against on the same plant and loop."""

from __future__ import annotations

import copy

__all__ = ["called_back"]


def called_back(controller):
    """A copy of ``controller`` without its compiled law (``sampled_core_law()`` is ``None``):
    the core's loop calls its readable :meth:`~delta_pin.control.base.Controller.evaluate`."""
    readable = copy.copy(controller)
    readable.sampled_core_law = lambda: None
    return readable
