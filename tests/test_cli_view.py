"""mjsuff view: the viewer it launches, where it serves, and what it says where none can open."""

import os
import signal
import subprocess
import sys
import time

import pytest

from mjsuff.cli import main
from mjsuff.cli import view as view_command


@pytest.fixture
def run_dir(tmp_path):
    (tmp_path / "recording.rrd").write_bytes(b"")  # the viewer is never launched here
    return tmp_path


@pytest.fixture
def launched(monkeypatch):
    """The commands mjsuff view would run, instead of running them."""
    calls = []
    monkeypatch.setattr(view_command, "run_viewer", lambda command: calls.append(command) or 0)
    return calls


def test_view_without_display_says_what_to_run(run_dir, monkeypatch, launched, capsys):
    monkeypatch.setattr(view_command, "has_display", lambda: False)
    assert main(["view", str(run_dir)]) == 1
    err = capsys.readouterr().err
    assert "no display here" in err and "rerun recording.rrd" in err and "--web" in err
    assert launched == []


def test_view_opens_the_viewer_on_the_runs_recording(run_dir, monkeypatch, launched):
    monkeypatch.setattr(view_command, "has_display", lambda: True)
    assert main(["view", str(run_dir)]) == 0
    assert launched[0][-1] == str(run_dir / "recording.rrd")


def test_the_web_viewer_serves_this_machine_only_unless_asked(run_dir, launched, capsys):
    """Issue #19, item 8: Rerun serves on every interface by default, without authentication."""
    assert main(["view", str(run_dir), "--web", "--port", "9123"]) == 0
    command = launched[0]
    assert "--web-viewer" in command and "9123" in command
    assert command[command.index("--bind") + 1] == "127.0.0.1"
    assert "http://localhost:9123" in capsys.readouterr().out
    assert main(["view", str(run_dir), "--web", "--bind", "0.0.0.0"]) == 0
    assert launched[1][launched[1].index("--bind") + 1] == "0.0.0.0"


def test_view_of_a_missing_recording_is_a_clear_error(tmp_path, capsys):
    assert main(["view", str(tmp_path)]) == 2
    assert "no recording" in capsys.readouterr().err


def test_sigterm_to_mjsuff_stops_the_viewer_it_started(tmp_path):
    """Issue #19, item 7: the viewer (a web viewer's server) must not outlive mjsuff."""
    pid_file = tmp_path / "viewer.pid"
    viewer = f"import os, time; open({str(pid_file)!r}, 'w').write(str(os.getpid())); time.sleep(60)"
    code = (
        "import sys; from mjsuff.cli.view import run_viewer; "
        f"sys.exit(run_viewer([sys.executable, '-c', {viewer!r}]))"
    )
    mjsuff = subprocess.Popen([sys.executable, "-c", code])
    deadline = time.monotonic() + 30
    while not pid_file.exists() or not pid_file.read_text():
        assert time.monotonic() < deadline, "the viewer never started"
        time.sleep(0.05)
    viewer_pid = int(pid_file.read_text())
    mjsuff.send_signal(signal.SIGTERM)
    assert mjsuff.wait(timeout=15) == 0
    with pytest.raises(ProcessLookupError):  # gone (and reaped by mjsuff)
        os.kill(viewer_pid, 0)
