"""The meshcat server of :func:`~delta_pin.viz.meshcat_export.view_live`: meshcat's own zmq /
websocket bridge, run as a child process that

* listens on 127.0.0.1 only (meshcat's server serves its page on every interface, 0.0.0.0 and
  ::, while the URL it prints says 127.0.0.1), and
* ends with its parent however the parent ends, SIGKILL included (meshcat's server outlived a
  killed ``delta-pin view`` on ports 6000/7000): it is told by two means, each enough alone, a
  supervisor pipe (its stdin, whose end of file it reads as "the parent is gone") and, on Linux,
  ``prctl(PR_SET_PDEATHSIG, SIGTERM)`` (:func:`~delta_pin.utils.processes.die_with_parent`).

``python -m delta_pin.viz.meshcat_server PARENT_PID`` runs the child; :func:`start_server`
starts it and returns once it is listening.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import tempfile
import threading

from delta_pin.utils.processes import die_with_parent

__all__ = ["HOST", "start_server"]

HOST = "127.0.0.1"  # the only interface the server listens on


def start_server() -> tuple[subprocess.Popen, str, str]:
    """Start the server child; returns (process, zmq URL, web URL).

    The process's stdin is the supervisor pipe: it stays open as long as this process lives (or
    until :func:`close <subprocess.Popen.terminate>`), and the server ends at its end of file.

    Raises:
        RuntimeError: the server exited before it listened (the message gives its stderr).
    """
    errors = tempfile.TemporaryFile()  # noqa: SIM115 - the server's stderr: not a pipe, which nobody reads
    process = subprocess.Popen(
        [sys.executable, "-u", "-m", "delta_pin.viz.meshcat_server", str(os.getpid())],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=errors,
        start_new_session=True,  # a terminal's Ctrl-C goes to `view`, which then closes the server
    )
    urls = {}
    for line in process.stdout:
        name, _, value = line.decode("utf-8", "replace").strip().partition("=")
        if name in ("zmq_url", "web_url"):
            urls[name] = value
        if len(urls) == 2:
            break
    if len(urls) != 2:
        process.wait()
        errors.seek(0)
        reason = " ".join(errors.read().decode("utf-8", "replace").split()[-40:])
        errors.close()
        raise RuntimeError(
            f"the meshcat server exited with code {process.returncode} before listening: {reason}"
        )
    process.stdout.close()  # the server prints nothing more
    errors.close()  # the server keeps its own descriptor of the (unnamed) file
    return process, urls["zmq_url"], urls["web_url"]


def _die_with_parent(parent: int) -> None:
    """End this process when ``parent`` ends: PR_SET_PDEATHSIG and a watch of the parent's pid
    (:func:`~delta_pin.utils.processes.die_with_parent`), and the supervisor pipe."""
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    die_with_parent(parent)

    def watch() -> None:
        try:
            while sys.stdin.buffer.read(4096):
                pass
        finally:
            os._exit(0)  # end of file: the parent is gone (or closed the pipe)

    threading.Thread(target=watch, name="supervisor-pipe", daemon=True).start()


def _local_bridge():
    """meshcat's ZMQWebSocketBridge with its page served on :data:`HOST` only."""
    from meshcat.servers.zmqserver import ZMQWebSocketBridge

    class LocalBridge(ZMQWebSocketBridge):
        def make_app(self):
            app = super().make_app()
            listen = app.listen
            app.listen = lambda port, **options: listen(port, address=HOST, **options)
            return app

    return LocalBridge(host=HOST)


def main(argv: list[str]) -> None:
    _die_with_parent(int(argv[0]))
    bridge = _local_bridge()
    print(f"zmq_url={bridge.zmq_url}", flush=True)
    print(f"web_url={bridge.web_url}", flush=True)
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 1)  # the parent reads no more: nothing may block on a full pipe
    with contextlib.suppress(KeyboardInterrupt):
        bridge.run()


if __name__ == "__main__":
    main(sys.argv[1:])
