"""Ctrl-C while ``reproduce`` draws its figures (issue 36, item 4): the forked child that draws
every other figure must not print a traceback, must not outlive the command, and the command
prints its one line and exits 130. Deterministic: the parent's first figure job sends SIGINT to
the whole process group (as a terminal's Ctrl-C does) while the child is inside its own job."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

SCRIPT = r"""
import os, signal, sys, time
from pathlib import Path
from delta_pin import cli
from delta_pin.studies import reproduce

def child_job():  # drawn by the forked child: interrupted inside it
    time.sleep(10)

def parent_job():
    time.sleep(1.0)  # the child is inside child_job by now
    os.killpg(0, signal.SIGINT)
    time.sleep(10)

reproduce._figure_jobs = lambda result, figures: [(None, parent_job, (), {}), (None, child_job, (), {})]

def command(args):
    reproduce._write_figures(None, Path(sys.argv[1]), workers=2)
    return 0

cli._cmd_reproduce = command  # build_parser reads it when it builds
sys.exit(cli.main(["reproduce", "--out", sys.argv[1]]))
"""


@pytest.mark.skipif(sys.platform != "linux", reason="the figure child is forked on Linux")
def test_ctrl_c_while_the_figures_are_drawn_is_one_line_and_leaves_no_child(tmp_path: Path):
    process = subprocess.Popen(
        [sys.executable, "-c", SCRIPT, str(tmp_path / "out")],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group: the SIGINT goes to it and its child only
    )
    try:
        _, stderr = process.communicate(timeout=60)
    finally:
        leftover = _group_alive(process.pid, wait=5.0)  # the child ends with its parent
        if leftover:
            os.killpg(process.pid, signal.SIGKILL)
    assert process.returncode == 130, stderr
    assert stderr.strip() == "delta-pin reproduce: interrupted; rerun the same command to resume"
    assert not leftover, "a process of the command's group outlived it"


def _group_alive(group: int, wait: float) -> bool:
    """Whether a process of ``group`` still lives after ``wait`` seconds."""
    deadline = time.monotonic() + wait
    while True:
        try:
            os.killpg(group, 0)
        except ProcessLookupError:
            return False
        if time.monotonic() > deadline:
            return True
        time.sleep(0.05)
