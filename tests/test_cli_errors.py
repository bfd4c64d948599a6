"""One error path for the whole command (issue 15): every expected failure of every subcommand is
one line on stderr that names the bad value, exit code 2 for bad input, 130 for Ctrl-C, and no
traceback unless ``--debug``. Every case fails before anything is simulated."""

import errno
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from delta_pin import cli
from delta_pin.cli import main
from delta_pin.errors import InvalidParameterError
from delta_pin.model.loaders import shipped_robot
from delta_pin.sim.run import ARRAYS
from delta_pin.studies import sweep as sweep_module

SCHEDULER = "tcp://127.0.0.1:1"  # nothing listens there
SHORT = ["--t-end", "0.1", "--workers", "1"]
SAMPLED = ["--plant", "analytic", "--mode", "sampled"]

# (argv, exit code, text the one line must contain); {file}: an existing file, {dir}: an existing
# folder, {out}: a fresh output folder, {binary}: random bytes, {npz}: a truncated run.npz,
# {missing}: a path that does not exist
CASES = [
    # the command itself
    (["nope"], 2, "'nope'"),
    ([], 2, "required: command"),
    # urdf
    (["urdf", "-o", "{dir}"], 2, "--output {dir} is a directory"),
    (["urdf", "-o", "{file}/x.urdf"], 2, "{file} is a file, not a folder"),
    (["urdf", "--set", "l_a=-1"], 2, "l_a='-1'"),
    (["urdf", "--set", "oops"], 2, "'oops'"),
    # validate
    (["validate", "--seed", "-1"], 2, "seed=-1"),
    (["validate", "--samples", "0"], 2, "--samples: 0 must be an integer >= 1"),
    (["validate", "--tol", "abc"], 2, "'abc'"),
    (["validate", "--urdf", "{binary}"], 2, "{binary}' is not text"),
    (["validate", "--urdf", "{missing}"], 2, "{missing}' does not exist"),
    (["validate", "--urdf", "{file}"], 2, "{file}': the URDF is not valid XML"),
    # a broken xacro, a binary robot.yaml: the file named (issue 25: "unexpected XacroException")
    (["validate", "--urdf", "{xacro}"], 2, "xacro file '{xacro}' does not expand (XacroException: Undefined"),
    (
        ["validate", "--robot", "{xacro}"],
        2,
        "xacro file '{xacro}' does not expand (XacroException: Undefined",
    ),
    (["validate", "--robot", "{gepetto}"], 2, "robot.yaml' is not text (a binary file?)"),
    (["validate", "--tol", "-5"], 2, "tol=-5.0 must be > 0"),
    # work without a bound (issue 36, item 3; before: --duration 1e9 ran until killed)
    (
        ["validate", "--robot", "five_bar", "--duration", "1e9"],
        2,
        "energy_duration=1e+09 s (--duration) is longer than the 60 s the energy check takes",
    ),
    (
        ["validate", "--robot", "five_bar", "--samples", "1000000"],
        2,
        "--samples: 1000000 must be an integer >= 1 and <= 100000",
    ),
    (
        ["validate", "--robot", "five_bar", "--tol", "-5"],
        2,
        "tol=-5.0 must be a finite relative tolerance > 0",
    ),
    # run
    (["run", "--out", "{file}"], 2, "--out {file} is a file; give a directory"),
    (["run", "--out", "{file}/sub"], 2, "{file} is a file, not a folder"),
    (["run", "--out", "{out}", "--html", "{dir}"], 2, "--html {dir} is a directory"),
    # an --html in place of the run's own files, or of its folder: refused before the run (issue 25)
    (
        ["run", "--out", "{out}", "--html", "{out}/run.npz"],
        2,
        "--html {out}/run.npz would overwrite the run's",
    ),
    (["run", "--out", "{out}", "--html", "{out}/summary.json"], 2, "overwrite the run's own summary.json"),
    (["run", "--out", "{out}", "--html", "{out}/"], 2, "'{out}/' names a folder, not a page: give a file"),
    (["run", "--out", "{out}", "--html", "{out}"], 2, "--html {out} is the output folder --out {out}"),
    (["run", "--out", "{out}", "--html", ""], 2, "'' is not a file name"),
    (["run", "--t-end", "-1", "--out", "{out}"], 2, "--t-end: -1 must be a finite number of seconds > 0"),
    (["run", "--dt", "inf", "--out", "{out}"], 2, "--dt: inf must be a finite number of seconds > 0"),
    (["run", "--t-end", "1e7", "--out", "{out}"], 2, "--t-end 1e+07"),
    (["run", "--dt", "1e-12", "--out", "{out}"], 2, "--dt 1e-12"),
    (["run", "--dt", "-1", "--out", "{out}"], 2, "--dt: -1 must be a finite number of seconds > 0"),
    (["run", "--dt", "nan", "--out", "{out}"], 2, "--dt: nan must be a finite number of seconds > 0"),
    (["run", "--dt", "0", "--out", "{out}"], 2, "--dt: 0 must be a finite number of seconds > 0"),
    (["run", "--t-end", "nan", "--out", "{out}"], 2, "--t-end: nan must be a finite number of seconds"),
    # a negative number in e-notation as its own word is the option's value, not an option (issue 25)
    (["run", "--dt", "-1e-3", "--out", "{out}"], 2, "--dt: -1e-3 must be a finite number of seconds > 0"),
    (["run", "--t-end", "-2E1", "--out", "{out}"], 2, "--t-end: -2E1 must be a finite number of seconds > 0"),
    # a delay no shorter than the run, refused up front (issue 25: 39 s, then "non-finite torque")
    (
        ["run", *SAMPLED, "--t-end", "1", "--delay", "5000", "--out", "{out}"],
        2,
        "delay=5000 samples is not shorter than the run, 1001 samples (t_end 1 s at dt 0.001 s)",
    ),
    (["run", "--robot", "{xacro}", "--out", "{out}"], 2, "xacro file '{xacro}' does not expand"),
    (["run", "--controller", "nope", "--out", "{out}"], 2, "'nope'"),
    (["run", "--seed", "-3", "--plant", "analytic", "--out", "{out}"], 2, "seed=-3"),
    (["run", "--uncertainty", "1.5", "--plant", "analytic", "--out", "{out}"], 2, "1.5"),
    (["run", "--controller", "tdc", "--plant", "analytic", "--out", "{out}"], 2, "'tdc'"),
    (["run", "--urdf", "{binary}", "--out", "{out}"], 2, "{binary}' is not text"),
    (["run", "--set", "wingspan=2", "--out", "{out}"], 2, "'wingspan'"),
    # LSODA left the package with the Python loop (the reference in tests/reference)
    (["run", "--integrator", "lsoda", "--out", "{out}"], 2, "invalid choice: 'lsoda'"),
    # options of one run path given to the other are refused, never ignored (issue 25)
    (
        [
            "run",
            "--robot",
            "five_bar",
            "--mode",
            "sampled",
            "--encoder-bits",
            "17",
            "--delay",
            "5",
            "--torque-limit",
            "0.0001",
            "--uncertainty",
            "0.9",
            "--plant",
            "analytic",
            "--integrator",
            "radau",
            "--out",
            "{out}",
        ],
        2,
        "--plant, --integrator, --uncertainty, --encoder-bits, --delay, --torque-limit apply to the packaged",
    ),
    (["run", "--robot", "five_bar", "--path", "II", "--out", "{out}"], 2, "--path applies to the packaged"),
    (["run", "--radius", "0.05", "--out", "{out}"], 2, "--radius applies with --robot PATH only"),
    (["run", "--frame", "tip", "--out", "{out}"], 2, "--frame applies with --robot PATH only"),
    # compare: an empty list names nothing (issue 25: "unexpected ValueError")
    (["compare", "--controllers", ",", "--out", "{out}"], 2, "--controllers ',' names nothing"),
    (["compare", "--paths", "", "--out", "{out}"], 2, "--paths '' names nothing"),
    # view
    (["view", "{missing}"], 2, "{missing}' does not exist"),
    (["view", "{npz}"], 2, "{npz}' is not a readable delta-pin run"),
    (["view", "{binary}"], 2, "{binary}' is not a readable delta-pin run"),
    # identify (issue 24; the log's own errors: tests/identification/test_bad_input.py)
    (["identify", "fit", "--data", "{missing}", "--out", "{out}"], 2, "{missing}: no such file"),
    (["identify", "fit", "--data", "{binary}", "--out", "{out}"], 2, "{binary} is not a text file"),
    (
        ["identify", "simulate", "--trajectory", "{file}", "--out", "{out}/log.csv"],
        2,
        "no '# fourier:' header",
    ),
    # identify's numbers, refused by the parser (issue 36, item 6; before: "unexpected
    # ZeroDivisionError" for --rate 0, "unexpected ValueError: arange" for nan, for --seed -1 too)
    (
        ["identify", "excite", "--out", "{out}/x.csv", "--rate", "0"],
        2,
        "--rate: 0 must be a finite number > 0",
    ),
    (
        ["identify", "excite", "--out", "{out}/x.csv", "--rate", "nan"],
        2,
        "--rate: nan must be a finite number > 0",
    ),
    (
        ["identify", "excite", "--out", "{out}/x.csv", "--rate", "inf"],
        2,
        "--rate: inf must be a finite number > 0",
    ),
    # plan
    (["plan", "--out", "{out}"], 2, "--torque-limit"),
    (["plan", "--torque-limit", "20", "--out", "{file}"], 2, "--out {file} is a file"),
    (["plan", "--torque-limit", "abc", "--out", "{out}"], 2, "--torque-limit 'abc'"),
    (
        ["plan", "--torque-limit", "20", "--points", "2", "--out", "{out}"],
        2,
        "--points: 2 must be an integer >= 3",
    ),
    (["plan", "--torque-limit", "20", "--blend", "nan", "--out", "{out}"], 2, "--blend nan"),
    (["plan", "--torque-limit", "20", "--rate", "1e9", "--out", "{out}"], 2, "--rate 1e+09 Hz: at most"),
    (["plan", "--torque-limit", "20", "--center", "0", "--out", "{out}"], 2, "--center '0'"),
    (["plan", "--torque-limit", "20", "--corners=0,0,-0.4", "--out", "{out}"], 2, "corners must be"),
    (["plan", "--torque-limit", "20", "--robot", "{missing}", "--out", "{out}"], 2, "{missing}"),
    (["plan", "--torque-limit", "20", "--robot", "stewart", "--map", "--out", "{out}"], 2, "--map"),
    (["identify", "excite", "--out", "{out}/x.csv", "--seed", "-1"], 2, "--seed: -1 must be an integer >= 0"),
    (
        ["identify", "excite", "--out", "{out}/x.csv", "--iterations", "1000000000"],
        2,
        "--iterations: 1000000000 must be an integer >= 0 and <= 1000",
    ),
    (
        ["identify", "excite", "--out", "{out}/x.csv", "--harmonics", "100000"],
        2,
        "--harmonics: 100000 must be an integer >= 1 and <= 100",
    ),
    (
        ["identify", "excite", "--out", "{out}/x.csv", "--harmonics", "40", "--rate", "10"],
        2,
        "--harmonics 40 over --period 5 s reach 8 Hz, at or above the Nyquist frequency of --rate 10 Hz",
    ),
    (
        ["identify", "excite", "--out", "{out}/x.csv", "--duration", "1e9"],
        2,
        "--duration 1e+09 s at --rate 1000 Hz is 1e+12 samples; at most 1e+07",
    ),
    (
        ["identify", "excite", "--out", "{out}/x.csv", "--velocity-limit", "0"],
        2,
        "--velocity-limit: 0 must be a finite number > 0",
    ),
    (
        ["identify", "simulate", "--trajectory", "{file}", "--out", "{out}/log.csv", "--torque-noise", "nan"],
        2,
        "--torque-noise: nan must be a finite number >= 0",
    ),
    (
        ["identify", "simulate", "--trajectory", "{file}", "--out", "{out}/log.csv", "--mass-spread", "1"],
        2,
        "--mass-spread: 1 must be a finite number >= 0 and < 1",
    ),
    (
        ["identify", "fit", "--data", "{file}", "--out", "{out}", "--cutoff", "-3"],
        2,
        "--cutoff: -3 must be a finite",
    ),
    # runs whose arrays or metadata are not what Run.save writes (issue 25: "unexpected ...")
    (
        ["view", "{run_list_metadata}"],
        2,
        "is not a delta-pin run: its metadata is a JSON list, expected an object",
    ),
    (["view", "{run_short_alpha}"], 2, "is not a delta-pin run: alpha has shape (4, 3), expected (10, 3)"),
    (["view", "{run_reversed_t}"], 2, "is not a delta-pin run: t does not increase at sample 1"),
    (["view", "{run_text_tau}"], 2, "is not a delta-pin run: tau holds <U"),
    (
        ["view", "{run_string_robot}"],
        2,
        "is not a delta-pin run: its metadata's 'robot' is a JSON str, expected an object",
    ),
    # compare
    (["compare", "--out", "{file}"], 2, "--out {file} is a file"),
    (["compare", "--controllers", "nope", "--paths", "I", *SHORT, "--out", "{out}"], 2, "'nope'"),
    (["compare", "--t-end", "1e7", "--out", "{out}"], 2, "--t-end 1e+07"),
    (["compare", "--workers", "0", "--out", "{out}"], 2, "--workers: 0 must be an integer >= 1"),
    (["compare", "--set", "wingspan=2", "--out", "{out}"], 2, "'wingspan'"),
    (
        [
            "compare",
            "--controllers",
            "design1",
            "--paths",
            "I",
            "--t-end",
            "0.1",
            "--scheduler",
            SCHEDULER,
            "--out",
            "{out}",
        ],
        2,
        f"--scheduler {SCHEDULER}",
    ),
    # sweep
    (["sweep", "--param", "delta_m=0:0.9:2", "--out", "{file}"], 2, "--out {file} is a file"),
    (["sweep", "--param", "delta_m=oops", "--out", "{out}"], 2, "'oops' is not a valid delta_m"),
    (
        ["sweep", "--param", "delta_m=0:0.9:1000", "--param", "delta_f=0:0.9:1000", "--out", "{out}"],
        2,
        "1,000,000 points",
    ),
    (["sweep", "--param", "delta_m=0,0.3", "--t-end", "1e7", "--out", "{out}"], 2, "--t-end 1e+07"),
    (["sweep", "--param", "delta_m=0,0.3", "--metric", "nope", *SHORT, "--out", "{out}"], 2, "'nope'"),
    # a point's value refused up front, naming the point (issue 25: failed points, ZeroDivisionError)
    (["sweep", "--param", "dt=0", "--out", "{out}"], 2, "the grid's point dt=0.0: dt=0.0 must be a finite"),
    (["sweep", "--param", "t_end=-1", "--out", "{out}"], 2, "point t_end=-1.0: t_end=-1.0 must be a finite"),
    (
        ["sweep", "--controller", "lqr", "--param", "dt=0.001,0", "--out", "{out}"],
        2,
        "the grid's point dt=0.0: dt=0.0 must be a finite number of seconds > 0",
    ),
    (
        ["sweep", "--param", "velocity=bogus", "--out", "{out}"],
        2,
        "velocity='bogus' must be one of difference",
    ),
    (["sweep", "--param", "xi=abc", "--out", "{out}"], 2, "gains {{'xi': 'abc'}} are not valid"),
    (
        ["sweep", "--mode", "sampled", "--t-end", "1", "--param", "delay=0,5000", "--out", "{out}"],
        2,
        "point delay=5000: delay=5000 samples is not shorter than the run",
    ),
    # the memory guard on every point, not only the base (issue 25: ~1e9 samples, then a traceback)
    (
        ["sweep", "--param", "dt=0.001,1e-8", "--out", "{out}"],
        2,
        "the grid's largest point: --t-end 15 at --dt 1e-08",
    ),
    (
        ["sweep", "--param", "delta_m=0,0.3", "--t-end", "0.1", "--scheduler", SCHEDULER, "--out", "{out}"],
        2,
        f"--scheduler {SCHEDULER}",
    ),
    # reproduce
    (["reproduce", "--out", "{file}"], 2, "--out {file} is a file"),
    (["reproduce", "--quick", "--full"], 2, "--full"),
    (["reproduce", "--workers", "-1", "--out", "{out}"], 2, "--workers: -1 must be an integer >= 1"),
    (["reproduce", "--set", "wingspan=2", "--out", "{out}"], 2, "'wingspan'"),
    (["reproduce", "--scheduler", SCHEDULER, "--out", "{out}"], 2, f"--scheduler {SCHEDULER}"),
]


