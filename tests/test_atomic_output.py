"""Atomic output (delta_pin/utils/atomic.py) and the temporaries a killed writer leaves (issue 36,
item 7: a SIGKILL left 2 MB ``.tmp`` files that no later run removed): the next write of the same
file removes them, and nothing else -- not a live writer's temporary, not a young one, not a
user's file that looks alike."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from delta_pin.utils.atomic import STALE_AFTER, atomic_open, remove_stale_temporaries, write_text_atomically

KILLED_WRITER = r"""
import os, signal, sys
from delta_pin.utils.atomic import atomic_open
with atomic_open(sys.argv[1], "wb") as handle:
    handle.write(b"x" * 2_000_000)
    handle.flush()
    os.kill(os.getpid(), signal.SIGKILL)
"""

LIVE_WRITER = r"""
import sys, time
from delta_pin.utils.atomic import atomic_open
with atomic_open(sys.argv[1], "w") as handle:
    handle.write("partial")
    handle.flush()
    print("writing", flush=True)
    time.sleep(30)
"""


def _temporaries(path: Path) -> list[Path]:
    return sorted(path.parent.glob(f".{path.name}.*.tmp"))


def _age(path: Path, seconds: float) -> None:
    then = time.time() - seconds
    os.utime(path, (then, then))


def test_a_killed_writers_temporary_is_removed_by_the_next_write(tmp_path):
    target = tmp_path / "run.npz"
    done = subprocess.run([sys.executable, "-c", KILLED_WRITER, str(target)], capture_output=True)
    assert done.returncode == -signal.SIGKILL
    (stale,) = _temporaries(target)  # what the SIGKILL left: 2 MB, never renamed
    assert stale.stat().st_size == 2_000_000 and not target.exists()
    _age(stale, 2 * STALE_AFTER)
    write_text_atomically(target, "whole")
    assert target.read_text() == "whole"
    assert _temporaries(target) == []


def test_a_live_writers_temporary_a_young_one_and_look_alikes_are_left_alone(tmp_path):
    target = tmp_path / "report.md"
    writer = subprocess.Popen(
        [sys.executable, "-c", LIVE_WRITER, str(target)], stdout=subprocess.PIPE, text=True
    )
    try:
        assert writer.stdout.readline().strip() == "writing"
        (live,) = _temporaries(target)
        _age(live, 2 * STALE_AFTER)  # old, but locked by its writer
        young = tmp_path / f".report.md.{'a' * 32}.tmp"
        young.write_text("someone's")
        other = tmp_path / f".notes.md.{'b' * 32}.tmp"  # another file's temporary
        other.write_text("other")
        _age(other, 2 * STALE_AFTER)
        users = [tmp_path / ".report.md.backup.tmp", tmp_path / f"report.md.{'c' * 32}.tmp"]
        for path in users:
            path.write_text("the user's")
            _age(path, 2 * STALE_AFTER)
        assert remove_stale_temporaries(target) == []
        assert live.exists() and young.exists() and other.exists() and all(p.exists() for p in users)
        _age(young, 2 * STALE_AFTER)  # once old and unlocked, it is a dead writer's
        assert remove_stale_temporaries(target) == [young]
    finally:
        writer.kill()
        writer.wait()
    # the writer is dead now: its temporary is unlocked, and goes once old
    _age(live, 2 * STALE_AFTER)
    assert remove_stale_temporaries(target) == [live]


def test_a_failed_write_leaves_neither_the_file_nor_a_temporary(tmp_path):
    target = tmp_path / "out.txt"
    try:
        with atomic_open(target, "w") as handle:
            handle.write("half")
            raise RuntimeError("disk full")
    except RuntimeError:
        pass
    assert not target.exists() and _temporaries(target) == []
