"""How much memory a command may plan to take: half of this machine's physical memory (what
``run``, the studies' workers and ``identify fit`` hold themselves to without ``--force``)."""

from __future__ import annotations

import os

__all__ = ["format_size", "memory_limit"]


def memory_limit() -> int:
    """Half of this machine's physical memory [bytes] (8 GiB where it cannot be read): what a
    command runs without ``--force``."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") // 2
    except (AttributeError, ValueError, OSError):  # pragma: no cover - not POSIX
        return 8 * 1024**3


def format_size(count: float) -> str:
    """A byte count in words: ``"2.3 GiB"``."""
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if count < 1024 or unit == "TiB":
            return f"{count:.3g} {unit}"
        count /= 1024
    raise AssertionError  # pragma: no cover
