"""Results unchanged, byte for byte: a small run of every registered domain against its record.

Issue #18 reshapes the code around the Domain seam without changing a single result. Each registered
domain runs a small scenario (tiny budgets for the scenes, as in ``test_scene_runs.py``); its
``summary.json`` must equal the recorded bytes and its ``steps.parquet`` the recorded rows, every
float exactly (JSON round-trips a float64). A change that is meant to move results rewrites the
record, on purpose and in its own commit: ``python tests/test_golden.py --write``.

Byte for byte holds only for the same floating-point kernels. OpenBLAS picks its kernel by CPU
(SkylakeX on an AVX-512 Intel, Haswell on an AMD EPYC with AVX-512 too) and numpy dispatches its
own loops by CPU features; the two kernels round matrix products differently in the last bit, a
planner or a bound turns that into other rows. So each run is a child process with both pinned
(``PINNED_KERNELS``: OpenBLAS's Haswell kernel, numpy's loops without AVX-512), and the test runs
on x86-64 CPUs with AVX2 and FMA only (elsewhere those kernels do not exist).
"""

from __future__ import annotations

import json
import math
import os
import platform
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

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


#: The floating-point kernels every recorded run uses, whatever the CPU (module docs). numpy's
#: AVX-512 groups are named both ways (numpy ≥ 2.3 and before); a name it does not know is ignored.
PINNED_KERNELS = {
    "OPENBLAS_CORETYPE": "Haswell",
    "NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR AVX512F AVX512CD AVX512_SKX AVX512_CLX "
    "AVX512_CNL AVX512_KNL AVX512_KNM AVX512FP16",
}


def _cpu_has_the_pinned_kernels() -> bool:
    if platform.machine().lower() not in ("x86_64", "amd64"):
        return False
    try:
        flags = Path("/proc/cpuinfo").read_text().split()
    except OSError:
        return False
    return "avx2" in flags and "fma" in flags


def run(name: str, out: Path) -> tuple[bytes, list[dict]]:
    """``summary.json`` bytes and ``steps.parquet`` rows of the small run of domain ``name``, made
    by a child process on the pinned kernels."""
    sets = [x for s in SETTINGS[REGISTRY[name].kind] for x in ("--set", s)]
    args = ["run", str(ROOT / "scenarios" / f"{name}.toml"), "--out", str(out), *SMALL, *sets]
    done = subprocess.run(
        [sys.executable, "-m", "mjsuff.cli", *args],
        env={**os.environ, **PINNED_KERNELS},
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    steps = pd.read_parquet(out / "steps.parquet")
    rows = [{k: _plain(v) for k, v in row.items()} for row in steps.to_dict("records")]
    return (out / "summary.json").read_bytes(), rows


def _plain(value: object) -> object:
    """A JSON-comparable cell: numpy scalars as Python ones, NaN as the string ``"nan"``."""
    value = value.item() if hasattr(value, "item") else value
    return "nan" if isinstance(value, float) and math.isnan(value) else value


@pytest.mark.skipif(not _cpu_has_the_pinned_kernels(), reason="the record is of x86-64 AVX2 kernels")
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
