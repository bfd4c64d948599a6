"""`identify` never replaces a file it did not write (issue 36, item 1): fit writes its --out like
`run` (manifest.json, the lock, "complete": false until done, only the fixed names of
report.OUTPUTS, and only where an earlier `identify fit`'s manifest lists them unchanged); excite
and simulate never write over an input, and replace an existing --out only when its header proves
it their own. Each case was reproduced before the change (the fits exited 0 over the user's files).
"""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from delta_pin.cli import main
from delta_pin.errors import InvalidParameterError
from delta_pin.identification.log import read_log
from delta_pin.identification.report import COMMAND, OUTPUTS, write_report
from delta_pin.identification.workflow import identify
from delta_pin.utils import manifest
from delta_pin.utils.manifest import LOCK, MANIFEST, sha256

GEPETTO_FIVE_BAR = Path(__file__).parents[1] / "data" / "gepetto" / "5bar_linkage"
EXCITE = ["--duration", "2", "--period", "2", "--iterations", "0"]
ERROR = "delta-pin identify: error: "
# a Delta's fit without figures and (for speed: it takes seconds) without the consistent estimate,
# so without robot.urdf
FIT_FILES = {"parameters.json", "xacro_arguments.json", "report.md"}


def _one_line(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]


def _hashes(folder: Path) -> dict[str, str]:
    """The SHA-256 of every file under ``folder`` but the lock."""
    return {
        p.relative_to(folder).as_posix(): sha256(p)
        for p in sorted(folder.rglob("*"))
        if p.is_file() and p.name != LOCK
    }


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    """The packaged Delta's URDF as a user's CAD file (``cad/robot.urdf``), a 2 s excitation of it
    and a simulated log (masses off by up to 30 %), all through the command line."""
    root = tmp_path_factory.mktemp("identify")
    robot, trajectory, log = root / "cad" / "robot.urdf", root / "traj.csv", root / "log.csv"
    assert main(["urdf", "--output", str(robot)]) == 0
    assert main(["identify", "excite", "--robot", str(robot), "--out", str(trajectory), *EXCITE]) == 0
    simulate = ["identify", "simulate", "--robot", str(robot), "--trajectory", str(trajectory)]
    assert main([*simulate, "--mass-spread", "0.3", "--out", str(log)]) == 0
    return {"robot": robot, "trajectory": trajectory, "log": log}


def _fit(case, out: Path, *extra: str, robot: Path | None = None) -> list[str]:
    """``identify fit`` of the case's log, without the consistent estimate (FIT_FILES)."""
    robot = case["robot"] if robot is None else robot
    fit = ["identify", "fit", "--robot", str(robot), "--data", str(case["log"]), "--no-consistent"]
    return [*fit, "--out", str(out), *extra]


# ------------------------------------------------------------------------------------------ fit
def test_a_gepetto_style_folder_is_not_the_fit_s_output_folder(case, tmp_path, capsys):
    """`fit --robot D/robot.urdf --out D` replaced the user's CAD robot.urdf and report.md by the
    identified ones and exited 0: now refused before any work, every byte of D unchanged."""
    folder = tmp_path / "D"
    folder.mkdir()
    shutil.copy(case["robot"], folder / "robot.urdf")
    (folder / "report.md").write_text("the user's own report\n")
    (folder / "notes.txt").write_text("the user's notes\n")
    before = _hashes(folder)
    capsys.readouterr()
    assert main(_fit(case, folder, "--no-figures", robot=folder / "robot.urdf")) == 2
    assert _one_line(capsys) == (
        f"{ERROR}--out {folder} holds robot.urdf, the file --robot reads ({folder / 'robot.urdf'}), and "
        "identify fit writes its own robot.urdf there; give another folder, e.g. --out "
        f"{folder / 'identified'}"
    )
    assert _hashes(folder) == before and not (folder / LOCK).exists()


