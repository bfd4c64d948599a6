"""The manifest of a study's output folder: a folder is whole, or marked as not, and only what
delta-pin provably wrote is ever removed from it.

``reproduce``, ``compare``, ``sweep`` and ``run`` write into one folder: their outputs, and (the
studies) a ``cache/`` of finished runs (whose keys hold each run's spec and robot arguments, so it
may be shared and reused).

:func:`claim` is called once every input check has passed, before any work. It takes the folder's
lock (:data:`LOCK`, an exclusive ``fcntl.flock`` that the kernel releases when the process ends,
however it ends), so that a second writer is refused in one line naming the holder's pid instead
of mixing its outputs with the first's. It refuses a folder that holds the outputs of a different
study (another command, other options or another robot: one line naming the first difference)
unless ``overwrite``, and works out which earlier outputs may go: only files listed in a complete
manifest delta-pin wrote, whose resolved paths lie inside the folder (outside ``cache/``) and
whose SHA-256 still matches the manifest's. A listed output that was changed since is refused in
one line (never removed, never overwritten); any other file (a user's notes, the files of an
interrupted run, which no manifest lists with a hash) is left alone.

:meth:`OutputFolder.start` then marks the folder incomplete (``manifest.json`` with ``"complete":
false``) and removes those earlier outputs, so that no stale file of an earlier run sits beside
new ones; a study calls it once its runs are done (a Ctrl-C, a refused scheduler or a crash while
they run leaves the earlier outputs and their manifest whole). :meth:`OutputFolder.finish` writes
the complete manifest, atomically, once the last output is written: the command, its options, the
robot arguments, the delta-pin version and git commit, and the SHA-256 of every output file
(``run`` also lists each file in the incomplete manifest as it writes it, :meth:`OutputFolder.record`,
so that a rerun may replace the files of a run that failed half-way). The lock is released when
the ``with`` block of the folder ends (or the process does).

A folder whose manifest says ``"complete": false`` was interrupted (Ctrl-C, SIGKILL, a crash): the
same command resumes it from its cache; a different one is refused like any other. A non-empty
folder without a manifest (not written by these commands, or by a delta-pin before manifests)
is refused too: its files cannot be told apart from the new ones. ``run`` writes a fixed set of
files (``outputs``): only those names must be delta-pin's own, and it replaces an earlier ``run``
whatever its options.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import os
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path

from delta_pin.errors import InvalidParameterError
from delta_pin.utils.atomic import write_text_atomically

__all__ = [
    "CACHE",
    "LOCK",
    "MANIFEST",
    "MANIFEST_FORMAT",
    "FolderLock",
    "OutputFolder",
    "begin",
    "claim",
    "lock",
    "read_manifest",
    "sha256",
]

MANIFEST = "manifest.json"
CACHE = "cache"
LOCK = ".delta-pin.lock"  # holds the pid of the process writing the folder; never removed
MANIFEST_FORMAT = "delta-pin-output-folder"
MANIFEST_VERSION = 1
_NOT_OUTPUTS = (MANIFEST, LOCK)  # files of the folder's own bookkeeping, at its top level


def sha256(path: Path) -> str:
    """The SHA-256 (hex) of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _plain(value):
    """``value`` as JSON reads it back (tuples as lists, keys as strings)."""
    return json.loads(json.dumps(value, sort_keys=True, default=str))


# ------------------------------------------------------------------------------------- the lock
class FolderLock:
    """An exclusive ``flock`` on ``out/LOCK``, held until :meth:`release` or the end of the process
    (the kernel drops a dead process's locks, so a SIGKILL never leaves a folder locked)."""

    def __init__(self, path: Path, fd: int, created_folder: bool = False, created_file: bool = False):
        self.path = path
        self._fd: int | None = fd
        self.created_folder = created_folder  # the folder did not exist before this lock
        self.created_file = created_file  # nor did the lock file

    @property
    def held(self) -> bool:
        return self._fd is not None

    def release(self) -> None:
        """Unlock (closing the file drops the lock); the lock file stays, so that two processes
        never lock two different files of one name."""
        fd, self._fd = self._fd, None
        if fd is not None:
            os.close(fd)

    def discard(self) -> None:
        """Release, and remove what this lock alone added: the lock file it created and the folder
        it created, where nothing else was written there (a command refused before its first
        output leaves the disk as it found it). Removed while still locked, so that no other writer
        can hold the lock in the meantime."""
        if self._fd is not None and self.created_file:
            self.path.unlink(missing_ok=True)
            if self.created_folder:
                with contextlib.suppress(OSError):  # not empty: something else is there, kept
                    self.path.parent.rmdir()
        self.release()

    def __del__(self):  # a safety net; the owner releases it
        self.release()


