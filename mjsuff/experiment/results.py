"""Run directories: every file written atomically, finished replicates kept on interruption.

Layout of ``DIR``:

* ``config.toml`` — the resolved scenario (written first);
* ``replicates/replicate-NNNNN.parquet`` — the steps of each finished replicate;
* ``steps.parquet`` — all finished replicates' steps, one row per replicate × rule × param × step;
* ``summary.json`` — the measures (see ``mjsuff.experiment.measures``), deterministic per seed;
* ``run.json`` — how the run went: versions, backend, timing, completed and planned replicates;
* ``recording.rrd`` — the Rerun recording (``recordings/`` holds per-replicate parts until the run
  ends and merges them).

A sweep (``[sweep]`` in the scenario) has one such directory per cell under ``cells/``, and at the
top ``config.toml``, ``sweep.json`` (the cells, their labels and directories), ``steps.parquet``
(every cell's rows with a ``cell`` column and one column per swept key), ``summary.json`` and
``run.json``.
"""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path
from typing import Any

import pandas as pd

from mjsuff.atomic import atomic_write_parquet, atomic_write_text
from mjsuff.errors import MjsuffError


class OutputError(MjsuffError, OSError):
    """The output directory cannot be used; the message is one line for the user."""


def prepare_output(directory: Path, overwrite: bool, resume: bool = False) -> None:
    """Create ``directory`` and prove it writable, before any work starts.

    A non-empty directory needs ``overwrite`` (its results are removed) or ``resume`` (its
    finished replicates are kept)."""
    if directory.exists() and not directory.is_dir():
        raise OutputError(f"{directory}: --out exists and is not a directory")
    if directory.is_dir() and any(directory.iterdir()) and not (overwrite or resume):
        raise OutputError(
            f"{directory}: --out is not empty; pass --resume to continue the run "
            "in it or --overwrite to replace it"
        )
    try:
        directory.mkdir(parents=True, exist_ok=True)
        probe = directory / ".write-probe"
        probe.write_text("ok")
        probe.unlink()
    except OSError as exc:
        raise OutputError(f"{directory}: --out is not writable ({exc.strerror or exc})") from None
    if overwrite and not resume:
        for old in (directory / "replicates").glob("replicate-*.parquet"):
            old.unlink()
        for name in (
            "steps.parquet",
            "summary.json",
            "run.json",
            "sweep.json",
            "recording.rrd",
            "recording.json",  # a manifest older versions of mjsuff wrote
        ):
            (directory / name).unlink(missing_ok=True)
        for name in ("cells", "recordings"):
            if (directory / name).is_dir():
                shutil.rmtree(directory / name)


def replicate_path(directory: Path, replicate: int) -> Path:
    return directory / "replicates" / f"replicate-{replicate:05d}.parquet"


def write_replicate(directory: Path, replicate: int, rows: list[dict[str, Any]]) -> None:
    atomic_write_parquet(replicate_path(directory, replicate), pd.DataFrame(rows))


def read_steps(directory: Path) -> pd.DataFrame:
    """All finished replicates' rows, in replicate order."""
    parts = sorted((directory / "replicates").glob("replicate-*.parquet"))
    if not parts:
        return pd.DataFrame()
    return pd.concat([pd.read_parquet(p) for p in parts], ignore_index=True)


def _finite_or_null(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _finite_or_null(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_finite_or_null(v) for v in value]
    return value


def write_json(path: Path, data: Any) -> None:
    """Strict JSON (NaN and infinities become null), written atomically."""
    text = json.dumps(_finite_or_null(data), indent=2, allow_nan=False)
    atomic_write_text(path, text + "\n")
