"""numba's ``njit``, or an identity decorator where numba is missing (the kernels then run as
plain Python: the same numbers, slower). ``FAST_BACKEND`` says which.

numba's on-disk cache (``cache=True``) is checked against the source file of each function only,
not against the files of the functions it calls: after an edit (or an upgrade) of one kernel
file, a cached caller in an unchanged file would keep the old callee's machine code, or read
records of an old layout and crash. :func:`invalidate_stale_caches` runs at import: it keeps a
hash of every source of this package beside the caches and removes the caches when it changes.

:func:`as_record` lets a kernel take its parameters either as a record (from compiled code) or as
a one-record array (from Python): numba's dispatcher types an array argument in ~0.4 us, a record
scalar in 1-3 us, which would dominate a ~5 us kernel called once per state from Python.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

__all__ = ["FAST_BACKEND", "as_record", "invalidate_stale_caches", "njit"]

PACKAGE = Path(__file__).resolve().parent
STAMP = "numba-sources.sha256"


def invalidate_stale_caches(package: Path = PACKAGE) -> bool:
    """Remove numba's cache files under ``package`` where its sources changed since they were
    written (the stamp ``__pycache__/numba-sources.sha256`` holds their hash); returns whether it
    removed any. A read-only installation is left as it is."""
    digest = hashlib.sha256()
    for source in sorted(package.rglob("*.py")):
        digest.update(str(source.relative_to(package)).encode() + b"\0" + source.read_bytes())
    stamp = package / "__pycache__" / STAMP
    try:
        if stamp.exists() and stamp.read_text().strip() == digest.hexdigest():
            return False
        stale = [*package.rglob("__pycache__/*.nbi"), *package.rglob("__pycache__/*.nbc")]
        for path in stale:
            path.unlink(missing_ok=True)
        stamp.parent.mkdir(exist_ok=True)
        stamp.write_text(digest.hexdigest() + "\n")
        return bool(stale)
    except OSError:  # pragma: no cover - a read-only site-packages
        return False


def as_record(parameters):
    """``parameters`` itself if it is a record, its only record if it is a one-record array
    (pass a plain ``np.ndarray``: numba types a ``np.recarray`` as slowly as a record)."""
    return parameters.view(np.recarray)[0] if isinstance(parameters, np.ndarray) else parameters


try:  # pragma: no cover - which branch runs depends on the environment
    from numba import njit, types

    invalidate_stale_caches()
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
