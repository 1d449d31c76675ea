"""`mjsuff report`: figures and markdown from a sweep, statistics that agree with their
definitions, clear errors for directories that are not runs."""

import math
import re
import shutil
import tomllib

import numpy as np
import pandas as pd
import pytest
import tomli_w
from scipy import stats

from mjsuff.cli import main
from mjsuff.experiment.measures import measure_group
from mjsuff.experiment.runner import run_scenario
from mjsuff.report import ReportError, compare_rules, load_cells
from mjsuff.report.figures import (
    f1_with_se,
    missing_point_note,
    noise_ablation,
    noise_table,
    replicate_outcomes,
    rule_curves,
)
from mjsuff.report.statistics import observations
from tests.conftest import small_scenario

PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def sweep_run(tmp_path_factory):
    directory = tmp_path_factory.mktemp("sweep") / "run"
    run_scenario(
        small_scenario(replicates=3, sweep={"demos.noise_fraction": [0.0, 0.4]}), directory, record=False
    )
    return directory


def test_report_writes_figures_linked_from_markdown(sweep_run, capsys):
    assert main(["report", str(sweep_run)]) == 0
    out = sweep_run / "report"
    text = (out / "report.md").read_text()
    links = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text)
    assert {"bound_vs_demos.png", "noise_ablation.png", "f1_and_demos_00.png", "f1_and_demos_01.png"} <= set(
        links
    )
    for link in links:
        assert (out / link).read_bytes()[:8] == PNG and (out / link).stat().st_size > 10_000
    assert "Kruskal-Wallis" in text and "Dunn" in text and "noise_fraction = 0.4" in text
    assert "H1, decision quality" in text and "F1 (notebook, FN = 1)" in text
    # MCMC diagnostics per demo step, one table per cell with a row per step (4 demos).
    assert text.count("| demos | mean R̂ | max R̂ |") == 2
    rows = re.findall(r"^\| ([1-4]) \| (1\.\d{3}) \| (1\.\d{3}) \|", text, flags=re.M)
    assert [r[0] for r in rows] == ["1", "2", "3", "4"] * 2
    assert all(float(mean) <= float(worst) for _, mean, worst in rows)
    assert "report.md" in capsys.readouterr().out


def test_f1_curves_agree_with_the_run_measures(sweep_run):
    cell = load_cells([sweep_run])[0]
    curves = rule_curves(cell)
    for _, row in curves.iterrows():
        group = cell.steps[(cell.steps["rule"] == row["rule"]) & (cell.steps["param"] == row["param"])]
        m = measure_group(group, False, row["epsilon"])
        assert (math.isnan(m["f1"]) and math.isnan(row["f1"])) or m["f1"] == pytest.approx(row["f1"])
        assert m["demos_needed"] == pytest.approx(row["demos"])


def test_bootstrap_se_of_f1():
    rng = np.random.default_rng(0)
    assert f1_with_se(np.zeros(20, int), rng) == (1.0, 0.0)  # every replicate a TP: no spread
    f1, se = f1_with_se(np.array([0] * 10 + [1] * 5 + [2] * 5), rng)
    assert f1 == pytest.approx(10 / 15) and 0.05 < se < 0.2


def test_rule_comparison_matches_scipy_and_separates_groups():
    rng = np.random.default_rng(1)
    values = pd.DataFrame(
        {
            "rule": ["nevd"] * 30 + ["patience"] * 30 + ["validation"] * 30,
            "demos": np.r_[rng.normal(3, 1, 30), rng.normal(3, 1, 30), rng.normal(9, 1, 30)],
        }
    )
    result = compare_rules(values, "demos")
    h, p = stats.kruskal(
        *(values.loc[values["rule"] == r, "demos"] for r in ("nevd", "patience", "validation"))
    )
    assert result.h == pytest.approx(h) and result.p == pytest.approx(p)
    assert result.dunn.loc["nevd", "validation"] < 0.001  # far apart
    assert result.dunn.loc["nevd", "patience"] > 0.05  # drawn from the same distribution
    assert compare_rules(values.assign(demos=1.0), "demos") is None  # no variation: no test


def test_outcomes_follow_the_stopping_step():
    steps = pd.DataFrame(
        {
            "replicate": [0, 0, 0, 1, 1, 1],
            "step": [1, 2, 3] * 2,
            "decision": [False, True, True, False, False, False],
            "true_nevd": [0.5, 0.1, 0.0, 0.5, 0.4, 0.05],
        }
    )
    codes, needed = replicate_outcomes(steps, 0.2)
    assert codes.tolist() == [0, 2] and needed.tolist() == [2, 3]  # TP at 2; FN, ran to 3