@pytest.fixture
def paths(tmp_path, monkeypatch):
    monkeypatch.setattr(sweep_module, "SCHEDULER_TIMEOUT", 0.5)  # [s] keep the unreachable case short
    (tmp_path / "a_file").write_text("not a folder\n")
    (tmp_path / "a_dir").mkdir()
    (tmp_path / "binary.urdf").write_bytes(np.random.default_rng(0).bytes(256) + b"\xff\xfe")
    np.savez(tmp_path / "whole.npz", t=np.zeros(1000))
    (tmp_path / "truncated.npz").write_bytes((tmp_path / "whole.npz").read_bytes()[:300])
    (tmp_path / "broken.xacro").write_text(
        '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">\n'
        '  <xacro:macro name="m" params="a"><link name="${a}"/></xacro:macro>\n  <xacro:m/>\n</robot>\n'
    )
    gepetto = tmp_path / "gepetto"
    gepetto.mkdir()
    (gepetto / "robot.urdf").write_text(shipped_robot("delta_gepetto").read_text())
    (gepetto / "robot.yaml").write_bytes(b"\xff\xfe\x00" + np.random.default_rng(1).bytes(64))
    names = ("list_metadata", "short_alpha", "reversed_t", "text_tau", "string_robot")
    runs = {name: _run_arrays() for name in names}
    runs["list_metadata"]["metadata_json"] = np.array("[1, 2]")
    runs["string_robot"]["metadata_json"] = np.array(
        json.dumps({"controller": {"name": "x"}, "robot": "delta"})
    )
    runs["short_alpha"]["alpha"] = runs["short_alpha"]["alpha"][:4]
    runs["reversed_t"]["t"] = runs["reversed_t"]["t"][::-1].copy()
    runs["text_tau"]["tau"] = runs["text_tau"]["tau"].astype(str)
    for name, arrays in runs.items():
        np.savez(tmp_path / f"{name}.npz", **arrays)
    return {
        **{f"run_{name}": str(tmp_path / f"{name}.npz") for name in runs},
        "xacro": str(tmp_path / "broken.xacro"),
        "gepetto": str(gepetto / "robot.urdf"),
        "file": str(tmp_path / "a_file"),
        "dir": str(tmp_path / "a_dir"),
        "out": str(tmp_path / "out"),
        "binary": str(tmp_path / "binary.urdf"),
        "npz": str(tmp_path / "truncated.npz"),
        "missing": str(tmp_path / "missing.npz"),
    }


