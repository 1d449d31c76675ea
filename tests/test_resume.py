"""Kill and resume: a run killed (SIGKILL, no clean-up) after some replicates and resumed gives the
same results as an uninterrupted run, without redoing or duplicating finished replicates."""

import json
import os
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import pandas as pd
import pytest
import tomli_w

from mjsuff.cli import main
from mjsuff.experiment import backend
from mjsuff.experiment.results import OutputError
from mjsuff.experiment.runner import run_scenario
from tests.conftest import small_scenario

GRIDWORLD = str(Path(__file__).parent.parent / "scenarios" / "gridworld.toml")
SETS = [
    "demos.max_demos=3",
    "posterior.num_samples=120",
    "posterior.chains=6",
    "posterior.burn_in=20",
    "rules.patience=[1]",
    "rules.validation_intervals=[2]",
]


def cli_args(out: Path, replicates: int, *extra: str) -> list[str]:
    args = [
        "run",
        GRIDWORLD,
        "--out",
        str(out),
        "--quiet",
        "--replicates",
        str(replicates),
        "--backend",
        "serial",
        *extra,
    ]
    for s in SETS:
        args += ["--set", s]
    return args


def test_killed_run_resumes_to_the_uninterrupted_result(tmp_path):
    whole, killed = tmp_path / "whole", tmp_path / "killed"
    assert main(cli_args(whole, 6)) == 0

    proc = subprocess.Popen(
        [sys.executable, "-m", "mjsuff.cli", *cli_args(killed, 6)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    second = killed / "replicates" / "replicate-00001.parquet"
    deadline = time.monotonic() + 120
    while not second.exists() and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.02)
    os.kill(proc.pid, signal.SIGKILL)  # no handler runs: nothing is summarized
    proc.wait()
    done_before = sorted(p.name for p in (killed / "replicates").glob("replicate-*.parquet"))
    assert 2 <= len(done_before) < 6
    assert not (killed / "steps.parquet").exists()
    stamps = {p: p.stat().st_mtime_ns for p in (killed / "replicates").glob("*.parquet")}

    assert main(cli_args(killed, 6, "--resume")) == 0
    # Finished replicates were kept as they were, not redone.
    for path, stamp in stamps.items():
        assert path.stat().st_mtime_ns == stamp
    steps = pd.read_parquet(killed / "steps.parquet")
    assert not steps.duplicated(["replicate", "rule", "param", "step"]).any()
    pd.testing.assert_frame_equal(steps, pd.read_parquet(whole / "steps.parquet"))
    assert (killed / "summary.json").read_bytes() == (whole / "summary.json").read_bytes()
    # The merged recording holds every replicate, however the run was split.
    from mjsuff.recording import Recording

    paths = Recording(killed / "recording.rrd").entity_paths()
    assert all(f"/r{r}/posterior/samples" in paths for r in range(6))


def test_resume_can_add_replicates_and_refuses_a_different_scenario(tmp_path):
    out = tmp_path / "r"
    run_scenario(small_scenario(replicates=1), out, record=False)
    first = json.loads((out / "run.json").read_text())
    calls = []
    real = backend.run_replicate

    def counting(scenario, replicate, *rest):
        calls.append(replicate)
        return real(scenario, replicate, *rest)

    backend.run_replicate = counting
    try:
        result = run_scenario(small_scenario(replicates=2), out, record=False, resume=True)
    finally:
        backend.run_replicate = real
    assert calls == [1] and result.completed == 2
    # Issue #19, item 7: run.json's elapsed time covers both invocations, not the last alone.
    both = json.loads((out / "run.json").read_text())
    assert both["invocations"] == 2 and first["invocations"] == 1
    total = first["elapsed_seconds"] + both["elapsed_seconds_last"]
    assert both["elapsed_seconds"] == pytest.approx(total, abs=2e-3)
    with pytest.raises(OutputError, match=r"demos\.beta"):
        run_scenario(small_scenario(replicates=2, **{"demos.beta": 5.0}), out, resume=True)
    with pytest.raises(OutputError, match=r"no config\.toml"):
        run_scenario(small_scenario(), tmp_path / "empty", resume=True)
    with pytest.raises(OutputError, match="grow, not shrink"):
        run_scenario(small_scenario(replicates=1), out, record=False, resume=True)
    run_scenario(small_scenario(replicates=3), out, record=True, overwrite=True)
    with pytest.raises(OutputError, match="without --no-record"):
        run_scenario(small_scenario(replicates=4), out, record=False, resume=True)


def test_a_run_from_before_a_key_existed_resumes(tmp_path):
    """A run whose ``config.toml`` lacks keys added since (here ``demos.lapse`` and the domain's
    ``baseline``) ran with their defaults, so it resumes with a scenario that has them; a key it
    has with another value is still refused (stop 64: runs from before ``planning.seed_zeroed``
    could not be resumed)."""
    out = tmp_path / "r"
    run_scenario(small_scenario(replicates=1), out, record=False)
    config = tomllib.loads((out / "config.toml").read_text())
    del config["demos"]["lapse"], config["domain"]["params"]["baseline"]
    (out / "config.toml").write_text(tomli_w.dumps(config))
    assert run_scenario(small_scenario(replicates=2), out, record=False, resume=True).completed == 2
    with pytest.raises(OutputError, match=r"domain\.params\.baseline"):
        other = small_scenario(replicates=3, **{"domain.params.baseline": "nonpessimal"})
        run_scenario(other, out, resume=True)


def test_a_run_whose_scenario_no_longer_validates_is_not_resumed(tmp_path):
    """A config.toml from before a key moved (issue #18) names the move, not some other key."""
    out = tmp_path / "r"
    run_scenario(small_scenario(replicates=1), out, record=False)
    config = tomllib.loads((out / "config.toml").read_text())
    config["rules"]["match_tolerance"] = 0.1
    (out / "config.toml").write_text(tomli_w.dumps(config))
    with pytest.raises(OutputError, match=r"no longer validates .*rules\.match_tolerance: a scene setting"):
        run_scenario(small_scenario(replicates=2), out, record=False, resume=True)


def test_resume_needs_out_and_a_non_empty_out_needs_a_choice(tmp_path, capsys):
    assert main(["run", GRIDWORLD, "--resume"]) == 2
    assert "--out" in capsys.readouterr().err
    (tmp_path / "x").mkdir()
    (tmp_path / "x" / "file").write_text("")
    assert main(cli_args(tmp_path / "x", 1)) == 2
    assert "--resume" in capsys.readouterr().err


@pytest.mark.parametrize("first_recorded", [False, True])
def test_a_run_killed_before_its_run_json_resumes_only_as_it_was_started(tmp_path, first_recorded):
    """Killed before it wrote run.json, a run is still known to have recorded or not (the parts
    directory a recorded run makes first, or its recording): resuming it the other way would
    leave finished replicates out of the recording, so it is refused."""
    out = tmp_path / "r"
    run_scenario(small_scenario(replicates=2), out, record=first_recorded)
    for name in ("run.json", "summary.json", "steps.parquet"):  # as if killed before finalize
        (out / name).unlink()
    other = "with --no-record" if not first_recorded else "without --no-record"
    with pytest.raises(OutputError, match=f"started {other}"):
        run_scenario(small_scenario(replicates=3), out, record=not first_recorded, resume=True)
    result = run_scenario(small_scenario(replicates=3), out, record=first_recorded, resume=True)
    assert result.completed == 3


def _write_part(path: Path, replicate: int) -> None:
    import rerun as rr

    rec = rr.RecordingStream(application_id="mjsuff", recording_id="merge-test")
    rec.save(str(path))
    for step in range(3):
        rec.set_time("step", sequence=step)
        rec.log(f"r{replicate}/v", rr.Scalars(float(step)))
    rec.flush()
    rec.disconnect()


@pytest.mark.parametrize("killed_at", ["replace", "part deletion"])
def test_a_merge_killed_midway_is_finished_without_duplicating_parts(tmp_path, monkeypatch, killed_at):
    """A kill before the merged file replaces recording.rrd, or after it but before the parts are
    deleted: the next merge leaves every replicate's series exactly once (the second case merges
    the parts into a file that already holds them; rerun keeps one copy of a row it sees twice)."""
    from mjsuff.experiment import run_summary
    from mjsuff.experiment.results import write_replicate
    from mjsuff.recording import Recording

    (tmp_path / run_summary.RECORDINGS).mkdir()
    (tmp_path / "replicates").mkdir()
    for r in range(3):
        write_replicate(tmp_path, r, [{"replicate": r}])
        _write_part(tmp_path / run_summary.RECORDINGS / f"replicate-{r:05d}.rrd", r)
    real_replace, real_unlink = Path.replace, Path.unlink

    def replace(self, target):
        if killed_at == "replace" and Path(target).name == run_summary.RECORDING:
            raise KeyboardInterrupt
        return real_replace(self, target)

    def unlink(self, missing_ok=False):
        if killed_at == "part deletion" and self.parent.name == run_summary.RECORDINGS:
            raise KeyboardInterrupt
        return real_unlink(self, missing_ok=missing_ok)

    monkeypatch.setattr(Path, "replace", replace)
    monkeypatch.setattr(Path, "unlink", unlink)
    with pytest.raises(KeyboardInterrupt):
        run_summary.merge_recordings(tmp_path)
    monkeypatch.undo()
    assert len(list((tmp_path / run_summary.RECORDINGS).glob("*.rrd"))) == 3  # the kill kept them all
    assert (tmp_path / run_summary.RECORDING).exists() == (killed_at == "part deletion")

    assert run_summary.merge_recordings(tmp_path) is None
    assert not list((tmp_path / run_summary.RECORDINGS).glob("*.rrd"))
    assert not list(tmp_path.glob(".*"))  # no journal, no temporary file
    recording = Recording(tmp_path / run_summary.RECORDING)
    for r in range(3):
        steps = recording.series(f"r{r}/v", "Scalars:scalars", "step").column("step").to_pylist()
        assert steps == [0, 1, 2]
