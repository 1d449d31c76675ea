"""Faults mid-run (issue #19): a full disk, a failing write, kills at random points. Each ends in
one line (or nothing, for a kill), keeps every finished replicate, and ``--resume`` completes the
run to the bytes of an uninterrupted one, its recording included."""

import contextlib
import errno
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from mjsuff.cli import main
from mjsuff.experiment import runner
from mjsuff.recording import Recording
from tests.test_resume import cli_args

REPLICATES = 6


@pytest.fixture(scope="module")
def whole(tmp_path_factory):
    """The uninterrupted run every faulted one must end up equal to."""
    out = tmp_path_factory.mktemp("whole") / "run"
    assert main(cli_args(out, REPLICATES)) == 0
    return out


def assert_same_as(run: Path, whole: Path) -> None:
    steps = pd.read_parquet(run / "steps.parquet")
    assert not steps.duplicated(["replicate", "rule", "param", "step"]).any()
    pd.testing.assert_frame_equal(steps, pd.read_parquet(whole / "steps.parquet"))
    assert (run / "summary.json").read_bytes() == (whole / "summary.json").read_bytes()
    # The recording holds every replicate up to its last demo step.
    last = steps.groupby("replicate")["step"].max()
    recorded: dict[int, int] = {}
    for chunk in Recording(run / "recording.rrd").chunks:
        if chunk.entity_path.startswith("/r") and "demo" in chunk.timeline_names:
            r = int(chunk.entity_path.split("/")[1][1:])
            recorded[r] = max(recorded.get(r, 0), *chunk.to_record_batch().column("demo").to_pylist())
    assert recorded == last.to_dict(), "the recording lacks steps of some replicates"


def test_a_failing_write_mid_run_is_one_line_and_resume_completes_the_run(
    whole, tmp_path, monkeypatch, capsys
):
    out = tmp_path / "run"
    real, writes = runner.write_replicate, []

    def full_at_the_third(directory, replicate, rows):
        writes.append(replicate)
        if len(writes) == 3:
            path = directory / "replicates" / f"replicate-{replicate:05d}.parquet"
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
        real(directory, replicate, rows)

    monkeypatch.setattr(runner, "write_replicate", full_at_the_third)
    assert main(cli_args(out, REPLICATES)) == 74
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "Traceback" not in err, err
    assert (
        "No space left on device" in err and "2 finished replicate(s) are kept" in err and "--resume" in err
    )
    assert len(list((out / "replicates").glob("replicate-*.parquet"))) == 2
    monkeypatch.setattr(runner, "write_replicate", real)
    assert main(cli_args(out, REPLICATES, "--resume")) == 0
    assert_same_as(out, whole)


@contextlib.contextmanager
def tiny_disk(where: Path, size: str):
    """A tmpfs of ``size`` at ``where`` (root only; skips where mounting is not allowed)."""
    where.mkdir()
    mounted = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(where)], capture_output=True
    )
    if mounted.returncode != 0:
        pytest.skip(
            f"cannot mount a tmpfs here ({mounted.stderr.decode().strip()}): the mocked test covers it"
        )
    try:
        yield where
    finally:
        subprocess.run(["umount", "-l", str(where)], check=False)


def test_a_full_disk_is_one_line_and_resume_on_a_roomier_one_records_every_replicate(whole, tmp_path):
    """A real ENOSPC (a 320 KiB tmpfs: one replicate's recording part is ~130 KB). The part being
    written when the disk filled, and the merge, are lost; the resumed run records again every
    finished replicate its recording lacks (issue #19, item 4)."""
    with tiny_disk(tmp_path / "disk", "320k") as disk:
        out = disk / "run"
        env = {**os.environ, "PYTHONPATH": str(Path(__file__).parent.parent)}
        done = subprocess.run(
            [sys.executable, "-m", "mjsuff.cli", *cli_args(out, REPLICATES)],
            capture_output=True,
            text=True,
            env=env,
        )
        assert done.returncode == 74, done.stderr
        assert done.stderr.strip().count("\n") == 0 and "No space left on device" in done.stderr, done.stderr
        assert "--resume" in done.stderr
        kept = sorted(p.name for p in (out / "replicates").glob("replicate-*.parquet"))
        assert 1 <= len(kept) < REPLICATES
        subprocess.run(["mount", "-o", "remount,size=64m", str(disk)], check=True)
        assert main(cli_args(out, REPLICATES, "--resume")) == 0
        assert_same_as(out, whole)


def test_a_full_disk_where_workers_record_is_one_line_and_resume_records_it(whole, tmp_path):
    """Rerun writes a worker's recording in the background and only logs a failure: with the
    temporary directory on a full disk, the part was cut short, merged, and the replicate's steps
    were missing from recording.rrd for good (issue #19, item 4)."""
    with tiny_disk(tmp_path / "tmp", "200k") as tmp:
        out = tmp_path / "run"
        env = {**os.environ, "PYTHONPATH": str(Path(__file__).parent.parent), "TMPDIR": str(tmp)}
        command = [sys.executable, "-m", "mjsuff.cli", *cli_args(out, REPLICATES)]
        done = subprocess.run(command, capture_output=True, text=True, env=env)
        assert done.returncode == 74, done.stderr
        ours = [line for line in done.stderr.splitlines() if line.startswith("error:")]
        assert len(ours) == 1 and "recording of replicate 0" in ours[0] and "--resume" in ours[0], done.stderr
        assert "Traceback" not in done.stderr
    assert main(cli_args(out, REPLICATES, "--resume")) == 0
    assert_same_as(out, whole)


def test_kills_at_seeded_random_moments_lose_and_duplicate_nothing(whole, tmp_path):
    """SIGKILL (no handler runs) three times, each at a moment drawn from a seeded generator:
    after a random number of further replicates has finished, plus a random delay (mid-replicate,
    between them, or while the run summarizes), each resume killed in turn; then one resume to
    the end."""
    rng = np.random.default_rng(1906)
    out = tmp_path / "run"
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).parent.parent)}
    kills = 0
    for _ in range(3):
        extra = ("--resume",) if (out / "config.toml").exists() else ()
        done = len(list(out.glob("replicates/replicate-*.parquet")))
        target = min(REPLICATES - 1, done + int(rng.integers(0, 2)))
        proc = subprocess.Popen(
            [sys.executable, "-m", "mjsuff.cli", *cli_args(out, REPLICATES, *extra)],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            env=env,
        )
        deadline = time.monotonic() + 120
        while len(list(out.glob("replicates/replicate-*.parquet"))) < target and proc.poll() is None:
            assert time.monotonic() < deadline
            time.sleep(0.01)
        time.sleep(rng.uniform(0.0, 0.3))
        if proc.poll() is None:
            os.kill(proc.pid, signal.SIGKILL)
            kills += 1
        proc.wait()
    assert kills >= 2  # the moments fell inside the runs, not after them
    assert main(cli_args(out, REPLICATES, "--resume")) == 0
    assert_same_as(out, whole)
    assert not (out / "recordings").exists()  # every part was merged into recording.rrd
