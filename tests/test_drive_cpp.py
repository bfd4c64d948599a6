"""examples/drive_cpp: designs I and II and the digital-robust law built as a small C++ library
without Python or Pinocchio (delta_pin/core/control/, Eigen only) from the installed package's
sources, replaying golden vectors recorded from delta-pin's readable law (make_golden.py).

The replay itself checks every torque to 1e-12 of the largest torque and every rho_hat to 1e-12
relative (the same arithmetic in another language: measured ~3e-16), and that no step allocates
on the heap (a counting operator new); this test runs it for design I (sampling-aware), design II
(the paper's law, over the 0.5 s before it diverges at 1 kHz) and the digital-robust law (one
sample of delay, a torque limit; 2 s of path I) and reads its report. The digital-robust torques
are held to 1e-10: the law is a recursion (its observer, commands and model at the estimate) that
each side carries, and its rounding differences grow to ~6e-12 by 2 s (examples/drive_cpp/main.cpp
says why); per sample the arithmetic agrees to ~1e-14 (tests/sim/test_core_laws.py)."""

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "drive_cpp"

pytestmark = pytest.mark.skipif(
    shutil.which("cmake") is None or shutil.which("c++") is None, reason="needs cmake and a C++ compiler"
)


@pytest.fixture(scope="module")
def replay(tmp_path_factory) -> Path:
    build = tmp_path_factory.mktemp("drive_build")
    configure = [
        "cmake", "-S", str(EXAMPLE), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release",
        f"-DPython_EXECUTABLE={sys.executable}",
    ]  # fmt: skip
    for command in (configure, ["cmake", "--build", str(build)]):
        done = subprocess.run(command, capture_output=True, text=True)
        assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    return build / "drive_replay"


@pytest.mark.parametrize(
    "arguments",
    [
        ["--design", "I"],
        ["--design", "II", "--paper-law", "--samples", "500"],
        ["--design", "digital-robust"],
    ],
    ids=["I", "II", "digital-robust"],
)
def test_the_c_library_replays_the_readable_law_without_allocating(replay, tmp_path, arguments):
    golden = tmp_path / "golden"
    done = subprocess.run(
        [sys.executable, str(EXAMPLE / "make_golden.py"), str(golden), *arguments],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    ran = subprocess.run(
        [str(replay), str(golden / "parameters.txt"), str(golden / "golden.csv")],
        capture_output=True,
        text=True,
    )
    report = dict(re.findall(r"^(.*?) ([-+0-9.e]+)(?: ns)?$", ran.stdout, flags=re.MULTILINE))
    assert ran.returncode == 0, ran.stdout + ran.stderr
    tolerance = 1e-10 if "digital-robust" in arguments else 1e-12  # module docstring
    assert float(report["torque tolerance"]) == tolerance
    assert float(report["largest torque error (relative to the largest torque)"]) <= tolerance
    assert float(report["largest rho_hat error (relative)"]) <= 1e-12
    assert int(report["heap allocations during the steps"]) == 0
    assert int(report["samples"]) == int(arguments[-1]) + 1 if "--samples" in arguments else 2001
