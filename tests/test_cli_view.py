"""mjsuff view: the viewer it launches, and what it says where none can open."""

import pytest

from mjsuff.cli import main
from mjsuff.cli import view as view_command


@pytest.fixture
def run_dir(tmp_path):
    (tmp_path / "recording.rrd").write_bytes(b"")  # the viewer is never launched here
    return tmp_path


def test_view_without_display_says_what_to_run(run_dir, monkeypatch, capsys):
    monkeypatch.setattr(view_command, "has_display", lambda: False)
    monkeypatch.setattr(view_command.subprocess, "call", lambda *a, **k: pytest.fail("no viewer here"))
    assert main(["view", str(run_dir)]) == 1
    err = capsys.readouterr().err
    assert "no display here" in err and "rerun recording.rrd" in err and "--web" in err


def test_view_opens_the_viewer_on_the_runs_recording(run_dir, monkeypatch):
    calls = []
    monkeypatch.setattr(view_command, "has_display", lambda: True)
    monkeypatch.setattr(view_command.subprocess, "call", lambda command: calls.append(command) or 0)
    assert main(["view", str(run_dir)]) == 0
    assert calls[0][-1] == str(run_dir / "recording.rrd")
    assert main(["view", str(run_dir / "recording.rrd"), "--web", "--port", "9123"]) == 0
    assert "--web-viewer" in calls[1] and "9123" in calls[1]


def test_view_of_a_missing_recording_is_a_clear_error(tmp_path, capsys):
    assert main(["view", str(tmp_path)]) == 2
    assert "no recording" in capsys.readouterr().err
