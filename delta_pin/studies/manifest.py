"""The manifest of a study's output folder: a folder is whole, or marked as not.

``reproduce``, ``compare`` and ``sweep`` write into one folder: their outputs, and a ``cache/``
of finished runs (whose keys hold each run's spec and robot arguments, so it may be shared and
reused). :func:`begin` is called before any work: it refuses a folder that holds the outputs of a
different study (another command, other options or another robot: one line naming the first
difference) unless ``overwrite``, then marks the folder incomplete (``manifest.json`` with
``"complete": false``) and removes every earlier output -- everything but ``cache/`` -- so that no
stale file of an earlier run sits beside new ones. :meth:`OutputFolder.finish` writes the
complete manifest, atomically, once the last output is written: the command, its options, the
robot arguments, the delta-pin version and git commit, and the SHA-256 of every output file.

A folder whose manifest says ``"complete": false`` was interrupted (Ctrl-C, SIGKILL, a crash): the
same command resumes it from its cache; a different one is refused like any other. A non-empty
folder without a manifest (not written by these commands, or by a delta-pin before manifests)
is refused too: its files cannot be told apart from the new ones.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path

from delta_pin.errors import InvalidParameterError
from delta_pin.utils.atomic import write_text_atomically

__all__ = ["CACHE", "MANIFEST", "MANIFEST_FORMAT", "OutputFolder", "begin", "read_manifest", "sha256"]

MANIFEST = "manifest.json"
CACHE = "cache"
MANIFEST_FORMAT = "delta-pin-output-folder"
MANIFEST_VERSION = 1


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
    """Every file of ``out`` but the manifest and the cache, sorted."""
    if not out.is_dir():
        return []
    found = []
    for root, dirs, files in os.walk(out):
        here = Path(root)
        if here == out:
            dirs[:] = [d for d in dirs if d != CACHE]
            files = [f for f in files if f != MANIFEST]
        dirs.sort()
        found += [here / name for name in sorted(files)]
    return found


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
    """A folder :func:`begin` accepted and marked incomplete; :meth:`finish` marks it whole."""

    out: Path
    header: dict

    def finish(self) -> dict:
        """Write the complete manifest (every output file with its SHA-256), atomically; return it."""
        files = {path.relative_to(self.out).as_posix(): sha256(path) for path in _outputs(self.out)}
        manifest = {**self.header, "complete": True, "finished": _now(), "files": files}
        write_text_atomically(self.out / MANIFEST, json.dumps(manifest, indent=1) + "\n")
        return manifest


def _now() -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%S%z")


def begin(
    out: str | Path,
    command: str,
    options: dict,
    *,
    robot_args: dict | None = None,
    overwrite: bool = False,
    command_line: list[str] | None = None,
) -> OutputFolder:
    """Accept ``out`` for ``command`` with ``options`` (what decides its outputs) and mark it
    incomplete, removing the outputs of any earlier run (``cache/`` is kept).

    Args:
        out: the output folder (created if needed).
        command: ``"reproduce"``, ``"compare"`` or ``"sweep"``.
        options: JSON-ready options that decide the outputs (not where the runs execute).
        robot_args: the robot's xacro arguments (part of what must match).
        overwrite: replace the outputs of a different study instead of refusing the folder.
        command_line: the command as typed, recorded in the manifest.

    Raises:
        InvalidParameterError: the folder holds a different study's outputs (the message names the
            first difference; unless ``overwrite``), or files without a manifest (always: those
            may be anyone's files).
    """
    from delta_pin import __version__

    out = Path(out)
    identity = _plain({"command": command, "options": options, "robot_args": robot_args or {}})
    old = read_manifest(out)
    outputs = _outputs(out)
    if old is None and outputs:  # never removed, even with overwrite: they may be anyone's files
        raise InvalidParameterError(
            f"the output folder {out} holds {len(outputs)} file(s) (e.g. {outputs[0].relative_to(out)}) "
            f"and no {MANIFEST}: not the outputs of a delta-pin study; give an empty or new folder, "
            "or remove them"
        )
    if old is not None and not overwrite:
        before = {key: old.get(key) for key in ("command", "options", "robot_args")}
        difference = _first_difference(before, identity)
        if difference:
            state = "a " if old.get("complete") else "an interrupted "
            raise InvalidParameterError(
                f"the output folder {out} holds the outputs of {state}delta-pin {old.get('command')} "
                f"with other options "
                f"({difference}; see its {MANIFEST}); give another folder, or --overwrite "
                "(overwrite=True) to replace its outputs (its cache/ is kept and reused)"
            )
    header = {
        "format": MANIFEST_FORMAT,
        "version": MANIFEST_VERSION,
        **identity,
        "command_line": command_line,
        "delta_pin": __version__,
        "git_commit": _git_commit(),
        "started": _now(),
    }
    out.mkdir(parents=True, exist_ok=True)
    write_text_atomically(out / MANIFEST, json.dumps({**header, "complete": False}, indent=1) + "\n")
    for path in outputs:  # the earlier run's outputs: the new run writes its own
        path.unlink(missing_ok=True)
    for child in sorted(out.iterdir()):
        if child.is_dir() and child.name != CACHE and not _outputs(child):
            shutil.rmtree(child, ignore_errors=True)  # folders the removal emptied (figures/)
    return OutputFolder(out, header)