def _holder(fd: int) -> str:
    """The pid written in a lock file (the holder writes it right after locking: retried briefly)."""
    for _ in range(20):
        text = os.pread(fd, 64, 0).decode(errors="replace").strip()
        if text:
            return text
        time.sleep(0.01)
    return "unknown"


def lock(out: str | Path) -> FolderLock:
    """Lock folder ``out`` (created if needed) for this process, without waiting.

    Raises:
        InvalidParameterError: another process (or another writer of this one) holds the lock; the
            message names its pid.
    """
    out = Path(out)
    created_folder = not os.path.lexists(out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / LOCK
    created_file = not os.path.lexists(path)
    fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        holder = _holder(fd)
        os.close(fd)
        raise InvalidParameterError(
            f"the output folder {out} is being written by another delta-pin (pid {holder}, which holds "
            f"{path}); wait until it ends, or give another folder"
        ) from None
    except BaseException:
        os.close(fd)
        raise
    os.ftruncate(fd, 0)
    os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
    return FolderLock(path, fd, created_folder, created_file)


# ---------------------------------------------------------------------------------- the manifest
def read_manifest(out: str | Path) -> dict | None:
    """The manifest of folder ``out`` (``None`` if it has none).

    Raises:
        InvalidParameterError: a manifest that is not one (unreadable, another format).
    """
    path = Path(out) / MANIFEST
    try:
        manifest = json.loads(path.read_text())
    except FileNotFoundError:
        return None
    except (OSError, ValueError) as exc:
        raise InvalidParameterError(
            f"{path} is unreadable ({exc}); give another folder, or remove the file"
        ) from None
    if not isinstance(manifest, dict) or manifest.get("format") != MANIFEST_FORMAT:
        raise InvalidParameterError(
            f"{path} is not a delta-pin manifest; give another output folder, or remove the file"
        )
    return manifest


def _outputs(out: Path) -> list[Path]:
    """Every file of ``out`` but the manifest, the lock and the cache, sorted."""
    if not out.is_dir():
        return []
    found = []
    for root, dirs, files in os.walk(out):
        here = Path(root)
        if here == out:
            dirs[:] = [d for d in dirs if d != CACHE]
            files = [f for f in files if f not in _NOT_OUTPUTS]
        dirs.sort()
        found += [here / name for name in sorted(files)]
    return found


def _signature(path: Path) -> tuple:
    """What changes when a file is written (an atomic write replaces the inode)."""
    stat = path.stat()
    return (stat.st_ino, stat.st_size, stat.st_mtime_ns)


def _inside(out: Path, name) -> Path | None:
    """The file a manifest names ``name``, if it is one delta-pin may have written there: a
    relative name whose resolved path lies inside ``out`` (not a link, not in ``cache/``, not the
    manifest or the lock); ``None`` otherwise."""
    if not isinstance(name, str) or not name:
        return None
    root = out.resolve()
    path = out / name
    try:
        resolved = path.resolve()
        relative = resolved.relative_to(root)
    except (OSError, ValueError, RuntimeError):
        return None
    if path.is_symlink() or not relative.parts or relative.parts[0] == CACHE:
        return None
    if len(relative.parts) == 1 and relative.parts[0] in _NOT_OUTPUTS:
        return None
    return resolved


def _listed(old: dict | None) -> dict:
    """The outputs a manifest lists with their SHA-256: a complete one's ``files``, or the
    ``written`` of an interrupted one that recorded its files as it wrote them (``run``)."""
    if old is None:
        return {}
    listed = old.get("files") if old.get("complete") is True else old.get("written")
    return listed if isinstance(listed, dict) else {}


def _earlier_outputs(out: Path, old: dict | None) -> list[Path]:
    """The earlier outputs that are provably delta-pin's: listed in a manifest (:func:`_listed`),
    inside ``out``, and unchanged since (their SHA-256 is the listed one).

    Raises:
        InvalidParameterError: a listed output that was changed since (never removed).
    """
    removable = []
    for name, digest in sorted(_listed(old).items()):
        path = _inside(out, name)
        if path is None or not path.is_file():
            continue  # not in the folder (any more), or not a file delta-pin writes: left alone
        if sha256(path) != digest:
            raise InvalidParameterError(
                f"the output folder {out} holds {name}, listed in its {MANIFEST} but changed since "
                "delta-pin wrote it (its SHA-256 differs): move it out of the folder, or give another folder"
            )
        removable.append(path)
    return removable


def _first_difference(old, new, where: str = "") -> str | None:
    """``"NAME: A before, B now"`` of the first option that differs, or ``None``."""
    if isinstance(old, dict) and isinstance(new, dict):
        for key in sorted(set(old) | set(new)):
            name = f"{where}.{key}" if where else key
            if key not in old or key not in new:
                before = json.dumps(old[key]) if key in old else "absent"
                now = json.dumps(new[key]) if key in new else "absent"
                return f"{name}: {before} before, {now} now"
            found = _first_difference(old[key], new[key], name)
            if found:
                return found
        return None
    if old != new:
        return f"{where or 'options'}: {json.dumps(old)} before, {json.dumps(new)} now"
    return None


def _git_commit() -> str | None:
    """The commit of the delta-pin checkout this package runs from (``None``: not a git checkout)."""
    package = Path(__file__).resolve().parents[1]
    if not (package.parent / ".git").exists():
        return None
    try:
        done = subprocess.run(
            ["git", "-C", str(package.parent), "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            timeout=5,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return done.stdout.strip() or None if done.returncode == 0 else None


@dataclass
class OutputFolder:
    """A folder :func:`claim` accepted and locked: :meth:`start` marks it incomplete and removes
    the earlier outputs, :meth:`finish` marks it whole; leaving its ``with`` block unlocks it.

    Attributes:
        out: the folder.
        header: the manifest's fields but ``complete``, ``finished`` and ``files``.
        lock: the folder's lock, held until :meth:`release`.
        earlier: the earlier outputs :meth:`start` removes (provably delta-pin's).
        kept: the other files found at :func:`claim` (relative name -> signature): never listed as
            outputs unless written again.
        started: whether :meth:`start` has run.
        written: the files :meth:`record` listed so far (relative name -> SHA-256).
    """

    out: Path
    header: dict
    lock: FolderLock
    earlier: list[Path] = field(default_factory=list)
    kept: dict[str, tuple] = field(default_factory=dict)
    started: bool = False
    written: dict[str, str] = field(default_factory=dict)

    def __enter__(self) -> OutputFolder:
        return self

    def __exit__(self, *exc) -> None:
        self.release()

    def release(self) -> None:
        """Unlock the folder (done by leaving the ``with`` block, or by the end of the process).
        Before :meth:`start` (the command refused or failed before its first output) the lock file
        and a folder the claim created go too (:meth:`FolderLock.discard`)."""
        if self.started:
            self.lock.release()
        else:
            self.lock.discard()

    def _check_held(self) -> None:
        if not self.lock.held:
            raise InvalidParameterError(f"the output folder {self.out} is no longer locked by this writer")

    def start(self) -> None:
        """Mark the folder incomplete and remove the earlier outputs (once; later calls do nothing)."""
        self._check_held()
        if self.started:
            return
        marked = {**self.header, "complete": False}
        write_text_atomically(self.out / MANIFEST, json.dumps(marked, indent=1) + "\n")
        root = self.out.resolve()
        for path in self.earlier:
            path.unlink(missing_ok=True)
            parent = path.parent
            while parent != root and root in parent.parents:  # folders the removal emptied (figures/)
                try:
                    parent.rmdir()
                except OSError:
                    break
                parent = parent.parent
        self.started = True

    def record(self, files: list[Path]) -> None:
        """List ``files`` (just written inside the folder) with their SHA-256 in the incomplete
        manifest (``written``), so that a rerun may replace them even if this command never
        finishes (``run``: a page that fails to export after run.npz was saved)."""
        self.start()
        for path in files:
            self.written[Path(path).resolve().relative_to(self.out.resolve()).as_posix()] = sha256(Path(path))
        marked = {**self.header, "complete": False, "written": dict(sorted(self.written.items()))}
        write_text_atomically(self.out / MANIFEST, json.dumps(marked, indent=1) + "\n")

    def finish(self, files: list[Path] | None = None) -> dict:
        """Write the complete manifest, atomically, and return it: ``files`` (the outputs this
        command wrote inside the folder; ``None``: every file of the folder but those found at
        :func:`claim` and not written since), each with its SHA-256."""
        self.start()
        if files is None:
            files = [
                path
                for path in _outputs(self.out)
                if self.kept.get(path.relative_to(self.out).as_posix()) != _signature(path)
            ]
        listed = {}
        for path in files:
            name = Path(path).resolve().relative_to(self.out.resolve()).as_posix()
            listed[name] = sha256(Path(path))
        manifest = {
            **self.header,
            "complete": True,
            "finished": _now(),
            "files": dict(sorted(listed.items())),
        }
        write_text_atomically(self.out / MANIFEST, json.dumps(manifest, indent=1) + "\n")
        return manifest


def _now() -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%S%z")


def _refuse_foreign(out: Path, old: dict | None, outputs: list[str] | None) -> None:
    """Refuse files that may be anyone's: with ``outputs`` (the names a command writes), those of
    them that exist and no manifest lists; else any file of a folder without a manifest."""
    if outputs is not None:
        listed = _listed(old)
        for name in outputs:
            if os.path.lexists(out / name) and name not in listed:  # a dangling link too
                raise InvalidParameterError(
                    f"the output folder {out} holds {name}, which no {MANIFEST} of delta-pin lists: it may "
                    "be anyone's file; move it away, or give another folder"
                )
        return
    found = _outputs(out)
    if old is None and found:  # never removed, even with overwrite: they may be anyone's files
        raise InvalidParameterError(
            f"the output folder {out} holds {len(found)} file(s) (e.g. {found[0].relative_to(out)}) "
            f"and no {MANIFEST}: not the outputs of a delta-pin study; give an empty or new folder, "
            "or remove them"
        )


def claim(
    out: str | Path,
    command: str,
    options: dict,
    *,
    robot_args: dict | None = None,
    overwrite: bool = False,
    command_line: list[str] | None = None,
    outputs: list[str] | None = None,
    replace_same_command: bool = False,
) -> OutputFolder:
    """Lock ``out`` for ``command`` with ``options`` (what decides its outputs) and work out which
    earlier outputs :meth:`OutputFolder.start` will remove; nothing but the lock file is written.

    Args:
        out: the output folder (created if needed).
        command: ``"reproduce"``, ``"compare"``, ``"sweep"`` or ``"run"``.
        options: JSON-ready options that decide the outputs (not where the runs execute).
        robot_args: the robot's xacro arguments (part of what must match).
        overwrite: replace the outputs of a different study instead of refusing the folder.
        command_line: the command as typed, recorded in the manifest.
        outputs: the names (relative to ``out``) the command writes, when it writes a fixed set
            (``run``): only those must be delta-pin's; ``None``: every file of the folder must be.
        replace_same_command: an earlier output of the same ``command`` is replaced whatever its
            options (``run``); any other command's is refused, even with ``overwrite``.

    Raises:
        InvalidParameterError: another process writes the folder (naming its pid); the folder
            holds a different study's outputs (the message names the first difference; unless
            ``overwrite``), files without a manifest (always: those may be anyone's files), or a
            listed output changed since it was written.
    """
    from delta_pin._version import __version__

    out = Path(out)
    identity = _plain({"command": command, "options": options, "robot_args": robot_args or {}})
    _refuse_foreign(out, read_manifest(out), outputs)  # before the lock: a user's folder is not written
    folder_lock = lock(out)
    try:
        old = read_manifest(out)  # again, under the lock: another writer may have finished since
        _refuse_foreign(out, old, outputs)
        if old is not None and not (overwrite and not replace_same_command):
            before = {key: old.get(key) for key in ("command", "options", "robot_args")}
            if replace_same_command and old.get("command") == command:
                difference = None
            elif replace_same_command:
                difference = f"command: {json.dumps(old.get('command'))} before, {json.dumps(command)} now"
            else:
                difference = _first_difference(before, identity)
            if difference:
                state = "a " if old.get("complete") else "an interrupted "
                remedy = (
                    "give another folder"
                    if replace_same_command
                    else "give another folder, or --overwrite (overwrite=True) to replace its outputs (its "
                    "cache/ is kept and reused)"
                )
                raise InvalidParameterError(
                    f"the output folder {out} holds the outputs of {state}delta-pin {old.get('command')} "
                    f"with other options ({difference}; see its {MANIFEST}); {remedy}"
                )
        earlier = _earlier_outputs(out, old)
        gone = set(earlier)
        kept = {
            path.relative_to(out).as_posix(): _signature(path)
            for path in _outputs(out)
            if path.resolve() not in gone
        }
    except BaseException:
        folder_lock.discard()
        raise
    header = {
        "format": MANIFEST_FORMAT,
        "version": MANIFEST_VERSION,
        **identity,
        "command_line": command_line,
        "delta_pin": __version__,
        "git_commit": _git_commit(),
        "started": _now(),
    }
    return OutputFolder(out, header, folder_lock, earlier, kept)


def begin(
    out: str | Path,
    command: str,
    options: dict,
    *,
    robot_args: dict | None = None,
    overwrite: bool = False,
    command_line: list[str] | None = None,
) -> OutputFolder:
    """:func:`claim` for a study, marking a folder without earlier outputs incomplete at once (so
    that a study interrupted while it runs leaves a marked folder); a folder with an earlier
    study's manifest is marked, and its earlier outputs removed, by the caller's
    :meth:`OutputFolder.start` once the runs are done. Use it as ``with begin(...) as folder:``."""
    folder = claim(
        out, command, options, robot_args=robot_args, overwrite=overwrite, command_line=command_line
    )
    try:
        if read_manifest(out) is None:
            folder.start()
    except BaseException:
        folder.release()
        raise
    return folder
