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
from mjsuff.cli.console import EXIT_INTERRUPTED

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
def commands_not_yet_imported(monkeypatch, usual_signal_handlers):
    """Make the next ``import mjsuff.cli.commands`` a fresh one (put back as it was afterwards),
    with Python's own SIGINT handler in place (as ``mjsuff`` has when started from a shell)."""
    import mjsuff.cli

    monkeypatch.delitem(sys.modules, COMMANDS_MODULE, raising=False)
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


def test_a_ctrl_c_a_library_swallows_during_the_import_still_ends_the_command(
    commands_not_yet_imported, capsys
):
    def swallowed():
        try:
            signal.raise_signal(signal.SIGINT)
        except KeyboardInterrupt:
            pass

    commands_not_yet_imported(swallowed)

    assert entry.main(["scenarios"]) == entry.EXIT_INTERRUPTED
    assert capsys.readouterr().err == entry.STARTUP_INTERRUPTED + "\n"


def test_an_ignored_ctrl_c_stays_ignored(commands_not_yet_imported, capsys):
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    commands_not_yet_imported(lambda: signal.raise_signal(signal.SIGINT))

    assert entry.main(["scenarios"]) == 0
    assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    assert entry.STARTUP_INTERRUPTED not in capsys.readouterr().err


def test_the_exit_status_is_the_commands_own():
    assert entry.EXIT_INTERRUPTED == EXIT_INTERRUPTED


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
    # The child says "ready" as the commands' import begins (the entry point's handler is then in
    # place); the import (numpy, scipy, MuJoCo, ArviZ) takes a second or more, so a Ctrl-C 0.1 s
    # later lands inside it. Python's own SIGINT handler first: a test run started in the
    # background has SIGINT ignored, and its children inherit that.
    child = """
import importlib.abc, signal, sys

class Ready(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name == "mjsuff.cli.commands":
            print("ready", flush=True)
        return None

signal.signal(signal.SIGINT, signal.default_int_handler)
sys.meta_path.insert(0, Ready())
from mjsuff.cli import entry
sys.exit(entry.main(["scenarios"]))
"""
    process = subprocess.Popen(
        [sys.executable, "-c", child],
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert process.stdout.readline() == "ready\n"
        time.sleep(0.1)
        process.send_signal(signal.SIGINT)
        _out, err = process.communicate(timeout=60)
    finally:
        process.kill()
        process.wait()

    assert process.returncode == entry.EXIT_INTERRUPTED, err
    assert "Traceback" not in err
    assert err.strip().splitlines()[-1] == entry.STARTUP_INTERRUPTED
