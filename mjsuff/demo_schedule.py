"""The passive demo schedule: which pool starts are demonstrated, in what order, and which demos
are poor.

The demonstrator picks pool starts uniformly without repeats (a shuffled order of the pool). For
each demo in turn it first draws whether the demo is poor (probability ``noise_fraction``, the
noise ablation) and then gives the demo, from the same generator. A replicate's schedule comes from
its own seed streams (``selection`` for the order, ``demos`` for the rest; ``mjsuff.seeds``): the
run, demo generation (``mjsuff demos``), saved demo sets and β calibration all read it here, so a
saved set holds exactly the demos a run of the same scenario and seed is shown.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mjsuff.seeds import stream_rng


def demo_budget(max_demos: int | None, pool_size: int) -> int:
    """Demos a replicate is shown: ``max_demos`` (``None``: the whole pool), at most the pool."""
    return min(max_demos or pool_size, pool_size)


@dataclass
class DemoSchedule:
    """One replicate's passive demo schedule.

    Attributes:
        order: ``(P,)`` the pool entries in the order they are demonstrated (a permutation).
        budget: Demos the replicate is shown (``demo_budget``).
        noise_fraction: Probability that a demo is poor.
        rng: The demos' generator: each demo's poor draw, then the demo's own randomness.
    """

    order: np.ndarray
    budget: int
    noise_fraction: float
    rng: np.random.Generator

    @classmethod
    def draw(
        cls,
        pool_size: int,
        max_demos: int | None,
        noise_fraction: float,
        order_rng: np.random.Generator,
        demo_rng: np.random.Generator,
    ) -> DemoSchedule:
        """A schedule whose order is drawn from ``order_rng`` and whose demos use ``demo_rng``."""
        order = order_rng.permutation(pool_size)
        return cls(order, demo_budget(max_demos, pool_size), noise_fraction, demo_rng)

    @classmethod
    def of_replicate(
        cls, seed: int, replicate: int, pool_size: int, max_demos: int | None, noise_fraction: float
    ) -> DemoSchedule:
        """Replicate ``replicate``'s schedule, from its ``selection`` and ``demos`` streams."""
        return cls.draw(
            pool_size,
            max_demos,
            noise_fraction,
            stream_rng(seed, replicate, "selection"),
            stream_rng(seed, replicate, "demos"),
        )

    def start(self, i: int) -> int:
        """The pool entry of the ``i``-th demo (0-based; past the pool, the order repeats)."""
        return int(self.order[i % len(self.order)])

    def passive_starts(self) -> np.ndarray:
        """The pool entries a passive replicate demonstrates, in order ``(budget,)``."""
        return self.order[: self.budget]

    def next_is_poor(self) -> bool:
        """Whether the next demo is poor (draws from ``rng``; call once per demo, before it)."""
        return bool(self.rng.random() < self.noise_fraction)
