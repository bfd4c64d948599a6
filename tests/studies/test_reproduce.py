"""``delta-pin reproduce`` on a tiny study: every output exists, the tables equal a recomputation
from the saved runs, a second call resumes from the cache; ``compare`` and ``sweep`` commands."""

import csv
import json
import re

import numpy as np
import pytest

from delta_pin.cli import main
from delta_pin.errors import InvalidParameterError, SimulationError
from delta_pin.sim.run import load_run
from delta_pin.studies.digital import DIGITAL_CONTROLLERS, DigitalStudy, digital_specs
from delta_pin.studies.experiments import run_spec
from delta_pin.studies.metrics import compute_metrics
from delta_pin.studies.reproduce import (
    ReproduceSettings,
    _claims,
    markdown_table,
    reproduce,
    settling_time,
)

DIGITAL = DigitalStudy(rates=(1000.0,), trade_off_points=1, t_end=0.3)
TINY = ReproduceSettings(
    plant="analytic", grid=(0.0, 0.6), main_t_end=0.3, surface_t_end=0.3, digital=DIGITAL
)
PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    out = tmp_path_factory.mktemp("reproduce")
    return out, reproduce(out, settings=TINY, workers=1)


def test_every_output_is_written(tiny):
    out, result = tiny
    for name in (
        "index.html",
        "report.md",
        "metrics.csv",
        "metrics.md",
        "claims.json",
        "design1_path_I.html",
    ):
        assert (out / name).stat().st_size > 0, name
    figures = sorted((out / "figures").glob("*.png"))
    numbers = sorted(int(p.name[3:5]) for p in figures)
    assert numbers == list(range(6, 33))  # Figs. 6-29 and the digital study's 30-32, one file each
    for figure in figures:
        data = figure.read_bytes()
        assert data.startswith(PNG) and len(data) > 5000, figure.name
    html = (out / "index.html").read_text()
    assert all(f"figures/{p.name}" in html for p in figures)
    assert len(result.claims) == len(json.loads((out / "claims.json").read_text())) >= 10


def test_index_html_renders_every_table_as_html_with_units(tiny):
    """index.html showed the digital study as one <pre> of raw Markdown pipes and the metrics'
    headers without units (issue 39): every table of report.md's digital section is now an HTML
    table with the same rows and cells (parsed back here), no Markdown pipe row is left in the
    page, and the metrics' headers carry their units."""
    from html.parser import HTMLParser

    class Tables(HTMLParser):
        def __init__(self):
            super().__init__()
            self.tables, self.cell = [], None

        def handle_starttag(self, tag, attrs):
            if tag == "table":
                self.tables.append([])
            elif tag == "tr":
                self.tables[-1].append([])
            elif tag in ("td", "th"):
                self.cell = ""

        def handle_data(self, data):
            if self.cell is not None:
                self.cell += data

        def handle_endtag(self, tag):
            if tag in ("td", "th"):
                self.tables[-1][-1].append(self.cell.strip())
                self.cell = None

    out, _ = tiny
    page = (out / "index.html").read_text()
    assert "<pre>" not in page and "|---|" not in page
    parser = Tables()
    parser.feed(page)
    report = (out / "report.md").read_text().split("## Digital")[1].split("## Figures")[0]
    markdown = [
        [cell.strip() for cell in line.strip().strip("|").split("|")]
        for line in report.splitlines()
        if line.startswith("|") and not line.startswith("|---")
    ]
    html_rows = [row for table in parser.tables[2:] for row in table]  # after the claims and metrics
    assert html_rows == markdown and len(markdown) >= 4
    metrics_header = parser.tables[1][0]
    assert "iae [rad·s]" in metrics_header and "settling_time [s]" in metrics_header
    assert "wall_time [s]" in metrics_header and "controller" in metrics_header


