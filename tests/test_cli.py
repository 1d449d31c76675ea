"""`mjsuff run` end to end: outputs, bad input, unwritable --out, Ctrl-C, determinism."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from mjsuff.atomic import FILE_MODE
from mjsuff.cli import main
from mjsuff.cli.console import fmt
from mjsuff.cli.run import SUMMARY_COLUMNS
from mjsuff.experiment import backend
from mjsuff.experiment.results import OutputError
from mjsuff.experiment.run_summary import RECORDING
from mjsuff.experiment.runner import run_scenario
from mjsuff.recording import Recording
from tests.conftest import small_scenario

SMALL_SETS = [
    "replicates=2",
    "demos.max_demos=3",
    "posterior.num_samples=120",
    "posterior.chains=6",
    "posterior.burn_in=20",
    "rules.patience=[1]",
    "rules.validation_intervals=[2]",
]
GRIDWORLD = str(Path(__file__).parent.parent / "scenarios" / "gridworld.toml")


def run_cli(out, *extra):
    # Serial: monkeypatched code is seen (worker processes would import their own).
    args = ["run", GRIDWORLD, "--out", str(out), "--quiet", "--backend", "serial"]
    for s in SMALL_SETS:
        args += ["--set", s]
    return main(args + list(extra))


def test_run_writes_parseable_outputs(tmp_path):
    assert run_cli(tmp_path / "r") == 0
    steps = pd.read_parquet(tmp_path / "r" / "steps.parquet")
    assert set(steps["replicate"]) == {0, 1} and set(steps["step"]) == {1, 2, 3}
    for col in ("rule", "param", "step", "bound", "true_value", "decision"):
        assert col in steps
    # one row per replicate x rule x param x step
    assert not steps.duplicated(["replicate", "rule", "param", "step"]).any()
    summary = json.loads((tmp_path / "r" / "summary.json").read_text())
    rules = {e["rule"] for e in summary["entries"]}
    assert rules == {"nevd", "piob", "patience", "validation"}
    for e in summary["entries"]:
        for key in (
            "f1",
            "accuracy",
            "bound_error",
            "demos_needed",
            "fraction_of_states",
            "tpr",
            "fpr",
            "policy_optimality",
            "replicates",
        ):
            assert key in e
    config = (tmp_path / "r" / "config.toml").read_text()
    assert "num_samples = 120" in config and "rows = 5" in config
    # Written through temporary files (created 0600), yet with the usual mode under the umask.
    for name in ("config.toml", "steps.parquet", "summary.json", "run.json"):
        assert (tmp_path / "r" / name).stat().st_mode & 0o777 == FILE_MODE


def test_same_seed_gives_identical_summary(tmp_path):
    assert run_cli(tmp_path / "a") == 0
    assert run_cli(tmp_path / "b") == 0
    assert (tmp_path / "a" / "summary.json").read_bytes() == (tmp_path / "b" / "summary.json").read_bytes()
    assert run_cli(tmp_path / "c", "--seed", "99") == 0
    assert (tmp_path / "a" / "summary.json").read_bytes() != (tmp_path / "c" / "summary.json").read_bytes()


def test_bad_scenario_exits_2_with_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\n[domain]\nname = "gridworld"\n[rules]\nnevd_thresholds = [2]\n')
    assert main(["run", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert str(bad) in err and "rules.nevd_thresholds.0" in err and "less than or equal to 1" in err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    ("setting", "expected"),
    [
        ("posterior.rhat_target=1.0", "posterior.rhat_target: input should be greater than 1"),
        ("posterior.max_steps=70", "posterior.max_steps: at least burn_in + num_samples / chains"),
        ("posterior.min_ess=20", "posterior.min_ess: the 0.95-confidence bound on the 0.95-VaR"),
        ("posterior.num_samples=490", "posterior.num_samples: must be a multiple of chains (20)"),
    ],
)
def test_bad_convergence_settings_exit_2_with_one_line(tmp_path, capsys, setting, expected):
    out = tmp_path / "o"
    assert main(["run", GRIDWORLD, "--out", str(out), "--set", setting]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and expected in err and f"--set {setting.split('=')[0]}" in err
    assert not out.exists()


def test_console_script_exit_code_for_missing_file(tmp_path):
    proc = subprocess.run(
        [sys.executable, "-m", "mjsuff.cli", "run", str(tmp_path / "x.toml")],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 2
    assert "x.toml: file not found" in proc.stderr and "Traceback" not in proc.stderr


@pytest.mark.skipif(os.geteuid() == 0, reason="root can write anywhere; see the file test")
def test_unwritable_out_fails_before_work(tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    with pytest.raises(OutputError, match="not writable"):
        run_scenario(small_scenario(), locked / "run")


def test_out_that_is_a_file_or_not_empty_fails_before_work(tmp_path, capsys, monkeypatch):
    calls = []
    monkeypatch.setattr(backend, "run_replicate", lambda *a, **k: calls.append(1) or [])
    a_file = tmp_path / "file"
    a_file.write_text("x")
    assert run_cli(a_file) == 2
    assert "not a directory" in capsys.readouterr().err
    full = tmp_path / "full"
    full.mkdir()
    (full / "keep.txt").write_text("x")
    assert run_cli(full) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert calls == []


@pytest.mark.parametrize("where", ["under-a-file", "proc"])
def test_unwritable_out_even_for_root(tmp_path, capsys, monkeypatch, where):
    calls = []
    monkeypatch.setattr(backend, "run_replicate", lambda *a, **k: calls.append(1) or [])
    if where == "proc":
        out = Path("/proc/mjsuff-cannot-write-here/run")
    else:
        (tmp_path / "file").write_text("x")
        out = tmp_path / "file" / "run"
    assert run_cli(out) == 2
    err = capsys.readouterr().err
    assert "not writable" in err and str(out) in err.replace("\n", "")
    assert calls == []


def test_interrupt_keeps_finished_replicates(tmp_path, monkeypatch):
    real = backend.run_replicate

    def interrupt_second(scenario, replicate, *rest):
        if replicate == 1:
            raise KeyboardInterrupt
        return real(scenario, replicate, *rest)

    monkeypatch.setattr(backend, "run_replicate", interrupt_second)
    with pytest.raises(KeyboardInterrupt):
        run_scenario(small_scenario(), tmp_path / "r")
    steps = pd.read_parquet(tmp_path / "r" / "steps.parquet")
    assert set(steps["replicate"]) == {0}
    run = json.loads((tmp_path / "r" / "run.json").read_text())
    assert run["interrupted"] and run["completed_replicates"] == 1
    assert json.loads((tmp_path / "r" / "summary.json").read_text())["entries"]
    # The recording is completed too, and holds the finished replicate.
    assert "/r0/posterior/samples" in Recording(tmp_path / "r" / RECORDING).entity_paths()


def live_group_members(pgid: int) -> list[int]:
    """Processes of process group ``pgid`` that are still running (zombies do not count)."""
    members = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[2]) == pgid and fields[0] != "Z":
            members.append(int(stat.parent.name))
    return members


def wait_for_group_exit(pgid: int, timeout: float) -> list[int]:
    deadline = time.monotonic() + timeout
    while (alive := live_group_members(pgid)) and time.monotonic() < deadline:
        time.sleep(0.1)
    return alive


def start_long_run(out: Path) -> subprocess.Popen:
    """A 50-replicate gridworld run on 2 local workers, in a process group of its own, once its
    first replicate is on disk."""
    args = [
        sys.executable,
        "-m",
        "mjsuff.cli",
        "run",
        GRIDWORLD,
        "--out",
        str(out),
        "--quiet",
        "--workers",
        "2",
    ]
    for s in [*SMALL_SETS[1:], "replicates=50"]:
        args += ["--set", s]
    # SIGINT back to its default: a test run started in the background inherits it ignored,
    # and Python then never turns it into KeyboardInterrupt.
    proc = subprocess.Popen(
        args,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    first = out / "replicates" / "replicate-00000.parquet"
    deadline = time.monotonic() + 120
    while not first.exists() and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.05)
    assert first.exists()
    return proc


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_interrupt_mid_run_leaves_readable_results_and_no_workers(tmp_path, signum):
    out = tmp_path / "r"
    proc = start_long_run(out)
    proc.send_signal(signum)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err, err  # the whole stderr, if not
    assert wait_for_group_exit(proc.pid, 10) == []  # the worker processes were stopped too
    steps = pd.read_parquet(out / "steps.parquet")
    assert 1 <= steps["replicate"].nunique() < 50
    assert not list(out.glob("**/*.tmp"))
    # Ctrl-C completes the recording: its footer is written, so the store opens.
    from rerun.chunk import RrdReader

    assert "/r0/posterior/samples" in RrdReader(str(out / RECORDING)).store().schema().entity_paths()


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")
def test_workers_exit_when_the_run_is_killed(tmp_path):
    proc = start_long_run(tmp_path / "r")
    assert len(live_group_members(proc.pid)) >= 3  # the run, its 2 workers (and helpers)
    proc.kill()  # SIGKILL: no handler runs, nothing can stop the workers but themselves
    proc.communicate(timeout=60)
    # Workers notice their parent is gone within a second and exit; they do not run on.
    assert wait_for_group_exit(proc.pid, 15) == []


def test_unconverged_posteriors_are_flagged_and_never_stop(tmp_path, capsys):
    # An R̂ target no sampler reaches and a cap of one short round: every posterior hits the cap.
    out = tmp_path / "r"
    assert run_cli(out, "--set", "posterior.rhat_target=1.000001", "--set", "posterior.max_steps=60") == 0
    steps = pd.read_parquet(out / "steps.parquet")
    assert not steps["converged"].any()
    assert (steps["mcmc_steps"] == 60).all()
    bound_rules = steps[steps["rule"].isin(["nevd", "piob"])]
    assert not bound_rules["decision"].any()  # a bound without its confidence never stops a run
    run = json.loads((out / "run.json").read_text())
    assert run["sampler"]["posteriors"] == 2 * 3
    assert run["sampler"]["unconverged_posteriors"] == 2 * 3
    main(
        [
            "run",
            GRIDWORLD,
            "--out",
            str(tmp_path / "printed"),
            "--backend",
            "serial",
            "--set",
            "posterior.rhat_target=1.000001",
            "--set",
            "posterior.max_steps=60",
            *[x for s in SMALL_SETS for x in ("--set", s)],
        ]
    )
    assert "6 hit the step cap (60) first" in capsys.readouterr().out


SHIPPED = sorted(p.stem for p in (Path(__file__).parent.parent / "scenarios").glob("*.toml"))
SMALL_ARGS = ["--quiet", "--backend", "serial", *[x for s in SMALL_SETS for x in ("--set", s)]]


def test_run_takes_a_shipped_scenario_by_name_unless_a_file_has_that_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["run", "gridworld", "--out", "shipped", *SMALL_ARGS]) == 0
    assert 'name = "gridworld"' in (tmp_path / "shipped" / "config.toml").read_text()
    # A file of that name in the working directory comes first.
    Path("gridworld").write_text('name = "mine"\n[domain]\nname = "gridworld"\n')
    assert main(["run", "gridworld", "--out", "local", *SMALL_ARGS]) == 0
    assert 'name = "mine"' in (tmp_path / "local" / "config.toml").read_text()


@pytest.mark.parametrize("command", ["run", "demos", "calibrate"])
def test_unknown_scenario_name_is_one_line_listing_the_shipped_ones(tmp_path, monkeypatch, capsys, command):
    monkeypatch.chdir(tmp_path)
    assert main([command, "nonesuch"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("error: nonesuch: ")
    assert f"(shipped: {', '.join(SHIPPED)})" in err
    assert list(tmp_path.iterdir()) == []  # nothing written (no runs/, no demos/)


def test_scenarios_lists_the_shipped_ones(capsys):
    assert main(["scenarios", "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    assert [s["name"] for s in listed] == SHIPPED
    by_name = {s["name"]: s for s in listed}
    assert by_name["lava_reacher"]["domain"] == "lava_reacher"
    assert by_name["gridworld_sweep"]["domain"] == "gridworld"
    assert by_name["lander"]["description"].startswith("Lander: a planar MuJoCo craft")
    assert all(Path(s["path"]).is_file() and s["description"] for s in listed)
    assert main(["scenarios"]) == 0
    table = capsys.readouterr().out
    for s in listed:
        assert s["name"] in table and s["description"] in table


@pytest.mark.parametrize(
    "command",
    [["scenarios"], ["hoeffding", "--gamma", "0.999"], ["calibrate", "gridworld", "--instances", "1"]],
)
def test_tables_keep_whole_columns_off_a_terminal(monkeypatch, capsys, command):
    # Off a terminal rich would fit the table to COLUMNS (80 by default) and cut cells with "…".
    monkeypatch.setenv("COLUMNS", "30")
    assert main(command) == 0
    printed = capsys.readouterr().out
    assert "┏" in printed and "…" not in printed
    assert max(len(line) for line in printed.splitlines()) > 30


def table_rows(text: str) -> list[list[str]]:
    """The cells of every body row of the rich tables in ``text``."""
    return [
        [cell.strip() for cell in line.strip().strip("│").split("│")]
        for line in text.splitlines()
        if line.startswith("│")
    ]


def test_run_summary_is_whole_in_a_log(tmp_path):
    # stdout a pipe, no terminal anywhere: what `mjsuff run ... > log` prints.
    env = {k: v for k, v in os.environ.items() if k not in ("COLUMNS", "LINES")}
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "mjsuff.cli",
            "run",
            GRIDWORLD,
            "--out",
            str(tmp_path / "r"),
            "--backend",
            "serial",
            "--no-record",
            *[x for s in SMALL_SETS for x in ("--set", s)],
        ],
        capture_output=True,
        text=True,
        timeout=120,
        stdin=subprocess.DEVNULL,
        env=env,
    )
    assert proc.returncode == 0, proc.stderr
    assert "…" not in proc.stdout
    header = next(line for line in proc.stdout.splitlines() if line.startswith("┃"))
    assert [c.strip() for c in header.strip("┃").split("┃")] == list(SUMMARY_COLUMNS)
    entries = json.loads((tmp_path / "r" / "summary.json").read_text())["entries"]
    expected = [
        [
            e["rule"],
            f"{e['param']:g}",
            f"{e['epsilon']:g}",
            fmt(e["f1"]),
            fmt(e["accuracy"]),
            fmt(e["bound_error"], 3),
            fmt(e["demos_needed"], 1),
            fmt(e["demos_needed_sem"], 1),
            fmt(e["fraction_of_states"]),
            fmt(e["tpr"]),
            fmt(e["fpr"]),
            fmt(e["policy_optimality"]),
        ]
        for e in entries
        if e["rule"] in ("nevd", "piob") or e["epsilon"] == 0.3
    ]
    assert table_rows(proc.stdout) == expected
    # Nor is a line of text wrapped: the results line names the run directory whole.
    assert f"mjsuff report {tmp_path / 'r'} for figures" in proc.stdout


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (["--replicates", "0"], "(--replicates)"),
        (["--seed", "-1"], "(--seed)"),
        (["--set", "replicates=0"], "(--set replicates)"),
        (["--set", "replicates=0", "--replicates", "0"], "(--replicates)"),  # the option applied last
    ],
)
def test_a_bad_value_names_the_option_that_gave_it(tmp_path, capsys, args, named):
    assert main(["run", GRIDWORLD, "--out", str(tmp_path / "r"), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"gridworld.toml {named}: " in err, err
    assert not (tmp_path / "r").exists()
