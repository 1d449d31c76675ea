"""β calibration: the maximum-likelihood fit (``mjsuff.posterior.calibration``), the calibration
stage on scenario instances (``mjsuff.experiment.calibration``) and ``mjsuff calibrate``."""

import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.special import logsumexp

from mjsuff.cli import main
from mjsuff.experiment.calibration import calibrate, calibration_demos
from mjsuff.experiment.replicate import make_instance
from mjsuff.posterior.calibration import BETA_RANGE, CalibrationError, fit_beta, fit_lapse
from tests.conftest import small_scenario

SCENARIOS = Path(__file__).parent.parent / "scenarios"


def choice_log_likelihood(values: np.ndarray, chosen: np.ndarray):
    """``β -> Σ_j log softmax(β v_j)[c_j]`` for choice sets ``values`` ``(n, m)``."""
    rows = np.arange(len(values))
    return lambda beta: float(np.sum(beta * values[rows, chosen] - logsumexp(beta * values, axis=1)))


@pytest.mark.parametrize("beta_true", [2.0, 7.0, 25.0])
def test_fit_recovers_the_beta_that_generated_boltzmann_choices(beta_true):
    rng = np.random.default_rng(11)
    values = rng.uniform(0.0, 1.0, (600, 6))
    p = np.exp(beta_true * values - logsumexp(beta_true * values, axis=1, keepdims=True))
    chosen = np.array([rng.choice(6, p=row) for row in p])
    fit = fit_beta(choice_log_likelihood(values, chosen))
    assert not fit.unbounded and math.isfinite(fit.standard_error)
    # Within 3 standard errors (observed information): a 99.7% interval if the fit is right.
    assert abs(fit.beta - beta_true) < 3 * fit.standard_error
    assert fit.standard_error < 0.25 * beta_true  # 600 choices pin β down


def test_fit_is_the_maximum_of_the_curve():
    rng = np.random.default_rng(2)
    values = rng.normal(size=(50, 4))
    p = np.exp(3.0 * values - logsumexp(3.0 * values, axis=1, keepdims=True))
    chosen = np.array([rng.choice(4, p=row) for row in p])
    curve = choice_log_likelihood(values, chosen)
    fit = fit_beta(curve)
    assert BETA_RANGE[0] < fit.beta < BETA_RANGE[1] and not (fit.unbounded or fit.at_lower)
    grid = np.exp(np.linspace(np.log(BETA_RANGE[0]), np.log(BETA_RANGE[1]), 4001))
    best = max(curve(b) for b in grid)
    # The search stops within 1e-6 in log β of the maximum: its value is within ~1e-8 of it.
    assert fit.log_likelihood >= best - 1e-6
    assert fit.log_likelihood == pytest.approx(curve(fit.beta))


def test_demos_that_are_always_best_fit_no_finite_beta():
    rng = np.random.default_rng(3)
    values = rng.uniform(size=(40, 5))
    fit = fit_beta(choice_log_likelihood(values, values.argmax(axis=1)))
    assert fit.unbounded and fit.beta == BETA_RANGE[1] and math.isinf(fit.standard_error)


def test_demos_no_better_than_their_alternatives_are_flagged_at_the_lower_end():
    rng = np.random.default_rng(4)
    values = rng.uniform(size=(40, 5))
    fit = fit_beta(choice_log_likelihood(values, values.argmin(axis=1)))
    assert fit.at_lower and fit.beta == BETA_RANGE[0] and math.isinf(fit.standard_error)
    assert not fit.unbounded


def test_demos_tied_with_the_best_plateau_and_count_as_unbounded():
    values = np.tile([1.0, 1.0, 0.2, 0.0], (30, 1))  # two equally good choices, always one of them
    fit = fit_beta(choice_log_likelihood(values, np.zeros(30, dtype=int)))
    assert fit.unbounded
    assert fit.log_likelihood == pytest.approx(-30 * math.log(2), abs=1e-6)


def test_bad_range_and_non_finite_likelihood_are_named():
    with pytest.raises(ValueError, match="beta_range"):
        fit_beta(lambda b: -b, (5.0, 1.0))
    with pytest.raises(CalibrationError, match="log-likelihood at β"):
        fit_beta(lambda b: math.nan)


def lapsing_choices(seed: int, beta: float, lapse: float, n: int = 1000, m: int = 6):
    """``(β, ε) -> Σ_j log[(1 − ε) softmax(β v_j)[c_j] + ε/m]`` for ``n`` choices among ``m``
    made by a demonstrator who lapses (a uniform pick) with probability ``lapse``."""
    rng = np.random.default_rng(seed)
    values = rng.uniform(0.0, 1.0, (n, m))
    p = np.exp(beta * values - logsumexp(beta * values, axis=1, keepdims=True))
    chosen = np.array([rng.choice(m, p=row) for row in (1 - lapse) * p + lapse / m])
    rows = np.arange(n)

    def log_likelihood(b: float, e: float) -> float:
        boltzmann = b * values[rows, chosen] - logsumexp(b * values, axis=1)
        uniform = (math.log(e) if e > 0 else -math.inf) - math.log(m)
        return float(np.sum(np.logaddexp(math.log1p(-e) + boltzmann, uniform)))

    return log_likelihood


