"""Nothing of the user's is ever deleted (issue 25): `run` removes only the files an earlier run
provably wrote (listed in its manifest.json, inside --out, unchanged), and only once the new run
is computed; --html cannot take the place of the run's own files; one writer per output folder
(an flock, released when the writer ends, however it ends). Cache records: test_cache_records.py."""

import json
import os
import signal
import subprocess
import sys
import textwrap

import pytest

from delta_pin.cli import main
from delta_pin.utils import manifest
from delta_pin.utils.manifest import LOCK, MANIFEST, sha256

RUN = ["run", "--plant", "analytic", "--mode", "sampled", "--sampling-aware", "--t-end", "0.01"]
SWEEP = ["sweep", "--t-end", "0.01", "--workers", "1", "--param", "delta_m=0,0.3"]


def _one_line(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]


def _files(folder) -> dict[str, bytes]:
    """Every file under ``folder`` but the lock, with its bytes."""
    return {
        p.relative_to(folder).as_posix(): p.read_bytes()
        for p in sorted(folder.rglob("*"))
        if p.is_file() and p.name != LOCK
    }


# ------------------------------------------------------------------------------------ run's files
def test_a_rerun_from_another_folder_never_removes_the_caller_s_files(tmp_path, monkeypatch, capsys):
    """summary.json listed its outputs relative to the folder the first run was started from; a
    rerun into the same --out from another folder deleted those paths relative to *its* folder."""
    first, second = tmp_path / "first", tmp_path / "second"
    (first / "o").mkdir(parents=True)
    (second / "o" / "x").mkdir(parents=True)
    monkeypatch.chdir(first)
    assert main([*RUN, "--out", "o/x", "--html", "o/x/run.html"]) == 0
    mine = {"run.npz": b"the user's own run", "run.html": b"the user's own page", "summary.json": b"{}"}
    for name, data in mine.items():
        (second / "o" / "x" / name).write_bytes(data)
    monkeypatch.chdir(second)
    capsys.readouterr()
    assert main([*RUN, "--out", str(first / "o" / "x")]) == 0, capsys.readouterr().err
    assert _files(second / "o" / "x") == mine  # the caller's folder is untouched
    assert not (first / "o" / "x" / "run.html").exists()  # the earlier run's own page went
    listed = json.loads((first / "o" / "x" / MANIFEST).read_text())["files"]
    assert set(listed) == {"run.npz", "summary.json"}
    summary = json.loads((first / "o" / "x" / "summary.json").read_text())
    assert summary["outputs"] == [str((first / "o" / "x" / n).resolve()) for n in ("run.npz", "summary.json")]


