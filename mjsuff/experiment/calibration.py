"""The calibration stage: fit the likelihood's β to a scenario's demonstrator (paper §6.2).

Calibration instances are drawn from the scenario's domain and demonstrator with seed streams no
run uses (the ``calibration`` seed stream, ``mjsuff.seeds``). Each gets the demos a passive run
would ask for (the scenario's ``max_demos``, its share of poor demos); β is then fitted by maximum
likelihood under each instance's known ``w*``, per instance and pooled over all of them
(``mjsuff.posterior.calibration``).

What a demo is compared with matters. On the MuJoCo scenes a demo's candidate set is built from
the start's trajectory library when the demo is first seen; in a run that library already holds
π_MAP plans and V* refinements near ``w*`` by the later demos. So before the demos, calibration
plans and refines ``w*`` itself from every start into the library (the converged condition of a
run; harmless here, since a calibration instance is never scored): the demos then face
alternatives at least as strong as a run's, and β̂ errs low (a less confident posterior) rather
than high.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from mjsuff.demo_schedule import DemoSchedule
from mjsuff.domain import Demo, Domain
from mjsuff.errors import UsageError
from mjsuff.experiment.replicate import make_instance
from mjsuff.experiment.scenario import Scenario
from mjsuff.posterior.calibration import BetaFit, LapseFit, at_lapse, fit_beta
from mjsuff.posterior.calibration import fit_lapse as fit_lapse_rate
from mjsuff.seeds import stream_rng, stream_seed


@dataclass(frozen=True)
class InstanceCalibration:
    """One calibration instance: its demos' fit, and where each demo ranks among its alternatives.

    ``beaten_by`` is, per demo, how many of the likelihood's alternatives (other actions, or
    candidate trajectories) are worth more under ``w*`` than the demo (0: the demo is the best).
    """

    instance: int
    demos: int
    poor_demos: int
    fit: BetaFit
    beaten_by: tuple[int, ...]


@dataclass(frozen=True)
class Calibration:
    """Per-instance fits and the fit pooled over every instance's demos, at lapse rate ``lapse``
    (the scenario's, or fitted: then ``profile`` holds the lapse fit)."""

    instances: list[InstanceCalibration]
    pooled: BetaFit
    lapse: float = 0.0
    profile: LapseFit | None = None

    def to_dict(self) -> dict:
        def fit(f: BetaFit) -> dict:
            return {
                "beta": f.beta,
                "log_likelihood": f.log_likelihood,
                "unbounded": f.unbounded,
                "at_lower": f.at_lower,
                "standard_error": f.standard_error if math.isfinite(f.standard_error) else None,
            }

        lapse: dict[str, Any] = {"lapse": self.lapse, "lapse_fitted": self.profile is not None}
        if self.profile is not None:
            lapse["lapse_profile"] = [{"lapse": e, "log_likelihood": ll} for e, ll in self.profile.profile]
        return {
            **lapse,
            "pooled": fit(self.pooled),
            "instances": [
                {
                    "instance": c.instance,
                    "demos": c.demos,
                    "poor_demos": c.poor_demos,
                    **fit(c.fit),
                    "beaten_by": list(c.beaten_by),
                }
                for c in self.instances
            ],
        }


def _stream(scenario: Scenario, instance: int, stream: int) -> np.random.Generator:
    return stream_rng(scenario.seed, instance, "calibration", stream)


def calibration_demos(scenario: Scenario, instance: int) -> tuple[Domain, list[Demo]]:
    """Calibration instance ``instance`` and the demos a passive run would be shown on it."""
    domain = make_instance(scenario, instance, stream_seed(scenario.seed, instance, "calibration", 0))
    # w*'s own plan and V* refinement join a scene's trajectory library before any demo.
    domain.plan(domain.true_weights)
    domain.optimal_start_values(np.asarray(domain.true_weights, dtype=float)[None])
    d = scenario.demos
    schedule = DemoSchedule.draw(
        domain.pool.size,
        d.max_demos,
        d.noise_fraction,
        _stream(scenario, instance, 1),
        _stream(scenario, instance, 2),
    )
    demos = []
    for start in schedule.passive_starts():
        poor = schedule.next_is_poor()
        demos.append(domain.demonstrate(int(start), schedule.rng, poor=poor))
    return domain, demos


def calibrate(
    scenario: Scenario,
    instances: int,
    on_instance: Callable[[InstanceCalibration], None] | None = None,
    fit_lapse: bool = False,
    on_demos: Callable[[int], None] | None = None,
) -> Calibration:
    """Fit β on ``instances`` calibration instances of ``scenario``: at the scenario's lapse rate,
    or, with ``fit_lapse``, at the lapse rate fitted with it over every instance's demos (profile
    likelihood, ``mjsuff.posterior.calibration.fit_lapse``). ``on_demos(i)`` follows each
    instance's demos (the slow part), ``on_instance`` each instance's fit.

    Raises:
        UsageError: If ``instances`` < 1.
    """
    if instances < 1:
        raise UsageError(f"--instances: expected at least 1, got {instances}")
    curves: list[Callable[[float, float], float]] = []
    collected: list[tuple[Domain, list[Demo]]] = []
    for i in range(instances):
        domain, demos = calibration_demos(scenario, i)
        w = np.asarray(domain.true_weights, dtype=float)[None]

        def curve(
            beta: float, lapse: float, domain: Domain = domain, demos: list[Demo] = demos, w: np.ndarray = w
        ) -> float:
            return float(domain.log_likelihood(w, demos, beta, lapse)[0])

        curves.append(curve)
        collected.append((domain, demos))
        if on_demos is not None:
            on_demos(i)
    profile = None
    if fit_lapse:
        profile = fit_lapse_rate(lambda beta, lapse: sum(c(beta, lapse) for c in curves))
        lapse, pooled = profile.lapse, profile.fit
    else:
        lapse = scenario.demos.lapse
        pooled = fit_beta(lambda beta: sum(c(beta, lapse) for c in curves))
    results: list[InstanceCalibration] = []
    for i, ((domain, demos), instance_curve) in enumerate(zip(collected, curves, strict=True)):
        w = np.asarray(domain.true_weights, dtype=float)
        beaten = tuple(domain.alternatives_better(d, w) for d in demos)
        fit = fit_beta(at_lapse(instance_curve, lapse))  # β̂ at the pooled ε
        results.append(InstanceCalibration(i, len(demos), sum(d.poor for d in demos), fit, beaten))
        if on_instance is not None:
            on_instance(results[-1])
    return Calibration(results, pooled, lapse, profile)
