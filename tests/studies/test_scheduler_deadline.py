"""--scheduler waits at most its deadline, whatever the peer does (issue 36, item 3).

``distributed.Client(address, timeout=5)`` bounds the TCP connect only: a peer that accepts and
never answers held it for 143 s (measured on the landed tree; more than 300 s here), and 8 bytes
from a peer that is not a scheduler were read as the length of a frame of exabytes. The sweep
now asks the peer for its identity under a hard deadline of SCHEDULER_TIMEOUT (5 s) first. Each
case below must end in SchedulerUnreachableError within that deadline plus 2 s (thread start-up
and the event loop's own tear-down on a loaded 2-core machine), and a real scheduler still runs.
"""

import socket
import threading
import time

import pytest

distributed = pytest.importorskip("distributed")

from delta_pin.cli import main  # noqa: E402
from delta_pin.errors import SchedulerUnreachableError  # noqa: E402
from delta_pin.studies import sweep  # noqa: E402

MARGIN = 2.0  # [s] beyond the deadline


@pytest.fixture
def peer():
    """A TCP peer that accepts and then sends ``reply`` (nothing: it never answers)."""
    sockets = []

    def start(reply: bytes) -> str:
        server = socket.socket()
        server.bind(("127.0.0.1", 0))
        server.listen(8)
        sockets.append(server)

        def serve():
            while True:
                try:
                    connection, _ = server.accept()
                except OSError:
                    return
                sockets.append(connection)
                if reply:
                    connection.sendall(reply)

        threading.Thread(target=serve, daemon=True).start()
        return f"tcp://127.0.0.1:{server.getsockname()[1]}"

    yield start
    for s in sockets:
        s.close()


@pytest.mark.parametrize(
    ("reply", "said"),
    [
        (b"", "TimeoutError"),  # accepts, never answers
        (b"\xff" * 8, "broke Dask's protocol"),  # 8 bytes: a frame count of 2^64 - 1
        (b"\x01" + b"\x00" * 7 + b"\xff" * 8, "broke Dask's protocol"),  # one frame of 2^64 - 1 bytes
        (b"HTTP/1.0 200 OK\r\n\r\nhello", "broke Dask's protocol"),  # a web server
    ],
    ids=["silent", "8 bytes", "exabyte frame", "http"],
)
def test_a_peer_that_is_not_a_scheduler_is_refused_within_the_deadline(peer, reply, said):
    address = peer(reply)
    start = time.perf_counter()
    with (
        pytest.raises(
            SchedulerUnreachableError, match=f"no Dask scheduler answers at --scheduler {address}"
        ) as e,
        sweep._backend("dask", None, address),
    ):
        pass
    waited = time.perf_counter() - start
    assert said in str(e.value)
    assert waited < sweep.SCHEDULER_TIMEOUT + MARGIN, waited


def test_the_command_says_it_in_one_line(peer, tmp_path, capsys):
    address = peer(b"")
    argv = [
        "sweep",
        "--param",
        "delta_m=0:0.3:2",
        "--t-end",
        "0.1",
        "--scheduler",
        address,
        "--out",
        str(tmp_path),
    ]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"no Dask scheduler answers at --scheduler {address} within 5 s" in err[0], err


def test_a_real_scheduler_passes_the_probe():
    cluster = distributed.LocalCluster(n_workers=1, processes=False, dashboard_address=None)
    try:
        sweep._probe_scheduler(cluster.scheduler_address, sweep.SCHEDULER_TIMEOUT)
        with sweep._backend("dask", None, cluster.scheduler_address) as run_all:
            assert list(run_all(lambda x: x + 1, [("a", (1,))])) == [("a", 2)]
    finally:
        cluster.close()
