"""Options several commands share, as argparse parent parsers, and the scenario they load."""

from __future__ import annotations

import argparse

from mjsuff.experiment.scenario import Scenario, load_scenario

SCENARIO_HELP = "scenario TOML file or a shipped scenario's name (mjsuff scenarios)"


def scenario_options(example: str, set_example: str) -> argparse.ArgumentParser:
    """The scenario and what overrides it: ``SCENARIO``, ``--seed``, ``--set KEY=VALUE``."""
    parent = argparse.ArgumentParser(add_help=False)
    parent.add_argument("scenario", help=f"{SCENARIO_HELP}, e.g. {example}")
    parent.add_argument("--seed", type=int, help="override the scenario's seed")
    parent.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUE",
        help=f"override a scenario key, e.g. --set {set_example} (repeatable)",
    )
    return parent


def quiet_option(what: str) -> argparse.ArgumentParser:
    """``--quiet``: no progress bar and no ``what`` (the command's table)."""
    parent = argparse.ArgumentParser(add_help=False)
    parent.add_argument("--quiet", action="store_true", help=f"no progress bar or {what}")
    return parent


def load(args: argparse.Namespace) -> Scenario:
    """The scenario with ``--set``, ``--seed`` and ``--replicates`` applied.

    Raises:
        ScenarioError: the file, a key or an override cannot be used (the message names it).
    """
    overrides, given_as = list(args.set or []), {}
    for option in ("seed", "replicates"):
        if getattr(args, option, None) is not None:
            text = f"{option}={getattr(args, option)}"
            overrides.append(text)
            given_as[text] = f"--{option}"
    return load_scenario(args.scenario, overrides, given_as)
