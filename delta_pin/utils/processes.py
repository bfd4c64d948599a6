"""Child processes that die with their parent.

A worker process of a study (a :class:`concurrent.futures.ProcessPoolExecutor` worker) blocks on a
pipe between tasks; if its parent is killed outright (SIGKILL, the OOM killer), nobody tells it
to stop, and it lives on under init holding its memory. :func:`die_with_parent`, called in the
child (e.g. as the pool's initializer), makes the kernel send it SIGTERM when its parent dies
(Linux: ``prctl(PR_SET_PDEATHSIG)``), and also starts a daemon thread that polls ``os.getppid()``
(every platform, and a second guard on Linux): a changed parent means the parent is gone.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys
import threading
import time

__all__ = ["PARENT_POLL", "die_with_parent"]

PARENT_POLL = 0.5  # [s] between two looks at the parent's pid
_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


def _set_parent_death_signal(signum: int) -> bool:
    """Ask the Linux kernel to send ``signum`` to this process when its parent dies."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(_PR_SET_PDEATHSIG, signum, 0, 0, 0) == 0
    except (OSError, AttributeError):  # pragma: no cover - no prctl in this libc
        return False


def _end(signum: int) -> None:
    """End this process with ``signum`` (its default action), or exit if the signal is handled."""
    os.kill(os.getpid(), signum)
    time.sleep(PARENT_POLL)
    os._exit(128 + signum)  # pragma: no cover - the signal was caught or ignored


def _watch(parent: int, signum: int, poll: float) -> None:
    while True:
        time.sleep(poll)
        if os.getppid() != parent:
            _end(signum)


def die_with_parent(
    parent: int | None = None, signum: int = signal.SIGTERM, poll: float = PARENT_POLL
) -> bool:
    """Make this (child) process end with ``signum`` when its parent process dies.

    Args:
        parent: the parent's pid, as the parent saw it (``os.getpid()`` there, passed down so that
            a parent that died before this call is noticed); ``None``: ``os.getppid()`` now.
        signum: the signal to end with (SIGTERM: the default action ends the process).
        poll: seconds between two looks at the parent's pid (the portable guard).

    Returns:
        Whether the kernel will send the signal (Linux); the polling thread runs either way.
    """
    parent = os.getppid() if parent is None else parent
    kernel = _set_parent_death_signal(int(signum))
    if os.getppid() != parent:  # the parent died before the kernel was asked
        _end(signum)
    threading.Thread(target=_watch, args=(parent, signum, poll), name="die-with-parent", daemon=True).start()
    return kernel
