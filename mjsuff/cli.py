"""The ``mjsuff`` command line: run scenarios, generate demos, print the paper's reference tables."""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn
from rich.table import Table

from mjsuff import __version__
from mjsuff.bounds.hoeffding import abbeel_ng_demos, syed_schapire_demos
from mjsuff.errors import MjsuffError
from mjsuff.experiment.backends import BackendError, ClusterConnectionError, make_backend
from mjsuff.experiment.results import OutputError
from mjsuff.experiment.runner import CellResult, RunResult, run_scenario
from mjsuff.experiment.scenario import Scenario, ScenarioError, load_scenario, shipped_scenarios

EXIT_USAGE = 2
#: The Ray cluster at --address cannot be reached or refused the connection (sysexits.h's
#: EX_UNAVAILABLE): not bad input; nothing is written.
EXIT_CLUSTER = 69
EXIT_INTERRUPTED = 130

#: Width of stdout off a terminal: wide enough that no table is cut and no line is wrapped.
LOG_WIDTH = 10_000


class _Stdout:
    """stdout through rich: on a terminal, fitted to the window; elsewhere (``> log``, a pipe) at
    full width, since rich would fit every table to 80 columns and cut its cells with "…"."""

    def __init__(self) -> None:
        self._terminal = Console()
        self._log = Console(width=LOG_WIDTH)

    def print(self, *objects: Any, **kwargs: Any) -> None:
        console = self._terminal if self._terminal.is_terminal else self._log
        console.print(*objects, **kwargs)


err = Console(stderr=True)
out = _Stdout()


def _fmt(x: Any, digits: int = 2) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "–"
    if isinstance(x, float):
        return f"{x:.{digits}f}"
    return str(x)