def _run_arrays(samples: int = 10) -> dict:
    """The arrays of a run.npz as Run.save writes them, of a 3-joint run of ``samples`` samples."""
    arrays = {name: np.zeros((samples, 3)) for name in ARRAYS}
    arrays["t"] = np.arange(samples) * 1e-3
    arrays["closure_residual"] = np.zeros(samples)
    arrays["metadata_json"] = np.array(json.dumps({"controller": {"name": "design1"}}))
    return arrays


def _one_line(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]


def _case_id(case) -> str:
    return " ".join(case[0])[:60] or "(no command)"


@pytest.mark.parametrize(("argv", "code", "text"), CASES, ids=[_case_id(c) for c in CASES])
def test_bad_input_is_one_line_naming_the_value(paths, capsys, argv, code, text):
    argv = [arg.format(**paths) for arg in argv]
    start = time.perf_counter()
    assert main(argv) == code
    line = _one_line(capsys)
    command = argv[0] if argv and argv[0] in cli.build_parser()._subparsers._group_actions[0].choices else ""
    prefixes = [f"delta-pin {command}".rstrip()]
    if command == "identify" and len(argv) > 1:  # argparse names the action too: "delta-pin identify fit"
        prefixes.append(f"delta-pin identify {argv[1]}")
    assert any(line.startswith(prefix + ": error: ") for prefix in prefixes), line
    assert text.format(**paths) in line
    assert time.perf_counter() - start < 20.0  # [s] it failed up front (the scheduler waits 0.5 s)
    assert not os.path.exists(os.path.join(paths["out"], "run.npz"))


