"""Benchmark: one sufficiency check on the 5x5 gridworld (issues #2, #15).

One check = MCMC posterior from 10 demos (500 samples, the shipped scenario's sampler: until it
has converged), π_MAP, nEVD for every sample, the α-VaR bound (index for the draws' effective
size); the worlds are the shipped scenario's. mjsuff's engine is timed on fresh instances (cold
policy cache: the honest cost of a first check) and inside the experiment loop's warm state; a
naive reference, written the way the paper's published code works (one proposal at a time, value
iteration in plain Python loops per proposal and per sample), runs in the same process on the
same instance, and the ratio is printed.

    python benchmarks/sufficiency_check.py [--naive-instances 1] [--instances 5]
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from mjsuff.bounds import normalized_evd, policy_values, upper_var_bound
from mjsuff.domains import get_domain
from mjsuff.domains.tabular import TabularDomain
from mjsuff.experiment.scenario import load_scenario
from mjsuff.posterior import sample_posterior

NUM_DEMOS = 10
BETA = 10.0
ALPHA, DELTA = 0.95, 0.05
#: The shipped scenario: its worlds and its sampler (500 samples, 20 chains, until R̂ ≤ 1.01 and
#: ESS ≥ 200).
SCENARIO = load_scenario(Path(__file__).resolve().parent.parent / "scenarios" / "gridworld.toml")
SETTINGS = SCENARIO.sampler()


def make_case(seed: int) -> tuple[TabularDomain, list]:
    rng = np.random.default_rng(seed)
    domain = get_domain("gridworld").make(SCENARIO.domain_params(), rng)
    starts = rng.permutation(domain.pool.size)[:NUM_DEMOS]
    demos = [domain.demonstrate(int(s), rng) for s in starts]
    return domain, demos


def fast_check(domain: TabularDomain, demos: list, seed: int) -> float:
    """One check as ``mjsuff run`` makes it: the sampler until converged (the shipped settings),
    then the bound with the index for the draws' effective size."""
    post = sample_posterior(
        lambda w: domain.log_likelihood(w, demos, BETA),
        domain.num_features,
        SETTINGS,
        np.random.default_rng(seed),
    )
    w = post.samples
    policy = domain.plan(post.map_weights)
    sw = domain.start_weights
    v_opt = domain.optimal_start_values(w) @ sw
    v_robot = policy_values(w, domain.start_feature_expectations(policy), sw)
    v_rand = policy_values(w, domain.random_start_feature_expectations(), sw)
    nevd = normalized_evd(v_opt, v_robot, v_rand)
    return upper_var_bound(nevd, ALPHA, DELTA, ess=post.effective_size(nevd, ALPHA))


# -- naive reference: the paper's code structure, plain Python loops ------------------------------
def naive_values(p, rewards, terminal, gamma, policy=None, eps=1e-4):
    """Iterative Bellman backups in plain loops: optimal values (``policy`` None) or the values
    of ``policy`` (``policy[s]`` a list of action probabilities)."""
    n, a_n = len(rewards), len(p[0])
    v = [0.0] * n
    while True:
        delta = 0.0
        new_v = [0.0] * n
        for s in range(n):
            if terminal[s]:
                new_v[s] = rewards[s]
                continue
            backups = [sum(p[s][a][t] * v[t] for t in range(n) if p[s][a][t]) for a in range(a_n)]
            if policy is None:
                future = max(backups)
            else:
                future = sum(policy[s][a] * backups[a] for a in range(a_n) if policy[s][a])
            new_v[s] = rewards[s] + gamma * future
            delta = max(delta, abs(new_v[s] - v[s]))
        v = new_v
        if delta < eps * (1 - gamma) / gamma:
            return v


def naive_q(p, rewards, terminal, gamma, v):
    n, a_n = len(rewards), len(p[0])
    return [
        [
            rewards[s]
            + (0.0 if terminal[s] else gamma * sum(p[s][a][t] * v[t] for t in range(n) if p[s][a][t]))
            for a in range(a_n)
        ]
        for s in range(n)
    ]


