"""Ctrl-C and SIGTERM that arrive during a compiled call.

The signal's Python handler raises :class:`KeyboardInterrupt` at the next point where CPython
checks for signals. Inside a compiled call that point can be the extension's own return path
(numba's did this, issue 25; any C extension can), which then reports ``SystemError: ...
returned a result with an exception set`` with the :class:`KeyboardInterrupt` as its cause.
:func:`reraise_interrupt` turns such an error back into the interrupt, so a command exits 130
(143 for SIGTERM) with its one line, and a study stops instead of recording the interrupt as a
failed point (issue 25).
"""

from __future__ import annotations

__all__ = ["interrupt_of", "reraise_interrupt"]


def interrupt_of(exc: BaseException) -> KeyboardInterrupt | None:
    """The :class:`KeyboardInterrupt` that ``exc`` is, or that a ``SystemError`` of a compiled
    call carries as its cause or context; else ``None``."""
    if isinstance(exc, KeyboardInterrupt):
        return exc
    if isinstance(exc, SystemError):
        for inner in (exc.__cause__, exc.__context__):
            if isinstance(inner, KeyboardInterrupt):
                return inner
    return None


def reraise_interrupt(exc: BaseException) -> None:
    """Raise the interrupt ``exc`` carries (:func:`interrupt_of`); return where it carries none."""
    interrupt = interrupt_of(exc)
    if interrupt is not None:
        raise interrupt from None
