"""steps.parquet's columns are defined once (``mjsuff.experiment.step_row``), and every copy agrees."""

from pathlib import Path

import pandas as pd

from mjsuff.cli import main
from mjsuff.experiment.step_row import STEP_COLUMNS, markdown_table

README = Path(__file__).parent.parent / "README.md"


def test_the_readme_table_is_the_definition():
    assert markdown_table() in README.read_text(), (
        "regenerate it: mjsuff.experiment.step_row.markdown_table()"
    )


def test_a_run_writes_exactly_the_defined_columns_in_order(tmp_path):
    out = tmp_path / "run"
    args = ["run", "gridworld", "--out", str(out), "--replicates", "1", "--quiet", "--no-record"]
    assert main([*args, "--set", "demos.max_demos=2", "--set", "posterior.num_samples=100"]) == 0
    assert tuple(pd.read_parquet(out / "steps.parquet").columns) == STEP_COLUMNS
