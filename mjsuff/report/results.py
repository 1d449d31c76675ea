"""Load finished runs for a report: one run, a sweep, or several runs side by side.

Every source becomes a list of ``ReportCell`` (labels + the rows of ``steps.parquet``). Several run
directories are labelled by the scenario keys in which their ``config.toml`` differ (for example
``demos.noise_fraction``), so separately launched runs report like a sweep.
"""

from __future__ import annotations

import json
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from mjsuff.errors import MjsuffError
from mjsuff.experiment.scenario import flat_keys, scenario_default, stored_settings


class ReportError(MjsuffError, ValueError):
    """A directory that cannot be reported on; the message is one line for the user."""


@dataclass(frozen=True)
class ReportCell:
    """One run (or sweep cell): its labels, ε thresholds and per-step rows."""

    labels: dict[str, Any]
    thresholds: list[float]
    steps: pd.DataFrame
    scenario: str
    directory: Path

    @property
    def title(self) -> str:
        """The scenario's name and up to three labels (a domain's own parameters are implied by
        its name, and left out when the domains differ; a key this run's config lacks and that has
        no default, as an older run's scene key, is left out: the other runs' titles show it)."""
        labels = self.labels
        if "domain.name" in labels:
            labels = {
                k: v for k, v in labels.items() if not k.startswith("domain.params") and "tolerance" not in k
            }
        shown = label_texts({k: v for k, v in labels.items() if k != "domain.name"})
        return ", ".join([self.scenario, *shown[:3]] + (["…"] if len(shown) > 3 else []))


def label_texts(labels: dict[str, Any]) -> list[str]:
    """``name = value`` for each label (its key's last part), leaving out keys a run's config
    lacks (``None``: an older run's; the other runs' labels show them)."""
    return [f"{k.split('.')[-1]} = {v}" for k, v in labels.items() if v is not None]


def _config(directory: Path) -> dict[str, Any]:
    path = directory / "config.toml"
    try:
        return tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise ReportError(f"{directory}: not a run directory (no config.toml)") from None
    except (OSError, tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ReportError(f"{path}: cannot be read ({exc})") from None


def _steps(directory: Path) -> pd.DataFrame:
    path = directory / "steps.parquet"
    if not path.is_file():
        raise ReportError(
            f"{directory}: no steps.parquet (no replicate has finished; mjsuff run --resume continues a run)"
        )
    try:
        steps = pd.read_parquet(path)
    except Exception as exc:  # pyarrow raises several types for damaged files
        raise ReportError(f"{path}: cannot be read ({exc})") from None
    needed = {
        "replicate",
        "rule",
        "param",
        "step",
        "bound",
        "true_value",
        "true_nevd",
        "true_piob",
        "decision",
        "pool_size",
        "policy_optimality",
    }
    if missing := needed - set(steps.columns):
        raise ReportError(f"{path}: missing columns {sorted(missing)}")
    if steps.empty:
        raise ReportError(f"{path}: no rows (no replicate has finished; mjsuff run --resume continues a run)")
    return steps


def _thresholds(config: dict[str, Any]) -> list[float]:
    return [float(t) for t in config.get("rules", {}).get("nevd_thresholds", [])]


def _sweep_cells(top: Path) -> list[ReportCell]:
    try:
        sweep = json.loads((top / "sweep.json").read_text())
        listed = [(c["labels"], top / c["directory"]) for c in sweep["cells"]]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ReportError(f"{top / 'sweep.json'}: not a sweep description ({exc})") from None
    cells = []
    for labels, directory in listed:
        if not (directory / "steps.parquet").is_file():
            continue  # a cell with no finished replicate (an interrupted sweep)
        config = _config(directory)
        cells.append(
            ReportCell(
                labels, _thresholds(config), _steps(directory), config.get("name", top.name), directory
            )
        )
    if not cells:
        raise ReportError(f"{top}: no sweep cell has a finished replicate yet")
    return cells


def _flat_default(key: str) -> Any:
    """A setting's default as ``flat_keys`` writes its value (a list as its JSON text)."""
    return flat_keys({key: scenario_default(key)})[key]


def _settings(config: dict[str, Any]) -> dict[str, Any]:
    """A run's settings as flat keys, those added since it ran filled (``stored_settings``); as
    stored when its config no longer validates or its domain cannot be loaded (labels only)."""
    try:
        return stored_settings(config, "config.toml")
    except Exception:  # another version's config, an external domain that fails to import
        return flat_keys(config)


def load_cells(directories: list[Path]) -> list[ReportCell]:
    """The cells of one run or sweep directory, or of several run directories (labelled by the
    scenario keys in which they differ; a key an older run's config lacks shows its default, the
    behaviour before the key existed, or is left out when it has none)."""
    if not directories:
        raise ReportError("report: name at least one run directory")
    if len(directories) == 1 and (directories[0] / "sweep.json").is_file():
        return _sweep_cells(directories[0])
    for d in directories:
        if (d / "sweep.json").is_file():
            raise ReportError(f"{d}: a sweep; report it on its own (mjsuff report {d})")
    configs = [_config(d) for d in directories]
    flat = [
        {k: v for k, v in _settings(c).items() if k not in ("seed", "replicates", "name")} for c in configs
    ]

    def value(settings: dict[str, Any], key: str) -> Any:
        return settings[key] if key in settings else _flat_default(key)

    keys = sorted({k for f in flat for k in f})
    differing = [k for k in keys if any(value(g, k) != value(flat[0], k) for g in flat)]
    return [
        ReportCell(
            {k: value(f, k) for k in differing},
            _thresholds(c),
            _steps(d),
            c.get("name", d.name),
            d,
        )
        for d, c, f in zip(directories, configs, flat, strict=True)
    ]