@pytest.mark.parametrize("lapse_true", [0.0, 0.25])
def test_fit_lapse_recovers_the_rate_and_beta_of_a_lapsing_demonstrator(lapse_true):
    """1000 choices among 6 at β = 10: over 10 seeds ε̂ fell within one grid step (0.025) of the
    truth, β̂ within 11%; the test allows three steps and 20%."""
    fit = fit_lapse(lapsing_choices(12, 10.0, lapse_true))
    assert abs(fit.lapse - lapse_true) <= 0.075 + 1e-9
    assert abs(fit.fit.beta - 10.0) < 2.0
    lapses = [e for e, _ in fit.profile]
    assert lapses == sorted(lapses) and lapses[0] == 0.0 and lapses[-1] == 0.5
    assert fit.fit.log_likelihood == max(ll for _, ll in fit.profile)


def test_fit_lapse_rejects_rates_outside_zero_to_one():
    with pytest.raises(ValueError, match="lapses"):
        fit_lapse(lambda b, e: 0.0, lapses=(0.0, 1.0))
    with pytest.raises(ValueError, match="lapses"):
        fit_lapse(lambda b, e: 0.0, lapses=())


def test_calibration_instances_are_not_the_runs_and_are_seeded():
    scenario = small_scenario(**{"demos.max_demos": 12})
    domain, demos = calibration_demos(scenario, 0)
    assert len(demos) == 12
    runs = [make_instance(scenario, r).true_weights for r in range(8)]
    assert not any(np.allclose(domain.true_weights, w) for w in runs)
    again, _ = calibration_demos(scenario, 0)
    np.testing.assert_array_equal(domain.true_weights, again.true_weights)
    assert calibrate(scenario, 2).to_dict() == calibrate(scenario, 2).to_dict()


def test_optimal_demos_fit_no_finite_beta_and_poor_ones_a_small_one():
    optimal = calibrate(small_scenario(**{"demos.max_demos": 12}), 3)
    assert optimal.pooled.unbounded
    assert all(b == 0 for c in optimal.instances for b in c.beaten_by)  # optimal actions
    noisy = calibrate(small_scenario(**{"demos.max_demos": 12, "demos.noise_fraction": 0.4}), 3)
    assert sum(c.poor_demos for c in noisy.instances) > 0
    # A poor demo is a non-optimal action: some other action beats it; an optimal one, none.
    for c in noisy.instances:
        assert sum(b > 0 for b in c.beaten_by) == c.poor_demos
    assert not noisy.pooled.unbounded and noisy.pooled.beta < 10.0
    # The pooled fit maximizes a sum of concave curves: its β lies between the instances'.
    fits = [c.fit for c in noisy.instances]
    assert min(f.beta for f in fits) - 1e-3 <= noisy.pooled.beta <= max(f.beta for f in fits) + 1e-3
    # Fitting the lapse rate too: its profile includes ε = 0 (the fit above), so it fits at least
    # as well. (Here β̂ is small enough that a Boltzmann choice already looks like a lapse: ε̂ = 0.)
    lapsed = calibrate(
        small_scenario(**{"demos.max_demos": 12, "demos.noise_fraction": 0.4}), 3, fit_lapse=True
    )
    assert lapsed.profile is not None and lapsed.profile.profile[0][0] == 0.0
    assert lapsed.profile.profile[0][1] == pytest.approx(noisy.pooled.log_likelihood, abs=1e-9)
    assert lapsed.pooled.log_likelihood >= noisy.pooled.log_likelihood - 1e-12
    assert lapsed.to_dict()["lapse_fitted"] and len(lapsed.to_dict()["lapse_profile"]) == 21


TINY_SCENE = [
    "--set",
    "domain.params.eval_starts=3",
    "--set",
    "demos.max_demos=3",
    "--set",
    "domain.params.planning.planner.iterations=4",
    "--set",
    "domain.params.planning.seed_directions=1",
]


def test_calibrate_cli_on_the_reacher_ranks_demos_against_their_candidates(tmp_path, capsys):
    out = tmp_path / "cal.json"
    code = main(
        [
            "calibrate",
            str(SCENARIOS / "lava_reacher.toml"),
            "--instances",
            "1",
            "--quiet",
            "--json",
            str(out),
            *TINY_SCENE,
        ]
    )
    assert code == 0
    data = json.loads(out.read_text())
    (instance,) = data["instances"]
    assert instance["demos"] == 3 and len(instance["beaten_by"]) == 3
    # A demo some candidates beat (the expert is not optimal under w*) makes β̂ finite; only
    # demos that beat every candidate leave it unbounded.
    beaten = instance["beaten_by"]
    assert all(isinstance(b, int) and b >= 0 for b in beaten)
    assert data["pooled"]["unbounded"] == (max(beaten) == 0)
    if not data["pooled"]["unbounded"]:
        assert 0.0 < data["pooled"]["beta"] < float("inf")
    assert "pooled over 1 instance(s): β̂ = " in capsys.readouterr().out


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--instances", "0"], "--instances: expected a positive number, got 0"),
        (["--json", "{tmp}/x.txt"], "expected a .json file name"),
        (["--json", "{tmp}/missing/x.json"], "missing does not exist"),
        (["--set", "demos.beta=-1"], "demos.beta"),
    ],
)
def test_calibrate_cli_errors_are_one_line_before_work(tmp_path, capsys, args, message):
    args = [a.replace("{tmp}", str(tmp_path)) for a in args]
    assert main(["calibrate", str(SCENARIOS / "gridworld.toml"), *args]) == 2
    captured = capsys.readouterr()
    assert message in captured.err and "Traceback" not in captured.err
    assert len(captured.err.strip().splitlines()) == 1 and captured.out == ""
    assert list(tmp_path.iterdir()) == []