def test_not_a_run_is_a_clear_error(tmp_path, capsys):
    with pytest.raises(ReportError, match=r"no config\.toml"):
        load_cells([tmp_path])
    assert main(["report", str(tmp_path)]) == 2
    assert str(tmp_path) in capsys.readouterr().err


def test_a_run_without_rows_is_a_clear_error_and_writes_nothing(sweep_run, tmp_path, capsys):
    """Issue #19, item 7: it was a KeyError traceback, with a partial figure left behind."""
    cell = next(p.parent for p in sorted(sweep_run.glob("cells/*/steps.parquet")))
    empty = tmp_path / "empty"
    shutil.copytree(cell, empty)
    pd.read_parquet(empty / "steps.parquet").iloc[0:0].to_parquet(empty / "steps.parquet")
    assert main(["report", str(empty), "--out", str(tmp_path / "report")]) == 2
    assert "steps.parquet: no rows" in capsys.readouterr().err
    assert not (tmp_path / "report").exists()


def _steps(rule, param, replicate, decisions, nevds):
    return [
        {
            "rule": rule,
            "param": param,
            "replicate": replicate,
            "step": i + 1,
            "decision": d,
            "true_nevd": n,
            "pool_size": 2,
        }
        for i, (d, n) in enumerate(zip(decisions, nevds, strict=True))
    ]


def test_rule_observations_are_one_per_replicate_and_rule_averaged_over_parameters():
    """nEVD at its own ε, baselines at every ε (0.1, 0.5); PIOB left out."""
    steps = pd.DataFrame(
        _steps("nevd", 0.1, 0, [False, True], [0.3, 0.05])  # stop 2, TP
        + _steps("nevd", 0.1, 1, [False, False], [0.3, 0.2])  # TN
        + _steps("nevd", 0.5, 0, [True, True], [0.3, 0.05])  # stop 1, TP
        + _steps("nevd", 0.5, 1, [False, False], [0.3, 0.2])  # FN
        + _steps("patience", 1.0, 0, [False, True], [0.3, 0.0])  # stop 2: TP, TP
        + _steps("patience", 1.0, 1, [True, True], [0.3, 0.3])  # stop 1: FP, TP
        + _steps("patience", 2.0, 0, [False, False], [0.3, 0.0])  # FN, FN
        + _steps("patience", 2.0, 1, [False, True], [0.3, 0.3])  # stop 2: FP, TP
        + _steps("validation", 3.0, 0, [False, False], [0.6, 0.6])  # TN, TN
        + _steps("validation", 3.0, 1, [False, True], [0.6, 0.05])  # stop 2: TP, TP
        + _steps("piob", 0.4, 0, [True, True], [0.0, 0.0])
    )
    quality, demos = observations(steps, [0.1, 0.5])
    assert quality.set_index(["rule", "replicate"])["correct"].to_dict() == {
        ("nevd", 0): 1.0,
        ("nevd", 1): 0.5,
        ("patience", 0): 0.5,
        ("patience", 1): 0.5,
        ("validation", 0): 1.0,
        ("validation", 1): 1.0,
    }
    assert demos.set_index(["rule", "replicate"])["demos"].to_dict() == {
        ("nevd", 0): 1.5,
        ("nevd", 1): 2.0,
        ("patience", 0): 2.0,
        ("patience", 1): 1.5,
        ("validation", 0): 2.0,
        ("validation", 1): 2.0,
    }


def test_rule_observations_of_a_run_are_one_per_replicate_and_rule(sweep_run):
    for cell in load_cells([sweep_run]):
        replicates = cell.steps["replicate"].nunique()
        for frame in observations(cell.steps, cell.thresholds):
            assert not frame.duplicated(["rule", "replicate"]).any()
            assert frame.groupby("rule").size().to_dict() == {
                "nevd": replicates,
                "patience": replicates,
                "validation": replicates,
            }


def test_noise_ablation_keeps_every_series_of_a_two_axis_sweep(tmp_path):
    """A noise × lapse sweep reports a noise series per lapse rate, not only the first one's."""
    directory = tmp_path / "run"
    run_scenario(
        small_scenario(replicates=2, sweep={"demos.noise_fraction": [0.0, 0.4], "demos.lapse": [0.0, 0.2]}),
        directory,
        record=False,
    )
    cells = load_cells([directory])
    table = noise_table(cells)
    assert sorted(table["series"].unique()) == ["lapse = 0.0", "lapse = 0.2"]
    for series, group in table.groupby("series"):
        assert sorted(group["noise"].unique()) == [0.0, 0.4]
        cell = next(
            c
            for c in cells
            if f"lapse = {c.labels['demos.lapse']}" == series and c.labels["demos.noise_fraction"] == 0.4
        )
        row = group[(group["noise"] == 0.4)].iloc[0]
        nevd = cell.steps[(cell.steps["rule"] == "nevd") & (cell.steps["param"] == row["epsilon"])]
        assert row["f1"] == pytest.approx(measure_group(nevd, False, row["epsilon"])["f1"], nan_ok=True)
    assert noise_ablation(cells, tmp_path / "noise.png").read_bytes()[:8] == PNG
    # One series: no series column, as before.
    assert "series" not in noise_table([c for c in cells if c.labels["demos.lapse"] == 0.0])


