"""``mjsuff calibrate``: fit the likelihood's β to the scenario's demonstrator (paper §6.2)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from rich.table import Table

from mjsuff.atomic import atomic_write_text
from mjsuff.cli.console import EXIT_INTERRUPTED, note, out, progress_bar, say
from mjsuff.cli.options import load, quiet_option, scenario_options
from mjsuff.errors import MjsuffError, UsageError, in_context
from mjsuff.posterior.calibration import BetaFit


def add_parser(commands: Any) -> None:
    cal = commands.add_parser(
        "calibrate",
        parents=[scenario_options("lander", "demos.noise_fraction=0.2"), quiet_option("table")],
        help="fit the likelihood's β to the scenario's demonstrator on calibration instances",
        description="The calibration stage of the paper's §6.2: draw calibration instances "
        "(never the ones a run is scored on), collect the demos a passive run would get, and fit "
        "β by maximum likelihood under the known w*, per instance and pooled. Set demos.beta in "
        "the scenario to the pooled value. With --fit-lapse, the lapse rate (demos.lapse) is "
        "fitted with it, by profile likelihood over 0, 0.025, ..., 0.5.",
    )
    cal.add_argument("--instances", type=int, default=4, help="calibration instances (default 4)")
    cal.add_argument(
        "--fit-lapse",
        action="store_true",
        help="also fit the likelihood's lapse rate (default: β at the scenario's demos.lapse)",
    )
    cal.add_argument("--json", metavar="FILE", help="also write the fits to this .json file")
    cal.set_defaults(func=cmd_calibrate)


def cmd_calibrate(args: argparse.Namespace) -> int:
    from mjsuff.experiment.calibration import InstanceCalibration, calibrate

    scenario = load(args)
    if args.instances < 1:
        raise UsageError(f"--instances: expected a positive number, got {args.instances}")
    json_path = Path(args.json) if args.json else None
    if json_path and json_path.suffix != ".json":
        raise UsageError(f"--json {json_path}: expected a .json file name")
    if json_path and not json_path.parent.is_dir():
        raise UsageError(f"--json {json_path}: directory {json_path.parent} does not exist")
    table = Table(
        title=f"β by maximum likelihood under w*, {scenario.name} "
        f"(β in the scenario: {scenario.demos.beta:g}, lapse rate {scenario.demos.lapse:g})"
    )
    for col in ("instance", "demos", "poor", "β̂", "log-lik.", "demo beaten by"):
        table.add_column(col, justify="right")
    progress = progress_bar(args.quiet, detail=False, remaining=False)
    task = progress.add_task("calibration instances", total=args.instances)

    def on_instance(c: InstanceCalibration) -> None:
        beaten_by = " ".join(map(str, c.beaten_by)) if c.beaten_by else "–"
        table.add_row(
            str(c.instance),
            str(c.demos),
            str(c.poor_demos),
            show(c.fit),
            f"{c.fit.log_likelihood:.2f}",
            beaten_by,
        )

    try:
        with progress:
            result = calibrate(
                scenario, args.instances, on_instance, args.fit_lapse, lambda _: progress.advance(task)
            )
    except MjsuffError as exc:
        raise in_context(args.scenario, exc) from exc
    except KeyboardInterrupt:
        note("interrupted: nothing written")
        return EXIT_INTERRUPTED
    if not args.quiet:
        out.print(table)
    if result.profile is not None:
        say(f"lapse rate by profile likelihood: ε̂ = {result.lapse:g} (every β̂ here is at ε̂)")
    say(f"pooled over {args.instances} instance(s): β̂ = {show(result.pooled)}")
    if json_path:
        payload = {"scenario": str(args.scenario), "seed": scenario.seed, **result.to_dict()}
        try:
            atomic_write_text(json_path, json.dumps(payload, indent=2) + "\n")
        except OSError as exc:
            raise UsageError(f"--json {json_path}: {exc.strerror or exc}") from exc
        say(f"calibration: {json_path}")
    return 0


def show(fit: BetaFit) -> str:
    """β̂ with its standard error, or what the fit ran into (β unbounded, or at the lower end)."""
    if fit.unbounded:
        return f"unbounded (> {fit.beta:g})"
    if fit.at_lower:
        return f"≤ {fit.beta:g} (demos no better than alternatives)"
    return f"{fit.beta:.1f} ± {fit.standard_error:.1f}"