def test_gepetto_s_five_bar_folder_is_refused_before_its_robot_is_loaded(tmp_path, capsys):
    """The Gepetto layout itself (robot.urdf + robot.yaml + meshes): the refusal names robot.urdf,
    before the log or the robot is looked at (before, the fit stopped at the empty log here, and
    would at the five-bar's idle motion: the folder was safe only by chance). `excite --out
    D/robot.yaml` (the file beside --robot's URDF) is refused too."""
    folder = tmp_path / "5bar_linkage"
    shutil.copytree(GEPETTO_FIVE_BAR, folder)
    before = _hashes(folder)
    log = tmp_path / "log.csv"
    log.write_text("t,q[mot1],q[mot2],tau[mot1],tau[mot2]\n")
    fit = ["identify", "fit", "--robot", str(folder / "robot.urdf"), "--data", str(log), "--out", str(folder)]
    assert main(fit) == 2
    assert _one_line(capsys) == (
        f"{ERROR}--out {folder} holds robot.urdf, the file --robot reads ({folder / 'robot.urdf'}), and "
        "identify fit writes its own robot.urdf there; give another folder, e.g. --out "
        f"{folder / 'identified'}"
    )
    yaml = folder / "robot.yaml"
    excite = ["identify", "excite", "--robot", str(folder / "robot.urdf"), *EXCITE]
    assert main([*excite, "--out", str(yaml)]) == 2
    assert _one_line(capsys) == (
        f"{ERROR}--out {yaml} is the file --robot reads ({yaml}): identify excite would write over it; "
        "give another --out file"
    )
    assert _hashes(folder) == before


@pytest.mark.parametrize("name", ["robot.urdf", "report.md", "parameters.json", "torque.png"])
def test_a_user_s_file_of_a_fit_s_name_is_refused(case, tmp_path, capsys, name):
    """A file of one of the fit's names that no manifest lists may be anyone's: refused in one line,
    nothing written (not even the lock), even with --no-figures (the names are a fixed set)."""
    folder = tmp_path / "D"
    folder.mkdir()
    (folder / name).write_bytes(b"the user's own file\n")
    before = _hashes(folder)
    capsys.readouterr()
    assert main(_fit(case, folder, "--no-figures")) == 2
    assert _one_line(capsys) == (
        f"{ERROR}the output folder {folder} holds {name}, which no {MANIFEST} of delta-pin lists: it may be "
        "anyone's file; move it away, or give another folder"
    )
    assert _hashes(folder) == before and sorted(p.name for p in folder.iterdir()) == [name]


def test_a_rerun_replaces_its_own_outputs_and_keeps_the_user_s_files(case, tmp_path, capsys):
    """A fit with figures into a folder of the user's notes and figures/ folder; a rerun with other
    options replaces its outputs (the PNGs it no longer writes go) and leaves the user's files'
    bytes alone; an output the user edited since is then refused, never replaced."""
    folder = tmp_path / "ident"
    (folder / "figures").mkdir(parents=True)
    (folder / "figures" / "torque.png").write_bytes(b"the user's own figure")
    (folder / "notes.txt").write_text("the user's notes\n")
    mine = _hashes(folder)
    assert main(_fit(case, folder)) == 0, capsys.readouterr().err
    first = json.loads((folder / MANIFEST).read_text())
    assert first["complete"] is True and first["command"] == COMMAND
    pngs = {"torque.png", "residual.png", "condition.png"}
    assert set(first["files"]) == {*FIT_FILES, *pngs}
    assert {name: _hashes(folder)[name] for name in mine} == mine
    assert main(_fit(case, folder, "--no-figures", "--cutoff", "15")) == 0, capsys.readouterr().err
    second = json.loads((folder / MANIFEST).read_text())
    assert second["complete"] is True and second["options"]["cutoff"] == 15.0
    assert set(second["files"]) == FIT_FILES
    assert not any((folder / name).exists() for name in pngs)
    assert json.loads((folder / "parameters.json").read_text())["fit"]["cutoff_hz"] == 15.0
    now = _hashes(folder)
    assert {name: now[name] for name in second["files"]} == second["files"]
    assert {name: now[name] for name in mine} == mine
    (folder / "report.md").write_text("edited by the user\n")
    capsys.readouterr()
    assert main(_fit(case, folder, "--no-figures")) == 2
    assert _one_line(capsys) == (
        f"{ERROR}the output folder {folder} holds report.md, listed in its {MANIFEST} but changed since "
        "delta-pin wrote it (its SHA-256 differs): move it out of the folder, or give another folder"
    )
    assert (folder / "report.md").read_text() == "edited by the user\n"