def test_every_subcommand_is_in_the_table():
    commands = set(cli.build_parser()._subparsers._group_actions[0].choices)
    assert commands == {case[0][0] for case in CASES if case[0] and case[0][0] != "nope"}


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write anywhere")
def test_an_output_folder_without_write_permission_is_refused(tmp_path, capsys):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o555)
    try:
        for argv in (["run"], ["compare"], ["sweep", "--param", "delta_m=0,0.3"], ["reproduce"]):
            assert main([*argv, "--out", str(locked / "out")]) == 2
            assert f"--out {locked / 'out'} is not writable" in _one_line(capsys)
        assert main(["urdf", "-o", str(locked / "x.urdf")]) == 2
        assert "is not writable" in _one_line(capsys)
    finally:
        locked.chmod(0o755)


def test_run_refuses_an_output_file_before_simulating(tmp_path, capsys, monkeypatch):
    """`run` used to simulate first and fail when saving; now nothing runs."""
    import delta_pin.studies.experiments as experiments

    def never(*args, **kwargs):
        raise AssertionError("simulated")

    monkeypatch.setattr(experiments, "run_spec", never)
    (tmp_path / "x").write_text("")
    assert main(["run", "--plant", "analytic", "--out", str(tmp_path / "x")]) == 2
    assert _one_line(capsys) == f"delta-pin run: error: --out {tmp_path / 'x'} is a file; give a directory"


