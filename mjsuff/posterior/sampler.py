"""Metropolis sampling of reward weights on the unit sphere (Bayesian IRL, paper §3.1.2, App. B).

**Target.** Several chains run side by side, so every step evaluates the likelihood for a batch.
Each chain walks on ``v ∈ R^k`` with target ``π(v) ∝ L(v/‖v‖)·exp(−‖v‖²/2)``: since ``v/‖v‖`` of a
standard normal ``v`` is uniform on the sphere and independent of ``‖v‖``, the direction
``w = v/‖v‖`` of a draw from ``π`` is a draw from the posterior under the uniform prior. In
``R^k`` proposals need no care for the sphere's geometry.

**Warm-up** (``burn_in`` steps, discarded). The first quarter is a random walk
``v' = v + σ z`` whose scale adapts with the paper's rule ``σ ← σ + σ/√(i+1)·(r − r*)`` (``r``
the chain's acceptance rate so far, ``r*`` the target). After each quarter the independence
proposal ``q`` is refitted to every chain's states of that quarter, and the later quarters jump.

**Jumps.** ``q`` is a mixture: with probability ``1 − DEFENSIVE`` a Gaussian kernel density
estimate on (at most ``MAX_CENTRES``) recent states, bandwidth ``INFLATE ×`` Scott's rule with
their covariance; else the prior ``N(0, I)``, which keeps ``π/q`` bounded, so the chain is
uniformly ergodic and never stalls in a tail the fit missed. A jump is an independent
multiple-try Metropolis step (I-MTM, Martino & Read 2013) with ``TRIES`` candidates. Random-walk
steps are too slow here: with a few demos the posterior is a thin curved ridge (one weight
pinned to ±0.02, another free over most of ``[−1, 1]``), along which a random walk needs
thousands of steps per independent draw; the jumps need one or two. Neither a jump's
candidates nor its pick depend on the chain's state, so a block of steps' candidates (at most
``BLOCK_ROWS``) is drawn and its likelihoods computed in one batch; only the accept test runs
step by step.

**Run until converged.** After warm-up the chains run in rounds with a fixed kernel. The first
round is ``max(FIRST_WINDOW, num_samples / chains × thin)`` steps; each later one is as long as
all the rounds before it, so the *window* — the last round — is the second half of the run and
the first half is discarded as further burn-in. ``q`` is refitted to each round's draws before
the next. The kept draws are the window thinned evenly to ``num_samples / chains`` per chain (the
longer the run, the closer to independent). The run stops when the window's rank-normalized
split-R̂ (every coordinate of ``w``) is at most ``rhat_target`` and the kept draws' bulk- and
tail-ESS are at least ``min_ess`` (default 0.4 × ``num_samples``), or when the next round would
pass ``max_steps`` per chain: then the posterior is returned with ``converged = False``, for the
caller to flag, never silently as converged. R̂ ≤ 1.01 needs about 100 effective draws per chain
whatever the number of chains (``R̂² − 1 ≈ 1/n_eff,chain``), hence the first window's length.

Assumption: a window with R̂ ≤ 1.01 whose chains started over-dispersed is from the stationary
distribution (Vehtari et al. 2021); a mode that no chain, no kernel centre and no prior draw ever
reaches cannot be detected.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from mjsuff.posterior.diagnostics import (
    effective_sizes,
    quantile_ess,
    rank_rhat,
)
from mjsuff.sphere import normalize, random_unit_vectors

LogLikelihood = Callable[[np.ndarray], np.ndarray]
"""Maps a batch of weights ``(N, k)`` to log-likelihoods ``(N,)``."""

#: Share of independence proposals drawn from the prior ``N(0, I)`` rather than the fitted
#: Gaussian: it keeps ``π/q`` bounded (``≤ max L / (DEFENSIVE · Z)``), so the jumps never stall
#: in a tail the fit missed.
DEFENSIVE = 0.05
#: Bandwidth of the kernel density proposal as a multiple of Scott's rule.
INFLATE = 1.3
#: Most kernel centres of the independence proposal.
MAX_CENTRES = 100
#: Candidates per chain in one multiple-try jump.
TRIES = 4
#: Least steps per chain in the first window after warm-up.
FIRST_WINDOW = 150
#: Most candidates evaluated in one likelihood call (bounds the memory of a batch of jumps).
BLOCK_ROWS = 4096


#: Most steps over all chains of one posterior: a posterior that never converges keeps every draw
#: (k + 1 floats each: 0.9 GB at k = 10), which no machine should be asked for more of.
MAX_CHAIN_STEPS = 10_000_000


class SamplerConfig(BaseModel):
    """MCMC settings (paper defaults: 500 samples, start step 0.5, 40% target acceptance) and the
    convergence targets (module docstring)."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True, allow_inf_nan=False)

    num_samples: int = Field(500, ge=10, le=100_000, description="posterior samples kept over all chains")
    chains: int = Field(20, ge=2, le=1_000, description="independent chains run side by side")
    burn_in: int = Field(
        60, ge=0, le=100_000, description="warm-up steps per chain, discarded (proposals adapt here)"
    )
    thin: int = Field(
        1, ge=1, le=1_000, description="least thinning of the kept draws (more when the run is longer)"
    )
    rhat_target: float = Field(
        1.01, gt=1.0, le=2.0, description="converged when rank-normalized split-R̂ is at most this"
    )
    min_ess: float | None = Field(
        None, gt=0.0, description="bulk- and tail-ESS the kept draws need (default: 0.4 × num_samples)"
    )
    max_steps: int = Field(4_000, ge=1, le=1_000_000, description="cap on steps per chain, warm-up included")
    step_size: float = Field(0.5, gt=0.0, le=10.0, description="initial proposal standard deviation")
    target_acceptance: float = Field(0.4, gt=0.0, lt=1.0, description="adaptation target")
    init_candidates: int = Field(
        4, ge=1, le=1_000, description="start candidates per chain; it takes the best"
    )
    stranded_gap: float = Field(10.0, gt=0.0, description="log-likelihood gap that restarts a chain")

    @model_validator(mode="after")
    def _consistent(self) -> SamplerConfig:
        if self.num_samples % self.chains:
            raise ValueError(
                f"num_samples: must be a multiple of chains ({self.chains}) so every "
                f"chain keeps the same number of draws (got {self.num_samples})"
            )
        if self.min_ess is not None and self.min_ess > self.num_samples:
            raise ValueError(
                f"min_ess: the kept draws' effective size cannot exceed num_samples "
                f"({self.num_samples}), got {self.min_ess:g}"
            )
        least = self.burn_in + self.num_samples // self.chains * self.thin
        if self.max_steps < least:
            raise ValueError(
                f"max_steps: at least burn_in + num_samples / chains × thin = {least} "
                f"steps per chain are needed, got {self.max_steps}"
            )
        if self.chains * self.max_steps > MAX_CHAIN_STEPS:
            raise ValueError(
                f"max_steps: chains × max_steps = {self.chains * self.max_steps:,} exceeds "
                f"{MAX_CHAIN_STEPS:,} (the draws of a posterior that never converges are kept: "
                f"{self.chains * self.max_steps * 8 * 11 / 1e9:.0f} GB at k = 10)"
            )
        return self

    @property
    def ess_target(self) -> float:
        """``min_ess``, or 0.4 × ``num_samples`` when unset."""
        return self.min_ess if self.min_ess is not None else 0.4 * self.num_samples

    @property
    def per_chain(self) -> int:
        """Draws kept per chain."""
        return self.num_samples // self.chains


