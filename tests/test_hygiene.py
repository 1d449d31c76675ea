"""Hygiene is part of the suite (issue #18): the code passes ruff's lint rules and its formatter,
and mypy (with the pydantic plugin; ``[tool.mypy]`` in pyproject.toml) finds no error in the package.

ruff and mypy are pinned in the ``test`` extra, since their rules change between releases.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("command", [["check"], ["format", "--check"]], ids=["lint", "format"])
def test_ruff_passes(command: list[str]) -> None:
    result = subprocess.run(
        [sys.executable, "-m", "ruff", *command, "."], cwd=ROOT, capture_output=True, text=True, check=False
    )
    assert result.returncode == 0, result.stdout + result.stderr


def test_mypy_finds_no_error(tmp_path: Path) -> None:
    result = subprocess.run(
        [sys.executable, "-m", "mypy", "--cache-dir", str(tmp_path / "cache")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 0, result.stdout + result.stderr


def test_the_suites_longest_first_list_names_its_modules() -> None:
    """``tests/conftest.py`` schedules these modules first (the suite's balance on two workers);
    a renamed or removed module would silently fall back to collection order."""
    from tests.conftest import LONGEST_FIRST

    here = Path(__file__).parent
    assert [name for name in LONGEST_FIRST if not (here / name).is_file()] == []
