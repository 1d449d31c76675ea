"""Local quadratic models of a trajectory's value: ``V*_w`` polished per reward vector.

For a reward vector ``w`` and a start, let ``u₀`` be the library's best trajectory under ``w``
(its knots in unit coordinates of the control range, ``u = (x − low) / (high − low)``) and let
its ``M`` nearest library neighbours lie within radius ``r``. A least-squares fit to their values
gives the model

    v(u₀ + r·d) = w·φ ≈ c + gᵀd + ½ dᵀHd,        ‖d‖ ≤ 1,

and its maximizer in that trust region (Moré & Sorensen, 1983): ``d(μ) = (μI − H)⁻¹g`` with the
smallest ``μ ≥ max(0, λ_max(H))`` for which ``‖d(μ)‖ ≤ 1``. The proposals ``u₀ + t·r·d`` (for a
few shares ``t``) are *simulated* and join the library; ``V*`` is the library maximum again. So the
model only proposes where to look: it never stands in for a simulation, and it can only raise
``V*`` (which must never be underestimated). Rounds repeat the fit around the new best.

Why it works where it does: a sample's optimum usually lies in the basin of the library's best
trajectory, a short way off (the planner's CMA-ES populations, kept in the library, fill that
neighbourhood), and there the value is smooth in the knots. It costs one rollout per proposal,
against hundreds for a search per sample. It cannot find a basin the library has not seen.
"""

from __future__ import annotations

import numpy as np

from mjsuff.scenes.library import TrajectoryLibrary
from mjsuff.scenes.scene import Scene

#: Shares of the trust-region step that are simulated per sample and start.
STEP_SHARES = (0.5, 1.0)
#: Bisection steps for the trust-region multiplier μ.
BISECTIONS = 60


def quadratic_design(d: np.ndarray) -> np.ndarray:
    """Regressors ``(..., M, 1 + n + n(n+1)/2)`` of a full quadratic in ``d`` ``(..., M, n)``:
    1, the coordinates, and the products ``d_a d_b`` for ``a ≤ b``."""
    a, b = np.triu_indices(d.shape[-1])
    return np.concatenate([np.ones((*d.shape[:-1], 1)), d, d[..., a] * d[..., b]], axis=-1)


def quadratic_terms(coef: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gradient ``g`` ``(B, n)`` and Hessian ``H`` ``(B, n, n)`` at 0 of fitted quadratics with
    coefficients ``coef`` ``(B, 1 + n + n(n+1)/2)`` (``quadratic_design``'s order)."""
    a, b = np.triu_indices(n)
    upper = np.zeros((len(coef), n, n))
    upper[:, a, b] = coef[:, 1 + n :]
    return coef[:, 1 : 1 + n], upper + np.swapaxes(upper, 1, 2)  # d_a² → H_aa = 2·coef


def trust_region_step(g: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Maximizers ``d`` ``(B, n)`` of ``gᵀd + ½ dᵀHd`` over ``‖d‖ ≤ 1``, for ``g`` ``(B, n)``
    and symmetric ``H`` ``(B, n, n)`` (module docs; the hard case is left to the bisection's
    limit, which is a step of length about 1 along the gradient's part)."""
    lam, vec = np.linalg.eigh(h)
    gv = np.einsum("bji,bj->bi", vec, g)  # g in the eigenbasis

    def length(mu: np.ndarray) -> np.ndarray:
        return np.linalg.norm(gv / (mu[:, None] - lam), axis=1)

    low = np.maximum(lam.max(axis=1), 0.0) + 1e-12
    high = low + np.linalg.norm(g, axis=1) + 1.0  # ‖d(high)‖ < 1
    inside = length(low) <= 1.0  # the unconstrained maximizer (H < 0) lies in the region
    for _ in range(BISECTIONS):
        mid = (low + high) / 2
        long = length(mid) > 1.0
        low = np.where(long, mid, low)
        high = np.where(long, high, mid)
    mu = np.where(inside, np.maximum(lam.max(axis=1), 0.0) + 1e-12, high)
    step = np.einsum("bij,bj->bi", vec, gv / (mu[:, None] - lam))
    norm = np.linalg.norm(step, axis=1, keepdims=True)
    return np.where(norm > 1.0, step / np.maximum(norm, 1e-300), step)


def propose(units: np.ndarray, values: np.ndarray, neighbours: int) -> np.ndarray:
    """Proposals ``(B, len(STEP_SHARES), n)`` in unit coordinates, one set per reward vector.

    Args:
        units: The library's knots from one start, flattened to unit coordinates ``(L, n)``.
        values: Their values ``(B, L)`` under ``B`` reward vectors.
        neighbours: ``M``, library entries the model of each reward vector is fitted to.
    """
    b, n = len(values), units.shape[1]
    size = 1 + n + n * (n + 1) // 2
    m = min(neighbours, len(units))
    if m < size + 1:
        return np.empty((b, 0, n))
    centre = units[values.argmax(axis=1)]  # (B, n)
    # ‖u − c‖² without the (B, L, n) differences (the library holds tens of thousands of entries)
    d2 = np.maximum(
        (units**2).sum(axis=1)[None] - 2.0 * centre @ units.T + (centre**2).sum(axis=1)[:, None], 0.0
    )  # (B, L)
    near = np.argpartition(d2, m - 1, axis=1)[:, :m]
    radius = np.sqrt(np.take_along_axis(d2, near, axis=1).max(axis=1))  # (B,)
    ok = radius > 0
    d = (units[near] - centre[:, None]) / np.where(ok, radius, 1.0)[:, None, None]
    x = quadratic_design(d)  # (B, M, size)
    y = np.take_along_axis(values, near, axis=1)
    y = y - y.mean(axis=1, keepdims=True)  # better conditioned; the constant is not used
    xtx = np.einsum("bmi,bmj->bij", x, x)
    ridge = 1e-9 * np.trace(xtx, axis1=1, axis2=2)[:, None, None] * np.eye(size)
    coef = np.linalg.solve(xtx + ridge, np.einsum("bmi,bm->bi", x, y)[..., None])[..., 0]
    g, h = quadratic_terms(coef, n)
    step = trust_region_step(g, h) * radius[:, None]
    shares = np.asarray(STEP_SHARES)[None, :, None]
    return np.clip(centre[:, None] + shares * step[:, None], 0.0, 1.0)[ok]


def polish(
    scene: Scene, library: TrajectoryLibrary, starts: np.ndarray, weights: np.ndarray, neighbours: int
) -> int:
    """One round: for each of ``starts`` ``(B,)`` (library starts) and reward vectors ``weights``
    ``(B, k)``, fit the model around the library's best, simulate its proposals and add them to
    the library. Returns the rollouts simulated."""
    spline = scene.spline
    low, span = spline.low, spline.high - spline.low
    knots, where = [], []
    for start in np.unique(starts):
        rows = np.flatnonzero(starts == start)
        features, entries = library.arrays(int(start))
        if not len(features):
            continue
        units = ((entries - low) / span).reshape(len(entries), -1)
        proposals = propose(units, weights[rows] @ features.T, neighbours)
        proposals = proposals.reshape(-1, *spline.shape) * span + low
        knots.append(proposals)
        where.append(np.full(len(proposals), start))
    if not knots or not sum(len(k) for k in knots):
        return 0
    knots_ = np.concatenate(knots)
    where_ = np.concatenate(where)
    _, features = scene.simulate(scene.all_starts[where_], knots_)
    for start in np.unique(where_):
        rows = where_ == start
        library.add(int(start), features[rows], knots_[rows])
    return len(knots_)