@dataclass(frozen=True)
class Posterior:
    """Samples from ``P(w | D)`` and their diagnostics.

    Attributes:
        samples: ``(num_samples, k)`` unit vectors, chains interleaved (sample ``i`` is draw
            ``i // chains`` of chain ``i % chains``).
        log_likelihoods: ``(num_samples,)`` log-likelihood of each sample.
        chain_samples: ``(chains, per_chain, k)`` the same samples by chain.
        map_weights: Highest-likelihood weights evaluated, chain state or candidate (the MAP
            under the uniform prior).
        map_log_likelihood: Its log-likelihood.
        acceptance_rate: Share of jumps after warm-up that moved a chain.
        rhat: Largest rank-normalized split-R̂ of the final window (all its draws).
        ess_bulk: Smallest bulk-ESS of the kept draws over the coordinates.
        ess_tail: Smallest tail-ESS of the kept draws over the coordinates.
        steps: Steps run per chain, warm-up included.
        converged: The targets were met within ``max_steps`` (False: the run hit the cap).
    """

    samples: np.ndarray
    log_likelihoods: np.ndarray
    chain_samples: np.ndarray
    map_weights: np.ndarray
    map_log_likelihood: float
    acceptance_rate: float
    rhat: float
    ess_bulk: float
    ess_tail: float
    steps: int
    converged: bool

    def by_chain(self, values: np.ndarray) -> np.ndarray:
        """Per-sample ``values`` ``(num_samples,)`` regrouped as ``(chains, per_chain)``."""
        chains = self.chain_samples.shape[0]
        return np.asarray(values).reshape(-1, chains).T

    def effective_size(self, values: np.ndarray, prob: float) -> float:
        """Effective sample size of the ``prob``-quantile of per-sample ``values``: their
        chains' quantile ESS, at most the sample count — what an order statistic near that
        quantile gets (``mjsuff.bounds.var_bound``). Non-finite values count as the largest; a
        constant indicator (every draw on one side, so every order statistic is the same)
        counts as independent."""
        values = np.asarray(values, dtype=float)
        finite = np.isfinite(values)
        if not finite.any():
            return float(values.size)
        values = np.where(finite, values, values[finite].max())
        ess = quantile_ess(self.by_chain(values), prob)
        return float(values.size) if math.isnan(ess) else min(ess, float(values.size))