def test_a_second_fit_is_refused_while_the_first_holds_the_folder(case, tmp_path):
    """Two fits into one --out at once both exited 0 and left one's parameters.json beside the
    other's report: the second (a subprocess here, while this test holds the lock) is refused in
    one line naming the holder's pid, and writes nothing."""
    folder = tmp_path / "ident"
    held = manifest.lock(folder)
    try:
        done = subprocess.run(
            [sys.executable, "-m", "delta_pin.cli", *_fit(case, folder, "--no-figures")],
            capture_output=True,
            text=True,
            timeout=120,
        )
    finally:
        held.release()
    assert done.returncode == 2, done.stderr
    assert done.stderr.strip() == (
        f"{ERROR}the output folder {folder} is being written by another delta-pin (pid {os.getpid()}, which "
        f"holds {folder / LOCK}); wait until it ends, or give another folder"
    )
    assert sorted(p.name for p in folder.iterdir()) == [LOCK]


def test_a_fit_stopped_midway_leaves_a_marked_folder_for_the_next_fit(case, tmp_path, capsys, monkeypatch):
    """A fit stopped after its first files (a Ctrl-C between two figures) left a folder of new and
    missing files that nothing marked: its manifest now says "complete": false and lists each file
    written so far, the first figure included, which the next fit replaces (a figure written but
    not listed would make the next fit refuse the folder as anyone's)."""
    from delta_pin.identification import report

    folder = tmp_path / "ident"
    real, saves = report._save, []

    def interrupted_at_the_second_figure(fig, path):
        saves.append(path.name)
        if len(saves) == 2:
            raise KeyboardInterrupt
        return real(fig, path)

    monkeypatch.setattr(report, "_save", interrupted_at_the_second_figure)
    assert main(_fit(case, folder)) == 130
    assert _one_line(capsys) == "delta-pin identify: interrupted"
    marked = json.loads((folder / MANIFEST).read_text())
    assert marked["complete"] is False and "files" not in marked
    assert set(marked["written"]) == {"parameters.json", "xacro_arguments.json", "torque.png"}
    assert not (folder / "report.md").exists() and not (folder / "residual.png").exists()
    monkeypatch.undo()
    assert main(_fit(case, folder, "--no-figures")) == 0, capsys.readouterr().err
    done = json.loads((folder / MANIFEST).read_text())
    assert done["complete"] is True and set(done["files"]) == FIT_FILES
    assert not (folder / "torque.png").exists()


def test_a_fit_refused_before_its_first_output_leaves_the_disk_as_it_was(case, tmp_path, capsys):
    """A log the fit refuses once the folder is claimed (0.6 s of one harmonic: rank-deficient) left
    a claimed --out behind, a folder holding only delta-pin's lock file: now the folder the claim
    created is gone, and a user's existing folder keeps exactly its own files (no lock file)."""
    trajectory, log = tmp_path / "short_traj.csv", tmp_path / "short_log.csv"
    short = ["--duration", "0.6", "--period", "0.6", "--harmonics", "1", "--iterations", "0"]
    assert main(["identify", "excite", "--robot", str(case["robot"]), "--out", str(trajectory), *short]) == 0
    simulate = ["identify", "simulate", "--robot", str(case["robot"]), "--trajectory", str(trajectory)]
    assert main([*simulate, "--out", str(log)]) == 0
    fit = ["identify", "fit", "--robot", str(case["robot"]), "--data", str(log), "--no-consistent"]
    capsys.readouterr()
    new = tmp_path / "new" / "ident"
    assert main([*fit, "--out", str(new)]) == 2
    assert _one_line(capsys).startswith(f"{ERROR}rank-deficient excitation")
    assert not new.exists() and (tmp_path / "new").exists()  # only the folder the claim made goes
    existing = tmp_path / "mine"
    existing.mkdir()
    (existing / "notes.txt").write_text("the user's notes\n")
    assert main([*fit, "--out", str(existing)]) == 2
    assert sorted(p.name for p in existing.iterdir()) == ["notes.txt"]


