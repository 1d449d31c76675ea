"""``mjsuff view``: open a run's Rerun recording in the viewer (native, or served to a browser)."""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
from importlib.metadata import version
from pathlib import Path
from typing import Any

from mjsuff.cli.console import note, say
from mjsuff.cli.signals import sigterm_interrupts
from mjsuff.errors import UsageError


def add_parser(commands: Any) -> None:
    view = commands.add_parser(
        "view",
        help="open a run's Rerun recording in the viewer",
        description="Open DIR/recording.rrd (or an .rrd file) in the Rerun viewer; without a "
        "display, says what to run instead.",
    )
    view.add_argument("path", help="a run directory or an .rrd file")
    view.add_argument(
        "--web", action="store_true", help="serve the web viewer instead (works without a display)"
    )
    view.add_argument("--port", type=int, default=9090, help="web viewer port (with --web)")
    view.add_argument(
        "--bind",
        default="127.0.0.1",
        metavar="ADDRESS",
        help="with --web, the address to serve on (default 127.0.0.1: this machine only; 0.0.0.0 "
        "serves every interface, to anyone who can reach them, without authentication)",
    )
    view.set_defaults(func=cmd_view)


def has_display() -> bool:
    """Whether a native viewer window can open here."""
    if sys.platform in ("darwin", "win32"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def cmd_view(args: argparse.Namespace) -> int:
    path = Path(args.path)
    if path.is_dir():
        path = path / "recording.rrd"
    if not path.is_file():
        raise UsageError(f"{path}: no recording (runs write DIR/recording.rrd unless --no-record)")
    rerun = shutil.which("rerun")
    command = [rerun] if rerun else [sys.executable, "-m", "rerun"]
    if args.web:
        command += ["--web-viewer", "--web-viewer-port", str(args.port), "--bind", args.bind, str(path)]
        host = "localhost" if args.bind in ("127.0.0.1", "::1", "localhost") else args.bind
        say(f"serving {path} to a browser at http://{host}:{args.port} (Ctrl-C stops)")
    elif not has_display():
        note(
            f"no display here to open {path} on. Either copy it to a machine with one and "
            f"run `rerun {path.name}` (pip install rerun-sdk=={version('rerun-sdk')}), or serve "
            f"it to a browser from here: mjsuff view {args.path} --web"
        )
        return 1
    else:
        command.append(str(path))
    return run_viewer(command)


def run_viewer(command: list[str]) -> int:
    """Run the viewer until it exits; Ctrl-C or SIGTERM to mjsuff stops it too (a web viewer's
    server would otherwise outlive mjsuff). Returns its exit status (0 when stopped)."""
    viewer = subprocess.Popen(command)
    try:
        with sigterm_interrupts():
            return viewer.wait()
    except KeyboardInterrupt:
        viewer.terminate()
        try:
            viewer.wait(timeout=5)
        except subprocess.TimeoutExpired:
            viewer.kill()
            viewer.wait()
        return 0
