"""Batched CMA-ES: convergence where a diagonal search struggles, bounds, batching, validation."""

import numpy as np
import pytest

from mjsuff.scenes.cma import BatchedCMAES, reflect


def run(es: BatchedCMAES, objective, generations: int, seed: int = 0) -> np.ndarray:
    """Best value per problem over ``generations`` of ``objective(points (B, P, n)) -> (B, P)``."""
    rng = np.random.default_rng(seed)
    best = np.full(len(es.mean), -np.inf)
    for _ in range(generations):
        y = es.ask(rng)
        values = objective(reflect(y))
        best = np.maximum(best, values.max(axis=1))
        es.tell(y, values)
    return best


def test_reflect_folds_into_the_unit_cube_and_keeps_the_inside():
    y = np.array([-2.3, -0.25, 0.0, 0.4, 1.0, 1.25, 3.6])
    np.testing.assert_allclose(reflect(y), [0.3, 0.25, 0.0, 0.4, 1.0, 0.75, 0.4])


def test_solves_a_rotated_ill_conditioned_quadratic():
    # Condition number 1e4 along rotated axes: a narrow diagonal ridge, which is what a soft
    # touchdown looks like in knot space. The optimum is inside the cube.
    n, b = 8, 4
    rotation, _ = np.linalg.qr(np.random.default_rng(1).standard_normal((n, n)))
    hessian = rotation @ np.diag(10.0 ** np.linspace(0, 4, n)) @ rotation.T
    optimum = np.random.default_rng(2).uniform(0.3, 0.7, (b, n))

    def objective(x):
        d = x - optimum[:, None]
        return -np.einsum("bpi,ij,bpj->bp", d, hessian, d)

    best = run(BatchedCMAES(np.full((b, n), 0.5), 0.2, 12), objective, 400)
    # From about -1e3 at the start; 1e-8 is where float64 round-off in C begins to show.
    assert np.all(best > -1e-8), best


def test_reaches_an_optimum_in_a_corner_without_the_step_size_running_away():
    # A linear objective is best at a corner (every throttle knot off): rejection or clipping at
    # the bounds biases the steps and blows σ up there; reflection does not.
    n, b = 10, 4
    es = BatchedCMAES(np.full((b, n), 0.5), 0.2, 12)
    best = run(es, lambda x: -x.sum(axis=2), 250)
    assert np.all(best > -1e-6), best
    assert np.all(es.sigma < 1e-3), es.sigma


def test_problems_in_a_batch_are_independent():
    # Each problem has its own optimum; each is found.
    n, b = 5, 6
    optimum = np.random.default_rng(3).uniform(0.1, 0.9, (b, n))
    es = BatchedCMAES(np.full((b, n), 0.5), 0.3, 10)
    run(es, lambda x: -((x - optimum[:, None]) ** 2).sum(axis=2), 200)
    np.testing.assert_allclose(reflect(es.mean), optimum, atol=1e-6)


def test_same_seed_same_search():
    def search(seed):
        es = BatchedCMAES(np.full((2, 4), 0.5), 0.2, 8)
        return run(es, lambda x: -(x**2).sum(axis=2), 20, seed=seed), es.mean

    (a, mean_a), (b, mean_b) = search(5), search(5)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(mean_a, mean_b)


@pytest.mark.parametrize(
    ("mean", "sigma", "population", "message"),
    [
        (np.full((1, 3), 0.5), 0.1, 3, "population of at least 4"),
        (np.full((1, 3), 0.5), 0.0, 8, "step size must be > 0"),
        (np.full((1, 3), 1.5), 0.1, 8, "unit cube"),
    ],
)
def test_invalid_settings_are_clear_errors(mean, sigma, population, message):
    with pytest.raises(ValueError, match=message):
        BatchedCMAES(mean, sigma, population)