def test_a_user_s_page_beside_a_summary_without_a_manifest_is_never_removed(tmp_path, capsys):
    """A summary.json without an `outputs` key made `run` delete the run.html beside it."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "summary.json").write_text("{}")
    (out / "run.html").write_text("the user's page")
    before = _files(out)
    assert main([*RUN, "--out", str(out)]) == 2
    assert _one_line(capsys) == (
        f"delta-pin run: error: the output folder {out} holds summary.json, which no manifest.json of "
        "delta-pin lists: it may be anyone's file; move it away, or give another folder"
    )
    assert _files(out) == before and not (out / LOCK).exists()  # not even a lock file written


def test_an_output_changed_since_it_was_written_is_kept(tmp_path, capsys):
    """The manifest lists each file with its SHA-256: a page the user edited is not the tool's any
    more, and is neither removed nor overwritten (one line names it)."""
    out = tmp_path / "out"
    assert main([*RUN, "--out", str(out), "--html", str(out / "run.html")]) == 0
    written = json.loads((out / MANIFEST).read_text())
    assert written["command"] == "run" and written["complete"] is True
    assert set(written["files"]) == {"run.npz", "summary.json", "run.html"}
    assert all(sha256(out / name) == digest for name, digest in written["files"].items())
    (out / "run.html").write_text("annotated by hand")
    capsys.readouterr()
    before = _files(out)
    assert main([*RUN, "--out", str(out)]) == 2
    line = _one_line(capsys)
    assert f"the output folder {out} holds run.html, listed in its manifest.json but changed since" in line
    assert _files(out) == before


def test_a_listed_path_outside_the_folder_is_never_removed(tmp_path, capsys):
    """A manifest is data: a name that leads out of --out (``../``, absolute, a link) is ignored."""
    out, victim = tmp_path / "out", tmp_path / "victim.txt"
    assert main([*RUN, "--out", str(out)]) == 0
    victim.write_text("precious")
    (out / "link.txt").symlink_to(victim)
    written = json.loads((out / MANIFEST).read_text())
    for name in ("../victim.txt", str(victim), "link.txt"):
        written["files"][name] = sha256(victim)
    (out / MANIFEST).write_text(json.dumps(written))
    assert main([*RUN, "--out", str(out)]) == 0, capsys.readouterr().err
    assert victim.read_text() == "precious" and (out / "link.txt").is_symlink()


@pytest.mark.parametrize(
    "bad",
    [
        ["--t-end", "-1"],
        ["--dt", "inf"],
        ["--uncertainty", "1.5"],
        ["--set", "l_a=0.1", "--set", "l_b=0.25"],  # path I leaves the workspace: found by the run
        ["--html", "{out}/run.npz"],
    ],
    ids=["t-end -1", "dt inf", "uncertainty 1.5", "workspace", "html run.npz"],
)
def test_refused_input_keeps_the_earlier_run(tmp_path, capsys, bad):
    """A refused input (exit 2) used to remove the earlier run first; the workspace error is found
    by the simulation itself, so the earlier run now goes only once the new one is computed."""
    out = tmp_path / "out"
    assert main([*RUN, "--out", str(out), "--html", str(out / "page.html")]) == 0
    before = _files(out)
    capsys.readouterr()
    assert main([*RUN, *[arg.format(out=out) for arg in bad], "--out", str(out)]) == 2
    _one_line(capsys)
    assert _files(out) == before


def test_a_run_that_fails_half_way_is_replaced_by_the_next(tmp_path, capsys, monkeypatch):
    """A page that fails to export after run.npz was saved leaves an incomplete manifest; it lists
    run.npz with its hash as written, so the next run replaces it instead of refusing it."""
    import delta_pin.viz.meshcat_export as meshcat_export
    from delta_pin.errors import InvalidParameterError

    def broken(*args, **kwargs):
        raise InvalidParameterError("this page cannot be drawn")

    out = tmp_path / "out"
    monkeypatch.setattr(meshcat_export, "export_html", broken)
    assert main([*RUN, "--out", str(out), "--html", str(out / "run.html")]) == 2
    assert "this page cannot be drawn" in _one_line(capsys)
    marked = json.loads((out / MANIFEST).read_text())
    assert marked["complete"] is False and set(marked["written"]) == {"run.npz"}
    monkeypatch.undo()
    assert main([*RUN, "--out", str(out)]) == 0, capsys.readouterr().err
    assert set(json.loads((out / MANIFEST).read_text())["files"]) == {"run.npz", "summary.json"}


# ----------------------------------------------------------------------------------------- --html
@pytest.mark.parametrize(
    ("page", "text"),
    [
        ("{out}/run.npz", "--html {out}/run.npz would overwrite the run's own run.npz in --out {out}"),
        ("{out}/summary.json", "--html {out}/summary.json would overwrite the run's own summary.json"),
        ("{out}/manifest.json", "would overwrite the run's own manifest.json"),
        ("{out}/", "'{out}/' names a folder, not a page: give a file name, e.g. {out}/run.html"),
        ("{out}", "--html {out} is the output folder --out {out} or a folder above it"),
        ("{parent}", "or a folder above it; give a page's file name, e.g. {out}/run.html"),
    ],
    ids=["run.npz", "summary.json", "manifest.json", "trailing slash", "the folder", "its parent"],
)
def test_an_html_in_place_of_the_run_s_files_is_refused_before_the_run(
    tmp_path, capsys, monkeypatch, page, text
):
    """`--html o/x/run.npz` exited 0 with the run data overwritten by the page; `--html o/x/`
    ran the whole simulation, then failed and left run.npz without summary.json."""
    import delta_pin.studies.experiments as experiments

    monkeypatch.setattr(experiments, "run_spec", lambda *a, **k: pytest.fail("simulated"))
    out = tmp_path / "o" / "x"
    values = {"out": out, "parent": tmp_path / "o"}
    assert main([*RUN, "--out", str(out), "--html", page.format(**values)]) == 2
    line = _one_line(capsys)
    assert line.startswith("delta-pin run: error: ") and text.format(**values) in line, line
    assert not out.exists()


def test_a_page_outside_the_folder_is_written_and_never_removed(tmp_path):
    out, page = tmp_path / "out", tmp_path / "page.html"
    assert main([*RUN, "--out", str(out), "--html", str(page)]) == 0
    assert page.is_file() and "page.html" not in json.loads((out / MANIFEST).read_text())["files"]
    assert main([*RUN, "--out", str(out)]) == 0
    assert page.is_file()


# ----------------------------------------------------------------------------------------- locks
_HOLDER = textwrap.dedent(
    """
    import sys, time
    from delta_pin.utils.manifest import lock
    held = lock(sys.argv[1])
    print("locked", flush=True)
    time.sleep(60)
    """
)


def test_a_second_writer_is_refused_naming_the_holder_and_a_killed_one_frees_the_folder(tmp_path, capsys):
    """The lock is an flock: refused while another process holds it (its pid named), free again the
    moment that process is killed outright (SIGKILL: no cleanup of its own runs)."""
    out = tmp_path / "out"
    holder = subprocess.Popen([sys.executable, "-c", _HOLDER, str(out)], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        for argv in (RUN, SWEEP):
            assert main([*argv, "--out", str(out)]) == 2
            assert _one_line(capsys) == (
                f"delta-pin {argv[0]}: error: the output folder {out} is being written by another "
                f"delta-pin (pid {holder.pid}, which holds {out / LOCK}); wait until it ends, or give "
                "another folder"
            )
        assert sorted(p.name for p in out.iterdir()) == [LOCK]  # nothing else was written
    finally:
        holder.send_signal(signal.SIGKILL)
        holder.wait(timeout=10)
    assert main([*RUN, "--out", str(out)]) == 0
    assert (out / LOCK).read_text().strip() == str(os.getpid())


def test_two_sweeps_started_into_one_folder_at_once_never_both_write(tmp_path, capsys, monkeypatch):
    """`manifest.begin` was check-then-write: two different sweeps started at once both exited 0
    and printed "wrote results.csv", and one's results were lost. The second one here starts in
    the first one's window between its check of the folder and its first write (where the first
    asks git for its commit): it is now refused naming the first's pid, and the first finishes
    whole (before, both exited 0 and the folder held the first's results under a manifest of
    either)."""
    out = tmp_path / "out"
    real, second = manifest._git_commit, []

    def the_second_sweep_starts():
        if not second:
            second.append(None)
            other = ["sweep", "--t-end", "0.01", "--workers", "1", "--param", "xi=0.001,0.002"]
            second.append(main([*other, "--out", str(out)]))
            second.append(capsys.readouterr().err)
        return real()

    monkeypatch.setattr(manifest, "_git_commit", the_second_sweep_starts)
    assert main([*SWEEP, "--out", str(out)]) == 0
    assert second[1] == 2, second[2]
    assert f"is being written by another delta-pin (pid {os.getpid()}" in second[2]
    written = json.loads((out / MANIFEST).read_text())
    assert written["complete"] is True and written["options"]["axes"] == {"delta_m": [0, 0.3]}
    assert set(written["files"]) == {"results.csv"}
    assert "delta_m" in (out / "results.csv").read_text().splitlines()[0]


def test_the_lock_is_released_when_a_study_fails_or_ends(tmp_path):
    out = tmp_path / "out"
    with pytest.raises(ZeroDivisionError), manifest.begin(out, "sweep", {"a": 1}):
        raise ZeroDivisionError
    with manifest.begin(out, "sweep", {"a": 1}) as folder:  # free again
        with pytest.raises(Exception, match=f"pid {os.getpid()}"):
            manifest.begin(out, "sweep", {"a": 1})
        folder.finish()
    manifest.lock(out).release()