def test_fit_s_out_is_never_one_of_its_inputs(case, tmp_path, capsys):
    """--out that is the --data or --validate file (here through '..') is refused naming the flag."""
    log = case["log"]
    before = sha256(log)
    twisted = log.parent / "cad" / ".." / log.name
    for out, flag in ((log, "--data"), (twisted, "--data")):
        assert main(_fit(case, out)) == 2
        assert _one_line(capsys) == (
            f"{ERROR}--out {out} is the file {flag} reads; give a folder for the fit's outputs, e.g. "
            f"--out {out.parent / 'identified'}"
        )
    unseen = tmp_path / "unseen.csv"
    shutil.copy(log, unseen)
    assert main(_fit(case, unseen, "--validate", str(unseen))) == 2
    assert "is the file --validate reads" in _one_line(capsys)
    assert sha256(log) == before and sha256(unseen) == before


# ----------------------------------------------------------------------------- excite, simulate
def test_excite_never_writes_over_the_robot_file(case, tmp_path, capsys):
    """`excite --robot X --out X` wrote a CSV over the robot file (exit 0); also through a symbolic
    link and a '..' path."""
    robot = tmp_path / "robot.urdf"
    shutil.copy(case["robot"], robot)
    (tmp_path / "sub").mkdir()
    link = tmp_path / "link.urdf"
    link.symlink_to(robot)
    before = sha256(robot)
    for out in (robot, link, tmp_path / "sub" / ".." / "robot.urdf"):
        assert main(["identify", "excite", "--robot", str(robot), "--out", str(out), *EXCITE]) == 2
        assert _one_line(capsys) == (
            f"{ERROR}--out {out} is the file --robot reads ({robot}): identify excite would write over it; "
            "give another --out file"
        )
    assert sha256(robot) == before and link.is_symlink()


def test_simulate_never_writes_over_its_trajectory(case, tmp_path, capsys):
    """`simulate --trajectory X --out X` wrote the log over its input (exit 0); also with --out a
    link to the trajectory, and --trajectory a link to --out."""
    trajectory = tmp_path / "traj.csv"
    shutil.copy(case["trajectory"], trajectory)
    link = tmp_path / "link.csv"
    link.symlink_to(trajectory)
    before = sha256(trajectory)
    simulate = ["identify", "simulate", "--robot", str(case["robot"])]
    for given, out in ((trajectory, trajectory), (trajectory, link), (link, trajectory)):
        assert main([*simulate, "--trajectory", str(given), "--out", str(out)]) == 2
        assert _one_line(capsys) == (
            f"{ERROR}--out {out} is the file --trajectory reads ({given}): identify simulate would write "
            "over it; give another --out file"
        )
    assert sha256(trajectory) == before and link.is_symlink()


