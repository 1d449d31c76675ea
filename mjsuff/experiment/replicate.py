"""One replicate of the experiment loop (paper Alg. 1 and §4.1).

Demonstrations arrive one at a time. After each: the posterior given all demos, π_MAP, nEVD and
PIOB for every posterior sample and their α-VaR bounds, every stopping rule's verdict, and the
ground truth (the hidden ``w*``) for the policy each rule would deploy.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, Protocol

import numpy as np

from mjsuff.bounds.regret import normalized_evd, percent_improvement, policy_values
from mjsuff.bounds.var_bound import QuantileMethod, lower_var_bound, upper_var_bound, var_bound_index
from mjsuff.demo_schedule import DemoSchedule
from mjsuff.domain import BoundIndex, Demo, Domain, Policy
from mjsuff.domains import get_domain
from mjsuff.experiment.scenario import Scenario, SufficiencySettings
from mjsuff.experiment.selection import active_choice
from mjsuff.experiment.step_row import SIMULATION_COUNTERS, StepRow
from mjsuff.posterior.sampler import Posterior, sample_posterior
from mjsuff.seeds import stream_seed
from mjsuff.stopping import (
    Evidence,
    NevdBoundRule,
    PatienceRule,
    PiobBoundRule,
    StoppingRule,
    ValidationSetRule,
)

StepCallback = Callable[[int, int], None]
"""Called as ``(step, max_demos)`` after each demonstration step."""


def build_rules(scenario: Scenario) -> list[StoppingRule]:
    """Every stopping rule of the scenario, one per rule parameter."""
    r = scenario.rules
    return [
        *(NevdBoundRule(t) for t in r.nevd_thresholds),
        *(PiobBoundRule(t) for t in r.piob_thresholds),
        *(PatienceRule(p) for p in r.patience),
        *(ValidationSetRule(i, r.validation_min_held_out) for i in r.validation_intervals),
    ]


def make_instance(scenario: Scenario, replicate: int, seed: np.random.SeedSequence | None = None) -> Domain:
    """The domain instance of ``replicate`` (its own seed stream), or drawn from ``seed``."""
    rng = np.random.default_rng(
        seed if seed is not None else stream_seed(scenario.seed, replicate, "instance")
    )
    return get_domain(scenario.domain.name).make(scenario.domain_params(), rng)


def demo_schedule(scenario: Scenario, replicate: int, pool_size: int) -> DemoSchedule:
    """Replicate ``replicate``'s passive demo schedule (``mjsuff.demo_schedule``)."""
    d = scenario.demos
    return DemoSchedule.of_replicate(scenario.seed, replicate, pool_size, d.max_demos, d.noise_fraction)


def nevd_bound_index(
    post: Posterior, alpha: float, delta: float, method: QuantileMethod = "normal"
) -> BoundIndex:
    """The order statistic the nEVD bound takes, as a function of the per-sample values (their
    quantile ESS sets it): what ``Domain.optimal_start_values`` refines toward."""
    return lambda nevd: var_bound_index(len(nevd), alpha, delta, method, post.effective_size(nevd, alpha))


def posterior_bounds(
    post: Posterior,
    nevd: np.ndarray,
    piob: np.ndarray,
    alpha: float,
    delta: float,
    method: QuantileMethod = "normal",
) -> tuple[float, float, float]:
    """(nEVD upper bound, PIOB lower bound, nEVD's effective size) of per-sample values, each
    bound's index chosen for its values' quantile ESS (``Posterior.effective_size``). PIOB's
    non-finite values (``|V_base| = 0``) are left out; with none finite its bound is −inf."""
    nevd_ess = post.effective_size(nevd, alpha)
    nevd_bound = upper_var_bound(nevd, alpha, delta, method, nevd_ess)
    finite = piob[np.isfinite(piob)]
    piob_bound = (
        lower_var_bound(finite, alpha, delta, method, post.effective_size(piob, 1.0 - alpha))
        if finite.size
        else -math.inf
    )
    return nevd_bound, piob_bound, nevd_ess


