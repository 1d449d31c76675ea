"""Sweep grids: every cell runs with the same seeds as the equivalent single run; bad grids are
refused before any work, naming the file and the key."""

import json

import pandas as pd
import pytest

from mjsuff.experiment import backend
from mjsuff.experiment.runner import run_scenario
from mjsuff.experiment.scenario import ScenarioError, load_scenario
from mjsuff.report import load_cells
from tests.conftest import small_scenario


def test_each_cell_equals_its_single_run(tmp_path):
    sweep = {"demos.noise_fraction": [0.0, 0.3], "demos.beta": [5.0, 20.0]}
    result = run_scenario(small_scenario(sweep=sweep), tmp_path / "s", record=False)
    assert len(result.cells) == 4 and result.completed == 8
    cells = json.loads((tmp_path / "s" / "sweep.json").read_text())["cells"]
    assert [c["labels"] for c in cells] == [
        {"demos.noise_fraction": n, "demos.beta": b} for n in (0.0, 0.3) for b in (5.0, 20.0)
    ]
    combined = pd.read_parquet(tmp_path / "s" / "steps.parquet")
    assert combined.groupby("cell")["replicate"].nunique().tolist() == [2, 2, 2, 2]
    # Cell 3 (noise 0.3, beta 20) is exactly the run with those settings.
    single = run_scenario(
        small_scenario(**{"demos.noise_fraction": 0.3, "demos.beta": 20.0}), tmp_path / "one", record=False
    )
    cell = pd.read_parquet(tmp_path / "s" / cells[3]["directory"] / "steps.parquet")
    pd.testing.assert_frame_equal(cell, pd.read_parquet(single.directory / "steps.parquet"))
    part = (
        combined[combined["cell"] == 3]
        .drop(columns=["cell", "demos.noise_fraction", "demos.beta"])
        .reset_index(drop=True)
    )
    pd.testing.assert_frame_equal(part, cell)
    # Noise happened: poor demos in the noisy cells only.
    poor = combined.groupby("demos.noise_fraction")["poor_demo"].any()
    assert not poor[0.0] and poor[0.3]


def test_interrupted_sweep_keeps_and_summarizes_what_finished(tmp_path, monkeypatch):
    real, calls = backend.run_replicate, []

    def interrupt_third(scenario, replicate, *rest):
        calls.append(replicate)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(scenario, replicate, *rest)

    monkeypatch.setattr(backend, "run_replicate", interrupt_third)
    scenario = small_scenario(sweep={"demos.beta": [5.0, 20.0]})
    with pytest.raises(KeyboardInterrupt):
        run_scenario(scenario, tmp_path / "s")
    combined = pd.read_parquet(tmp_path / "s" / "steps.parquet")
    assert combined.groupby("cell")["replicate"].nunique().to_dict() == {0: 2}
    run = json.loads((tmp_path / "s" / "run.json").read_text())
    assert run["interrupted"] and run["completed_replicates"] == 2
    # A report covers the finished cell; resuming finishes the rest.
    assert len(load_cells([tmp_path / "s"])) == 1
    monkeypatch.setattr(backend, "run_replicate", real)
    result = run_scenario(scenario, tmp_path / "s", resume=True)
    assert result.completed == 4 and not result.interrupted


def test_list_values_can_be_swept(tmp_path):
    result = run_scenario(
        small_scenario(sweep={"rules.patience": [[1], [1, 2]]}), tmp_path / "s", record=False
    )
    assert [c.result.directory.name for c in result.cells] == ["cell-00_patience=1", "cell-01_patience=1+2"]
    combined = pd.read_parquet(tmp_path / "s" / "steps.parquet")
    assert set(combined["rules.patience"]) == {"[1]", "[1, 2]"}
    patience = combined[combined["rule"] == "patience"]
    assert set(patience.loc[patience["cell"] == 1, "param"]) == {1.0, 2.0}


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ('"demos.noise_fraction" = [0.0, 1.5]', "sweep cell demos.noise_fraction=1.5: demos.noise_fraction"),
        ('"demos.typo" = [1]', "demos.typo: unknown key"),
        ('"seed" = [1, 2]', "sweep.seed"),
        ('"demos.beta" = []', "sweep.demos.beta"),
    ],
)
def test_bad_grids_name_the_file_and_key(tmp_path, line, message):
    path = tmp_path / "s.toml"
    path.write_text(f'name = "s"\n[domain]\nname = "gridworld"\n[sweep]\n{line}\n')
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert str(path) in str(info.value) and message in str(info.value)
