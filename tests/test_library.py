"""The per-start trajectory library (mjsuff.scenes.library): V*'s lower bound for many rewards."""

import numpy as np

from mjsuff.scenes import library
from mjsuff.scenes.library import TrajectoryLibrary


def filled_library(rng: np.random.Generator) -> TrajectoryLibrary:
    lib = TrajectoryLibrary(2, 3, (2, 1))
    for _ in range(3):  # several batches: the library packs them on first use
        lib.add(0, rng.standard_normal((400, 3)), rng.standard_normal((400, 2, 1)))
    lib.add_features(0, rng.standard_normal((5, 3)))
    return lib


def test_best_is_the_maximum_over_every_entry_and_feature_only_ones_count_for_value():
    rng = np.random.default_rng(0)
    lib = filled_library(rng)
    weights = rng.standard_normal((30, 3))
    features, _ = lib.arrays(0)
    value, index = lib.best(0, weights)
    np.testing.assert_array_equal(index, (weights @ features.T).argmax(axis=1))
    np.testing.assert_allclose(value, (weights @ features.T).max(axis=1))
    extra = (weights @ lib._extra[0].T).max(axis=1)
    np.testing.assert_allclose(lib.best_value(0, weights), np.maximum(value, extra))
    assert (lib.best(1, weights)[1] == -1).all()  # an empty start has no best entry


def test_best_scores_a_large_batch_in_slices_with_the_same_answer(monkeypatch):
    """A long replicate's library holds hundreds of thousands of entries per start; ``best``
    bounds its product's memory by slicing the weights, and the answer must not change."""
    rng = np.random.default_rng(1)
    lib = filled_library(rng)
    weights = rng.standard_normal((50, 3))
    whole = lib.best(0, weights)
    monkeypatch.setattr(library, "MAX_PRODUCT", 3000)  # 2 weights per slice of 1,200 entries
    sliced = lib.best(0, weights)
    np.testing.assert_array_equal(whole[0], sliced[0])
    np.testing.assert_array_equal(whole[1], sliced[1])
