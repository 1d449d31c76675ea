"""The candidate sets of the trajectory-level likelihood: what each demo is compared with.

Demo ``j`` from pool start ``s_j`` with features ``φ_j`` has ``P(φ_j | w) = exp(β w·φ_j) /
Σ_{τ ∈ C_j} exp(β w·φ(τ))`` (DESIGN, trajectory-level Bayesian IRL). ``C_j`` is fixed when the demo
is first seen: the demo itself; either (``"library"``) the library's best trajectory from ``s_j``
for each of ``CANDIDATE_DIRECTIONS`` fixed reward directions over the prior's orthant, or
(``"family"``) the demonstrator's own first candidates from ``s_j`` (its coarse path family,
executed: the set a demonstrator that shows its best must have beaten); uniform-random
trajectories from ``s_j``; and the demo's own controls under smooth perturbations
(``mjsuff.scenes.perturbation``), simulated. The demo and its perturbations join the library.

With ``"library"`` the likelihood is misspecified for a demonstrator restricted to a path family:
the library's optima beat its demos under ``w*`` in a direction shared by an instance's demos, so
more demos move the posterior away from ``w*`` (docs/issue-17-history.md, "Why the bound
misses"). The perturbations matter: against planner trajectories alone the likelihood would favour
whatever directions the demo happens to beat the planner in most; against its own neighbours it
favours the directions under which the demo is locally optimal.
"""

from __future__ import annotations

import zlib
from typing import TYPE_CHECKING

import numpy as np

from mjsuff.domain import Demo
from mjsuff.scenes.library import TrajectoryLibrary
from mjsuff.scenes.params import Candidates
from mjsuff.scenes.perturbation import perturb_controls
from mjsuff.scenes.scene import Scene
from mjsuff.sphere import random_negative_unit_vectors

if TYPE_CHECKING:
    from mjsuff.experts.expert import Expert

#: Reward directions (fixed, spread over the prior's orthant) whose library optimum joins a
#: demo's candidate set (``"library"``).
CANDIDATE_DIRECTIONS = 64


class CandidateSets:
    """Each demo's candidate set ``C_j``, built once per demo (module docs).

    Args:
        scene: The instance.
        library: Its trajectory library (evaluation starts first, then the pool).
        expert: The demonstrator (its path family for ``"family"``).
        kind: ``"library"`` or ``"family"``.
        random_features: Uniform-random trajectories' features per library start ``(S + P, R, k)``.
    """

    def __init__(
        self,
        scene: Scene,
        library: TrajectoryLibrary,
        expert: Expert | None,
        kind: Candidates,
        random_features: np.ndarray,
    ) -> None:
        self.scene, self.library, self.expert, self.kind = scene, library, expert, kind
        self.random_features = random_features
        self.pool = np.arange(len(scene.starts), len(scene.all_starts))
        # Fixed, instance-independent directions: they must not draw from the instance's stream.
        self.directions = random_negative_unit_vectors(
            np.random.default_rng(0), CANDIDATE_DIRECTIONS, scene.num_features
        )
        self._sets: dict[bytes, np.ndarray] = {}
        self._family: dict[int, np.ndarray] = {}

    def features(self, demo: Demo) -> np.ndarray:
        """The features ``(M, k)`` of the demo's candidate set, the demo first.

        Raises:
            ValueError: The demo's features are not ``k`` finite numbers.
        """
        phi = np.asarray(demo.data["features"], dtype=float)
        key = _key(demo.start, phi)
        if key not in self._sets:
            k = self.scene.num_features
            if phi.shape != (k,) or not np.isfinite(phi).all():
                raise ValueError(
                    f"demo from pool start {demo.start}: features must be {k} finite numbers, got {phi}"
                )
            s = int(self.pool[demo.start])
            if self.kind == "family":
                alternatives = self.family(s)
            else:
                features, _ = self.library.arrays(s)
                alternatives = features[np.unique(self.library.best(s, self.directions)[1])]
            randoms = self.random_features[s]
            parts = [phi[None], alternatives, randoms[np.isfinite(randoms).all(axis=1)]]
            if "controls" in demo.data:
                controls = np.asarray(demo.data["controls"], dtype=float)
                near = self._perturbed(s, controls, np.random.default_rng(zlib.crc32(key)))
                parts.append(near)
                self.library.add_features(s, near)
            self._sets[key] = np.concatenate(parts)
            self.library.add_features(s, phi)
        return self._sets[key]

    def choose(self, demo: Demo, pick: int) -> Demo:
        """The demo a demonstrator would have given had it chosen candidate ``pick`` of ``demo``'s
        set: its candidate set is the same set, the chosen one first (for likelihood checks that
        draw demos from the likelihood itself, e.g. ``benchmarks/posterior_coverage.py``)."""
        candidates = self.features(demo)
        if not 0 <= pick < len(candidates):
            raise IndexError(f"pick {pick}: the candidate set has {len(candidates)} candidates")
        phi = candidates[pick]
        chosen = np.vstack([phi[None], np.delete(candidates, pick, axis=0)])
        stored = self._sets.setdefault(_key(demo.start, phi), chosen)
        if stored is not chosen and not np.array_equal(stored, chosen):
            raise ValueError(
                f"pick {pick}: a demo from start {demo.start} with these features already has another "
                "candidate set (its likelihood would change)"
            )
        return Demo(start=demo.start, data={"features": phi})

    def family(self, start: int) -> np.ndarray:
        """Features of the demonstrator's first candidates (``Expert.first_candidates``: the
        execution its demo from that start ran) from library start ``start`` ``(M, k)``, those it
        could follow; cached per start."""
        if start not in self._family:
            if self.expert is None:
                raise RuntimeError("candidates = 'family' needs the domain's expert")
            done, _ = self.expert.first_candidates(self.scene.all_starts[start])
            features = done.features.reshape(-1, self.scene.num_features)
            self._family[start] = features[np.isfinite(features).all(axis=1)]
        return self._family[start]

    def _perturbed(self, start: int, controls: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Features of smooth perturbations of ``controls`` ``(T, nu)``, simulated from library
        start ``start``; diverged ones dropped."""
        batch = perturb_controls(self.scene.spline, controls, rng)
        starts = np.repeat(self.scene.all_starts[start][None], len(batch), axis=0)
        _, features = self.scene.simulate_controls(starts, batch)
        return features[np.isfinite(features).all(axis=1)]


def _key(start: int, phi: np.ndarray) -> bytes:
    """A demo's cache key: its pool start and its features, bit for bit."""
    return np.int64(start).tobytes() + np.asarray(phi, dtype=float).tobytes()