def test_the_size_guard_gives_its_estimate_and_force_lifts_it(tmp_path, capsys, monkeypatch):
    import delta_pin.studies.experiments as experiments

    assert main(["run", "--t-end", "1e7", "--out", str(tmp_path)]) == 2
    line = _one_line(capsys)
    assert "1e+10 samples: about 23.3 TiB of arrays" in line and "--force" in line  # 1e10 x 2560 bytes
    calls = []
    monkeypatch.setattr(experiments, "run_spec", lambda *a, **k: calls.append(a) or (_ for _ in ()).throw(
        KeyboardInterrupt))  # fmt: skip
    assert main(["run", "--t-end", "1e7", "--force", "--plant", "analytic", "--out", str(tmp_path)]) == 130
    assert len(calls) == 1  # --force: it ran (and was interrupted at once)
    capsys.readouterr()


def test_a_large_sweep_runs_with_force(tmp_path, capsys, monkeypatch):
    import delta_pin.studies.reproduce as reproduce

    seen = []
    monkeypatch.setattr(reproduce, "sweep", lambda base, axes, out, **k: seen.append(axes) or [])
    argv = ["sweep", "--param", "delta_m=0:0.9:400", "--param", "xi=0.001:0.01:400", "--out", str(tmp_path)]
    assert main(argv) == 2
    assert "160,000 points (delta_m 400 x xi 400), more than 100,000" in _one_line(capsys)
    assert main([*argv, "--force"]) == 0 and len(seen) == 1


def test_debug_shows_the_traceback(tmp_path):
    (tmp_path / "x").write_text("")
    with pytest.raises(InvalidParameterError, match="is a file"):
        main(["--debug", "run", "--out", str(tmp_path / "x")])
    with pytest.raises(InvalidParameterError, match="is a file"):
        main(["run", "--debug", "--out", str(tmp_path / "x")])


def test_an_unexpected_error_is_one_line_and_exit_1(tmp_path, capsys, monkeypatch):
    import delta_pin.model.description as description

    def broken(**kwargs):
        raise ZeroDivisionError("a bug")

    monkeypatch.setattr(description, "compile_urdf", broken)
    assert main(["urdf"]) == 1
    assert _one_line(capsys) == (
        "delta-pin urdf: error: unexpected ZeroDivisionError: a bug (rerun with --debug for the traceback)"
    )


