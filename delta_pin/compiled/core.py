"""The compiled core, ``delta_pin.compiled._core`` (``delta_pin/core/``, nanobind), imported once
and checked against the running Pinocchio.

The core links ``libpinocchio_default`` of the ``pin`` wheel it was built against; another
``pin`` installed since (another C++ ABI) is refused here in one line that says which and how to
rebuild, instead of a crash or a wrong number later. The core is not optional: every run, model
and law goes through it (docs/architecture.md section 7), so a core that cannot be imported is an
error that names the rebuild command, never a silent slower path.
"""

from __future__ import annotations

import functools
from types import ModuleType

from delta_pin.errors import NativeUnavailableError

__all__ = ["core"]

REBUILD = "pip install --force-reinstall --no-deps -e . (or reinstall delta-pin)"


@functools.cache
def core() -> ModuleType:
    """The imported core module.

    Raises:
        NativeUnavailableError: the core is not built (a source tree without an install) or
            built against another Pinocchio than the one installed.
    """
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
