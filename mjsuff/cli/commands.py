"""The ``mjsuff`` parser, assembled from the command modules, and the one place errors are caught."""

from __future__ import annotations

import argparse

import mjsuff.cli.calibrate as calibrate
import mjsuff.cli.demos as demos
import mjsuff.cli.hoeffding as hoeffding
import mjsuff.cli.report as report
import mjsuff.cli.run as run
import mjsuff.cli.scenarios as scenarios
import mjsuff.cli.view as view
from mjsuff import __version__
from mjsuff.cli.console import EXIT_INTERRUPTED, EXIT_MEMORY, error, note
from mjsuff.errors import MjsuffError

#: The commands in the order ``mjsuff --help`` lists them.
COMMANDS = (run, demos, calibrate, view, report, scenarios, hoeffding)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="mjsuff",
        description="Demonstration sufficiency testbed: Bayesian IRL with high-confidence "
        "bounds on the robot's regret, on tabular and MuJoCo domains.",
    )
    parser.add_argument("--version", action="version", version=f"mjsuff {__version__}")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for command in COMMANDS:
        command.add_parser(commands)
    return parser


def run_command(argv: list[str] | None = None) -> int:
    """Run one command; an :class:`MjsuffError` becomes one line on stderr and its exit status."""
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args))
    except MjsuffError as exc:
        error(str(exc))
        return exc.exit_code
    except KeyboardInterrupt:
        # Commands that keep partial work (run, demos, calibrate, view) say what they kept
        # themselves; any other stops here, its files written whole or not at all.
        note(f"mjsuff {args.command}: interrupted; nothing half-written was left")
        return EXIT_INTERRUPTED
    except MemoryError:
        error(
            f"mjsuff {args.command}: out of memory. A run keeps its finished replicates: free memory or "
            "lower the sizes (--workers, posterior.num_samples, posterior.chains), then --resume"
        )
        return EXIT_MEMORY