# every command, interrupted inside its work: (argv, function to interrupt, resumable)
INTERRUPTS = [
    (["urdf"], "delta_pin.model.description.compile_urdf", False),
    (["validate"], "delta_pin.model.validation.validate", False),
    (["run", "--plant", "analytic", "--out", "{out}"], "delta_pin.studies.experiments.run_spec", False),
    (["view", "{run}"], "delta_pin.viz.meshcat_export.view_live", False),
    (["compare", "--out", "{out}"], "delta_pin.studies.reproduce.compare", True),
    (["sweep", "--param", "delta_m=0,0.3", "--out", "{out}"], "delta_pin.studies.reproduce.sweep", True),
    (["reproduce", "--out", "{out}"], "delta_pin.studies.reproduce.reproduce", True),
]


@pytest.mark.parametrize(("argv", "target", "resumable"), INTERRUPTS, ids=[i[0][0] for i in INTERRUPTS])
def test_ctrl_c_is_one_line_and_exit_130(tmp_path, capsys, monkeypatch, argv, target, resumable):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(target, interrupted)
    argv = [arg.format(out=tmp_path / "out", run=tmp_path / "run.npz") for arg in argv]
    assert main(argv) == 130
    expected = "interrupted; rerun the same command to resume" if resumable else "interrupted"
    assert _one_line(capsys) == f"delta-pin {argv[0]}: {expected}"


