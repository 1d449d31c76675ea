"""The scenarios shipped with mjsuff: the repository's ``scenarios/``, installed as
``mjsuff.scenarios``; ``mjsuff run NAME`` and ``mjsuff scenarios`` use them."""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass
from pathlib import Path

from mjsuff.package_data import data_dir


@dataclass(frozen=True)
class ShippedScenario:
    """A scenario file shipped with mjsuff (the repository's ``scenarios/``, installed as
    ``mjsuff.scenarios``): ``mjsuff run NAME`` runs it."""

    name: str
    domain: str
    description: str
    path: Path


def shipped_scenario_files() -> dict[str, Path]:
    """The shipped scenario files by name (file stem)."""
    return {p.stem: p for p in sorted(data_dir("mjsuff.scenarios").glob("*.toml"))}


def _description(text: str) -> str:
    """The first sentence of a scenario file's leading comment block ("" without one)."""
    lines = []
    for line in text.splitlines():
        if not line.startswith("#"):
            break
        lines.append(line.lstrip("#").strip())
    comment = " ".join(x for x in lines if x)
    match = re.match(r"(.+?\.)(\s|$)", comment)
    return match.group(1) if match else comment


def shipped_scenarios() -> list[ShippedScenario]:
    """The shipped scenarios, by name, with their domain and a one-line description."""
    shipped = []
    for name, path in shipped_scenario_files().items():
        text = path.read_text()
        domain = tomllib.loads(text).get("domain", {}).get("name", "?")
        shipped.append(ShippedScenario(name, str(domain), _description(text), path))
    return shipped
