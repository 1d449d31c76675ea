"""Results unchanged, byte for byte: a small run of every registered domain against its record.

Issue #18 reshapes the code around the Domain seam without changing a single result. Each registered
domain runs a small scenario (tiny budgets for the scenes, as in ``test_scene_runs.py``); its
``summary.json`` must equal the recorded bytes and its ``steps.parquet`` the recorded rows, every
float exactly (JSON round-trips a float64). A change that is meant to move results rewrites the
record, on purpose and in its own commit: ``python tests/test_golden.py --write``.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import pandas as pd
import pytest

from mjsuff.cli import main
from mjsuff.domains import REGISTRY

ROOT = Path(__file__).parent.parent
RECORDS = Path(__file__).parent / "golden"
SMALL = ["--replicates", "2", "--quiet", "--no-record", "--workers", "1"]
#: Per kind of domain, settings that keep a run to seconds while every stage still runs.
SETTINGS = {
    "tabular": ["demos.max_demos=3", "posterior.num_samples=200"],
    "scene": [
        "domain.params.eval_starts=3",
        "domain.params.pool_starts=4",
        "demos.max_demos=2",
        "posterior.num_samples=100",
        "domain.params.planning.planner.iterations=3",
        "domain.params.planning.refine_rounds=0",
        "domain.params.planning.seed_directions=1",
        "domain.params.planning.truth_scale=1.0",
        "rules.validation_intervals=[2]",
        "rules.patience=[1]",
    ],
}


def run(name: str, out: Path) -> tuple[bytes, list[dict]]:
    """``summary.json`` bytes and ``steps.parquet`` rows of the small run of domain ``name``."""
    sets = [x for s in SETTINGS[REGISTRY[name].kind] for x in ("--set", s)]
    code = main(["run", str(ROOT / "scenarios" / f"{name}.toml"), "--out", str(out), *SMALL, *sets])
    assert code == 0
    steps = pd.read_parquet(out / "steps.parquet")
    rows = [{k: _plain(v) for k, v in row.items()} for row in steps.to_dict("records")]
    return (out / "summary.json").read_bytes(), rows


def _plain(value: object) -> object:
    """A JSON-comparable cell: numpy scalars as Python ones, NaN as the string ``"nan"``."""
    value = value.item() if hasattr(value, "item") else value
    return "nan" if isinstance(value, float) and math.isnan(value) else value


@pytest.mark.parametrize("name", sorted(REGISTRY))
def test_results_match_the_record(name, tmp_path):
    record = json.loads((RECORDS / f"{name}.json").read_text())
    summary, rows = run(name, tmp_path / name)
    assert summary.decode() == record["summary"]
    assert len(rows) == len(record["steps"])
    for i, (got, want) in enumerate(zip(rows, record["steps"], strict=True)):
        assert got == want, f"steps.parquet row {i} differs"


if __name__ == "__main__" and sys.argv[1:] == ["--write"]:
    import tempfile

    RECORDS.mkdir(exist_ok=True)
    for name in sorted(REGISTRY):
        with tempfile.TemporaryDirectory() as tmp:
            summary, rows = run(name, Path(tmp) / name)
        record = {"summary": summary.decode(), "steps": rows}
        (RECORDS / f"{name}.json").write_text(json.dumps(record) + "\n")
        print(f"recorded {name}: {len(rows)} steps rows")