class _Truth:
    """Ground truth under ``w*`` for any policy, cached per policy.

    ``V*_{w*}`` per evaluation start comes from ``Domain.true_optimal_start_values`` (a larger
    budget) and is raised to the policy's own value where a policy beats it, so a true nEVD is
    never negative. When the replicate ends, :meth:`raise_to` lifts it to the best of everything
    the replicate simulated under ``w*`` (``Domain.final_true_start_values``) and every
    policy's values are recomputed: a truth nothing the replicate found beats.
    """

    def __init__(self, domain: Domain) -> None:
        self.domain = domain
        w = domain.true_weights[None]
        sw = domain.start_weights
        self.initial = np.asarray(domain.true_optimal_start_values(), dtype=float)
        self.v_opt_starts = self.initial.copy()
        self.mu_rand = domain.random_start_feature_expectations()
        self.v_rand = float(policy_values(w, self.mu_rand, sw)[0])
        self.v_base = float(policy_values(w, domain.baseline_start_feature_expectations(), sw)[0])
        self._cache: dict[bytes, tuple[float, float, float]] = {}
        self._policies: dict[bytes, Policy] = {}

    def __call__(self, policy: Policy) -> tuple[float, float, float]:
        """(true nEVD, true PIOB, policy optimality) of ``policy``."""
        key = self.domain.policy_key(policy)
        if key not in self._cache:
            self._policies[key] = policy
            self._cache[key] = self._score(policy)
        return self._cache[key]

    def _score(self, policy: Policy) -> tuple[float, float, float]:
        w = self.domain.true_weights[None]
        mu = self.domain.start_feature_expectations(policy)
        v = policy_values(w, mu, self.domain.start_weights)
        v_opt = self.domain.start_weights @ np.maximum(self.v_opt_starts, mu @ w[0])
        nevd = float(normalized_evd(np.array([v_opt]), v, np.array([self.v_rand]))[0])
        piob = float(percent_improvement(v, np.array([self.v_base]))[0])
        optimality = self.domain.policy_optimality(
            policy, None if np.array_equal(self.v_opt_starts, self.initial) else self.v_opt_starts
        )
        return nevd, piob, optimality

    def raise_to(self, best: np.ndarray) -> tuple[int, float]:
        """Raise ``V*`` per start to ``best`` ``(S,)`` where higher and rescore every policy;
        returns how often (starts raised) and by how much (largest raise, in units of that
        start's ``V* − V_rand``)."""
        raised = np.maximum(self.v_opt_starts, best)
        gain = raised - self.initial
        scale = np.maximum(self.initial - self.mu_rand @ self.domain.true_weights, 1e-12)
        raised_starts = int(np.sum(gain > 1e-12 * (1 + np.abs(self.initial))))
        if raised_starts:
            self.v_opt_starts = raised
            self._cache = {key: self._score(p) for key, p in self._policies.items()}
        return raised_starts, float(np.max(gain / scale, initial=0.0))


class DemoSource(Protocol):
    """Where a replicate's demos come from when not from the domain's own expert."""

    def demonstrate(self, start: int, rng: np.random.Generator, poor: bool = False) -> Demo: ...


class ReplicateObserver(Protocol):
    """Watches a replicate (e.g. ``mjsuff.recording.ReplicateRecorder``)."""

    def begin(self, domain: Domain) -> None: ...

    def step(
        self,
        step: int,
        demo: Demo,
        samples: np.ndarray,
        nevd: np.ndarray,
        map_weights: np.ndarray,
        map_policy: Policy,
        rows: list[dict[str, Any]],
    ) -> None:
        """One demo step; ``rows`` carry the truth the replicate began with (raised at its end)."""

    def end(self, rows: list[dict[str, Any]]) -> None:
        """The replicate has ended: every row, scored against the final truth (as in steps.parquet)."""


