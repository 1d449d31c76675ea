"""Benchmark: a check's hot paths outside planning, fast against naive, side by side (issue #17).

Each pair computes the same thing on the same inputs in one run (medians of ``--rounds``
alternating rounds, one core for BLAS as in a replicate) and says whether the bits agree:

1. the likelihood of one sampler batch (4,096 weight rows, the first check's 10 reacher demos
   and their candidate sets): SciPy's ``logsumexp`` per demo, as before stop 60, against
   ``mjsuff.scenes.likelihood`` (its own log-sum-exp, demos shared among the rollout threads);
2. a control spline's per-step controls for a planner batch (the basis product with ``einsum``
   against the two-knot interpolation ``ControlSpline.controls`` uses);
3. the reacher's simulated trajectories and features (1,200 rollouts from its evaluation starts)
   with MuJoCo's collision pass on (the model before stop 60) and off (shipped: no geom collides).

    python benchmarks/hot_paths.py [--rounds 7]
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import mujoco
import numpy as np
from scipy.special import logsumexp
from threadpoolctl import threadpool_limits

from mjsuff.experiment.replicate import make_instance
from mjsuff.experiment.run_summary import machine_info
from mjsuff.experiment.scenario import load_scenario
from mjsuff.scenes.likelihood import demo_log_likelihoods
from mjsuff.sphere import random_unit_vectors

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"
BATCH_ROWS = 4096
DEMOS = 10
CONTACT = int(mujoco.mjtDisableBit.mjDSBL_CONTACT)


def timed(pairs: dict[str, object], rounds: int) -> dict[str, tuple[float, object]]:
    """Median seconds and the last result of each callable, rounds alternating between them."""
    times: dict[str, list[float]] = {name: [] for name in pairs}
    results: dict[str, object] = {}
    for _ in range(rounds):
        for name, call in pairs.items():
            t0 = time.perf_counter()
            results[name] = call()  # type: ignore[operator]
            times[name].append(time.perf_counter() - t0)
    return {name: (float(np.median(t)), results[name]) for name, t in times.items()}


def report(title: str, naive: str, fast: str, measured: dict[str, tuple[float, object]]) -> None:
    (t_naive, r_naive), (t_fast, r_fast) = measured[naive], measured[fast]
    same = all(np.array_equal(a, b) for a, b in zip(_arrays(r_naive), _arrays(r_fast), strict=True))
    print(
        f"{title}: {naive} {t_naive * 1e3:.1f} ms, {fast} {t_fast * 1e3:.1f} ms "
        f"({t_naive / t_fast:.2f}x); same bits: {same}"
    )


def _arrays(result: object) -> tuple[np.ndarray, ...]:
    return tuple(np.asarray(r) for r in result) if isinstance(result, tuple) else (np.asarray(result),)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=7)
    args = parser.parse_args()
    machine = machine_info()
    print(
        f"machine: {machine['cpu']}, {os.cpu_count()} cores; "
        f"BLAS {machine['blas']}; MuJoCo {machine['mujoco']}"
    )
    scenario = load_scenario(SCENARIOS / "lava_reacher.toml")
    with threadpool_limits(limits=1):
        domain = make_instance(scenario, 0)
        rng = np.random.default_rng(1)
        demos = [domain.demonstrate(s % len(domain.pool), rng) for s in range(DEMOS)]
        sets = [domain.candidate_features(d) for d in demos]
        weights = random_unit_vectors(rng, BATCH_ROWS, domain.num_features)
        beta = scenario.demos.beta

        def scipy_per_demo() -> np.ndarray:
            out = np.zeros((len(weights), len(sets)))
            for j, c in enumerate(sets):
                values = beta * (weights @ c.T)
                out[:, j] = values[:, 0] - logsumexp(values, axis=1)
            return out

        print(
            f"lava_reacher instance 0, {DEMOS} demos ({sum(len(c) for c in sets)} candidates), "
            f"medians of {args.rounds} alternating rounds"
        )
        report(
            f"1. likelihood of a {BATCH_ROWS}-row batch",
            "SciPy per demo",
            "mjsuff",
            timed(
                {
                    "SciPy per demo": scipy_per_demo,
                    "mjsuff": lambda: demo_log_likelihoods(weights, sets, beta),
                },
                args.rounds,
            ),
        )
        spline = domain.scene.spline
        knots = spline.uniform(rng, 1200)
        anchors = domain.scene.all_starts[rng.integers(len(domain.scene.all_starts), size=len(knots))]

        def basis_product() -> np.ndarray:
            full = np.concatenate([spline.clip(anchors)[:, None, :], spline.clip(knots)], axis=1)
            return np.einsum("tk,bku->btu", spline.basis, full)

        report(
            f"2. spline controls for {len(knots)} knot sets",
            "basis product",
            "two knots",
            timed(
                {"basis product": basis_product, "two knots": lambda: spline.controls(knots, anchors)},
                args.rounds,
            ),
        )
        scene, model = domain.scene, domain.scene.model
        starts = np.repeat(scene.starts, len(knots) // len(scene.starts), axis=0)
        batch = knots[: len(starts)]
        shipped = model.opt.disableflags

        def simulate(flags: int):
            def run():
                model.opt.disableflags = flags
                try:
                    rollouts, features = scene.simulate(starts, batch)
                    return rollouts.qpos, rollouts.qvel, features
                finally:
                    model.opt.disableflags = shipped

            return run

        report(
            f"3. {len(starts)} reacher rollouts with features",
            "contacts on",
            "contacts off",
            timed(
                {"contacts on": simulate(shipped & ~CONTACT), "contacts off": simulate(shipped)},
                args.rounds,
            ),
        )


if __name__ == "__main__":
    main()