def summary_table(result: RunResult, thresholds: list[float]) -> Table:
    """Bound rules at their thresholds; baselines scored at the middle nEVD threshold."""
    eps_mid = sorted(thresholds)[len(thresholds) // 2] if thresholds else math.nan
    table = Table(title=f"{result.completed} replicate(s); baselines scored at ε = {eps_mid:g}")
    for col in (
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
    ):
        table.add_column(col, justify="right" if col != "rule" else "left")
    for e in result.summary["entries"]:
        if e["rule"] in ("patience", "validation") and e["epsilon"] != eps_mid:
            continue
        table.add_row(
            e["rule"],
            f"{e['param']:g}",
            f"{e['epsilon']:g}",
            _fmt(e["f1"]),
            _fmt(e["accuracy"]),
            _fmt(e["bound_error"], 3),
            _fmt(e["demos_needed"], 1),
            _fmt(e["demos_needed_sem"], 1),
            _fmt(e["fraction_of_states"]),
            _fmt(e["tpr"]),
            _fmt(e["fpr"]),
            _fmt(e["policy_optimality"]),
        )
    return table


def _load(args: argparse.Namespace) -> Scenario | None:
    """The scenario with ``--set``/``--seed``/``--replicates`` applied; None after printing why not."""
    overrides = list(args.set or [])
    if args.seed is not None:
        overrides.append(f"seed={args.seed}")
    if getattr(args, "replicates", None) is not None:
        overrides.append(f"replicates={args.replicates}")
    try:
        return load_scenario(args.scenario, overrides)
    except ScenarioError as exc:
        err.print(f"[red]error:[/] {exc}", highlight=False, soft_wrap=True)
        return None


@contextlib.contextmanager
def _sigterm_interrupts() -> Iterator[None]:
    """Treat SIGTERM (``kill``, a batch scheduler's stop) like Ctrl-C while a run goes: finished
    replicates are kept and summarized, worker processes are stopped."""

    def interrupt(signum: int, frame: Any) -> None:
        raise KeyboardInterrupt

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def cmd_run(args: argparse.Namespace) -> int:
    scenario = _load(args)
    if scenario is None:
        return EXIT_USAGE
    if args.resume and not args.out:
        err.print(
            "[red]error:[/] --resume: name the run directory to continue with --out DIR", highlight=False
        )
        return EXIT_USAGE
    directory = (
        Path(args.out) if args.out else Path("runs") / (f"{scenario.name}-{time.strftime('%Y%m%d-%H%M%S')}")
    )
    progress = Progress(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        TextColumn("{task.fields[detail]}"),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        console=err,
        disable=args.quiet,
    )
    cells = len(scenario.cells())
    task = progress.add_task(scenario.name, total=cells * scenario.replicates, detail="")

    def on_progress(finished: int, planned: int, done: float) -> None:
        progress.update(
            task,
            completed=done,
            total=planned,
            detail=f"{finished}/{planned} replicates" + (f" in {cells} sweep cells" if cells > 1 else ""),
        )

    try:
        backend = make_backend(args.backend, args.workers, args.address)
    except BackendError as exc:
        err.print(f"[red]error:[/] {exc}", highlight=False, soft_wrap=True)
        return EXIT_USAGE
    sources = None
    bad_input: tuple[type[Exception], ...] = ()
    if args.demos:
        from mjsuff.experts.demo_set import DemoFileError
        from mjsuff.experts.recorded import load_recorded_demos  # mink only when asked for

        try:
            sources = load_recorded_demos(args.demos, scenario)
            bad_input = (DemoFileError,)
        except MjsuffError as exc:
            err.print(f"[red]error:[/] --demos: {exc}", highlight=False, soft_wrap=True)
            return EXIT_USAGE
    try:  # a cluster that cannot be used is found before anything is written to --out
        backend.connect()
    except ClusterConnectionError as exc:
        err.print(f"[red]error:[/] {exc}", highlight=False, soft_wrap=True)
        return EXIT_CLUSTER
    except BackendError as exc:
        err.print(f"[red]error:[/] {exc}", highlight=False, soft_wrap=True)
        return EXIT_USAGE
    except KeyboardInterrupt:
        err.print("interrupted while connecting: nothing written", highlight=False)
        return EXIT_INTERRUPTED
    try:
        with progress, _sigterm_interrupts():
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
    except ClusterConnectionError as exc:
        err.print(f"[red]error:[/] {exc}", highlight=False, soft_wrap=True)
        return EXIT_CLUSTER
    except (OutputError, BackendError) as exc:
        err.print(f"[red]error:[/] {exc}", highlight=False, soft_wrap=True)
        return EXIT_USAGE
    except bad_input as exc:  # found mid-run: a demo set without the demo asked for
        err.print(
            f"[red]error:[/] {exc} (finished replicates are saved in {directory})",
            highlight=False,
            soft_wrap=True,
        )
        return EXIT_USAGE
    except KeyboardInterrupt:
        err.print(
            f"interrupted: finished replicates are saved in {directory} (steps.parquet, summary.json)",
            highlight=False,
        )
        return EXIT_INTERRUPTED
    if not args.quiet:
        for cell in result.cells or (CellResult({}, result),):
            table = summary_table(cell.result, scenario.rules.nevd_thresholds)
            if cell.labels:
                table.title = ", ".join(f"{k} = {v}" for k, v in cell.labels.items()) + f": {table.title}"
            out.print(table)
    if result.simulation["simulated_steps"]:
        out.print(
            f"MuJoCo: {result.simulation['simulated_steps']:,} steps simulated; "
            f"{result.simulation['diverged_rollouts']:,} diverged rollouts detected and "
            "never scored",
            highlight=False,
        )
    sampler = result.sampler
    if sampler.get("posteriors"):
        capped = sampler["unconverged_posteriors"]
        cfg = scenario.sampler()
        note = (
            f"{capped:,} hit the step cap ({cfg.max_steps}) first: flagged (converged = false "
            "in steps.parquet) and never used to stop"
            if capped
            else "all converged"
        )
        out.print(
            f"MCMC: {sampler['posteriors']:,} posteriors (R̂ ≤ {cfg.rhat_target:g}, ESS ≥ "
            f"{cfg.ess_target:g}); {note}",
            highlight=False,
        )
    if result.recording_error:
        err.print(
            f"[yellow]warning:[/] the recording was not merged: {result.recording_error}",
            highlight=False,
            soft_wrap=True,
        )
    recorded = "" if args.no_record else ", recording.rrd (mjsuff view DIR)"
    cells_note = " (per cell in cells/*/; sweep.json)" if result.cells else ""
    out.print(
        f"results: {directory}/steps.parquet, summary.json, config.toml{recorded}"
        f"{cells_note}; mjsuff report {directory} for figures",
        highlight=False,
    )
    return 0


def cmd_hoeffding(args: argparse.Namespace) -> int:
    table = Table(
        title=f"Demos for a {1 - args.delta:.0%}-confidence Hoeffding bound (γ = {args.gamma}, k = {args.k})"
    )
    for col in ("Threshold", "Abbeel and Ng", "Syed and Schapire"):
        table.add_column(col, justify="right")
    for eps in args.thresholds:
        table.add_row(
            f"{eps:g}",
            f"{abbeel_ng_demos(eps, args.gamma, args.k, args.delta):,}",
            f"{syed_schapire_demos(eps, args.gamma, args.k, args.delta):,}",
        )
    out.print(table)
    return 0


def cmd_demos(args: argparse.Namespace) -> int:
    from mjsuff.experts.demo_set import truth_path
    from mjsuff.experts.generate import generate_demos, scene_parts  # mink only when asked for

    scenario = _load(args)
    if scenario is None:
        return EXIT_USAGE
    try:
        scene_parts(scenario.domain.name)  # a scene with an expert, or one line saying which are
    except MjsuffError as exc:
        err.print(f"[red]error:[/] {args.scenario}: {exc}", highlight=False, soft_wrap=True)
        return EXIT_USAGE
    if args.replicate < 0:
        err.print(
            f"[red]error:[/] --replicate: expected a replicate index ≥ 0, got {args.replicate}",
            highlight=False,
            soft_wrap=True,
        )
        return EXIT_USAGE
    if args.count is not None and args.count < 1:
        err.print(
            f"[red]error:[/] --count: expected a positive number, got {args.count}",
            highlight=False,
            soft_wrap=True,
        )
        return EXIT_USAGE
    count = args.count or scenario.demos.max_demos or 10
    path = Path(args.out or f"demos/{scenario.name}-seed{scenario.seed}-r{args.replicate}.npz")
    if path.suffix != ".npz":
        err.print(f"[red]error:[/] --out {path}: expected a .npz file name", highlight=False)
        return EXIT_USAGE
    if path.exists() and not args.overwrite:
        err.print(f"[red]error:[/] {path} exists; pass --overwrite to replace it", highlight=False)
        return EXIT_USAGE
    progress = Progress(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        TextColumn("{task.fields[detail]}"),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        console=err,
        disable=args.quiet,
    )
    task = progress.add_task(f"{scenario.name} demos", total=count, detail="")

    def on_demo(i: int, demo) -> None:
        progress.update(
            task, completed=i + 1, detail=f"{i + 1}/{count}, tracking {demo.tracking_error * 1000:.1f} mm"
        )

    started = time.perf_counter()
    try:
        with progress:
            demo_set = generate_demos(scenario, count, args.replicate, on_demo)
    except MjsuffError as exc:
        err.print(f"[red]error:[/] {args.scenario}: {exc}", highlight=False, soft_wrap=True)
        return EXIT_USAGE
    elapsed = time.perf_counter() - started
    if len(demo_set) == 0:
        err.print("interrupted before the first demo: nothing written", highlight=False)
        return EXIT_INTERRUPTED
    demo_set.save(path)
    a, meta = demo_set.arrays, demo_set.meta
    if not args.quiet:
        table = Table(title=f"{len(demo_set)} demos, {scenario.domain.name}, instance {meta['instance']}")
        for col in ("#", "start", *meta["feature_names"], "tracking (mm)", "poor"):
            table.add_column(col, justify="right")
        for i in range(len(demo_set)):
            table.add_row(
                str(i),
                str(a["start_index"][i]),
                *(f"{f:.3f}" for f in a["features"][i]),
                f"{a['tracking_error'][i] * 1000:.2f}",
                "yes" if a["poor"][i] else "",
            )
        out.print(table)
    out.print(
        f"{len(demo_set)} demos in {elapsed:.1f} s ({len(demo_set) / elapsed:.2f} demos/s); "
        f"max tracking error {a['tracking_error'].max() * 1000:.2f} mm; "
        f"IK failures among candidates {sum(meta['ik_failures'])}",
        highlight=False,
    )
    out.print(f"demos: {path} (true weights apart: {truth_path(path)})", highlight=False)
    if meta["interrupted"]:
        err.print(f"interrupted: the {len(demo_set)} finished demos are saved", highlight=False)
        return EXIT_INTERRUPTED
    return 0


def cmd_calibrate(args: argparse.Namespace) -> int:
    import json

    from mjsuff.experiment.calibration import InstanceCalibration, calibrate
    from mjsuff.posterior.calibration import BetaFit

    scenario = _load(args)
    if scenario is None:
        return EXIT_USAGE
    if args.instances < 1:
        err.print(
            f"[red]error:[/] --instances: expected a positive number, got {args.instances}",
            highlight=False,
            soft_wrap=True,
        )
        return EXIT_USAGE
    if args.json and Path(args.json).suffix != ".json":
        err.print(
            f"[red]error:[/] --json {args.json}: expected a .json file name", highlight=False, soft_wrap=True
        )
        return EXIT_USAGE
    if args.json and not Path(args.json).parent.is_dir():
        err.print(
            f"[red]error:[/] --json {args.json}: directory {Path(args.json).parent} does not exist",
            highlight=False,
            soft_wrap=True,
        )
        return EXIT_USAGE

    def show(fit: BetaFit) -> str:
        if fit.unbounded:
            return f"unbounded (> {fit.beta:g})"
        if fit.at_lower:
            return f"≤ {fit.beta:g} (demos no better than alternatives)"
        return f"{fit.beta:.1f} ± {fit.standard_error:.1f}"

    table = Table(
        title=f"β by maximum likelihood under w*, {scenario.name} "
        f"(β in the scenario: {scenario.demos.beta:g})"
    )
    for col in ("instance", "demos", "poor", "β̂", "log-lik.", "demo beaten by"):
        table.add_column(col, justify="right")
    progress = Progress(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        TextColumn("{task.completed}/{task.total}"),
        TimeElapsedColumn(),
        console=err,
        disable=args.quiet,
    )
    task = progress.add_task("calibration instances", total=args.instances)

    def on_instance(c: InstanceCalibration) -> None:
        table.add_row(
            str(c.instance),
            str(c.demos),
            str(c.poor_demos),
            show(c.fit),
            f"{c.fit.log_likelihood:.2f}",
            " ".join(map(str, c.beaten_by)) if c.beaten_by else "–",
        )
        progress.advance(task)

    try:
        with progress:
            result = calibrate(scenario, args.instances, on_instance)
    except MjsuffError as exc:
        err.print(f"[red]error:[/] {args.scenario}: {exc}", highlight=False, soft_wrap=True)
        return EXIT_USAGE
    except KeyboardInterrupt:
        err.print("interrupted: nothing written", highlight=False, soft_wrap=True)
        return EXIT_INTERRUPTED
    if not args.quiet:
        out.print(table)
    out.print(
        f"pooled over {args.instances} instance(s): β̂ = {show(result.pooled)}",
        highlight=False,
        soft_wrap=True,
    )
    if args.json:
        from mjsuff.atomic import atomic_write_text

        payload = {"scenario": str(args.scenario), "seed": scenario.seed, **result.to_dict()}
        try:
            atomic_write_text(Path(args.json), json.dumps(payload, indent=2) + "\n")
        except OSError as exc:
            err.print(
                f"[red]error:[/] --json {args.json}: {exc.strerror or exc}", highlight=False, soft_wrap=True
            )
            return EXIT_USAGE
        out.print(f"calibration: {args.json}", highlight=False, soft_wrap=True)
    return 0


def cmd_report(args: argparse.Namespace) -> int:
    from mjsuff.report import ReportError, write_report  # matplotlib only when asked for

    directories = [Path(d) for d in args.directories]
    out_dir = Path(args.out) if args.out else directories[0] / "report"
    try:
        path = write_report(directories, out_dir)
    except ReportError as exc:
        err.print(f"[red]error:[/] {exc}", highlight=False, soft_wrap=True)
        return EXIT_USAGE
    figures = sorted(p.name for p in out_dir.glob("*.png"))
    out.print(f"report: {path} (figures: {', '.join(figures)})", highlight=False)
    return 0


def cmd_scenarios(args: argparse.Namespace) -> int:
    import json

    shipped = shipped_scenarios()
    if args.json:
        print(
            json.dumps(
                [
                    {"name": s.name, "domain": s.domain, "description": s.description, "path": str(s.path)}
                    for s in shipped
                ],
                indent=2,
            )
        )
        return 0
    table = Table(title="Shipped scenarios: mjsuff run NAME")
    for col in ("name", "domain", "description"):
        table.add_column(col)
    for s in shipped:
        table.add_row(s.name, s.domain, s.description)
    out.print(table)
    folder = shipped[0].path.parent if shipped else "(none)"
    out.print(
        f"files: {folder} (a file of the same name in the working directory comes first)", highlight=False
    )
    return 0


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
        err.print(
            f"[red]error:[/] {path}: no recording (runs write DIR/recording.rrd unless --no-record)",
            highlight=False,
            soft_wrap=True,
        )
        return EXIT_USAGE
    rerun = shutil.which("rerun")
    command = [rerun] if rerun else [sys.executable, "-m", "rerun"]
    if args.web:
        command += ["--web-viewer", "--web-viewer-port", str(args.port), str(path)]
        out.print(
            f"serving {path} to a browser at http://localhost:{args.port} (Ctrl-C stops)", highlight=False
        )
    elif not has_display():
        err.print(
            f"no display here to open {path} on. Either copy it to a machine with one and "
            f"run `rerun {path.name}` (pip install rerun-sdk=={_rerun_version()}), or serve "
            f"it to a browser from here: mjsuff view {args.path} --web",
            highlight=False,
            soft_wrap=True,
        )
        return 1
    else:
        command.append(str(path))
    try:
        return subprocess.call(command)
    except KeyboardInterrupt:
        return 0


def _rerun_version() -> str:
    from importlib.metadata import version

    return version("rerun-sdk")


SCENARIO_HELP = "scenario TOML file or a shipped scenario's name (mjsuff scenarios)"


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="mjsuff",
        description="Demonstration sufficiency testbed: Bayesian IRL with high-confidence "
        "bounds on the robot's regret, on tabular and MuJoCo domains.",
    )
    parser.add_argument("--version", action="version", version=f"mjsuff {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    run = sub.add_parser(
        "run",
        help="run a scenario: demos one at a time, every stopping rule decides, ground truth scores it",
        description="Run a scenario file (or a shipped scenario by name: "
        "mjsuff scenarios lists them) and write steps.parquet, "
        "summary.json and config.toml to the output directory.",
        epilog=f"exit status: 0 done, {EXIT_USAGE} bad input (nothing written), "
        f"{EXIT_CLUSTER} the Ray cluster at --address cannot be used "
        f"(nothing written), {EXIT_INTERRUPTED} interrupted (finished "
        "replicates kept; --resume continues)",
    )
    run.add_argument("scenario", help=f"{SCENARIO_HELP}, e.g. scenarios/gridworld.toml or lava_reacher")
    run.add_argument("--out", help="output directory (default: runs/NAME-TIMESTAMP)")
    run.add_argument("--seed", type=int, help="override the scenario's seed")
    run.add_argument("--replicates", type=int, help="override the number of replicates")
    run.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUE",
        help="override a scenario key, e.g. --set sufficiency.alpha=0.99 (repeatable)",
    )
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
        help="local: worker processes (default: all cores; 1 = serial); ray: CPUs of the local Ray instance",
    )
    run.add_argument(
        "--address", help="ray: address of a running cluster (default: start a local Ray instance)"
    )
    run.add_argument("--quiet", action="store_true", help="no progress bar or summary table")
    run.set_defaults(func=cmd_run)

    demos = sub.add_parser(
        "demos",
        help="generate scripted kinesthetic demonstrations (mink IK, "
        "executed in MuJoCo) for a MuJoCo scenario",
        description="Generate a demo set (.npz, true weights apart in "
        ".truth.json) for one replicate's scene instance, with "
        "the seed streams mjsuff run uses.",
    )
    demos.add_argument("scenario", help=f"{SCENARIO_HELP}, e.g. lava_reacher")
    demos.add_argument("--count", type=int, help="number of demos (default: demos.max_demos)")
    demos.add_argument("--out", help="output .npz (default: demos/NAME-seedS-rR.npz)")
    demos.add_argument("--seed", type=int, help="override the scenario's seed")
    demos.add_argument("--replicate", type=int, default=0, help="which replicate's instance")
    demos.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUE",
        help="override a scenario key, e.g. --set expert.rationality=20",
    )
    demos.add_argument("--overwrite", action="store_true", help="replace an existing --out file")
    demos.add_argument("--quiet", action="store_true", help="no progress bar or demo table")
    demos.set_defaults(func=cmd_demos)

    cal = sub.add_parser(
        "calibrate",
        help="fit the likelihood's β to the scenario's demonstrator on calibration instances",
        description="The calibration stage of the paper's §6.2: draw "
        "calibration instances (never the ones a run is scored on), "
        "collect the demos a passive run would get, and fit β by "
        "maximum likelihood under the known w*, per instance and "
        "pooled. Set demos.beta in the scenario to the pooled value.",
    )
    cal.add_argument("scenario", help=f"{SCENARIO_HELP}, e.g. lander")
    cal.add_argument("--instances", type=int, default=4, help="calibration instances (default 4)")
    cal.add_argument("--seed", type=int, help="override the scenario's seed")
    cal.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUE",
        help="override a scenario key, e.g. --set demos.noise_fraction=0.2",
    )
    cal.add_argument("--json", metavar="FILE", help="also write the fits to this .json file")
    cal.add_argument("--quiet", action="store_true", help="no progress bar or table")
    cal.set_defaults(func=cmd_calibrate)

    view = sub.add_parser(
        "view",
        help="open a run's Rerun recording in the viewer",
        description="Open DIR/recording.rrd (or an .rrd file) in the Rerun "
        "viewer; without a display, says what to run instead.",
    )
    view.add_argument("path", help="a run directory or an .rrd file")
    view.add_argument(
        "--web", action="store_true", help="serve the web viewer instead (works without a display)"
    )
    view.add_argument("--port", type=int, default=9090, help="web viewer port (with --web)")
    view.set_defaults(func=cmd_view)

    report = sub.add_parser(
        "report",
        help="figures, rule comparisons and a markdown summary of finished runs",
        description="Write the paper's figures (F1 and demos needed vs. ε, "
        "bound and true nEVD vs. demos, the noise ablation), "
        "Kruskal-Wallis and Dunn-Bonferroni tests between rules, "
        "and report.md linking them. Give one run or sweep "
        "directory, or several runs (labelled by the scenario "
        "keys in which they differ).",
    )
    report.add_argument("directories", nargs="+", metavar="DIR", help="run or sweep directories")
    report.add_argument("--out", help="where to write (default: DIR/report of the first DIR)")
    report.set_defaults(func=cmd_report)

    scen = sub.add_parser(
        "scenarios",
        help="list the shipped scenarios (mjsuff run NAME runs one)",
        description="List the scenario files shipped with mjsuff: name, "
        "domain and the first sentence of the file's comment. "
        "Commands that take a scenario take these names when no "
        "file of that name exists.",
    )
    scen.add_argument(
        "--json",
        action="store_true",
        help="print a JSON list (name, domain, description, path) instead of a table",
    )
    scen.set_defaults(func=cmd_scenarios)

    hoeff = sub.add_parser("hoeffding", help="print the paper's Table 1 (Hoeffding-based demo counts)")
    hoeff.add_argument("--gamma", type=float, default=0.95)
    hoeff.add_argument("--k", type=int, default=4)
    hoeff.add_argument("--delta", type=float, default=0.05)
    hoeff.add_argument("--thresholds", type=float, nargs="+", default=[0.1, 0.2, 0.3, 0.4, 0.5])
    hoeff.set_defaults(func=cmd_hoeffding)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return int(args.func(args))


if __name__ == "__main__":
    sys.exit(main())
