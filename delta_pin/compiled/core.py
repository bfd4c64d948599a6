"""The compiled core, ``delta_pin.compiled._core`` (``delta_pin/core/``, nanobind), imported once
and checked against the running Pinocchio.

The core links ``libpinocchio_default`` of the ``pin`` wheel it was built against; another
``pin`` installed since (another C++ ABI) is refused here in one line that says which and how to
rebuild, instead of a crash or a wrong number later. ``DELTA_PIN_NATIVE=0`` turns the core off
(every run then takes the Python loop).
"""

from __future__ import annotations

import functools
import os
from types import ModuleType

from delta_pin.errors import NativeUnavailableError

__all__ = ["core"]

REBUILD = "pip install --force-reinstall --no-deps -e . (or reinstall delta-pin)"


@functools.cache
def core() -> ModuleType:
    """The imported core module.

    Raises:
        NativeUnavailableError: the core is turned off (``DELTA_PIN_NATIVE=0``), not built (a
            source tree without an install) or built against another Pinocchio than the one
            installed.
    """
    if os.environ.get("DELTA_PIN_NATIVE", "1") == "0":
        raise NativeUnavailableError("the compiled core is turned off (DELTA_PIN_NATIVE=0)")
    import pinocchio  # loads libpinocchio_default, which the core links

    try:
        from delta_pin.compiled import _core
    except ImportError as exc:
        raise NativeUnavailableError(f"the compiled core cannot be imported ({exc}); {REBUILD}") from None
    if _core.pinocchio_version != pinocchio.__version__:
        raise NativeUnavailableError(
            f"the compiled core was built against Pinocchio {_core.pinocchio_version} but Pinocchio "
            f"{pinocchio.__version__} is installed; rebuild it: {REBUILD}"
        )
    return _core