def naive_check(domain: TabularDomain, demos: list, seed: int) -> float:
    rng = np.random.default_rng(seed)
    mdp = domain.mdp
    p = mdp.transitions.tolist()
    phi = mdp.features.tolist()
    terminal = mdp.terminal.tolist()
    gamma, k = mdp.gamma, mdp.num_features
    pairs = [(int(domain.pool[d.start]), d.action) for d in demos]

    def rewards_of(w):
        return [sum(f[i] * w[i] for i in range(k)) for f in phi]

    def log_lik(w):
        r = rewards_of(w)
        q = naive_q(p, r, terminal, gamma, naive_values(p, r, terminal, gamma))
        total = 0.0
        for s, a in pairs:
            top = max(q[s])
            total += BETA * q[s][a] - (BETA * top + math.log(sum(math.exp(BETA * (x - top)) for x in q[s])))
        return total

    # One chain, one proposal at a time, the paper's adaptive step; 500 kept after burn-in/thinning.
    w = rng.standard_normal(k)
    w /= np.linalg.norm(w)
    ll = log_lik(w.tolist())
    best_w, best_ll, sigma, accepted = w, ll, 0.5, 0
    chain = []
    length = 1100  # burn-in 100, thin 2 -> 500 samples
    for i in range(length):
        prop = w + sigma * rng.standard_normal(k)
        prop /= np.linalg.norm(prop)
        ll_prop = log_lik(prop.tolist())
        if math.log(rng.random()) < ll_prop - ll:
            w, ll, accepted = prop, ll_prop, accepted + 1
            if ll > best_ll:
                best_w, best_ll = w, ll
        sigma += sigma / math.sqrt(i + 1) * (accepted / (i + 1) - 0.4)
        chain.append(w)
    samples = chain[100::2]
    r_map = rewards_of(best_w.tolist())
    q_map = naive_q(p, r_map, terminal, gamma, naive_values(p, r_map, terminal, gamma))
    n_actions = len(p[0])
    robot = [[1.0 if a == int(np.argmax(q_map[s])) else 0.0 for a in range(n_actions)] for s in range(len(p))]
    uniform = [[1.0 / n_actions] * n_actions for _ in range(len(p))]
    nevd = []
    for w_i in samples:
        r = rewards_of(w_i.tolist())
        v_opt = statistics.fmean(naive_values(p, r, terminal, gamma))
        v_rob = statistics.fmean(naive_values(p, r, terminal, gamma, robot))
        v_rand = statistics.fmean(naive_values(p, r, terminal, gamma, uniform))
        nevd.append((v_opt - v_rob) / (v_opt - v_rand) if v_opt != v_rand else 0.0)
    return upper_var_bound(np.array(nevd), ALPHA, DELTA)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--instances", type=int, default=5, help="instances for the fast engine")
    parser.add_argument("--naive-instances", type=int, default=1)
    args = parser.parse_args()

    cold, warm, bounds = [], [], []
    for seed in range(args.instances):
        domain, demos = make_case(seed)
        t = time.perf_counter()
        bounds.append(fast_check(domain, demos, seed))
        cold.append(time.perf_counter() - t)
        t = time.perf_counter()
        fast_check(domain, demos, seed + 1000)
        warm.append(time.perf_counter() - t)
    naive_times, naive_bounds = [], []
    for seed in range(args.naive_instances):
        domain, demos = make_case(seed)
        t = time.perf_counter()
        naive_bounds.append(naive_check(domain, demos, seed))
        naive_times.append(time.perf_counter() - t)
    fast_cold = statistics.median(cold[: max(1, args.naive_instances)])
    print(f"gridworld 5x5, {NUM_DEMOS} demos, 500 posterior samples, alpha={ALPHA}, delta={DELTA}")
    print(
        f"mjsuff, fresh instance (cold cache): median {statistics.median(cold):.4f} s "
        f"over {len(cold)} instances (min {min(cold):.4f}, max {max(cold):.4f})"
    )
    print(f"mjsuff, second check on the same instance (warm cache): median {statistics.median(warm):.4f} s")
    if naive_times:
        print(
            f"naive reference: median {statistics.median(naive_times):.2f} s over "
            f"{len(naive_times)} instance(s)"
        )
        print(
            f"speed-up (naive / mjsuff cold, same instances): "
            f"{statistics.median(naive_times) / fast_cold:.0f}x"
        )
    print(
        "bounds (mjsuff):",
        " ".join(f"{b:.3f}" for b in bounds[: args.naive_instances]),
        "| bounds (naive):",
        " ".join(f"{b:.3f}" for b in naive_bounds),
    )


if __name__ == "__main__":
    # As in `mjsuff run`: the matrices are small, BLAS threads only add overhead (and stall
    # badly when another process holds the other core).
    with threadpool_limits(limits=1):
        main()