def _checked(ll: np.ndarray) -> np.ndarray:
    ll = np.asarray(ll, dtype=float)
    if np.isnan(ll).any() or np.isposinf(ll).any():
        raise FloatingPointError("log-likelihood is NaN or +inf (is beta finite and moderate?)")
    return ll


class _Chains:
    """The chains' states in ``R^k``, the proposals, and the MAP visited.

    Attributes (per chain): ``v`` the state, ``ll`` its log-likelihood, ``lq`` its log density
    under the independence proposal ``q``, ``sigma`` the random walk's scale.
    """

    def __init__(
        self,
        log_likelihood: LogLikelihood,
        w: np.ndarray,
        ll: np.ndarray,
        step_size: float,
        rng: np.random.Generator,
    ) -> None:
        c, k = w.shape
        self.log_likelihood, self.rng = log_likelihood, rng
        self.v = w * np.sqrt(rng.chisquare(k, size=c))[:, None]
        self.ll = ll
        self.lq = np.zeros(c)
        self.sigma = np.full(c, step_size)
        self.fitted = False
        best = int(np.argmax(ll))
        self.map_w, self.map_ll = w[best].copy(), float(ll[best])

    def advance(self, steps: int) -> tuple[np.ndarray, np.ndarray, int]:
        """``steps`` steps of every chain with the current kernel: jumps once ``q`` is fitted,
        else random-walk steps at the current scales (no adaptation).

        Returns the chains' states ``(chains, steps, k)``, their log-likelihoods
        ``(chains, steps)`` and how many chain-steps moved.
        """
        if not self.fitted:
            states, lls, moved = [], [], 0
            for _ in range(steps):
                moved += int(self.step().sum())
                states.append(self.v)
                lls.append(self.ll)
            return np.stack(states, axis=1), np.stack(lls, axis=1), moved
        block = max(1, BLOCK_ROWS // (len(self.v) * TRIES))
        parts = [self.jumps(min(block, steps - t)) for t in range(0, steps, block)]
        return (
            np.concatenate([p[0] for p in parts], axis=1),
            np.concatenate([p[1] for p in parts], axis=1),
            sum(p[2] for p in parts),
        )

    def step(self) -> np.ndarray:
        """One random-walk Metropolis step ``v' = v + σz`` (symmetric: the ratio is ``π``'s)."""
        c, k = self.v.shape
        proposal = self.v + self.sigma[:, None] * self.rng.standard_normal((c, k))
        ll_prop = _checked(self.log_likelihood(normalize(proposal)))
        with np.errstate(invalid="ignore"):  # −inf − (−inf): both outside the support, stay
            log_ratio = ll_prop - self.ll + 0.5 * (_sq(self.v) - _sq(proposal))
        accept = np.log(self.rng.random(c)) < log_ratio
        self.v = np.where(accept[:, None], proposal, self.v)
        self.ll = np.where(accept, ll_prop, self.ll)
        self._track_map(self.v, self.ll)
        return accept

    def jumps(self, steps: int) -> tuple[np.ndarray, np.ndarray, int]:
        """``steps`` independent multiple-try Metropolis steps (I-MTM) of every chain from ``q``.

        At each step each chain draws ``TRIES`` candidates ``y_i ~ q`` with importance weights
        ``ω(y) = π(y)/q(y)``, picks ``y_j`` with probability ``ω(y_j)/Σω`` and moves there with
        probability ``min(1, Σ_i ω(y_i) / (Σ_i ω(y_i) − ω(y_j) + ω(v)))``, which leaves ``π``
        invariant. The candidates and the pick do not depend on the chain's state, so every
        step's candidates are drawn and evaluated in one batch; only the accept test runs step
        by step. Returns as :meth:`advance`.
        """
        c, k = self.v.shape
        m, rng = TRIES, self.rng
        n = steps * c * m
        z = rng.standard_normal((n, k))
        centre = self.centres[rng.integers(len(self.centres), size=n)]
        fitted = rng.random(n) >= DEFENSIVE
        y = np.where(fitted[:, None], centre + z @ self.spread.T, z)
        lq = self._log_q(y)
        ll = _checked(self.log_likelihood(normalize(y)))
        self._track_map(y, ll)
        log_w = (ll - 0.5 * _sq(y) - lq).reshape(steps, c, m)
        top = log_w.max(axis=2)
        top = np.where(np.isfinite(top), top, 0.0)  # every candidate at log-likelihood −inf
        weight = np.exp(log_w - top[..., None])
        total = weight.sum(axis=2)
        below = weight.cumsum(axis=2) < (rng.random((steps, c)) * total)[..., None]
        pick = np.minimum(below.sum(axis=2), m - 1)
        at = np.arange(steps)[:, None], np.arange(c)[None, :]
        rest = total - weight[(*at, pick)]
        chosen = (at[0] * c + at[1]) * m + pick  # the picked candidate's row in y
        chosen_log_w = log_w[(*at, pick)]
        u = rng.random((steps, c))
        # Rows of (current states, candidates): a chain's state is a row index.
        here = np.arange(c)
        here_log_w = self.ll - 0.5 * _sq(self.v) - self.lq
        states = np.empty((steps, c), dtype=np.intp)
        moved = 0
        for t in range(steps):
            # ω(v) relative to the candidates' largest weight; huge means "stay" (no overflow).
            ratio = np.exp(np.minimum(here_log_w - top[t], 700.0))
            move = u[t] * (rest[t] + ratio) < total[t]
            here = np.where(move, c + chosen[t], here)
            here_log_w = np.where(move, chosen_log_w[t], here_log_w)
            states[t] = here
            moved += int(move.sum())
        rows_v = np.concatenate([self.v, y])
        rows_ll = np.concatenate([self.ll, ll])
        rows_lq = np.concatenate([self.lq, lq])
        self.v, self.ll, self.lq = rows_v[here], rows_ll[here], rows_lq[here]
        return rows_v[states.T], rows_ll[states.T], moved

    def _track_map(self, v: np.ndarray, ll: np.ndarray) -> None:
        """Keep the highest-likelihood point of ``v`` (rows) if it beats the best so far."""
        top = int(np.argmax(ll))
        if ll[top] > self.map_ll:
            self.map_w, self.map_ll = normalize(v[top]), float(ll[top])

    def _log_q(self, v: np.ndarray) -> np.ndarray:
        """Log density (up to a constant) of ``q`` at each row of ``v``."""
        zv = v @ self.whiten.T
        d2 = _sq(zv)[:, None] + self.centres_norm2[None] - 2.0 * zv @ self.centres_white.T
        top = -0.5 * d2.min(axis=1)
        kde = top + np.log(np.exp(-0.5 * d2 - top[:, None]).sum(axis=1)) - self.log_norm
        return np.logaddexp(np.log1p(-DEFENSIVE) + kde, np.log(DEFENSIVE) - 0.5 * _sq(v))

    def fit(self, recent: np.ndarray) -> None:
        """Fit ``q`` to ``recent`` states ``(chains, steps, k)`` (module docstring)."""
        k = recent.shape[-1]
        flat = recent.reshape(-1, k)
        if len(flat) > MAX_CENTRES:
            flat = flat[np.linspace(0, len(flat) - 1, MAX_CENTRES).astype(int)]
        root = np.linalg.cholesky(np.cov(flat.T) + 1e-6 * np.eye(k))
        self.spread = INFLATE * len(flat) ** (-1.0 / (k + 4)) * root
        self.whiten = np.linalg.inv(self.spread)
        self.centres = flat.copy()
        self.centres_white = flat @ self.whiten.T
        self.centres_norm2 = _sq(self.centres_white)
        self.log_norm = math.log(len(flat)) + float(np.log(np.diag(self.spread)).sum())
        self.fitted = True
        self.lq = self._log_q(self.v)


def _sq(x: np.ndarray) -> np.ndarray:
    """Squared norm of each row."""
    return np.einsum("ck,ck->c", x, x)


def _initial_states(
    log_likelihood: LogLikelihood,
    num_features: int,
    config: SamplerConfig,
    rng: np.random.Generator,
    initial: np.ndarray | None,
) -> tuple[np.ndarray, np.ndarray]:
    """Each chain starts at the best of a few candidates: over-dispersed, yet not stranded in a
    far tail that warm-up would have to climb out of."""
    c, m = config.chains, config.init_candidates
    pool = random_unit_vectors(rng, c * m, num_features)
    if initial is not None and len(initial):
        take = rng.integers(len(initial), size=c * m)
        use = rng.random(c * m) < 0.75
        pool[use] = normalize(np.asarray(initial, dtype=float)[take[use]])
    pool_ll = _checked(log_likelihood(pool)).reshape(c, m)
    pick = pool_ll.argmax(axis=1)
    return pool.reshape(c, m, num_features)[np.arange(c), pick], pool_ll[np.arange(c), pick]


def _warm_up(chains: _Chains, config: SamplerConfig) -> None:
    """``burn_in`` steps (module docstring); then chains stranded far below the best move to a
    good one."""
    c, k = chains.v.shape
    quarter = max(config.burn_in // 4, 1)
    accepted = np.zeros(c)
    for start in range(0, config.burn_in, quarter):
        length = min(quarter, config.burn_in - start)
        if chains.fitted:
            recent = chains.advance(length)[0]
        else:  # the adaptive random walk, step by step
            recent = np.empty((c, length, k))
            for t in range(start, start + length):
                accepted += chains.step()
                rate = accepted / (t + 1)
                sigma = chains.sigma + chains.sigma / np.sqrt(t + 1) * (rate - config.target_acceptance)
                chains.sigma = np.clip(sigma, 1e-4, 10.0)
                recent[:, t - start] = chains.v
        if length == quarter and quarter * c > 2 * k:
            chains.fit(recent)
    if config.burn_in:
        stranded = chains.ll < chains.ll.max() - config.stranded_gap
        if stranded.any():
            donors = chains.rng.choice(np.flatnonzero(~stranded), size=int(stranded.sum()))
            chains.v[stranded], chains.ll[stranded] = chains.v[donors], chains.ll[donors]
            chains.lq[stranded] = chains.lq[donors]


def _thinned(window: int, keep: int) -> np.ndarray:
    """``keep`` evenly spaced indices of a window of ``window`` draws, ending at its last."""
    return window - 1 - (np.arange(keep)[::-1] * (window / keep)).astype(int)


def sample_posterior(
    log_likelihood: LogLikelihood,
    num_features: int,
    config: SamplerConfig,
    rng: np.random.Generator,
    initial: np.ndarray | None = None,
    until_converged: bool = True,
) -> Posterior:
    """Run ``config.chains`` adaptive Metropolis chains on the sphere in ``R^num_features``.

    Args:
        initial: Optional ``(M, k)`` unit vectors to start from (e.g. the previous posterior's
            samples when one more demo arrives); each chain's start candidates are drawn from
            them, together with uniform draws.
        until_converged: False runs a single round of ``num_samples / chains × thin`` steps after
            warm-up whatever the diagnostics say (for callers that only need the MAP).

    At the end of warm-up, a chain whose log-likelihood lies more than ``stranded_gap`` below the
    best chain's is moved to the state of a randomly chosen well-placed chain (a head start out of
    a far tail; it happens in the discarded warm-up, so the kept draws' distribution does not
    depend on it). Set ``stranded_gap`` very large to disable it.
    """
    c, k, per_chain = config.chains, num_features, config.per_chain
    chains = _Chains(
        log_likelihood, *_initial_states(log_likelihood, k, config, rng, initial), config.step_size, rng
    )
    _warm_up(chains, config)
    # The first round is at least FIRST_WINDOW steps: R̂ of a shorter window is mostly noise.
    round_length = per_chain * config.thin
    if until_converged:
        round_length = min(max(round_length, FIRST_WINDOW), config.max_steps - config.burn_in)
    capacity = round_length
    draws = np.empty((c, capacity, k))
    draws_ll = np.empty((c, capacity))
    done = accepted = 0
    while True:
        if capacity < done + round_length:
            capacity = done + round_length
            draws = np.concatenate([draws, np.empty((c, capacity - draws.shape[1], k))], axis=1)
            draws_ll = np.concatenate([draws_ll, np.empty((c, capacity - draws_ll.shape[1]))], axis=1)
        states, states_ll, moved = chains.advance(round_length)
        draws[:, done : done + round_length], draws_ll[:, done : done + round_length] = states, states_ll
        accepted += moved
        done += round_length
        first = 0 if done == round_length else done // 2
        keep = first + _thinned(done - first, per_chain)
        kept = normalize(draws[:, keep])
        if not until_converged:
            rhat, (ess_bulk, ess_tail), converged = math.nan, (math.nan, math.nan), False
            break
        rhat = rank_rhat(normalize(draws[:, first:done]))
        # Double the post-warm-up run (each round as long as everything before it), up to the cap.
        round_length = min(done, config.max_steps - config.burn_in - done)
        if rhat <= config.rhat_target or round_length <= 0:  # the ESS only for a window that can pass
            ess_bulk, ess_tail = effective_sizes(kept)
            converged = rhat <= config.rhat_target and min(ess_bulk, ess_tail) >= config.ess_target
            if converged or round_length <= 0:
                break
        # The next round is the next window: its kernel may adapt to this round's draws.
        chains.fit(draws[:, first:done])
    return Posterior(
        samples=kept.transpose(1, 0, 2).reshape(-1, k),
        log_likelihoods=draws_ll[:, keep].T.reshape(-1),
        chain_samples=kept,
        map_weights=chains.map_w,
        map_log_likelihood=chains.map_ll,
        acceptance_rate=accepted / (done * c),
        rhat=rhat,
        ess_bulk=ess_bulk,
        ess_tail=ess_tail,
        steps=config.burn_in + done,
        converged=bool(converged),
    )
