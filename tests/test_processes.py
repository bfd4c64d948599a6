"""Processes die with their parent (issue 15), checked on real processes through /proc.

SIGKILL of ``delta-pin sweep --workers 2`` (or ``reproduce``) left its pool's workers alive under
init, blocked on their pipe with ~220 MB each; SIGTERM of ``delta-pin view`` left the meshcat server
on port 7000. Each test starts the command, finds its children in /proc, signals the command and
requires every child to be gone within DEADLINE seconds.
"""

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux's /proc")

DEADLINE = 5.0  # [s] for the children to go (measured: ~0.1 s for the workers, ~0.1 s for the server)


def _stat(pid: int) -> tuple[str, int] | None:
    """(state, ppid) of a process, or None once it is gone."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except (FileNotFoundError, ProcessLookupError):
        return None
    fields = text[text.rindex(")") + 2 :].split()
    return fields[0], int(fields[1])


def _alive(pid: int) -> bool:
    stat = _stat(pid)
    return stat is not None and stat[0] not in ("Z", "X")  # a zombie has ended, unreaped


def _cmdline(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    except OSError:
        return ""


def _children(pid: int) -> list[int]:
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            stat = _stat(int(entry.name))
            if stat is not None and stat[1] == pid and stat[0] not in ("Z", "X"):
                found.append(int(entry.name))
    return found


def _wait_for(predicate, timeout: float, step: float = 0.05):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        value = predicate()
        if value:
            return value
        time.sleep(step)
    return predicate()


def _gone_within(pids: list[int], timeout: float) -> tuple[list[int], float]:
    """The pids still alive after up to ``timeout`` s, and the seconds it took."""
    start = time.monotonic()
    _wait_for(lambda: not any(_alive(pid) for pid in pids), timeout)
    return [pid for pid in pids if _alive(pid)], time.monotonic() - start


def _end(pids: list[int]) -> None:
    """Cleanup: SIGKILL what this test started and what is still alive."""
    for pid in pids:
        if _alive(pid):
            os.kill(pid, signal.SIGKILL)


def test_sweep_workers_die_when_the_sweep_is_killed(tmp_path):
    command = [
        sys.executable, "-m", "delta_pin.cli", "sweep", "--workers", "2", "--plant", "analytic",
        "--param", "delta_m=0:0.9:8", "--t-end", "15", "--out", str(tmp_path / "sweep"),
    ]  # fmt: skip
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    workers = None
    try:

        def forks():  # the pool's workers are forks of the command (the same command line)
            own = _cmdline(process.pid)
            found = [c for c in _children(process.pid) if own and _cmdline(c) == own]
            return found if len(found) == 2 else None

        workers = _wait_for(forks, 120.0)
        assert workers, f"the sweep did not start its 2 workers: children {_children(process.pid)}"
        time.sleep(1.0)  # the workers are simulating
        everyone = _children(process.pid)  # the workers and multiprocessing's resource tracker
        os.kill(process.pid, signal.SIGKILL)
        process.wait(timeout=10)
        left, seconds = _gone_within(everyone, DEADLINE)
        assert not left, f"still alive {DEADLINE} s after SIGKILL of their parent: {left}"
        print(f"the sweep's {len(everyone)} children went {seconds:.2f} s after SIGKILL")
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
        _end(workers or [])


def test_a_worker_whose_parent_died_before_it_started_ends_at_once():
    """The race the initializer closes: the parent pid it is given is not its parent any more."""
    code = (
        "import os, time\n"
        "from delta_pin.utils.processes import die_with_parent\n"
        "die_with_parent(os.getppid() + 10**6)\n"  # a pid that is not the parent
        "time.sleep(30)\n"
    )
    started = time.monotonic()
    done = subprocess.run([sys.executable, "-c", code], timeout=60)
    assert done.returncode == -signal.SIGTERM
    assert time.monotonic() - started < 20  # ended at once (Python's start-up), not after its 30 s sleep


def test_without_the_kernel_s_help_the_polling_thread_ends_an_orphan(tmp_path):
    """The portable guard alone (prctl disabled): a grandchild whose parent is SIGKILLed ends within
    a poll or two (PARENT_POLL = 0.5 s)."""
    ready = tmp_path / "ready"
    grandchild = (
        "import time\n"
        "import delta_pin.utils.processes as p\n"
        "p._set_parent_death_signal = lambda signum: False\n"
        "p.die_with_parent()\n"
        f"open({str(ready)!r}, 'w').close()\n"
        "time.sleep(60)\n"
    )
    parent = (
        "import subprocess, sys, time\n"
        f"child = subprocess.Popen([sys.executable, '-c', {grandchild!r}])\n"
        "print(child.pid, flush=True)\n"
        "time.sleep(60)\n"
    )
    process = subprocess.Popen([sys.executable, "-c", parent], stdout=subprocess.PIPE, text=True)
    pid = None
    try:
        pid = int(process.stdout.readline())
        assert _wait_for(ready.exists, 60.0), "the grandchild never got ready"
        os.kill(process.pid, signal.SIGKILL)
        process.wait(timeout=10)
        left, seconds = _gone_within([pid], DEADLINE)
        assert not left, f"the orphan {pid} outlived its parent by {DEADLINE} s"
        print(f"the orphan went {seconds:.2f} s after its parent (polling alone)")
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
        _end([pid] if pid else [])


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    import delta_pin as dp

    robot = dp.load_delta()
    run = dp.simulate(robot, dp.PDGravity(dp.DeltaNominalModel(robot)), dp.PathI(), plant="analytic",
                      t_end=0.2, alpha0=np.full(3, 0.2492))  # fmt: skip
    path = tmp_path_factory.mktemp("view") / "run.npz"
    run.save(path)
    return path


def _read_until(stream, text: str, timeout: float) -> list[str]:
    """Lines of ``stream`` up to the one containing ``text`` (in a thread: readline blocks)."""
    lines = []

    def read():
        for line in stream:
            lines.append(line)
            if text in line:
                return

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    reader.join(timeout)
    return lines


SERVER = "delta_pin.viz.meshcat_server"  # the command line of view's meshcat server


def _listening(pid: int) -> list[tuple[str, int]]:
    """The (address, port) of each TCP socket process ``pid`` listens on (IPv4 and IPv6, from
    /proc/net/tcp*; the address in /proc's hex, 0100007F for 127.0.0.1, 00000000 for 0.0.0.0)."""
    inodes = set()
    for fd in Path(f"/proc/{pid}/fd").iterdir():
        try:
            target = os.readlink(fd)
        except OSError:
            continue
        if target.startswith("socket:["):
            inodes.add(target[len("socket:[") : -1])
    found = []
    for table in ("tcp", "tcp6"):
        path = Path(f"/proc/{pid}/net/{table}")
        if not path.exists():
            continue
        for line in path.read_text().splitlines()[1:]:
            fields = line.split()
            if fields[3] == "0A" and fields[9] in inodes:  # 0A: LISTEN
                address, port = fields[1].split(":")
                found.append((address, int(port, 16)))
    return found


@pytest.mark.parametrize(
    "signum", [signal.SIGTERM, signal.SIGINT, signal.SIGKILL], ids=["SIGTERM", "SIGINT", "SIGKILL"]
)
def test_view_ends_its_meshcat_server(run_file, signum):
    """`view`'s meshcat server listens on 127.0.0.1 only (meshcat's own served its page on
    0.0.0.0) and goes with `view` however it ends: SIGKILL left it on ports 6000/7000 (issue 25)."""
    pytest.importorskip("meshcat")
    process = subprocess.Popen(
        [sys.executable, "-m", "delta_pin.cli", "view", str(run_file)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    servers = []
    try:
        lines = _read_until(process.stdout, "meshcat viewer at", 120.0)
        assert lines and "meshcat viewer at" in lines[-1], lines
        servers = [c for c in _children(process.pid) if SERVER in _cmdline(c)]
        assert len(servers) == 1, _children(process.pid)
        listening = _listening(servers[0])
        assert len(listening) == 2, listening  # the zmq socket and the page
        assert {address for address, _ in listening} == {"0100007F"}, listening  # 127.0.0.1 only
        os.kill(process.pid, signum)
        assert process.wait(timeout=10) == (-signal.SIGKILL if signum == signal.SIGKILL else 0)
        left, seconds = _gone_within(servers, DEADLINE)
        assert not left, f"the meshcat server {left} outlived `delta-pin view` ({signum.name})"
        assert "Traceback" not in process.stderr.read()
        print(f"the meshcat server went {seconds:.2f} s after delta-pin view ended ({signum.name})")
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
        _end(servers)


def test_view_replays_a_closed_chain_run_with_its_robot_file(tmp_path):
    """A run on the MJCF Delta carries no URDF: `view --robot delta_mjcf` rebuilds the robot from
    its file and serves the scene; without it the command names what to pass."""
    pytest.importorskip("meshcat")
    pytest.importorskip("mujoco")
    import delta_pin as dp

    robot = dp.load_robot("delta_mjcf", g=9.8)
    run = dp.simulate(robot, lambda t, a, ad: np.zeros(3), None, t_end=0.05, alpha0=robot.home)
    path = tmp_path / "run.npz"
    run.save(path)
    refused = subprocess.run(
        [sys.executable, "-m", "delta_pin.cli", "view", str(path)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert refused.returncode == 2 and "robot=load_robot(path)" in refused.stderr, refused.stderr
    process = subprocess.Popen(
        [sys.executable, "-m", "delta_pin.cli", "view", str(path), "--robot", "delta_mjcf"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    servers = []
    try:
        lines = _read_until(process.stdout, "meshcat viewer at", 120.0)
        assert lines and "meshcat viewer at" in lines[-1], (lines, process.stderr)
        servers = [c for c in _children(process.pid) if SERVER in _cmdline(c)]
        os.kill(process.pid, signal.SIGTERM)
        assert process.wait(timeout=10) == 0
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
        _end(servers)