@pytest.mark.parametrize(
    ("signum", "group", "code"),
    [(signal.SIGINT, True, 130), (signal.SIGTERM, False, 143)],
    ids=["Ctrl-C to the group", "SIGTERM to the command"],
)
def test_ctrl_c_of_a_real_reproduction(tmp_path, signum, group, code):
    """SIGINT to the whole process group, as a terminal's Ctrl-C: the command and its worker
    processes stop, one line, exit 130, no traceback from anyone. SIGTERM to the command alone,
    as a supervisor's ``kill``: the same line, exit 143 (128 + SIGTERM); it used to end the
    command silently (issue 25). Either way the folder stays marked unfinished."""
    process = subprocess.Popen(
        [sys.executable, "-m", "delta_pin.cli", "reproduce", "--workers", "2", "--out", str(tmp_path)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group, which the signal goes to
    )
    try:
        assert "delta-pin reproduce:" in process.stdout.readline()  # the runs have started
        time.sleep(2.0)
        (os.killpg if group else os.kill)(process.pid, signum)
        _, err = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
    assert process.returncode == code, err
    assert "Traceback" not in err
    assert err.strip().splitlines() == ["delta-pin reproduce: interrupted; rerun the same command to resume"]
    manifest = json.loads((tmp_path / "manifest.json").read_text())  # the folder is marked unfinished
    assert manifest["complete"] is False and manifest["options"]["quick"] is True


@pytest.mark.parametrize("command", ["urdf", "validate", "run", "view", "compare", "sweep", "reproduce"])
def test_help_shows_the_defaults(capsys, command):
    assert main([command, "--help"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    expected = {
        "urdf": "(default: [])",
        "validate": "random states (default: 100)",
        "run": "sample / control period [s] (default: 0.001)",
        "view": "",
        "compare": "comma-separated (default: design1,design2,lqr)",
        "sweep": "surface of this metric for two axes (default: rho_hat_max)",
        "reproduce": "output directory (default: out/reproduce)",
    }[command]
    assert expected in out
    if command != "view":  # its only option is a flag
        assert "(default: " in out


def test_run_summary_says_the_last_5_s_indices_are_nan_on_a_short_run(tmp_path, capsys):
    argv = ["run", "--plant", "analytic", "--mode", "sampled", "--sampling-aware", "--t-end", "0.3"]
    assert main([*argv, "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "note: the run lasts 0.3 s, less than the 5 s of the 'last_5s' indices: they are NaN" in out
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["metrics"]["max_joint_error_last_5s"] is None  # strict JSON: null, not NaN
    assert summary["metrics"]["iae"] > 0


def test_a_rerun_removes_the_earlier_run_s_page(tmp_path, capsys):
    """A rerun of `run` without --html left the earlier run.html beside the new results. It goes,
    as the earlier run's own (listed in its manifest.json, unchanged); a user's file stays, and a
    summary.json that no manifest lists (an older delta-pin's, or anyone's) is refused, not
    removed: it used to take the run.html beside it along (issue 25)."""
    out = tmp_path / "out"
    argv = ["run", "--plant", "analytic", "--mode", "sampled", "--sampling-aware", "--t-end", "0.1"]
    assert main([*argv, "--out", str(out), "--html", str(out / "run.html")]) == 0
    assert (out / "run.html").is_file()
    first = (out / "run.npz").stat().st_mtime_ns
    (out / "keep.txt").write_text("not a run's")
    assert main([*argv, "--out", str(out)]) == 0
    assert not (out / "run.html").exists() and (out / "keep.txt").exists()
    assert (out / "run.npz").stat().st_mtime_ns >= first
    assert json.loads((out / "summary.json").read_text())["outputs"] == [
        str((out / name).resolve()) for name in ("run.npz", "summary.json")
    ]
    # a summary written before manifests existed: refused, and nothing removed
    (out / "manifest.json").unlink()
    (out / "run.html").write_text("old page")
    capsys.readouterr()
    assert main([*argv, "--out", str(out)]) == 2
    assert "holds run.npz, which no manifest.json of delta-pin lists" in _one_line(capsys)
    assert (out / "run.html").read_text() == "old page" and (out / "keep.txt").exists()


def test_sigterm_is_ctrl_c_s_line_and_exit_143(tmp_path, capsys, monkeypatch):
    """SIGTERM of a study (here inside its sweep, as a serial one is) is Ctrl-C's one line, exit
    143; main() puts the handler it replaced back (issue 25: SIGTERM printed nothing)."""
    import delta_pin.studies.reproduce as reproduce

    def terminated(*args, **kwargs):
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(5.0)  # the handler interrupts this
        raise AssertionError("SIGTERM did not interrupt the sweep")

    monkeypatch.setattr(reproduce, "sweep", terminated)
    before = signal.getsignal(signal.SIGTERM)
    assert main(["sweep", "--param", "delta_m=0,0.3", "--out", str(tmp_path)]) == 143
    assert _one_line(capsys) == "delta-pin sweep: interrupted; rerun the same command to resume"
    assert signal.getsignal(signal.SIGTERM) is before


def test_a_law_that_accounts_for_a_delay_runs_only_with_that_delay():
    """The docs of Controller.delay say simulate checks it (issue 25: a TDC built with delay=2
    ran in a loop with delay=0); a continuous-time law with a drive delay is still accepted."""
    import delta_pin as dp
    from delta_pin.errors import InvalidParameterError

    robot = dp.load_delta()
    nominal = dp.DeltaNominalModel(robot)
    options = {"plant": "analytic", "t_end": 0.005, "mode": "sampled"}
    for built, run_with in ((2, 0), (0, 1)):
        with pytest.raises(InvalidParameterError, match=rf"accounts for delay={built} .* delay={run_with}"):
            dp.simulate(robot, dp.tdc(nominal, 1e-3, delay=built), dp.PathI(), delay=run_with, **options)
    assert dp.simulate(robot, dp.tdc(nominal, 1e-3, delay=2), dp.PathI(), delay=2, **options).t[-1] > 0
    assert dp.simulate(robot, dp.design1(nominal), dp.PathI(), delay=1, **options).t[-1] > 0


def test_a_closed_pipe_is_a_quiet_exit():
    """``delta-pin ... | head``: the reader leaves, the command stops with 141 (128 + SIGPIPE, as a
    shell reports it) and writes nothing to stderr (issue 36, item 4; before: exit 1 "unexpected
    BrokenPipeError"). The reader closes its end before the command writes (the command waits
    0.5 s after its imports), so the write meets a closed pipe whatever the pipe's buffer holds."""
    code = (
        "import sys, time\nimport delta_pin.model.description as d\nfrom delta_pin import cli\n"
        "d.compile_urdf = lambda **k: 'x' * 10_000_000\ntime.sleep(0.5)\nsys.exit(cli.main(['urdf']))\n"
    )
    process = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    process.stdout.close()
    _, err = process.communicate(timeout=120)
    assert process.returncode == 141, err
    assert err == b""


@pytest.mark.parametrize(
    ("argv", "advice"),
    [
        (["run", "--out", "{out}"], "shorten the run (--t-end) or lengthen --dt"),
        (["urdf"], "the command asked for more than this machine has; ask for less"),
    ],
)
def test_out_of_memory_advises_options_the_command_has(tmp_path, capsys, monkeypatch, argv, advice):
    """Before: every command said "shorten the run (--t-end)", which urdf, validate and identify do
    not have (issue 36, item 6)."""
    import delta_pin.model.description as description

    def exhausted(*args, **kwargs):
        raise MemoryError

    import delta_pin.studies.experiments as experiments

    monkeypatch.setattr(description, "compile_urdf", exhausted)
    monkeypatch.setattr(experiments, "check_specs", exhausted)  # run's first step after its checks
    assert main([arg.format(out=tmp_path / "o") for arg in argv]) == 1
    assert _one_line(capsys).endswith(advice)


def test_a_full_disk_is_one_line_not_an_unexpected_oserror(tmp_path, capsys, monkeypatch):
    """ENOSPC without a file name (a flush, a rename) was "unexpected OSError 28"."""
    import delta_pin.model.description as description

    def full(**kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(description, "compile_urdf", full)
    assert main(["urdf"]) == 1
    line = _one_line(capsys)
    assert "no space left on the device" in line and "free some space and rerun" in line


@pytest.mark.parametrize("command", ["compare", "sweep", "reproduce"])
def test_more_local_workers_than_memory_holds_are_refused(tmp_path, capsys, monkeypatch, command):
    """--workers N local processes need ~250 MiB each: past half of the machine's memory the command
    refuses in one line, naming the most it would take (before: --workers 64 started processes for
    over 3 minutes on a 24 GiB, 2-core machine, then ended in distributed's tracebacks)."""
    import delta_pin.studies.experiments as experiments

    monkeypatch.setattr(experiments, "memory_limit", lambda: 1024**3)  # [bytes] 1 GiB: 4 workers
    argv = {
        "compare": ["compare", "--out", str(tmp_path)],
        "sweep": ["sweep", "--param", "delta_m=0:0.3:2", "--out", str(tmp_path)],
        "reproduce": ["reproduce", "--out", str(tmp_path)],
    }[command]
    assert main([*argv, "--workers", "64", "--scheduler", "local"]) == 2
    line = _one_line(capsys)
    assert "--workers 64 local processes take about 15.6 GiB" in line and "give at most 4" in line
    assert not any(tmp_path.iterdir())  # refused before anything was written


@pytest.mark.parametrize("allow", [False, True])
def test_compare_where_every_run_fails_says_so(tmp_path, capsys, allow):
    """Every run of a compare diverges (designs I/II sampled at 10 ms): the table lists each
    failure, the command says how many failed and exits 1, or 0 with --allow-failures (issue 36,
    item 6; before: exit 2, "table must be a non-empty dict", --allow-failures ignored)."""
    argv = ["compare", "--controllers", "design1,design2", "--paths", "I", "--mode", "sampled",
            "--dt", "0.01", "--t-end", "1", "--workers", "1", "--out", str(tmp_path)]  # fmt: skip
    assert main([*argv, *(["--allow-failures"] if allow else [])]) == (0 if allow else 1)
    captured = capsys.readouterr()
    assert captured.err.strip().startswith("2 of 2 runs failed; the first: the run diverged")
    assert "metrics.csv" in captured.out
    assert json.loads((tmp_path / "manifest.json").read_text())["complete"] is True


@pytest.mark.parametrize(
    "flag", [["--path", "I"], ["--plant", "pinocchio"], ["--delay", "0"], ["--seed", "0"]]
)
def test_run_robot_refuses_a_delta_flag_given_at_its_default(tmp_path, capsys, flag):
    """--path I is run's default: given with --robot it was silently ignored (compared with the
    default, it looked absent); now any Delta-only flag on the command line is refused (issue 36,
    item 6)."""
    assert main(["run", "--robot", "five_bar", *flag, "--out", str(tmp_path / "o")]) == 2
    assert f"{flag[0]} applies to the packaged Delta's scenario, not to --robot" in _one_line(capsys)


def test_run_robot_has_the_memory_guard(tmp_path, capsys):
    """run --robot had no memory guard (issue 36, item 6): 1e9 s at 1 ms is refused with its estimate."""
    assert main(["run", "--robot", "five_bar", "--t-end", "1e9", "--out", str(tmp_path / "o")]) == 2
    line = _one_line(capsys)
    assert "--t-end 1e+09 at --dt 0.001 is 1e+12 samples of 'five_bar'" in line and "give --force" in line
    assert not (tmp_path / "o").exists()


def test_urdf_output_replaces_only_its_own_file(tmp_path, capsys):
    """urdf --output replaced any file of that name (a user's hand-edited URDF included, exit 0):
    now only one an earlier urdf --output wrote (its mark), which loads as the packaged Delta."""
    import delta_pin as dp

    mine = tmp_path / "mine.urdf"
    mine.write_text("<robot name='hand-edited'/>\n")
    assert main(["urdf", "--output", str(mine)]) == 2
    assert "exists and was not written by delta-pin urdf" in _one_line(capsys)
    assert mine.read_text() == "<robot name='hand-edited'/>\n"
    out = tmp_path / "delta.urdf"
    assert main(["urdf", "--output", str(out)]) == 0
    assert main(["urdf", "--output", str(out), "--set", "l_a=0.25"]) == 0  # its own: replaced
    capsys.readouterr()
    assert cli.URDF_MARK in out.read_text().splitlines()[1]
    assert dp.load_delta(out).params.l_a == pytest.approx(0.25, abs=1e-12)


def test_a_dangling_symbolic_link_named_like_an_output_is_kept(tmp_path, capsys):
    """A dangling symbolic link named like an output passed every existence check (Path.exists
    follows the link) and the atomic write replaced it: urdf --output, identify excite --out and a
    run's --out folder now refuse it like any file of someone else's, and the link is still there,
    still pointing where it pointed."""
    target = tmp_path / "elsewhere" / "not_yet_there"
    cases = {
        "urdf": (tmp_path / "robot.urdf", ["urdf", "--output", str(tmp_path / "robot.urdf")]),
        "excite": (
            tmp_path / "traj.csv",
            ["identify", "excite", "--out", str(tmp_path / "traj.csv"), "--duration", "1", "--period", "1"],
        ),
        "run": (
            tmp_path / "run" / "run.npz",
            ["run", "--t-end", "0.01", "--out", str(tmp_path / "run")],
        ),
    }
    for name, (link, command) in cases.items():
        link.parent.mkdir(exist_ok=True)
        link.symlink_to(target)
        assert main(command) == 2, name
        line = _one_line(capsys)
        refusals = (f"{link} is a symbolic link to {target}, which does not exist", "it may be anyone's file")
        assert link.name in line and any(refusal in line for refusal in refusals), line
        assert link.is_symlink() and os.readlink(link) == str(target), name
        assert not target.exists(), name
