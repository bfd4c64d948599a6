#!/usr/bin/env bash
# Issue 23's wheel check: `pip wheel .` from a clean clone, then the wheel installed in a fresh
# venv and run with no C++ compiler on PATH (the compiled core must come in the wheel, nothing
# compiled at run time on the core's paths). Usage: bash scripts/check_wheel.sh [work folder]
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
work="${1:-$(mktemp -d)}"
mkdir -p "$work"
echo "check_wheel: working in $work"
git clone --quiet "$repo" "$work/clone"
python3 -m venv "$work/build-venv"
"$work/build-venv/bin/python" -m pip install --quiet --upgrade pip
start=$(date +%s)
"$work/build-venv/bin/python" -m pip wheel --quiet --no-deps -w "$work/wheels" "$work/clone"
echo "check_wheel: pip wheel took $(($(date +%s) - start)) s"
python3 -m venv "$work/run-venv"
"$work/run-venv/bin/python" -m pip install --quiet "$work"/wheels/delta_pin-*.whl
mkdir -p "$work/no-compiler" "$work/home"
cat > "$work/run.py" <<'PY'
import shutil

import numpy as np

import delta_pin as dp

for tool in ("c++", "g++", "cc", "gcc", "clang++"):
    assert shutil.which(tool) is None, f"{tool} is on PATH: the check needs it hidden"
robot = dp.load_robot("five_bar")
nominal = dp.ClosedChainNominalModel(robot)
path = dp.JointSinusoid(robot.home, amplitude=0.1, frequency=0.5)
sampled = dp.simulate(robot, dp.design1(nominal, sampling_period=1e-3), path, t_end=1.0, alpha0=robot.home)
continuous = dp.simulate(robot, dp.design1(nominal), path, t_end=1.0, mode="continuous", alpha0=robot.home)
assert sampled.metadata.get("core_plant") and continuous.metadata.get("core_plant")
assert continuous.metadata["integrator"] == "radau"
assert np.abs(continuous.alpha - continuous.alpha_d).max() < 1e-3
print(
    f"check_wheel: the core runs from the wheel without a compiler: sampled {sampled.metadata['wall_time']:.3f} s, "
    f"continuous {continuous.metadata['wall_time']:.3f} s (1 s of the five-bar each)"
)
PY
cd "$work"
env -i HOME="$work/home" PATH="$work/run-venv/bin:$work/no-compiler" "$work/run-venv/bin/python" "$work/run.py"