def test_figures_drawn_by_two_processes_are_the_ones_one_process_draws(tiny, tmp_path):
    """With two workers a forked child draws every other figure (studies.reproduce._write_figures):
    the same files, byte for byte, as the one-process run (matplotlib's Agg output is
    deterministic), and the run's cache answers every point. The surface and digital points keep
    no run, the main runs do."""
    import shutil

    out = tmp_path / "reproduce"
    shutil.copytree(tiny[0] / "cache", out / "cache")
    result = reproduce(out, settings=TINY, workers=2)
    assert result.claims == tiny[1].claims
    one = {p.name: p.read_bytes() for p in (tiny[0] / "figures").glob("*.png")}
    two = {p.name: p.read_bytes() for p in (out / "figures").glob("*.png")}
    assert two.keys() == one.keys() and len(one) == 27
    assert [name for name in one if one[name] != two[name]] == []
    runs = list((out / "cache").glob("*.npz"))
    assert len(runs) == len(result.runs) == 10


def _cells(row: str) -> int:
    """The cells of a Markdown table row: its unescaped pipes, less one."""
    return len(re.findall(r"(?<!\\)\|", row)) - 1


def _table_is_whole(text: str) -> None:
    """Every row of the (one) table in ``text`` has as many cells as its header."""
    rows = [line for line in text.splitlines() if line.startswith("|") and not line.startswith("|---")]
    assert len(rows) > 1
    for row in rows:
        assert _cells(row) == _cells(rows[0]), row


def test_report_tables_are_whole(tiny):
    """The claims mention ||r||: escaped, they no longer split their rows (issue 15)."""
    out, _ = tiny
    report = (out / "report.md").read_text()
    assert "\\|\\|r\\|\\|" in report
    claims = report.split("## The paper's claims")[1].split("## Metrics")[0]
    _table_is_whole(claims)
    _table_is_whole((out / "metrics.md").read_text())


def test_a_failed_row_has_the_header_s_cells():
    table = markdown_table(
        [{"controller": "design I", "path": "I", "error": "the run diverged: |alpha_dot| = 2e3 rad/s"}]
    )
    header, _, failed = table.splitlines()
    assert _cells(failed) == _cells(header) == 11


def test_metrics_table_equals_a_recomputation_from_the_saved_runs(tiny):
    out, result = tiny
    rows = list(csv.DictReader((out / "metrics.csv").open()))
    assert len(rows) == 10  # 5 controllers x 2 paths
    runs = {(label, path): run for (label, path), run in result.runs.items()}
    for row in rows:
        run = runs[(row["controller"], row["path"])]
        again = compute_metrics(
            load_run(
                next(p for p in (out / "cache").glob("*.npz") if np.array_equal(load_run(p).alpha, run.alpha))
            )
        )
        for name in ("iae", "ise", "control_effort", "control_effort_sum"):
            assert float(row[name]) == pytest.approx(getattr(again, name), rel=1e-12), name


def test_surfaces_hold_one_value_per_grid_point(tiny):
    _, result = tiny
    assert len(result.surfaces) == 6  # 3 planes x 2 designs
    for values in result.surfaces.values():
        assert values.shape == (2, 2) and np.all(np.isfinite(values)) and np.all(values > 0.02)


def test_the_runtime_claim_does_not_depend_on_the_machine_s_load(tiny):
    """The runtime claim flipped between "yes" and "n/a" from run to run: it was judged from wall
    times (issue 25). It is judged from the integrator's evaluations of the closed loop, which
    are the same on any machine and load; the wall times are reported beside, not judged."""
    _, result = tiny
    (runtime,) = [c for c in result.claims if c["claim"] == "design I runs faster than design II"]
    evaluations = [
        result.runs[(design, "I")].metadata["rhs_evaluations"] for design in ("design I", "design II")
    ]
    assert runtime["holds"] == ("yes" if evaluations[0] < evaluations[1] else "no")
    assert runtime["ours"].startswith(f"{evaluations[0]} vs {evaluations[1]} evaluations")
    assert "wall times" in runtime["ours"] and "not judged" in runtime["ours"]
    for slow, fast in ((100.0, 1e-3), (1e-3, 100.0), (1.0, 1.0)):  # a busy machine, either way
        metrics = [
            {**row, "wall_time": slow if row["controller"] == "design I" else fast} for row in result.metrics
        ]
        claims = _claims(result.runs, metrics, result.surfaces, result.grid)
        assert [c["holds"] for c in claims] == [c["holds"] for c in result.claims]