def test_an_existing_out_file_is_replaced_only_when_its_header_proves_it_delta_pin_s(case, tmp_path, capsys):
    """excite and simulate replaced any file at --out; now only their own earlier output: a
    trajectory (first line and its `# fourier:` line), a simulated log (first line and `# source:
    delta-pin identify simulate`: a drive's log in the documented format has the same first line)."""
    robot = ["--robot", str(case["robot"])]
    mine = tmp_path / "mine.csv"
    mine.write_text("t,q\n0,1\n")
    measured = tmp_path / "measured.csv"
    measured.write_text("# delta-pin identification log\n# sample_rate_hz: 1000\nt,q[active_1]\n0,0\n")
    user = {path: sha256(path) for path in (mine, measured)}
    assert main(["identify", "excite", *robot, "--out", str(mine), *EXCITE]) == 2
    assert _one_line(capsys) == (
        f"{ERROR}--out {mine} exists and is not an excitation trajectory delta-pin identify excite wrote "
        "(its header has no '# delta-pin excitation trajectory' and '# fourier:' lines): it may be anyone's "
        "file; move it away, or give another --out file"
    )
    simulate = ["identify", "simulate", *robot, "--trajectory", str(case["trajectory"])]
    excited = tmp_path / "excited.csv"
    shutil.copy(case["trajectory"], excited)
    user[excited] = sha256(excited)
    for out in (measured, excited):  # a drive's log, and excite's own trajectory
        assert main([*simulate, "--out", str(out)]) == 2
        assert _one_line(capsys) == (
            f"{ERROR}--out {out} exists and is not a simulated log delta-pin identify simulate wrote (its "
            "header has no '# delta-pin identification log' and '# source: delta-pin identify simulate' "
            "lines): it may be anyone's file; move it away, or give another --out file"
        )
    assert {path: sha256(path) for path in user} == user
    trajectory, log = tmp_path / "traj.csv", tmp_path / "log.csv"
    shutil.copy(case["trajectory"], trajectory)
    shutil.copy(case["log"], log)
    assert main(["identify", "excite", *robot, "--out", str(trajectory), *EXCITE, "--seed", "3"]) == 0
    assert sha256(trajectory) != sha256(case["trajectory"])
    assert main([*simulate, "--out", str(log), "--seed", "3"]) == 0
    assert sha256(log) != sha256(case["log"])


# ------------------------------------------------------------------------------------ Python API
def test_write_report_claims_its_folder_like_the_command(case, tmp_path):
    """write_report(result, log, out) replaced a folder's robot.urdf; now it claims ``out`` by the
    command's rule, given a claimed folder or not: a user's file is refused, an earlier fit's
    outputs are replaced, and the folder's manifest lists what it wrote."""
    from delta_pin.model.loaders import load_robot

    robot = load_robot(str(case["robot"]))
    log = read_log(case["log"], robot.actuated_joints)
    result = identify(robot, log, consistent=False)
    folder = tmp_path / "D"
    folder.mkdir()
    (folder / "robot.urdf").write_text("the user's CAD file\n")
    before = _hashes(folder)
    with pytest.raises(InvalidParameterError, match=r"holds robot\.urdf, which no manifest\.json"):
        write_report(result, log, folder, figures=False)
    with pytest.raises(InvalidParameterError, match=r"holds robot\.urdf, which no manifest\.json"):
        manifest.claim(folder, COMMAND, {}, outputs=list(OUTPUTS), replace_same_command=True)
    assert _hashes(folder) == before
    out = tmp_path / "ident"
    assert {p.name for p in write_report(result, log, out, figures=False)} == FIT_FILES
    assert {p.name for p in write_report(result, log, out, figures=False)} == FIT_FILES  # replaced
    (out / "parameters.json").write_text("edited by hand\n")
    with pytest.raises(
        InvalidParameterError, match=r"holds parameters\.json, listed in its manifest\.json but changed since"
    ):
        write_report(result, log, out, figures=False)  # changed since: never replaced
    shutil.rmtree(out)
    for _ in range(2):  # the second replaces the first
        with manifest.claim(out, COMMAND, {}, outputs=list(OUTPUTS), replace_same_command=True) as claimed:
            write_report(result, log, out, figures=False, folder=claimed)
    listed = json.loads((out / MANIFEST).read_text())
    assert listed["complete"] is True and set(listed["files"]) == set(_hashes(out)) - {MANIFEST}


def test_another_command_s_folder_is_refused(case, tmp_path, capsys):
    """A folder holding a `delta-pin run` (its manifest names "run") is not a fit's: refused in one
    line, its files untouched (replace_same_command replaces only an earlier `identify fit`)."""
    folder = tmp_path / "run"
    assert main(["run", "--plant", "analytic", "--t-end", "0.01", "--out", str(folder)]) == 0
    before = _hashes(folder)
    capsys.readouterr()
    assert main(_fit(case, folder, "--no-figures")) == 2
    assert _one_line(capsys) == (
        f"{ERROR}the output folder {folder} holds the outputs of a delta-pin run with other options "
        f'(command: "run" before, "{COMMAND}" now; see its {MANIFEST}); give another folder'
    )
    assert _hashes(folder) == before
