"""``mjsuff run``: run a scenario and print what every stopping rule decided."""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path
from typing import Any

from rich.table import Table

from mjsuff.cli.console import (
    EXIT_CLUSTER,
    EXIT_INTERRUPTED,
    EXIT_MEMORY,
    EXIT_USAGE,
    EXIT_WRITE,
    fmt,
    note,
    out,
    progress_bar,
    say,
    warning,
)
from mjsuff.cli.options import load, quiet_option, scenario_options
from mjsuff.cli.signals import sigterm_interrupts
from mjsuff.errors import MjsuffError, UsageError, in_context
from mjsuff.experiment.backends import make_backend
from mjsuff.experiment.run_summary import CellResult, RunResult
from mjsuff.experiment.runner import run_scenario
from mjsuff.experiment.scenario import Scenario
from mjsuff.experts.demo_set import DemoFileError

SUMMARY_COLUMNS = (
    "rule",
    "param",
    "ε",
    "F1",
    "accuracy",
    "bound err",
    "demos",
    "± sem",
    "states",
    "TPR",
    "FPR",
    "optimality",
)


def add_parser(commands: Any) -> None:
    run = commands.add_parser(
        "run",
        parents=[
            scenario_options("scenarios/gridworld.toml or lava_reacher", "sufficiency.alpha=0.99"),
            quiet_option("summary table"),
        ],
        help="run a scenario: demos one at a time, every stopping rule decides, ground truth scores it",
        description="Run a scenario file (or a shipped scenario by name: mjsuff scenarios lists "
        "them) and write steps.parquet, summary.json and config.toml to the output directory.",
        epilog=f"exit status: 0 done, {EXIT_USAGE} bad input (nothing written), {EXIT_CLUSTER} the "
        f"Ray cluster at --address cannot be used (nothing written), {EXIT_WRITE} results could not "
        f"be written mid-run (disk full, permissions: finished replicates kept; --resume continues "
        f"once fixed), {EXIT_MEMORY} out of memory (finished replicates kept), {EXIT_INTERRUPTED} "
        "interrupted (finished replicates kept; --resume continues)",
    )
    run.add_argument("--out", help="output directory (default: runs/NAME-TIMESTAMP)")
    run.add_argument("--replicates", type=int, help="override the number of replicates")
    run.add_argument(
        "--demos",
        action="append",
        metavar="FILE",
        help="a saved demo set (mjsuff demos) for the replicate it names, instead of "
        "the live expert; repeat for more replicates",
    )
    run.add_argument(
        "--no-record", action="store_true", help="do not write the Rerun recording DIR/recording.rrd"
    )
    existing = run.add_mutually_exclusive_group()
    existing.add_argument(
        "--overwrite", action="store_true", help="replace the results in a non-empty --out directory"
    )
    existing.add_argument(
        "--resume",
        action="store_true",
        help="continue the run in --out: keep its finished replicates, run the rest "
        "(the scenario must match its config.toml; --replicates may grow)",
    )
    run.add_argument(
        "--backend",
        choices=("local", "serial", "ray"),
        default="local",
        help="where replicates run: local worker processes (default), serial (this "
        "process, per-demo progress) or a Ray cluster (pip install 'mjsuff[ray]')",
    )
    run.add_argument(
        "--workers",
        type=int,
        help="local: worker processes (default: the thread budget, $MJSUFF_SIM_THREADS or all cores; "
        "1 = serial); ray: CPUs of the local Ray instance",
    )
    run.add_argument(
        "--address", help="ray: address of a running cluster (default: start a local Ray instance)"
    )
    run.add_argument(
        "--cpus-per-task",
        type=int,
        help="ray: CPUs each replicate reserves, and its MuJoCo rollout threads (default: a local "
        "instance's CPUs shared among the replicates; 1 on a cluster)",
    )
    run.set_defaults(func=cmd_run)


def cmd_run(args: argparse.Namespace) -> int:
    scenario = load(args)
    if args.resume and not args.out:
        raise UsageError("--resume: name the run directory to continue with --out DIR")
    directory = Path(args.out or f"runs/{scenario.name}-{time.strftime('%Y%m%d-%H%M%S')}")
    backend = make_backend(args.backend, args.workers, args.address, args.cpus_per_task)
    sources = None
    if args.demos:
        from mjsuff.experiment.recorded_demos import load_recorded_demos  # mink only when asked for

        try:
            sources = load_recorded_demos(args.demos, scenario)
        except MjsuffError as exc:
            raise in_context("--demos", exc) from exc
    try:  # a cluster that cannot be used is found before anything is written to --out
        backend.connect()
    except KeyboardInterrupt:
        note("interrupted while connecting: nothing written")
        return EXIT_INTERRUPTED
    progress = progress_bar(args.quiet)
    cells = len(scenario.cells())
    task = progress.add_task(scenario.name, total=cells * scenario.replicates, detail="")

    def on_progress(finished: int, planned: int, done: float) -> None:
        in_cells = f" in {cells} sweep cells" if cells > 1 else ""
        progress.update(
            task, completed=done, total=planned, detail=f"{finished}/{planned} replicates{in_cells}"
        )

    try:
        with progress, sigterm_interrupts():
            result = run_scenario(
                scenario,
                directory,
                args.overwrite,
                on_progress,
                sources,
                record=not args.no_record,
                backend=backend,
                resume=args.resume,
            )
    except DemoFileError as exc:  # found mid-run: a demo set without the demo asked for
        raise UsageError(f"{exc} (finished replicates are saved in {directory})") from exc
    except KeyboardInterrupt:
        note(interrupted_note(directory))
        return EXIT_INTERRUPTED
    print_summary(result, scenario, directory, quiet=args.quiet, recorded=not args.no_record)
    return 0