class _Posteriors:
    """The posteriors of one step of a replicate, per held-out set of demos (paper Alg. 1).

    The full posterior (nothing held out) is sampled until converged; a held-out posterior (the
    validation baseline) only serves its MAP, so it keeps one sample per chain from one round.
    Chains start near the step before's posterior given the same held-out set.
    """

    def __init__(self, scenario: Scenario, replicate: int, domain: Domain, demos: list[Demo]) -> None:
        self.seed, self.replicate, self.beta = scenario.seed, replicate, scenario.demos.beta
        self.lapse = scenario.demos.lapse
        self.domain, self.demos = domain, demos
        self.sampler = scenario.sampler()
        chains = self.sampler.chains
        self.map_only = self.sampler.model_copy(update={"num_samples": chains * -(-10 // chains)})
        self._current: dict[frozenset[int], tuple[Posterior, Policy]] = {}
        self._previous: dict[frozenset[int], np.ndarray] = {}

    def next_step(self) -> None:
        """A demo was added: this step's posteriors become the next step's chain starts."""
        self._previous = {key: post.samples for key, (post, _) in self._current.items()}
        self._current.clear()

    def excluding(self, excluded: frozenset[int]) -> tuple[Posterior, Policy]:
        """The posterior given every demo but ``excluded`` (indices), and its MAP's policy."""
        key = frozenset(excluded)
        if key not in self._current:
            domain, n = self.domain, len(self.demos)
            used = [d for j, d in enumerate(self.demos) if j not in key]
            rng = np.random.default_rng(stream_seed(self.seed, self.replicate, "mcmc", n, *sorted(key)))
            settings = self.sampler if not key else self.map_only
            initial = self._previous.get(key)
            if initial is None and not domain.uniform_prior:  # start the chains in the support
                initial = domain.sample_prior(rng, 4 * settings.chains)
            post = sample_posterior(
                lambda w: domain.log_prior(w) + domain.log_likelihood(w, used, self.beta, self.lapse),
                domain.num_features,
                settings,
                rng,
                initial=initial,
                until_converged=not key,
            )
            self._current[key] = (post, domain.plan(post.map_weights))
        return self._current[key]


def per_sample_regrets(
    domain: Domain,
    post: Posterior,
    map_policy: Policy,
    suff: SufficiencySettings,
    mu_rand: np.ndarray,
    mu_base: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """nEVD (Eq. 4) and PIOB (Eq. 6) of ``map_policy`` under every posterior sample ``(N,)``;
    V* is refined toward the order statistic the nEVD bound takes."""
    w, sw = post.samples, domain.start_weights
    mu_robot = domain.start_feature_expectations(map_policy)
    v_opt_starts = domain.optimal_start_values(
        w,
        robot=mu_robot,
        bound_index=nevd_bound_index(post, suff.alpha, suff.delta, suff.quantile_method),
    )
    v_robot = policy_values(w, mu_robot, sw)
    nevd = normalized_evd(v_opt_starts @ sw, v_robot, policy_values(w, mu_rand, sw))
    piob = percent_improvement(v_robot, policy_values(w, mu_base, sw))
    return nevd, piob


def _posterior_columns(post: Posterior, bound_ess: float) -> dict[str, Any]:
    """The posterior's diagnostics, as ``StepRow`` fields."""
    return {
        "map_log_likelihood": post.map_log_likelihood,
        "acceptance_rate": post.acceptance_rate,
        "rhat": post.rhat,
        "ess_bulk": post.ess_bulk,
        "ess_tail": post.ess_tail,
        "bound_ess": bound_ess,
        "mcmc_steps": post.steps,
        "converged": post.converged,
    }


def _simulation_columns(domain: Domain) -> dict[str, int]:
    """The simulation behind the instance so far (``Domain.simulation_stats``), as ``StepRow``
    fields; 0 for exact domains."""
    stats = domain.simulation_stats()
    return {name: stats.get(name, 0) for name in SIMULATION_COUNTERS}


def _decide(
    rules: list[StoppingRule],
    evidence: Evidence,
    truth: _Truth,
    shared: dict[str, Any],
    scored: list[tuple[Policy, bool]],
) -> list[StepRow]:
    """Every rule's decision on ``evidence`` as a row, with the truth of the policy it would
    deploy; ``shared`` holds the step's other columns. Each deployed policy joins ``scored``."""
    rows = []
    for rule in rules:
        decision = rule.decide(evidence)
        true_nevd, true_piob, optimality = truth(decision.policy)
        scored.append((decision.policy, rule.measures_improvement))
        rows.append(
            StepRow(
                rule=rule.kind,
                param=float(rule.param),
                bound=float(decision.bound),
                true_value=true_piob if rule.measures_improvement else true_nevd,
                true_nevd=true_nevd,
                true_piob=true_piob,
                decision=bool(decision.sufficient),
                policy_optimality=optimality,
                **shared,
            )
        )
    return rows


def run_replicate(
    scenario: Scenario,
    replicate: int,
    on_step: StepCallback | None = None,
    demo_source: DemoSource | None = None,
    observer: ReplicateObserver | None = None,
) -> list[dict[str, Any]]:
    """Run one replicate; returns one row per rule and demo step (see README, steps.parquet).

    ``demo_source`` (e.g. a saved demo set) replaces the domain's expert; ``observer`` sees the
    instance, every step (the demo, the posterior with each sample's nEVD, π_MAP, the rows) and
    the rows again when the replicate ends, scored against the final truth.
    """
    domain = make_instance(scenario, replicate)
    if observer is not None:
        observer.begin(domain)
    source: DemoSource = demo_source or domain
    rules = build_rules(scenario)
    for rule in rules:
        rule.reset()
    suff = scenario.sufficiency
    pool_size = domain.pool.size
    schedule = demo_schedule(scenario, replicate, pool_size)
    truth = _Truth(domain)
    mu_rand = domain.random_start_feature_expectations()
    mu_base = domain.baseline_start_feature_expectations()
    demos: list[Demo] = []
    posteriors = _Posteriors(scenario, replicate, domain, demos)

    rows: list[StepRow] = []
    scored: list[tuple[Policy, bool]] = []  # per row: the deployed policy, whether PIOB is its truth
    asked: set[int] = set()
    start = schedule.start(0)
    for step in range(1, schedule.budget + 1):
        posteriors.next_step()
        asked.add(start)
        demos.append(source.demonstrate(start, schedule.rng, poor=schedule.next_is_poor()))
        post, map_policy = posteriors.excluding(frozenset())
        nevd, piob = per_sample_regrets(domain, post, map_policy, suff, mu_rand, mu_base)
        nevd_bound, piob_bound, nevd_ess = posterior_bounds(
            post, nevd, piob, suff.alpha, suff.delta, suff.quantile_method
        )
        evidence = Evidence(
            domain,
            list(demos),
            map_policy,
            nevd_bound,
            piob_bound,
            lambda ex: posteriors.excluding(ex)[1],
            post.converged,
        )
        shared = {
            "replicate": replicate,
            "step": step,
            "start": start,
            "pool_size": pool_size,
            "poor_demo": demos[-1].poor,
            **_posterior_columns(post, nevd_ess),
            **_simulation_columns(domain),
            "truth_raised_starts": 0,  # set when the replicate ends (the truth is raised then)
            "truth_raise": 0.0,
            "truth_passes": 0,
            "truth_last_gain": 0.0,
        }
        step_rows = _decide(rules, evidence, truth, shared, scored)
        rows += step_rows
        if observer is not None:
            new_rows = [r.as_dict() for r in step_rows]
            observer.step(step, demos[-1], post.samples, nevd, post.map_weights, map_policy, new_rows)
        if on_step is not None:
            on_step(step, schedule.budget)
        if step < schedule.budget and scenario.demos.selection == "active":
            pool_evd = domain.pool_regrets(post.samples, map_policy)
            start = active_choice(pool_evd, asked, suff.alpha, suff.delta, suff.quantile_method, nevd_ess)
        elif step < schedule.budget:
            start = schedule.start(step)
    _rescore(domain, truth, rows, scored)
    final_rows = [row.as_dict() for row in rows]
    if observer is not None:
        observer.end(final_rows)
    return final_rows


def _rescore(domain: Domain, truth: _Truth, rows: list[StepRow], scored: list[tuple[Policy, bool]]) -> None:
    """The truth nothing beats: raised to the best of everything the replicate simulated under
    w* (and searched again from there, ``Domain.final_true_start_values``), and every row
    scored again against it (``scored``: each row's policy, and whether PIOB
    is its truth)."""
    final = domain.final_true_start_values()
    raised = truth.raise_to(final.values)
    last_step = max(row.step for row in rows)
    simulated = _simulation_columns(domain)  # all of it: the last step's scoring, the end searches
    for row, (policy, measures_improvement) in zip(rows, scored, strict=True):
        if row.step == last_step:
            for name, value in simulated.items():
                setattr(row, name, value)
        row.true_nevd, row.true_piob, row.policy_optimality = truth(policy)
        row.true_value = row.true_piob if measures_improvement else row.true_nevd
        row.truth_raised_starts, row.truth_raise = raised
        row.truth_passes, row.truth_last_gain = final.passes, final.last_gain
