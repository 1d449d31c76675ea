"""Seed streams: every random draw of a run comes from one named stream of one replicate.

A stream's seed is ``SeedSequence(scenario seed, spawn_key=(replicate, stream id, *key))``, so the
streams of a replicate are independent of each other, of the other replicates and of the order in
which anything runs (backends, resume, saved demos all see the same draws). ``calibration`` is the
calibration stage's own (``mjsuff.experiment.calibration``): its instances come from streams no run
uses.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

Stream = Literal["instance", "demos", "mcmc", "selection", "calibration"]

#: Stream ids in the spawn key; fixed forever (changing one changes every result).
STREAMS: dict[str, int] = {"instance": 0, "demos": 1, "mcmc": 2, "selection": 3, "calibration": 100}


def stream_seed(seed: int, replicate: int, stream: Stream, *key: int) -> np.random.SeedSequence:
    """The seed of stream ``stream`` (sub-keyed by ``key``) of replicate ``replicate``."""
    return np.random.SeedSequence(seed, spawn_key=(replicate, STREAMS[stream], *key))


def stream_rng(seed: int, replicate: int, stream: Stream, *key: int) -> np.random.Generator:
    """A generator on ``stream_seed(seed, replicate, stream, *key)``."""
    return np.random.default_rng(stream_seed(seed, replicate, stream, *key))