def interrupted_note(directory: Path) -> str:
    """What an interrupted run left in ``directory``: the files that are there, and how to go on."""
    finished = len(list(directory.glob("**/replicates/replicate-*.parquet")))
    go_on = f"mjsuff run ... --out {directory} --resume continues"
    if not finished:
        return f"interrupted before any replicate finished: nothing but the settings in {directory}; {go_on}"
    kept = [
        p.name
        for p in (directory / n for n in ("steps.parquet", "summary.json", "recording.rrd"))
        if p.exists()
    ]
    return f"interrupted: {finished} finished replicate(s) kept in {directory} ({', '.join(kept)}); {go_on}"


def print_summary(
    result: RunResult, scenario: Scenario, directory: Path, *, quiet: bool, recorded: bool
) -> None:
    """The run's tables (one per sweep cell), its simulation and sampler notes, and its files."""
    if not quiet:
        for cell in result.cells or (CellResult({}, result),):
            table = summary_table(cell.result, scenario.rules.nevd_thresholds)
            if cell.labels:
                table.title = ", ".join(f"{k} = {v}" for k, v in cell.labels.items()) + f": {table.title}"
            out.print(table)
    simulation = result.simulation
    if simulation["simulated_steps"]:
        say(
            f"MuJoCo: {simulation['simulated_steps']:,} steps simulated; "
            f"{simulation['diverged_rollouts']:,} diverged rollouts detected and never scored"
        )
        say(truth_line(result.truth, result.completed))
    sampler = result.sampler
    if sampler.get("posteriors"):
        capped = sampler["unconverged_posteriors"]
        cfg = scenario.sampler()
        converged = (
            f"{capped:,} hit the step cap ({cfg.max_steps}) first: flagged (converged = false "
            "in steps.parquet) and never used to stop"
            if capped
            else "all converged"
        )
        say(
            f"MCMC: {sampler['posteriors']:,} posteriors (R̂ ≤ {cfg.rhat_target:g}, ESS ≥ "
            f"{cfg.ess_target:g}); {converged}"
        )
    if result.recording_error:
        warning(f"the recording was not merged: {result.recording_error}")
    recording = ", recording.rrd (mjsuff view DIR)" if recorded else ""
    cells_note = " (per cell in cells/*/; sweep.json)" if result.cells else ""
    say(
        f"results: {directory}/steps.parquet, summary.json, config.toml{recording}{cells_note}; "
        f"mjsuff report {directory} for figures"
    )


def summary_table(result: RunResult, thresholds: list[float]) -> Table:
    """Bound rules at their thresholds; baselines scored at the middle nEVD threshold."""
    eps_mid = sorted(thresholds)[len(thresholds) // 2] if thresholds else math.nan
    table = Table(title=f"{result.completed} replicate(s); baselines scored at ε = {eps_mid:g}")
    for col in SUMMARY_COLUMNS:
        table.add_column(col, justify="right" if col != "rule" else "left")
    for e in result.summary["entries"]:
        if e["rule"] in ("patience", "validation") and e["epsilon"] != eps_mid:
            continue
        table.add_row(
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
        )
    return table


def truth_line(truth: dict[str, Any], completed: int) -> str:
    """The run's ground truth in one line: how often the replicates' ends raised it, and how its
    searches again went (``run_summary.truth_totals``)."""
    raised = truth.get("raised_replicates", 0)
    line = (
        f"Ground truth: raised at the end of {raised} of {completed} replicates ("
        f"{truth['raised_starts']} evaluation starts; by at most {truth['largest_raise']:.3f} of "
        "V* − V_rand)"
        if raised
        else "Ground truth: never raised (nothing the replicates simulated under w* beat it)"
    )
    searches = truth.get("searches", 0)
    if searches:
        unsettled = truth.get("unsettled_replicates", 0)
        times = "once" if searches == 1 else f"{searches} times"
        line += f"; searched again {times}, " + (
            f"still rising at the last search in {unsettled} of {completed} replicates"
            if unsettled
            else "settled in every replicate"
        )
    return line
