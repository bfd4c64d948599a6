"""Ctrl-C inside the compiled core is prompt (issue 36, item 3).

The core's loops run with Python's GIL released, so before the poll (delta_pin/core/run/interrupt.hpp)
Python's SIGINT handler ran only when a run had finished: Ctrl-C on a long ``run`` waited for the
whole simulation (3-23 s measured on ``run --robot``). Now each loop asks Python's signal handlers
at least every 20 ms of work; these tests start a run that takes several seconds, interrupt it one
second in and require the process to be gone within 1.5 s of the signal (a bound with room for a
loaded 2-core machine: process exit and the CLI's one line, not the simulation, take that time).
"""

import os
import signal
import subprocess
import sys
import time

import pytest

PROMPT = 1.5  # [s] from the signal to the process's exit


def _interrupt(code: str, *, after: float = 1.0):
    """Start ``code`` in a fresh Python, SIGINT it ``after`` seconds past its "go" line, and return
    (seconds from the signal to its exit, exit code, stderr, seconds it ran after "go")."""
    process = subprocess.Popen(
        [sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        assert process.stdout.readline().strip() == "go", process.stderr.read()
        started = time.perf_counter()
        time.sleep(after)
        assert process.poll() is None, "the run ended before it was interrupted: make it longer"
        sent = time.perf_counter()
        process.send_signal(signal.SIGINT)
        _, err = process.communicate(timeout=120)
        ended = time.perf_counter()
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    return ended - sent, process.returncode, err, ended - started


# core runs of the Delta long enough (10 s or more uninterrupted here) that an interrupt one
# second in lands inside the compiled loop: path I in sampled mode with 200 RK4 steps a sample,
# and holding home in continuous mode for 1000 s; "go" is printed once the robot and the law are
# built (and the core warmed up), so that second is spent simulating
RUN = """
import delta_pin as dp
robot = dp.load_delta()
law = dp.design1(dp.DeltaNominalModel(robot))
dp.simulate(robot, law, None, t_end=0.05, mode="continuous")
print("go", flush=True)
if "{mode}" == "sampled":
    dp.simulate(robot, law, dp.PathI(), t_end=15.0, mode="sampled", substeps=200)
else:
    dp.simulate(robot, law, None, t_end=1000.0, mode="continuous")
"""


@pytest.mark.parametrize("mode", ["sampled", "continuous"])
def test_ctrl_c_stops_a_compiled_run_promptly(mode):
    waited, code, err, _ = _interrupt(RUN.replace("{mode}", mode))
    assert code != 0 and "KeyboardInterrupt" in err, err
    assert waited < PROMPT, f"the {mode} run took {waited:.2f} s to stop after Ctrl-C"


def test_ctrl_c_stops_the_command_promptly(tmp_path):
    """The CLI's Ctrl-C: exit 130 and its one line, within the same bound, from inside the core."""
    code = (
        "import sys\nfrom delta_pin.cli import main\nprint('go', flush=True)\n"
        f"sys.exit(main(['run', '--dt', '2e-5', '--out', {str(tmp_path)!r}]))\n"
    )
    waited, status, err, _ = _interrupt(code, after=4.0)  # [s] the command's set-up takes 1-3 s
    assert status == 130, err
    assert err.strip().splitlines()[-1].startswith("delta-pin run: interrupted"), err
    assert "Traceback" not in err
    assert waited < PROMPT, f"run took {waited:.2f} s to stop after Ctrl-C"
    assert not os.path.exists(tmp_path / "run.npz")