def test_a_second_reproduction_resumes_from_the_cache(tiny):
    out, first = tiny
    cached = {p.name: p.stat().st_mtime_ns for p in (out / "cache").iterdir()}
    again = reproduce(out, settings=TINY, workers=1)
    assert {p.name: p.stat().st_mtime_ns for p in (out / "cache").iterdir()} == cached  # nothing re-run
    assert again.metrics == first.metrics


def test_settling_time():
    class Fake:
        t = np.linspace(0.0, 1.0, 11)
        error = np.zeros((11, 3))

    run = Fake()
    run.error[:4, 0] = 0.1  # above 1e-3 rad until t = 0.3 s
    assert settling_time(run) == pytest.approx(0.4)
    run.error[-1, 0] = 0.1
    assert settling_time(run) == np.inf


def test_compare_and_sweep_commands(tmp_path, capsys):
    out = tmp_path / "compare"
    assert (
        main(
            [
                "compare",
                "--controllers",
                "design1,lqr",
                "--paths",
                "I",
                "--t-end",
                "0.3",
                "--mode",
                "sampled",
                "--sampling-aware",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    assert "design I" in capsys.readouterr().out
    assert len(list(csv.DictReader((out / "metrics.csv").open()))) == 2
    assert (out / "figures" / "errors_I.png").read_bytes().startswith(PNG)
    out = tmp_path / "sweep"
    assert (
        main(
            [
                "sweep",
                "--param",
                "delta_m=0:0.6:2",
                "--param",
                "delta_f=0,0.5",
                "--t-end",
                "0.3",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    rows = list(csv.DictReader((out / "results.csv").open()))
    assert len(rows) == 4
    assert (out / "rho_hat_max_delta_m_delta_f.png").read_bytes().startswith(PNG)
    assert main(["sweep", "--param", "delta_m=oops", "--out", str(out)]) == 2


def test_compare_on_another_robot(tmp_path, capsys):
    out = tmp_path / "long_arms"
    assert (
        main(
            [
                "compare",
                "--controllers",
                "design1",
                "--paths",
                "II",
                "--t-end",
                "0.2",
                "--mode",
                "sampled",
                "--sampling-aware",
                "--set",
                "l_a=0.25",
                "--set",
                "l_b=0.5",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    run = load_run(next((out / "cache").glob("*.npz")))
    assert run.metadata["robot"]["l_a"] == 0.25 and run.metadata["robot"]["l_b"] == 0.5
    assert main(["compare", "--set", "wingspan=2", "--out", str(out)]) == 2
    assert "wingspan" in capsys.readouterr().err


def test_the_digital_study_reports_each_run_or_when_it_diverged(tiny):
    """Each (controller, rate) cell is the run's own metric, or the time the same spec run alone
    diverges at (the reference: SimulationError.t of run_spec)."""
    out, result = tiny
    by_rate, _ = digital_specs(DIGITAL)
    assert [row["controller"] for row in result.digital_rates] == list(DIGITAL_CONTROLLERS.values())
    for row in result.digital_rates:
        spec = by_rate[(row["controller"], row["rate_hz"])]
        assert spec.encoder_bits == 17 and spec.delay == 1 and spec.dt == 1e-3
        if row["diverged_at"] is None:
            continue
        with pytest.raises(SimulationError) as failure:
            run_spec(spec)
        assert row["diverged_at"] == pytest.approx(failure.value.time, abs=1e-12)
    assert any(row["diverged_at"] is not None for row in result.digital_rates)  # the paper's designs
    robust = next(row for row in result.digital_rates if row["controller"] == "digital robust")
    assert robust["diverged_at"] is None  # it held (its "last 5 s" indices are NaN on a 0.3 s run)
    section = (out / "report.md").read_text().split("## Digital implementation")[1].split("## Figures")[0]
    tables = [t for t in section.split("\n\n") if t.startswith("|")]
    assert len(tables) == 2
    for table in tables:
        _table_is_whole(table)
    assert "diverged at t = " in section


def test_digital_study_sizes():
    study = DigitalStudy(rates=(1000.0, 8000.0), trade_off_points=3)
    assert study.gain_values((1.0, 2.0, 3.0, 4.0, 5.0)) == (1.0, 3.0, 5.0)
    assert study.gain_values((1.0, 2.0)) == (1.0, 2.0)
    assert DigitalStudy(trade_off_points=0).gain_values((1.0, 2.0)) == ()
    by_rate, trade_off = digital_specs(study)
    assert len(by_rate) == 6 * 2 and len(trade_off) == 4 * 3  # 3 values of each main gain
    assert {spec.dt for spec in by_rate.values()} == {1e-3, 1.25e-4}


def test_reproduce_on_another_robot_in_the_same_folder(tiny, tmp_path):
    """``reproduce --set l_a=0.22`` ran everything, then failed with a KeyError: the result lookup
    ignored the robot arguments that the cache keys hold (issue 15). Into a folder that already
    holds the Table 1 robot's cache, none of it may answer for the other robot."""
    import shutil

    out = tmp_path / "reproduce"
    shutil.copytree(tiny[0], out)
    before = len(list((out / "cache").glob("*.json")))
    with pytest.raises(InvalidParameterError, match=r'robot_args.l_a: absent before, "0.22" now'):
        reproduce(out, settings=TINY, workers=1, robot_args={"l_a": "0.22"})  # outputs never mix
    result = reproduce(out, settings=TINY, workers=1, robot_args={"l_a": 0.22}, overwrite=True)
    assert len(list((out / "cache").glob("*.json"))) == 2 * before  # all computed again
    assert len(result.runs) == 10
    assert {run.metadata["robot"]["l_a"] for run in result.runs.values()} == {0.22}
    assert "Table 1 robot with l_a = 0.22" in (out / "report.md").read_text()


def test_a_truncated_cached_run_is_computed_again(tiny, tmp_path):
    """A cached run.npz cut short (a killed copy, a full disk) used to end the reproduction with a
    traceback; like an unreadable record, it is now computed again (issue 15)."""
    import shutil

    out = tmp_path / "reproduce"
    shutil.copytree(tiny[0], out)
    runs = sorted((out / "cache").glob("*.npz"))
    victim = runs[0]
    victim.write_bytes(victim.read_bytes()[:1000])
    others = {p.name: p.stat().st_mtime_ns for p in runs[1:]}
    reproduce(out, settings=TINY, workers=1)
    assert load_run(victim).t[-1] == pytest.approx(0.3)  # whole again (every TINY run is 0.3 s)
    assert {p.name: p.stat().st_mtime_ns for p in runs[1:]} == others  # the rest from the cache


def test_claims_are_graded_against_the_paper_s_numbers(tiny):
    """A settling claim holds only within 10 % of the paper's time (it held at anything under 1 s:
    0.56 s "yes" against the paper's 0.3 s), and design II's lower cost is "partly" when the
    difference is less than a tenth of the paper's 0.10 % (it was "yes" at 0.0013 %) (issue 39)."""
    from delta_pin.studies.reproduce import PAPER_COST_GAIN, SETTLING_GRACE, settling_time

    _, result = tiny
    claims = {c["claim"]: c for c in result.claims}
    for design, paper in (("design I", 0.3), ("design II", 0.2)):
        claim = claims[f"{design}: ||r|| enters a narrow zone around 0 quickly and stays (path I)"]
        t = settling_time(result.runs[(design, "I")])
        assert claim["holds"] == ("yes" if t <= paper * (1 + SETTLING_GRACE) else "no"), (t, claim)
    cost = claims["design II has the lower control cost S (eq. 68, path I)"]
    e1, e2 = (next(m["control_effort"] for m in result.metrics if m["controller"] == d and m["path"] == "I")
              for d in ("design I", "design II"))  # fmt: skip
    expected = "no" if e2 >= e1 else ("yes" if (e1 - e2) / e1 >= PAPER_COST_GAIN / 10 else "partly")
    assert cost["holds"] == expected
