"""Every example runs headless in a fast setting."""

import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
FAST = {
    "validate_model.py": ["--samples", "5"],
    "batch_tune_xi.py": ["--t-end", "0.5", "--xi", "0.001,0.05"],
    "swap_dimensions.py": [],
    "track_path_design1.py": ["--t-end", "0.3", "--plant", "analytic", "--out", "{tmp}/design1.npz"],
    "compare_controllers.py": ["--t-end", "0.2", "--out", "{tmp}/compare"],
    "sweep_on_dask.py": ["--points", "2", "--t-end", "0.2", "--out", "{tmp}/sweep"],
    "serial_robot_design1.py": ["--t-end", "1.2"],
    "export_run_html.py": ["--t-end", "0.3", "--out", "{tmp}/run.html"],
    "mujoco_digital_robust.py": ["--t-end", "1"],
    "five_bar_circle.py": ["--t-end", "0.5"],
    "delta_from_three_files.py": ["--t-end", "0.2"],
    "three_rrr_joint_space.py": ["--t-end", "0.3"],
}


def test_every_example_is_covered():
    assert sorted(p.name for p in EXAMPLES.glob("*.py")) == sorted(FAST)


@pytest.mark.parametrize("name", sorted(FAST))
def test_example_runs_headless(name, tmp_path):
    if name == "sweep_on_dask.py":
        pytest.importorskip("dask.distributed")
    if name == "serial_robot_design1.py":
        pytest.importorskip("cmeel")
    if name in ("mujoco_digital_robust.py", "delta_from_three_files.py", "three_rrr_joint_space.py"):
        pytest.importorskip("mujoco")
    args = [a.format(tmp=tmp_path) for a in FAST[name]]
    result = subprocess.run(
        [sys.executable, str(EXAMPLES / name), *args],
        capture_output=True,
        text=True,
        timeout=300,
        env={"MPLBACKEND": "Agg", "PATH": "/usr/bin:/bin", "HOME": str(tmp_path)},
        check=False,
    )
    assert result.returncode == 0, result.stderr[-2000:]
    assert result.stdout.strip()
