"""``mjsuff scenarios``: the scenario files shipped with mjsuff."""

from __future__ import annotations

import argparse
import json
from typing import Any

from rich.table import Table

from mjsuff.cli.console import out, say
from mjsuff.experiment.shipped_scenarios import shipped_scenarios


def add_parser(commands: Any) -> None:
    scenarios = commands.add_parser(
        "scenarios",
        help="list the shipped scenarios (mjsuff run NAME runs one)",
        description="List the scenario files shipped with mjsuff: name, domain and the first "
        "sentence of the file's comment. Commands that take a scenario take these names when no "
        "file of that name exists.",
    )
    scenarios.add_argument(
        "--json",
        action="store_true",
        help="print a JSON list (name, domain, description, path) instead of a table",
    )
    scenarios.set_defaults(func=cmd_scenarios)


def cmd_scenarios(args: argparse.Namespace) -> int:
    shipped = shipped_scenarios()
    if args.json:
        listing = [
            {"name": s.name, "domain": s.domain, "description": s.description, "path": str(s.path)}
            for s in shipped
        ]
        print(json.dumps(listing, indent=2))
        return 0
    table = Table(title="Shipped scenarios: mjsuff run NAME")
    for col in ("name", "domain", "description"):
        table.add_column(col)
    for s in shipped:
        table.add_row(s.name, s.domain, s.description)
    out.print(table)
    folder = shipped[0].path.parent if shipped else "(none)"
    say(f"files: {folder} (a file of the same name in the working directory comes first)")
    return 0
