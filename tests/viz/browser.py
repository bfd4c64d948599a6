"""Headless chromium for the browser tests, without orphans.

chromium forks a GPU process and renderers; ``subprocess.run(..., timeout=...)`` kills only the
browser process on a timeout and leaves them running. Left behind, they took 55 % of a core each
and slowed every later browser run of the suite past its wall-time limit (two full runs of
2026-12-03: the mesh page timed out at 300 s; alone it renders in 3-5 s). Here chromium runs in a
process group of its own that is killed whole on a timeout, and a hung run is tried once more with
a fresh profile before the test fails.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess


def run_browser(command: list[str], timeout: float, retries: int = 1) -> subprocess.CompletedProcess:
    """Run ``command`` (chromium with a fresh ``--user-data-dir``) to completion within ``timeout``
    seconds, its whole process group killed if it does not; a run that hangs is tried ``retries``
    more times (the profile folder renamed so that each try starts fresh).

    Raises:
        subprocess.TimeoutExpired: every try hung.
    """
    for attempt in range(retries + 1):
        tried = [
            f"{part}-retry{attempt}" if part.startswith("--user-data-dir=") and attempt else part
            for part in command
        ]
        process = subprocess.Popen(
            tried, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True
        )
        try:
            stdout, stderr = process.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.communicate()
            if attempt == retries:
                raise
            continue
        finally:
            with contextlib.suppress(ProcessLookupError):  # the GPU process and renderers, if any outlived it
                os.killpg(process.pid, signal.SIGKILL)
        return subprocess.CompletedProcess(tried, process.returncode, stdout, stderr)
    raise AssertionError("unreachable")  # pragma: no cover
