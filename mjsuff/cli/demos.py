"""``mjsuff demos``: scripted kinesthetic demonstrations of one replicate's scene instance."""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

from rich.table import Table

from mjsuff.cli.console import EXIT_INTERRUPTED, note, out, progress_bar, say
from mjsuff.cli.options import load, quiet_option, scenario_options
from mjsuff.errors import MjsuffError, UsageError, in_context
from mjsuff.experts.demo_set import DemoSet, truth_path


def add_parser(commands: Any) -> None:
    demos = commands.add_parser(
        "demos",
        parents=[
            scenario_options("lava_reacher", "domain.params.expert.rationality=20"),
            quiet_option("demo table"),
        ],
        help="generate scripted kinesthetic demonstrations (mink IK, executed in MuJoCo) "
        "for a MuJoCo scenario",
        description="Generate a demo set (.npz, true weights apart in .truth.json) for one "
        "replicate's scene instance, with the seed streams mjsuff run uses.",
    )
    demos.add_argument("--count", type=int, help="number of demos (default: demos.max_demos)")
    demos.add_argument("--out", help="output .npz (default: demos/NAME-seedS-rR.npz)")
    demos.add_argument("--replicate", type=int, default=0, help="which replicate's instance")
    demos.add_argument("--overwrite", action="store_true", help="replace an existing --out file")
    demos.set_defaults(func=cmd_demos)


def cmd_demos(args: argparse.Namespace) -> int:
    from mjsuff.experiment.demo_generation import generate_demos, scene_parts  # mink only when asked for

    scenario = load(args)
    try:
        scene_parts(scenario.domain.name)  # a scene with an expert, or one line saying which are
    except MjsuffError as exc:
        raise in_context(args.scenario, exc) from exc
    if args.replicate < 0:
        raise UsageError(f"--replicate: expected a replicate index ≥ 0, got {args.replicate}")
    if args.count is not None and args.count < 1:
        raise UsageError(f"--count: expected a positive number, got {args.count}")
    count = args.count or scenario.demos.max_demos or 10
    path = Path(args.out or f"demos/{scenario.name}-seed{scenario.seed}-r{args.replicate}.npz")
    if path.suffix != ".npz":
        raise UsageError(f"--out {path}: expected a .npz file name")
    if path.exists() and not args.overwrite:
        raise UsageError(f"{path} exists; pass --overwrite to replace it")
    progress = progress_bar(args.quiet)
    task = progress.add_task(f"{scenario.name} demos", total=count, detail="")

    def on_demo(i: int, demo: Any) -> None:
        tracking = f"tracking {demo.tracking_error * 1000:.1f} mm"
        progress.update(task, completed=i + 1, detail=f"{i + 1}/{count}, {tracking}")

    started = time.perf_counter()
    try:
        with progress:
            demo_set = generate_demos(scenario, count, args.replicate, on_demo)
    except MjsuffError as exc:
        raise in_context(args.scenario, exc) from exc
    elapsed = time.perf_counter() - started
    if len(demo_set) == 0:
        note("interrupted before the first demo: nothing written")
        return EXIT_INTERRUPTED
    demo_set.save(path)
    if not args.quiet:
        out.print(demo_table(demo_set, scenario.domain.name))
    a, meta = demo_set.arrays, demo_set.meta
    say(
        f"{len(demo_set)} demos in {elapsed:.1f} s ({len(demo_set) / elapsed:.2f} demos/s); "
        f"max tracking error {a['tracking_error'].max() * 1000:.2f} mm; "
        f"IK failures among candidates {sum(meta['ik_failures'])}"
    )
    say(f"demos: {path} (true weights apart: {truth_path(path)})")
    if meta["interrupted"]:
        note(f"interrupted: the {len(demo_set)} finished demos are saved")
        return EXIT_INTERRUPTED
    return 0


def demo_table(demo_set: DemoSet, domain: str) -> Table:
    """One row per demo: its start, features, tracking error (mm) and whether it is a poor one."""
    a, meta = demo_set.arrays, demo_set.meta
    table = Table(title=f"{len(demo_set)} demos, {domain}, instance {meta['instance']}")
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
    return table
