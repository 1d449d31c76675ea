"""Design probes: override a scene module's constants (``--constant NAME=VALUE``) in a benchmark.

A scene's design lives in its module's constants (``mjsuff.scenes.lander.ZONE_RADII``,
``IMPACT_SCALE``, …). A benchmark given ``--constant IMPACT_SCALE=10`` sets that constant
before it builds an instance (in each worker process), so a candidate design is measured by the
same code as the shipped one, without editing the package. For design seeds only.

Only the scene module's own reads see the override: a module that imported the name by value
keeps the shipped one (the lander's expert imports ``REST_HEIGHT`` and ``TOUCH_THRESHOLD``), so
override only constants the scene module alone reads (``grep`` before trusting a probe). A
constant that the scenario file sets as a scene parameter (``ZONE_RADII`` is the lander's
``domain.params.zone_radii``) is refused: the file's value would win; ``--set`` it instead.
"""

from __future__ import annotations

import argparse
import importlib
import json
import tomllib
from pathlib import Path

SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"


def parse_constant(text: str) -> tuple[str, object]:
    """``NAME=VALUE`` with a JSON value (a list becomes a tuple) -> ``(NAME, value)``."""
    name, sep, value = text.partition("=")
    if not sep or not name.isidentifier() or not name.isupper():
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE with an upper-case NAME, got {text!r}")
    try:
        parsed = json.loads(value)
    except json.JSONDecodeError as err:
        raise argparse.ArgumentTypeError(f"{name}: expected a JSON value, got {value!r} ({err})") from None
    return name, tuple(parsed) if isinstance(parsed, list) else parsed


def set_scene_constants(scene: str, constants: list[tuple[str, object]]) -> None:
    """Set each ``(NAME, value)`` on ``mjsuff.scenes.<scene>``; an unknown NAME is an error."""
    module = importlib.import_module(f"mjsuff.scenes.{scene}")
    params = tomllib.loads((SCENARIOS / f"{scene}.toml").read_text())["domain"].get("params", {})
    for name, value in constants:
        if not hasattr(module, name):
            raise SystemExit(f"--constant {name}: mjsuff.scenes.{scene} has no constant {name}")
        if name.lower() in params:
            raise SystemExit(
                f"--constant {name}: scenarios/{scene}.toml sets domain.params.{name.lower()}, which "
                f"would win; use --set 'domain.params.{name.lower()}=VALUE'"
            )
        setattr(module, name, value)


def add_argument(parser: argparse.ArgumentParser) -> None:
    """``--constant NAME=VALUE`` (repeatable) on ``parser``."""
    parser.add_argument(
        "--constant",
        action="append",
        default=[],
        type=parse_constant,
        metavar="NAME=VALUE",
        help="override a constant of the scene's module (JSON value), for design probes",
    )
