"""Every ```python block of README.md runs as pasted: each in a fresh interpreter, in an empty
folder, with HOME there too, so a snippet that leans on an earlier one, on a file of the checkout or
on the user's home fails here. Shell blocks are not run."""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"
FENCE = re.compile(r"^```python[ \t]*\n(.*?)^```[ \t]*$", re.DOTALL | re.MULTILINE)
TIMEOUT_S = 120


def python_blocks(text: str) -> list[str]:
    return [match.group(1) for match in FENCE.finditer(text)]


BLOCKS = python_blocks(README.read_text(encoding="utf-8"))


def first_line(block: str) -> str:
    return next((line for line in block.splitlines() if line.strip()), "")


def test_readme_has_python_blocks():
    assert BLOCKS, f"no ```python block found in {README}"


def test_fence_pattern_finds_blocks():
    text = "intro\n```python\nprint(1)\n```\n```bash\nls\n```\n```python\nx = 2\n```\n"
    assert python_blocks(text) == ["print(1)\n", "x = 2\n"]


def run_block(block: str, folder: Path, what: str) -> None:
    """Run ``block`` in a fresh interpreter in ``folder`` (HOME there, matplotlib headless);
    fail naming ``what`` and the block's first line unless it exits 0 within TIMEOUT_S."""
    env = {**os.environ, "HOME": str(folder), "MPLBACKEND": "Agg"}
    try:
        done = subprocess.run(
            [sys.executable, "-c", block],
            cwd=folder,
            env=env,
            capture_output=True,
            text=True,
            timeout=TIMEOUT_S,
        )
    except subprocess.TimeoutExpired:
        pytest.fail(f"{what} starting {first_line(block)!r} ran past {TIMEOUT_S} s")
    assert done.returncode == 0, (
        f"{what} starting {first_line(block)!r} exited {done.returncode}:\n"
        f"{done.stdout[-2000:]}\n{done.stderr[-4000:]}"
    )


@pytest.mark.parametrize("block", BLOCKS, ids=[f"block{i + 1}" for i in range(len(BLOCKS))])
def test_readme_block_runs_as_pasted(block, tmp_path):
    run_block(block, tmp_path, "README block")
