"""numba's ``njit``, or an identity decorator where numba is missing (the kernels then run as
plain Python: the same numbers, slower). ``FAST_BACKEND`` says which.

:func:`as_record` lets a kernel take its parameters either as a record (from compiled code) or as
a one-record array (from Python): numba's dispatcher types an array argument in ~0.4 us, a record
scalar in 1-3 us, which would dominate a ~5 us kernel called once per state from Python.
"""

from __future__ import annotations

import numpy as np

__all__ = ["FAST_BACKEND", "as_record", "njit"]


def as_record(parameters):
    """``parameters`` itself if it is a record, its only record if it is a one-record array
    (pass a plain ``np.ndarray``: numba types a ``np.recarray`` as slowly as a record)."""
    return parameters.view(np.recarray)[0] if isinstance(parameters, np.ndarray) else parameters


try:  # pragma: no cover - which branch runs depends on the environment
    from numba import njit, types
    from numba.extending import overload

    FAST_BACKEND = "numba"

    @overload(as_record)
    def _as_record(parameters):
        if isinstance(parameters, types.Record):
            return lambda parameters: parameters
        if isinstance(parameters, types.Array) and isinstance(parameters.dtype, types.Record):
            return lambda parameters: parameters[0]
        return None

except ImportError:  # pragma: no cover
    FAST_BACKEND = "python"

    def njit(*args, **kwargs):
        """Identity decorator standing in for ``numba.njit``."""
        if args and callable(args[0]):
            return args[0]
        return lambda function: function
