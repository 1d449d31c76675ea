"""The entry point: a Ctrl-C while the commands are still importing is one line and status 130."""

from __future__ import annotations

import importlib.abc
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mjsuff.cli import entry

ROOT = Path(__file__).resolve().parents[1]
COMMANDS_MODULE = "mjsuff.cli.commands"


class _ImportHook(importlib.abc.MetaPathFinder):
    """Runs ``action`` when ``mjsuff.cli.commands`` is imported, before the real import."""

    def __init__(self, action):
        self.action = action

    def find_spec(self, fullname, path, target=None):
        if fullname == COMMANDS_MODULE:
            self.action()
        return None


@pytest.fixture
def commands_not_yet_imported(monkeypatch):
    """Make the next ``import mjsuff.cli.commands`` a fresh one (put back as it was afterwards)."""
    import mjsuff.cli

    monkeypatch.delitem(sys.modules, COMMANDS_MODULE)
    monkeypatch.delattr(mjsuff.cli, "commands", raising=False)

    def hook(action):
        finder = _ImportHook(action)
        monkeypatch.setattr(sys, "meta_path", [finder, *sys.meta_path])

    return hook


def test_a_ctrl_c_during_the_import_is_one_line(commands_not_yet_imported, capsys):
    commands_not_yet_imported(lambda: signal.raise_signal(signal.SIGINT))
    handler = signal.getsignal(signal.SIGINT)

    assert entry.main(["scenarios"]) == entry.EXIT_INTERRUPTED

    assert capsys.readouterr().err == entry.STARTUP_INTERRUPTED + "\n"
    assert signal.getsignal(signal.SIGINT) is handler


def test_an_import_error_from_an_interrupted_extension_is_the_same_line(commands_not_yet_imported, capsys):
    def interrupted_extension():
        try:
            signal.raise_signal(signal.SIGINT)
        except KeyboardInterrupt:
            raise ImportError("initialization failed") from None

    commands_not_yet_imported(interrupted_extension)

    assert entry.main(["scenarios"]) == entry.EXIT_INTERRUPTED
    assert capsys.readouterr().err == entry.STARTUP_INTERRUPTED + "\n"


def test_an_import_error_without_a_ctrl_c_is_not_hidden(commands_not_yet_imported):
    def broken():
        raise ImportError("No module named 'mujoco'")

    commands_not_yet_imported(broken)

    with pytest.raises(ImportError, match="mujoco"):
        entry.main(["scenarios"])


def test_importing_the_package_and_its_command_line_imports_nothing_heavy():
    probe = (
        "import sys, mjsuff, mjsuff.cli; "
        "print(sorted(m for m in ('numpy', 'scipy', 'mujoco', 'arviz') if m in sys.modules))"
    )
    result = subprocess.run(
        [sys.executable, "-c", probe], cwd=ROOT, capture_output=True, text=True, check=True
    )
    assert result.stdout.strip() == "[]"


def test_a_real_ctrl_c_while_starting_ends_with_one_line():
    # The child reports once it is about to call the entry point; the commands' imports (numpy,
    # scipy, MuJoCo, ArviZ) take about a second and a half on CI's cores, so a Ctrl-C 0.2 s later
    # lands inside them.
    child = (
        "import sys; from mjsuff.cli import entry; print('ready', flush=True); "
        "sys.exit(entry.main(['scenarios']))"
    )
    process = subprocess.Popen(
        [sys.executable, "-c", child],
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        # Python ignores SIGINT in children started from a shell's background job; give it back.
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    assert process.stdout.readline() == "ready\n"
    time.sleep(0.2)
    process.send_signal(signal.SIGINT)
    _out, err = process.communicate(timeout=60)

    assert process.returncode == entry.EXIT_INTERRUPTED, err
    assert err == entry.STARTUP_INTERRUPTED + "\n"
