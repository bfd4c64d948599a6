"""Atomic output: every file delta-pin writes appears whole or not at all.

A temporary file is created in the destination folder (same file system), written, and renamed
over the destination with :func:`os.replace`; on any error it is removed. Permissions follow the
umask, as for any new file.

A writer killed outright (SIGKILL, the OOM killer, a power cut) cannot remove its temporary, so
the next write of the same destination does (:func:`remove_stale_temporaries`). What is removed
is provably a dead writer's own: a file named as only :func:`atomic_open` names them
(``.NAME.<32 hex digits>.tmp`` beside ``NAME``), older than :data:`STALE_AFTER`, and not locked:
each writer holds an exclusive ``flock`` on its temporary from the moment it creates it until it
is renamed, and the kernel drops the lock when the writer dies, however it dies.
"""

from __future__ import annotations

import fcntl
import os
import re
import time
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO

__all__ = ["STALE_AFTER", "atomic_open", "remove_stale_temporaries", "write_text_atomically"]

STALE_AFTER = 2.0  # [s] a temporary younger than this may belong to a writer about to lock it
_TEMPORARY = re.compile(r"\.(?P<name>.+)\.[0-9a-f]{32}\.tmp")


def _temporary_of(path: Path) -> Path:
    return path.parent / f".{path.name}.{uuid.uuid4().hex}.tmp"


def remove_stale_temporaries(path: str | Path) -> list[Path]:
    """Remove the temporaries that killed writers of ``path`` left beside it (module docstring);
    returns those removed. A temporary a live writer holds, a young one, or any file not named
    like one is left alone."""
    path = Path(path)
    removed = []
    try:
        entries = list(os.scandir(path.parent))
    except OSError:
        return removed
    for entry in entries:
        found = _TEMPORARY.fullmatch(entry.name)
        if found is None or found["name"] != path.name or not entry.is_file(follow_symlinks=False):
            continue
        try:
            if time.time() - entry.stat(follow_symlinks=False).st_mtime < STALE_AFTER:
                continue
            fd = os.open(entry.path, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC)
        except OSError:
            continue
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # held: a live writer's
        except OSError:
            os.close(fd)
            continue
        try:
            os.unlink(entry.path)
            removed.append(Path(entry.path))
        except OSError:
            pass
        finally:
            os.close(fd)
    return removed


@contextmanager
def atomic_open(path: str | Path, mode: str = "w", **kwargs) -> Iterator[IO]:
    """Open a temporary sibling of ``path`` for writing; rename it to ``path`` on success.

    Args:
        path: destination (its parent folders are created).
        mode: ``"w"`` (text, UTF-8 by default) or ``"wb"``.
        **kwargs: passed to :func:`os.fdopen` (e.g. ``newline=""``).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(path)
    tmp = _temporary_of(path)
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o666)
    fcntl.flock(fd, fcntl.LOCK_EX)  # ours until it is renamed or we die (module docstring)
    if "b" not in mode:
        kwargs.setdefault("encoding", "utf-8")
    try:
        with os.fdopen(fd, mode, **kwargs) as handle:
            yield handle
            handle.flush()
            os.replace(tmp, path)  # still locked: the lock goes with the closing of the file
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_text_atomically(path: str | Path, text: str) -> Path:
    """Write ``text`` to ``path`` atomically and return the path."""
    with atomic_open(path, "w") as handle:
        handle.write(text)
    return Path(path)
