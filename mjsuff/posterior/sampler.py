"""Metropolis sampling of reward weights on the unit sphere (Bayesian IRL, paper §3.1.2, App. B).

Several chains run side by side, so every step evaluates the likelihood for a batch of proposals.
Proposals are Gaussian perturbations renormalized to the sphere (symmetric, so the Metropolis ratio
is the likelihood ratio under the uniform prior). Each chain adapts its step size during burn-in
with the paper's rule ``σ ← σ + σ/√(i+1)·(r − r*)`` (``r`` the chain's acceptance rate so far,
``r*`` the target): steps grow while too many proposals are accepted and shrink while too few are.
The step is frozen after burn-in so the kept samples come from a fixed Markov kernel.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from mjsuff.posterior.diagnostics import split_rhat
from mjsuff.sphere import normalize, random_unit_vectors

LogLikelihood = Callable[[np.ndarray], np.ndarray]
"""Maps a batch of weights ``(N, k)`` to log-likelihoods ``(N,)``."""


class SamplerConfig(BaseModel):
    """MCMC settings (paper defaults: 500 samples, start step 0.5, 40% target acceptance)."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True, allow_inf_nan=False)

    num_samples: int = Field(500, ge=10, description="posterior samples kept over all chains")
    chains: int = Field(20, ge=2, description="independent chains run side by side")
    burn_in: int = Field(75, ge=0, description="steps per chain discarded (step adapts here)")
    thin: int = Field(1, ge=1, description="keep every thin-th step after burn-in")
    step_size: float = Field(0.5, gt=0.0, le=10.0, description="initial proposal standard deviation")
    target_acceptance: float = Field(0.4, gt=0.0, lt=1.0, description="adaptation target")
    init_candidates: int = Field(4, ge=1, description="start candidates per chain; it takes the best")
    stranded_gap: float = Field(10.0, gt=0.0, description="log-likelihood gap that restarts a chain")


@dataclass(frozen=True)
class Posterior:
    """Samples from ``P(w | D)`` and their diagnostics.

    Attributes:
        samples: ``(num_samples, k)`` unit vectors, chains interleaved.
        log_likelihoods: ``(num_samples,)`` log-likelihood of each sample.
        chain_samples: ``(chains, per_chain, k)`` the same samples by chain.
        map_weights: Highest-likelihood weights visited (the MAP under the uniform prior).
        map_log_likelihood: Its log-likelihood.
        acceptance_rate: Mean acceptance after burn-in over all chains.
        rhat: Largest split-R̂ over the ``k`` coordinates.
    """

    samples: np.ndarray
    log_likelihoods: np.ndarray
    chain_samples: np.ndarray
    map_weights: np.ndarray
    map_log_likelihood: float
    acceptance_rate: float
    rhat: float


def _checked(ll: np.ndarray) -> np.ndarray:
    ll = np.asarray(ll, dtype=float)
    if np.isnan(ll).any() or np.isposinf(ll).any():
        raise FloatingPointError("log-likelihood is NaN or +inf (is beta finite and moderate?)")
    return ll


def sample_posterior(
    log_likelihood: LogLikelihood,
    num_features: int,
    config: SamplerConfig,
    rng: np.random.Generator,
    initial: np.ndarray | None = None,
) -> Posterior:
    """Run ``config.chains`` adaptive Metropolis chains on the sphere in ``R^num_features``.

    Args:
        initial: Optional ``(M, k)`` unit vectors to start from (e.g. the previous posterior's
            samples when one more demo arrives); each chain's start candidates are drawn from
            them, together with uniform draws.

    At the end of burn-in, a chain whose log-likelihood lies more than ``stranded_gap`` below the
    best chain's is moved to the state of a randomly chosen well-placed chain. This is a
    heuristic against chains stuck in a far tail (1/chains of the samples would come from there
    and inflate the upper quantiles the bounds read); it assumes a state that much less likely is
    not in a broad mode of comparable total mass. Set ``stranded_gap`` very large to disable it.
    """
    c = config.chains
    per_chain = -(-config.num_samples // c)
    steps = config.burn_in + per_chain * config.thin
    # Start each chain at the best of a few candidates: over-dispersed, yet not stranded in a
    # far tail that burn-in would have to climb out of.
    m = config.init_candidates
    pool = random_unit_vectors(rng, c * m, num_features)
    if initial is not None and len(initial):
        take = rng.integers(len(initial), size=c * m)
        use = rng.random(c * m) < 0.75
        pool[use] = normalize(np.asarray(initial, dtype=float)[take[use]])
    pool_ll = _checked(log_likelihood(pool)).reshape(c, m)
    pick = pool_ll.argmax(axis=1)
    w = pool.reshape(c, m, num_features)[np.arange(c), pick]
    ll = pool_ll[np.arange(c), pick]
    sigma = np.full(c, config.step_size)
    accepted = np.zeros(c)
    accepted_after_burn = 0
    best = int(np.argmax(ll))
    map_w, map_ll = w[best].copy(), float(ll[best])
    kept = np.empty((c, per_chain, num_features))
    kept_ll = np.empty((c, per_chain))
    for t in range(steps):
        proposal = normalize(w + sigma[:, None] * rng.standard_normal((c, num_features)))
        ll_prop = _checked(log_likelihood(proposal))
        accept = np.log(rng.random(c)) < ll_prop - ll
        w = np.where(accept[:, None], proposal, w)
        ll = np.where(accept, ll_prop, ll)
        top = int(np.argmax(ll))
        if ll[top] > map_ll:
            map_w, map_ll = w[top].copy(), float(ll[top])
        if t < config.burn_in:
            accepted += accept
            rate = accepted / (t + 1)
            sigma = sigma + sigma / np.sqrt(t + 1) * (rate - config.target_acceptance)
            sigma = np.clip(sigma, 1e-4, 10.0)
            if t == config.burn_in - 1:
                stranded = ll < ll.max() - config.stranded_gap
                if stranded.any():
                    donors = rng.choice(np.flatnonzero(~stranded), size=int(stranded.sum()))
                    w[stranded], ll[stranded] = w[donors], ll[donors]
                    sigma[stranded] = sigma[donors]
        else:
            accepted_after_burn += int(accept.sum())
            j, r = divmod(t - config.burn_in, config.thin)
            if r == config.thin - 1:
                kept[:, j] = w
                kept_ll[:, j] = ll
    flat = kept.transpose(1, 0, 2).reshape(-1, num_features)[: config.num_samples]
    flat_ll = kept_ll.T.reshape(-1)[: config.num_samples]
    after = max(steps - config.burn_in, 1) * c
    return Posterior(
        samples=flat,
        log_likelihoods=flat_ll,
        chain_samples=kept,
        map_weights=map_w,
        map_log_likelihood=map_ll,
        acceptance_rate=accepted_after_burn / after,
        rhat=split_rhat(kept),
    )
