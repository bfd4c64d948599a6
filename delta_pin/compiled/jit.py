"""numba's ``njit``, or an identity decorator where numba is missing (the kernels then run as
plain Python: the same numbers, slower). ``FAST_BACKEND`` says which."""

from __future__ import annotations

__all__ = ["FAST_BACKEND", "njit"]

try:  # pragma: no cover - which branch runs depends on the environment
    from numba import njit

    FAST_BACKEND = "numba"
except ImportError:  # pragma: no cover
    FAST_BACKEND = "python"

    def njit(*args, **kwargs):
        """Identity decorator standing in for ``numba.njit``."""
        if args and callable(args[0]):
            return args[0]
        return lambda function: function
