"""Output folders are whole or marked (issue 15): ``reproduce``, ``compare`` and ``sweep`` write a
manifest.json that lists every output with its SHA-256 once the folder is complete, refuse a
folder that holds another study's outputs, and never leave an earlier run's files beside theirs."""

import json
import shutil

import pytest

from delta_pin.cli import main
from delta_pin.errors import InvalidParameterError
from delta_pin.studies import reproduce as reproduce_module
from delta_pin.studies.reproduce import ReproduceSettings, reproduce
from delta_pin.utils.manifest import CACHE, LOCK, MANIFEST, sha256

from .test_reproduce import TINY

SWEEP = ["sweep", "--t-end", "0.2", "--workers", "1"]
TWO_AXES = ["--param", "delta_m=0,0.3", "--param", "delta_f=0,0.3"]  # results.csv and a surface PNG
ONE_AXIS = ["--param", "xi=0.001,0.002"]  # results.csv only


def _manifest(out):
    return json.loads((out / MANIFEST).read_text())


def _outputs(out):
    """Every file but the manifest, the lock and the cache, as manifest paths."""
    return {
        p.relative_to(out).as_posix()
        for p in out.rglob("*")
        if p.is_file() and p.relative_to(out).parts[0] not in (MANIFEST, LOCK, CACHE)
    }


def _assert_whole(out):
    """The manifest says complete and lists exactly the folder's outputs, each with its hash."""
    manifest = _manifest(out)
    assert manifest["complete"] is True
    assert set(manifest["files"]) == _outputs(out)
    for name, digest in manifest["files"].items():
        assert sha256(out / name) == digest, name
    return manifest


def test_two_different_sweeps_never_mix_in_one_folder(tmp_path, capsys):
    """Two sweeps into one --out left results.csv from one and the PNG from the other. Now the
    second is refused with one line naming the difference, and the folder stays whole; with
    --overwrite the first's outputs go (its PNG too) and its cache is kept and reused."""
    out = tmp_path / "sweep"
    assert main([*SWEEP, *TWO_AXES, "--out", str(out)]) == 0
    first = _assert_whole(out)
    assert set(first["files"]) == {"results.csv", "rho_hat_max_delta_m_delta_f.png"}
    assert first["command"] == "sweep" and first["command_line"][:2] == ["delta-pin", "sweep"]
    assert first["options"]["axes"] == {"delta_m": [0, 0.3], "delta_f": [0, 0.3]}
    assert first["delta_pin"] and "git_commit" in first
    cached = {p.name: p.stat().st_mtime_ns for p in (out / CACHE).iterdir()}
    capsys.readouterr()

    assert main([*SWEEP, *ONE_AXIS, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        f"delta-pin sweep: error: the output folder {out} holds the outputs of a delta-pin sweep with "
        "other options (options.axes.delta_f: [0, 0.3] before, absent now; see its manifest.json); give "
        "another folder, or --overwrite (overwrite=True) to replace its outputs (its cache/ is kept and "
        "reused)"
    ]
    assert _assert_whole(out) == first  # untouched

    assert main([*SWEEP, *ONE_AXIS, "--overwrite", "--out", str(out)]) == 0
    second = _assert_whole(out)
    assert set(second["files"]) == {"results.csv"}  # the first sweep's PNG is gone
    assert not (out / "rho_hat_max_delta_m_delta_f.png").exists()
    assert second["options"]["axes"] == {"xi": [0.001, 0.002]}
    assert {p.name: p.stat().st_mtime_ns for p in (out / CACHE).iterdir() if p.name in cached} == cached

    assert main([*SWEEP, *ONE_AXIS, "--out", str(out)]) == 0  # the same sweep again: accepted
    assert _assert_whole(out)["files"] == second["files"]


def test_an_interrupted_reproduction_is_marked_and_holds_no_earlier_outputs(tmp_path, monkeypatch):
    """Ctrl-C of a bigger reproduction over a finished one left 7 new figures beside the old report,
    metrics and 17 figures, unmarked. Now the folder is marked incomplete before the first new
    output, the earlier outputs are gone, another study is refused, and the same one resumes."""
    from .test_reproduce import DIGITAL

    out = tmp_path / "reproduce"
    reproduce(out, settings=TINY, workers=1)
    old = _assert_whole(out)
    assert len([n for n in old["files"] if n.startswith("figures/")]) == 27
    bigger = ReproduceSettings(plant="analytic", grid=(0.0, 0.3, 0.6), main_t_end=0.3, surface_t_end=0.3,
                               digital=DIGITAL)  # fmt: skip

    def interrupted(result):
        raise KeyboardInterrupt  # after the figures, before the tables and the report

    monkeypatch.setattr(reproduce_module, "_write_tables", interrupted)
    with pytest.raises(KeyboardInterrupt):
        reproduce(out, settings=bigger, workers=1, overwrite=True)
    monkeypatch.undo()
    marked = _manifest(out)
    assert marked["complete"] is False and "files" not in marked
    assert marked["options"]["settings"]["grid"] == [0.0, 0.3, 0.6]
    for name in ("report.md", "metrics.csv", "metrics.md", "index.html", "claims.json"):
        assert not (out / name).exists(), name  # the earlier run's, removed before any new output
    surfaces = [f"figures/{p.name}" for p in (out / "figures").glob("*_rho_max_*.png")]
    assert len(surfaces) == 6  # written by the bigger study before Ctrl-C: its 3 x 3 grids
    assert all(sha256(out / name) != old["files"][name] for name in surfaces)

    with pytest.raises(InvalidParameterError, match="holds the outputs of an interrupted delta-pin"):
        reproduce(out, settings=TINY, workers=1)  # not the options of the interrupted run
    cached = {p.name: p.stat().st_mtime_ns for p in (out / CACHE).iterdir()}
    reproduce(out, settings=bigger, workers=1)  # the same command resumes
    assert {p.name: p.stat().st_mtime_ns for p in (out / CACHE).iterdir()} == cached  # all cached
    assert _assert_whole(out)["options"]["settings"]["grid"] == [0.0, 0.3, 0.6]


def test_a_folder_of_other_files_is_refused_and_left_alone(tmp_path, capsys):
    """A folder with files and no manifest (a `run` folder, a user's folder) is never written into:
    its files cannot be told apart from a study's."""
    out = tmp_path / "run"
    out.mkdir()
    (out / "summary.json").write_text("{}")
    argv = ["compare", "--controllers", "pd", "--paths", "I", "--t-end", "0.2", "--out", str(out)]
    for extra in ([], ["--overwrite"]):
        assert main([*argv, *extra]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert err == [
            f"delta-pin compare: error: the output folder {out} holds 1 file(s) (e.g. summary.json) and "
            "no manifest.json: not the outputs of a delta-pin study; give an empty or new folder, or "
            "remove them"
        ]
    assert sorted(p.name for p in out.iterdir()) == ["summary.json"]
    shutil.rmtree(out)
    (out / CACHE).mkdir(parents=True)  # a cache alone (shared, or of an old version) is fine
    assert main([*argv, "--workers", "1"]) == 0
    assert set(_assert_whole(out)["files"]) >= {"metrics.csv", "metrics.md", "figures/errors_I.png"}