def test_noise_ablation_notes_missing_points_only_where_a_panel_misses_one():
    """A panel says why it misses a point (its rate's denominator is empty), and only then: the
    FPR of a sweep where every step is truly sufficient, not the accuracy or TPR beside it."""
    note = missing_point_note("fpr", pd.Series([0.0, math.nan]))
    assert note == "missing points: no truly insufficient step"
    assert missing_point_note("tpr", pd.Series([math.nan])) == "missing points: no truly sufficient step"
    assert missing_point_note("accuracy", pd.Series([1.0, 0.9])) is None
    assert missing_point_note("fpr", pd.Series([0.0, 0.25])) is None


def test_title_leaves_out_a_key_one_run_lacks(tmp_path):
    """Two runs compared across code versions: a key only the newer run's config has (None in
    the older's labels) is not shown as ``= None`` in the older run's title."""
    from mjsuff.report.results import ReportCell

    older = ReportCell(
        {"demos.lapse": None, "candidates": "family"}, [0.1], pd.DataFrame(), "lander", tmp_path
    )
    newer = ReportCell({"demos.lapse": 0.2, "candidates": None}, [0.1], pd.DataFrame(), "lander", tmp_path)
    assert older.title == "lander, candidates = family"
    assert newer.title == "lander, lapse = 0.2"


def test_a_key_an_older_run_lacks_shows_its_default(sweep_run, tmp_path):
    """An older run (its config has no ``demos.lapse``: it ran before the key existed) beside a
    newer one with lapse 0.2: the older is labelled with the default it ran with, lapse = 0.0,
    not left unlabelled (stop 43: a figure's left panel did not say which lapse it had)."""
    cell = next(p.parent for p in sorted(sweep_run.glob("cells/*/steps.parquet")))
    older, newer = tmp_path / "older", tmp_path / "newer"
    for directory, edit in ((older, lambda d: d.pop("lapse")), (newer, lambda d: d.update(lapse=0.2))):
        shutil.copytree(cell, directory)
        config = tomllib.loads((directory / "config.toml").read_text())
        edit(config["demos"])
        (directory / "config.toml").write_text(tomli_w.dumps(config))
    labelled = {c.directory.name: c.labels for c in load_cells([older, newer])}
    assert labelled == {"older": {"demos.lapse": 0.0}, "newer": {"demos.lapse": 0.2}}


def test_a_domain_key_an_older_run_lacks_shows_its_default(sweep_run, tmp_path):
    """The same for a key of the domain's own parameters (its default is the domain's, which
    ``scenario_default`` cannot know): the older run lacks ``domain.params.baseline``, the newer
    has "nonpessimal"; the older is labelled "random", the default it ran with, and a key both
    runs have at its default is no label at all."""
    cell = next(p.parent for p in sorted(sweep_run.glob("cells/*/steps.parquet")))
    older, newer = tmp_path / "older", tmp_path / "newer"
    edits = ((older, lambda d: d.pop("baseline")), (newer, lambda d: d.update(baseline="nonpessimal")))
    for directory, edit in edits:
        shutil.copytree(cell, directory)
        config = tomllib.loads((directory / "config.toml").read_text())
        edit(config["domain"]["params"])
        (directory / "config.toml").write_text(tomli_w.dumps(config))
    labelled = {c.directory.name: c.labels for c in load_cells([older, newer])}
    key = "domain.params.baseline"
    assert labelled == {"older": {key: "random"}, "newer": {key: "nonpessimal"}}


def test_a_ctrl_c_while_a_figure_is_written_leaves_no_partial_file(sweep_run, tmp_path, monkeypatch, capsys):
    import matplotlib.figure

    def interrupted_savefig(self, handle, **kwargs):
        handle.write(PNG + b"half a figure")
        raise KeyboardInterrupt

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", interrupted_savefig)
    out = tmp_path / "report"

    assert main(["report", str(sweep_run), "--out", str(out)]) == 130

    assert "mjsuff report: interrupted" in capsys.readouterr().err
    assert not out.exists() or sorted(p.name for p in out.iterdir()) == []
