"""The Ray backend on a real cluster, started as the README says (`ray start --head`, token
authentication on), driven through `mjsuff run --address`; and a cluster that cannot be used.

The head node runs in a session of its own, with a private temp dir and home (for its token), and
is stopped by killing exactly its processes: `ray stop` would stop every Ray process on the
machine, other tests' local instances included.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
import pytest

from mjsuff.cli import main
from mjsuff.cli.console import EXIT_CLUSTER, EXIT_USAGE
from tests.test_cli import GRIDWORLD, SMALL_SETS, run_cli

pytest.importorskip("ray", reason="the ray extra is not installed")
RAY = shutil.which("ray", path=str(Path(sys.executable).parent)) or shutil.which("ray")
pytestmark = [
    pytest.mark.skipif(RAY is None, reason="the ray command is not on PATH"),
    pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc"),
]
AUTH_VARIABLES = ("RAY_AUTH_MODE", "RAY_AUTH_TOKEN", "RAY_AUTH_TOKEN_PATH", "RAY_ADDRESS")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def cluster_processes(session: int, temp_dir: Path) -> list[int]:
    """Live (not zombie) processes of the head node: in its session, or naming its temp dir."""
    marker, found = f"{temp_dir}/", []
    for proc in Path("/proc").glob("[0-9]*"):
        try:
            fields = (proc / "stat").read_text().rsplit(")", 1)[1].split()
            cmdline = (proc / "cmdline").read_bytes().decode(errors="replace")
        except OSError:
            continue
        if fields[0] != "Z" and (int(fields[3]) == session or marker in cmdline):
            found.append(int(proc.name))
    return found


@dataclass
class Cluster:
    """A head node started with `ray start --head` in a session of its own."""

    address: str
    session: int
    temp_dir: Path
    env: dict[str, str]  # a user's environment on it: HOME with the token, token mode on

    def stop(self, grace: float = 2.0) -> list[int]:
        """SIGTERM its processes, SIGKILL what is left after ``grace``; returns the survivors."""
        for sig, wait in ((signal.SIGTERM, grace), (signal.SIGKILL, 10.0)):
            for pid in cluster_processes(self.session, self.temp_dir):
                try:
                    os.kill(pid, sig)
                except ProcessLookupError:
                    pass
            deadline = time.monotonic() + wait
            while cluster_processes(self.session, self.temp_dir) and time.monotonic() < deadline:
                time.sleep(0.1)
        return cluster_processes(self.session, self.temp_dir)


def user_env(home: Path, **extra: str) -> dict[str, str]:
    """This environment without Ray's auth settings (a local Ray instance of another test in
    this process sets RAY_AUTH_MODE), with ``home`` as HOME and ``extra`` added."""
    env = {k: v for k, v in os.environ.items() if k not in AUTH_VARIABLES}
    return {**env, "HOME": str(home), "RAY_USAGE_STATS_ENABLED": "0", **extra}


@pytest.fixture(scope="module")
def cluster(tmp_path_factory) -> Iterator[Cluster]:
    home = tmp_path_factory.mktemp("home")
    # Ray's socket paths (temp dir + about 62 characters) must fit in 107 bytes.
    temp_dir = tmp_path_factory.mktemp("ray")
    own_dir = len(str(temp_dir)) > 40
    if own_dir:
        temp_dir = Path(tempfile.mkdtemp(prefix="mjr-", dir="/tmp"))
    env = user_env(home, RAY_AUTH_MODE="token")
    # The README's recipe: a token in ~/.ray/auth_token, token mode, then the head node.
    subprocess.run(
        [RAY, "get-auth-token", "--generate"], env=env, check=True, capture_output=True, timeout=60
    )
    port = free_port()
    started = subprocess.Popen(
        [
            RAY,
            "start",
            "--head",
            f"--port={port}",
            f"--temp-dir={temp_dir}",
            "--num-cpus=2",
            "--include-dashboard=false",
            "--disable-usage-stats",
            f"--dashboard-agent-listen-port={free_port()}",
        ],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=True,
    )
    head = Cluster(f"127.0.0.1:{port}", started.pid, temp_dir, env)
    try:
        output, _ = started.communicate(timeout=120)
        assert started.returncode == 0, output
        yield head
    finally:
        head.stop()
        if own_dir:
            shutil.rmtree(temp_dir, ignore_errors=True)


def start_mjsuff_run(out: Path, env: dict[str, str], *extra: str) -> subprocess.Popen:
    """``mjsuff run`` of the small gridworld sweep of ``test_cli``, as a user runs it."""
    args = [
        sys.executable,
        "-m",
        "mjsuff.cli",
        "run",
        GRIDWORLD,
        "--out",
        str(out),
        "--quiet",
        "--no-record",
        *extra,
    ]
    for s in SMALL_SETS:
        args += ["--set", s]
    return subprocess.Popen(args, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def test_run_on_a_cluster_matches_the_local_backend(cluster, tmp_path):
    on_cluster = start_mjsuff_run(
        tmp_path / "ray", cluster.env, "--backend", "ray", "--address", cluster.address
    )
    # The reference, meanwhile, in this process: serial, which tests/test_backends.py shows
    # gives the local worker processes' rows and summary byte for byte.
    assert run_cli(tmp_path / "local", "--no-record") == 0
    _, stderr = on_cluster.communicate(timeout=300)
    assert on_cluster.returncode == 0, stderr
    assert (tmp_path / "ray" / "summary.json").read_bytes() == (
        tmp_path / "local" / "summary.json"
    ).read_bytes()
    pd.testing.assert_frame_equal(
        pd.read_parquet(tmp_path / "ray" / "steps.parquet"),
        pd.read_parquet(tmp_path / "local" / "steps.parquet"),
    )
    assert f'"backend": "ray ({cluster.address})"' in (tmp_path / "ray" / "run.json").read_text()


def test_a_refused_token_is_one_line_saying_what_to_set(cluster, tmp_path):
    home = Path(cluster.env["HOME"])  # holds the cluster's token in ~/.ray/auth_token
    cases = {  # name: (environment, what the line says)
        "token mode unset": (
            user_env(home),
            "the cluster requires token authentication; set "
            "RAY_AUTH_MODE=token here, and Ray sends the token in "
            "~/.ray/auth_token",
        ),
        "wrong token": (
            user_env(home, RAY_AUTH_MODE="token", RAY_AUTH_TOKEN="0" * 64),
            "the cluster refused the token in RAY_AUTH_TOKEN",
        ),
        "no token": (
            user_env(tmp_path, RAY_AUTH_MODE="token"),
            "RAY_AUTH_MODE=token, but no token is set here",
        ),
    }
    started = time.monotonic()
    runs = {
        name: start_mjsuff_run(tmp_path / name, env, "--backend", "ray", "--address", cluster.address)
        for name, (env, _) in cases.items()
    }
    for name, run in runs.items():
        _, stderr = run.communicate(timeout=120)
        assert run.returncode == EXIT_CLUSTER, (name, stderr)
        assert stderr.startswith(f"error: --address {cluster.address}: "), (name, stderr)
        assert stderr.count("\n") == 1 and cases[name][1] in stderr, (name, stderr)
        assert not (tmp_path / name).exists(), name
    # Refused at once, not after ray.init's 20 one-second retries (each, on top of start-up).
    assert time.monotonic() - started < 20


def test_stopping_the_cluster_leaves_no_process(cluster):
    assert cluster_processes(cluster.session, cluster.temp_dir)  # it was running
    assert cluster.stop() == []


def test_an_unreachable_cluster_has_its_own_exit_code_and_writes_nothing(tmp_path, capsys):
    address = f"127.0.0.1:{free_port()}"  # nothing listens there
    out = tmp_path / "new"
    args = ["run", GRIDWORLD, "--out", str(out), "--quiet", "--backend", "ray", "--address", address]
    assert main(args) == EXIT_CLUSTER
    stderr = capsys.readouterr().err
    assert stderr.startswith(f"error: --address {address}: no Ray cluster answers there")
    assert stderr.count("\n") == 1 and "ray start --head" in stderr
    assert not out.exists()
    # Resuming a run: the run's files are left as they were.
    previous = tmp_path / "previous"
    (previous / "replicates").mkdir(parents=True)
    for name in ("config.toml", "summary.json", "run.json", "replicates/replicate-00000.parquet"):
        (previous / name).write_text(name)
    before = {p: p.read_bytes() for p in previous.rglob("*") if p.is_file()}
    assert (
        main(["run", GRIDWORLD, "--out", str(previous), "--resume", "--backend", "ray", "--address", address])
        == EXIT_CLUSTER
    )
    assert {p: p.read_bytes() for p in previous.rglob("*") if p.is_file()} == before
    # A malformed address is bad input (exit 2), not an unreachable cluster.
    assert main([*args[:-1], "no-port-here"]) == EXIT_USAGE
    assert "expected HOST:PORT" in capsys.readouterr().err
    assert not out.exists()
