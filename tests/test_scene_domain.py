"""The MuJoCo scenes behind the Domain seam (issue #5): trajectory likelihood, V*, baselines, truth.

One small instance per scene (3 evaluation starts, small planning budgets) shared by the module;
the expensive pieces (expert demos, planning) run once.
"""

import copy
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

from mjsuff.domain import TRUTH_SETTLED, Demo
from mjsuff.domains import REGISTRY, get_domain
from mjsuff.experiment.scenario import ScenarioError, load_scenario
from mjsuff.posterior import SamplerConfig, grid_posterior, sample_posterior
from mjsuff.scenes.truth import TRUTH_CLOUD, search_truth
from mjsuff.sphere import random_unit_vectors

SCENES = sorted(n for n, spec in REGISTRY.items() if spec.kind == "scene")
SCENARIOS = Path(__file__).parent.parent / "scenarios"
SMALL_PLANNING = {
    "planner": {"population": 32, "elites": 4, "iterations": 8},
    "refine_groups": 4,
    "refine_rounds": 1,
    "seed_directions": 2,
}
BETA = 10.0


def small_domain(name, seed=3, **settings):
    params = {"eval_starts": 3, "pool_starts": 3, "planning": SMALL_PLANNING, **settings}
    return get_domain(name).make(params, np.random.default_rng(seed))


@pytest.fixture(scope="module", params=SCENES)
def case(request):
    domain = small_domain(request.param)
    rng = np.random.default_rng(4)
    demos = [domain.demonstrate(s, rng) for s in range(3)]
    return domain, demos


def test_candidate_set_holds_the_demo_and_the_demo_joins_the_library(case):
    domain, demos = case
    for demo in demos:
        candidates = domain.candidate_features(demo)
        np.testing.assert_array_equal(candidates[0], demo.data["features"])
        assert len(candidates) > 20 and np.isfinite(candidates).all()
        assert candidates is domain.candidate_features(demo)  # fixed once seen
        w = domain.true_weights
        assert domain.library.best_value(int(domain.pool[demo.start]), w[None])[0] >= (
            w @ demo.data["features"] - 1e-12
        )


def test_a_chosen_candidate_keeps_the_demos_set_and_the_choices_are_a_distribution(case):
    """``CandidateSets.choose``: a demo drawn from the likelihood itself (a coverage check's
    demonstrator) is compared with the same candidates, so its probabilities over every choice
    sum to 1 for any w."""
    domain, demos = case
    candidates = domain.candidate_features(demos[0]).copy()
    w = random_unit_vectors(np.random.default_rng(6), 20, domain.num_features)
    total = np.zeros(len(w))
    for pick in range(len(candidates)):
        chosen = domain.candidate_sets.choose(demos[0], pick)
        own = domain.candidate_features(chosen)
        np.testing.assert_array_equal(own[0], candidates[pick])
        assert sorted(map(tuple, own)) == sorted(map(tuple, candidates))
        total += np.exp(domain.log_likelihood(w, [chosen], BETA))
    np.testing.assert_allclose(total, 1.0, rtol=1e-9)
    with pytest.raises(IndexError, match="the candidate set has"):
        domain.candidate_sets.choose(demos[0], len(candidates))
    # Choosing again is the same demo; another demo from the start cannot take over a chosen set.
    again = domain.candidate_features(domain.candidate_sets.choose(demos[0], 1))
    np.testing.assert_array_equal(again[0], candidates[1])
    other = Demo(start=demos[0].start, data={"features": candidates[0] + 0.01})
    theirs = domain.candidate_features(other)
    shared = next(i for i in range(1, len(theirs)) if (theirs[i] == candidates).all(axis=1).any())
    with pytest.raises(ValueError, match="already has another candidate set"):
        domain.candidate_sets.choose(other, shared)


@pytest.mark.parametrize("name", SCENES)
def test_family_candidates_are_the_demonstrators_own_and_never_beat_its_choice(name):
    """With ``domain.params.candidates = "family"`` (issue #17) a demo is compared with the
    expert's first candidates from its start, which a demonstrator that shows its best has beaten
    under w*: the likelihood's assumption holds by construction (up to its random perturbations).
    The scene's settings reach the domain through its parameters alone (issue #18)."""
    expert = {"refine_rounds": 1, "refine_candidates": 8}  # refining only improves on the family
    fresh = small_domain(
        name, candidates="family", unchanged_tolerance=0.2, match_tolerance=0.3, expert=expert
    )
    assert fresh.candidates == "family"
    assert (fresh.unchanged_tolerance, fresh.match_tolerance) == (0.2, 0.3)
    assert fresh.expert.settings.refine_candidates == 8
    w = fresh.true_weights
    for demo in (fresh.demonstrate(s, np.random.default_rng(4)) for s in range(2)):
        candidates = fresh.candidate_features(demo)
        family = fresh.candidate_sets.family(int(fresh.pool[demo.start]))
        assert len(family) >= 5 and np.isfinite(candidates).all()
        np.testing.assert_array_equal(candidates[1 : 1 + len(family)], family)
        assert (family @ w <= candidates[0] @ w + 1e-12).all()


def test_likelihood_is_a_boltzmann_distribution_over_the_candidates(case):
    domain, demos = case
    w = random_unit_vectors(np.random.default_rng(5), 50, domain.num_features)
    ll = domain.log_likelihood(w, demos[:1], BETA)
    candidates = domain.candidate_features(demos[0])
    # Treating each candidate as the demonstrated trajectory must give probabilities summing to 1.
    values = BETA * w @ candidates.T
    probs = np.exp(values - values.max(axis=1, keepdims=True))
    probs /= probs.sum(axis=1, keepdims=True)
    np.testing.assert_allclose(np.exp(ll), probs[:, 0], rtol=1e-10)
    total = domain.log_likelihood(w, demos, BETA)
    np.testing.assert_allclose(total, sum(domain.log_likelihood(w, [d], BETA) for d in demos))
    # With a lapse rate ε, each demo's probability is (1 − ε) of that plus ε over the candidates.
    np.testing.assert_array_equal(domain.choice_counts(demos[:1]), [len(candidates)])
    lapsed = domain.log_likelihood(w, demos[:1], BETA, lapse=0.25)
    np.testing.assert_allclose(np.exp(lapsed), 0.75 * probs[:, 0] + 0.25 / len(candidates), rtol=1e-10)


def test_demos_are_informative_about_the_true_weights(case):
    """Three demos never move the posterior (orthant prior) away from w*, and put at least the
    prior's mass near it. Not "w* is the MAP": a feature the demos never trade off (the lava,
    when it is in no demo's way) stays unidentified, Boltzmann favours the weights under which the
    demos win by the widest margin, and a demonstrator worse than the planner pulls the posterior
    off w*. Measured on these instances (mean angle to w*, prior → posterior; mass of the prior's
    10% nearest w*): reacher 28.6° → 28.6°, 0.11 (the lava unidentified); lander 51.4° → 32.1°,
    0.38; other seeds 49° → 28°, 45° → 29° (reacher), 33° → 28°, 39° → 36° (lander)."""
    domain, demos = case
    w = domain.sample_prior(np.random.default_rng(6), 20_000)
    ll = domain.log_likelihood(w, demos, BETA)
    assert np.all(np.isfinite(ll))
    p = np.exp(ll - ll.max())
    p /= p.sum()
    cosine = w @ domain.true_weights
    angle = np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))
    assert p @ angle <= angle.mean() + 1.0
    near = cosine > np.quantile(cosine, 0.9)  # the prior's 10% nearest w*
    assert p[near].sum() >= 0.1


def test_demos_come_from_a_pool_apart_from_the_evaluation_starts(case):
    domain, demos = case
    scene = domain.scene
    assert domain.pool.tolist() == list(range(3, 6)) and len(scene.all_starts) == 6
    np.testing.assert_array_equal(scene.all_starts[domain.pool], scene.pool_starts)
    # No pool start is an evaluation start, and every demo starts at its pool start.
    assert not (np.abs(scene.pool_starts[:, None] - scene.starts[None]).max(axis=2) < 1e-9).any()
    for demo in demos:
        np.testing.assert_allclose(demo.data["qpos"][0], scene.pool_starts[demo.start], atol=0.05)


def test_prior_is_the_all_negative_orthant(case):
    domain, _ = case
    rng = np.random.default_rng(16)
    draws = domain.sample_prior(rng, 1000)
    assert (draws <= 0).all() and np.allclose(np.linalg.norm(draws, axis=1), 1.0)
    w = random_unit_vectors(rng, 1000, domain.num_features)
    inside = (w <= 0).all(axis=1)
    np.testing.assert_array_equal(np.isfinite(domain.log_prior(w)), inside)
    assert (domain.true_weights <= 0).all()


def test_random_policy_is_random_goal_directed_paths_of_the_expert(case):
    """V_rand comes from the demonstrator's family with random parameters: purposeful (they make
    for the goal: feature 0, the distance to it, is smaller than uniform-random splines'), and
    worse than the plan for w*. (Worth more than uniform-random splines under w* too on the
    reacher; not always on the lander, where aimless set-points often hover far from the keep-out
    zones that goal-directed descents cross.)"""
    domain, _ = case
    w = domain.true_weights
    random_mu = domain.random_start_feature_expectations()
    v_plan = domain.start_feature_expectations(domain.plan(w)) @ w
    aimless = domain._random_features[:3].mean(axis=1)  # uniform-random splines
    assert np.all(v_plan > random_mu @ w)
    assert np.all(random_mu[:, 0] < aimless[:, 0])
    if domain.scene.feature_names[0] == "distance":  # the reacher
        assert np.all(random_mu @ w > aimless @ w)


def test_pool_regrets_are_nonnegative_where_the_library_holds_the_plan(case):
    domain, _ = case
    rng = np.random.default_rng(17)
    w = domain.sample_prior(rng, 50)
    regrets = domain.pool_regrets(w, domain.plan(domain.true_weights))
    assert regrets.shape == (50, 3) and np.all(regrets >= -1e-12)


def test_pool_plans_are_made_only_for_the_entries_asked(case):
    """A held-out demo is matched from its own start alone: the policy is planned from that pool
    entry (once), not from the whole pool; asking for all fills in the rest, keeping the first."""
    domain, _ = case
    policy = domain.plan(domain.sample_prior(np.random.default_rng(21), 1)[0])
    steps = domain.scene.simulator.steps_simulated
    one = domain.pool_features(policy, [1]).copy()
    assert np.isfinite(one[1]).all() and np.isnan(np.delete(one, 1, axis=0)).all()
    assert domain.scene.simulator.steps_simulated > steps
    steps = domain.scene.simulator.steps_simulated
    np.testing.assert_array_equal(domain.pool_features(policy, [1]), one)  # cached: no planning
    assert domain.scene.simulator.steps_simulated == steps
    every = domain.pool_features(policy)
    assert np.isfinite(every).all()
    np.testing.assert_array_equal(every[1], one[1])


def test_optimal_values_never_fall_below_a_planned_policy(case):
    """nEVD ≥ 0 for every sample: V* includes π_MAP's own trajectories."""
    domain, _ = case
    rng = np.random.default_rng(7)
    policy = domain.plan(-np.abs(random_unit_vectors(rng, 1, domain.num_features)[0]))
    w = random_unit_vectors(rng, 100, domain.num_features)
    v_opt = domain.optimal_start_values(w)
    assert np.all(v_opt >= w @ domain.start_feature_expectations(policy).T - 1e-12)


def with_planning(domain, **update):
    """The domain's budgets changed in place: its own, and its V*'s."""
    domain.planning = domain.vstar.planning = domain.planning.model_copy(update=update)


def test_plan_samples_plans_the_top_of_the_tail_once_and_raises_its_v_star(case):
    """``planning.plan_samples`` (issue #17): the samples with the largest nEVD are planned one by
    one with π's budget from every evaluation start; their V* rises above the groups' refinement
    alone, and asking again for the same samples simulates nothing new."""
    domain, _ = case
    rng = np.random.default_rng(11)
    robot = domain.start_feature_expectations(domain.plan(domain.sample_prior(rng, 1)[0]))
    weights = domain.sample_prior(rng, 40)
    base = copy.deepcopy(domain)
    with_planning(base, polish_rounds=0, refine_rounds=0)
    planned = copy.deepcopy(base)
    with_planning(planned, plan_samples=3)
    v_base = base.optimal_start_values(weights, robot=robot)
    top = planned.vstar.tail(weights, robot, 3)
    v_planned = planned.optimal_start_values(weights, robot=robot)
    for start in range(len(domain.scene.starts)):
        assert ((planned.vstar.refined[start] @ weights[top].T).max(axis=0) > 1 - 1e-12).all()
    assert (v_planned[top] >= v_base[top] - 1e-12).all() and (v_planned[top] > v_base[top]).any()
    sizes = [planned.library.size(s) for s in range(len(domain.scene.starts))]
    planned.optimal_start_values(weights, robot=robot)
    assert [planned.library.size(s) for s in range(len(domain.scene.starts))] == sizes


def test_plan_samples_plans_from_the_bound_down(case, monkeypatch):
    """``plan_samples`` plans the samples that can move the bound (issue #17): the one at the
    order statistic the bound takes and those next below it; the samples above it, which stay
    above it however much they rise, are not planned."""
    domain, _ = case
    rng = np.random.default_rng(12)
    robot = domain.start_feature_expectations(domain.plan(domain.sample_prior(rng, 1)[0]))
    weights = domain.sample_prior(rng, 40)
    probe = copy.deepcopy(domain)
    with_planning(probe, polish_rounds=0, refine_rounds=0, plan_samples=3)
    planned = []
    monkeypatch.setattr(probe.vstar, "plan_samples", lambda w: planned.append(w.copy()))
    order = np.argsort(-probe.vstar.nevd(weights, robot), kind="stable")
    probe.optimal_start_values(weights, robot=robot, bound_index=lambda nevd: 30)  # 10th largest
    assert len(planned) == 1
    np.testing.assert_array_equal(planned[0], weights[order[9:12]])


def test_the_decisive_samples_are_planned_by_pi_s_planner_by_default(case):
    domain, _ = case
    assert domain.vstar.planner is domain.planner


def test_the_decisive_samples_are_planned_by_their_own_planner_when_set():
    """``planning.decisive``: the ``plan_samples`` stage plans with that budget from every
    evaluation start (here 4 × 2 CMA-ES rollouts a problem), π keeps its own."""
    decisive = {"iterations": 0, "cma_population": 4, "cma_iterations": 2}
    domain = small_domain("lava_reacher", planning={**SMALL_PLANNING, "decisive": decisive})
    assert domain.vstar.planner.config.budget == 8 and domain.planner.config.budget == 32 * 8
    scene, sim = domain.scene, domain.scene.simulator
    before = sim.steps_simulated
    scene.simulate(scene.starts[:1], scene.initial_knots(scene.starts[:1]))
    horizon = sim.steps_simulated - before
    before = sim.steps_simulated
    domain.vstar.plan_samples(domain.sample_prior(np.random.default_rng(14), 1))
    assert sim.steps_simulated - before == len(scene.starts) * 8 * horizon


def test_the_decisive_samples_get_a_second_search_from_the_same_warm_start_when_set(monkeypatch):
    """``planning.decisive_second``: each ``plan_samples`` problem is searched again with that
    budget (here 4 × 1 CMA-ES rollouts after the first search's 4 × 2), from the warm start the first search
    had, and both searches' rollouts are simulated; unset, there is no second search."""
    decisive = {"iterations": 0, "cma_population": 4, "cma_iterations": 2}
    second = {"iterations": 0, "cma_population": 4, "cma_iterations": 1}
    planning = {**SMALL_PLANNING, "decisive": decisive, "decisive_second": second}
    domain = small_domain("lava_reacher", planning=planning)
    assert domain.vstar.second is not None and domain.vstar.second.config.budget == 4
    assert small_domain("lava_reacher").vstar.second is None
    scene, sim = domain.scene, domain.scene.simulator
    before = sim.steps_simulated
    scene.simulate(scene.starts[:1], scene.initial_knots(scene.starts[:1]))
    horizon = sim.steps_simulated - before
    warm_starts = []
    for planner in (domain.vstar.planner, domain.vstar.second):
        plan = planner.plan
        monkeypatch.setattr(
            planner,
            "plan",
            lambda *a, plan=plan, **k: warm_starts.append(k["warm_knots"].copy()) or plan(*a, **k),
        )
    before = sim.steps_simulated
    domain.vstar.plan_samples(domain.sample_prior(np.random.default_rng(14), 1))
    assert sim.steps_simulated - before == len(scene.starts) * (8 + 4) * horizon
    assert len(warm_starts) == 2
    np.testing.assert_array_equal(warm_starts[0], warm_starts[1])


def test_seed_zeroed_adds_a_seed_plan_ignoring_each_named_feature(monkeypatch):
    """``planning.seed_zeroed``: beside the ``seed_directions`` prior draws (the same draws as
    without it), each start plans one direction per named feature, every weight equal but that
    feature's, zeroed, and its plan enters the library (the library's best under that reward is
    the plan's value or better)."""
    from mjsuff.scenes import domain as domain_module

    calls = []
    plan = domain_module.SamplingPlanner.plan

    def recording(self, problems, weights, rng, **kwargs):
        result = plan(self, problems, weights, rng, **kwargs)
        calls.append((np.array(problems), np.array(weights), result))
        return result

    monkeypatch.setattr(domain_module.SamplingPlanner, "plan", recording)
    small_domain("lava_reacher")
    (_, plain_weights, _), *_ = calls  # the seed plans: the only plans an instance makes up front
    calls.clear()
    planning = {**SMALL_PLANNING, "seed_zeroed": ["lava", "motion"]}
    domain = small_domain("lava_reacher", planning=planning)
    (problems, weights, seeds), *_ = calls
    count = len(domain.scene.all_starts)
    assert weights.shape == (count * 4, domain.num_features)
    per_start = weights.reshape(count, 4, -1)
    np.testing.assert_array_equal(per_start, np.broadcast_to(per_start[0], per_start.shape))
    np.testing.assert_array_equal(problems, np.repeat(np.arange(count), 4))
    directions = per_start[0]
    np.testing.assert_array_equal(directions[:2], plain_weights.reshape(count, 2, -1)[0])
    lava, motion = 1, 3  # the reacher's features: distance, lava, water, motion (step_features)
    for row, feature in ((2, lava), (3, motion)):
        expected = np.full(4, -1 / np.sqrt(3))
        expected[feature] = 0.0
        np.testing.assert_allclose(directions[row], expected)
    for feature in (lava, motion):
        zeroed = np.flatnonzero(weights[:, feature] == 0.0)
        assert len(zeroed) == count
        for j in zeroed:
            best = domain.library.best_value(int(problems[j]), weights[j : j + 1])[0]
            assert best >= seeds.values[j] - 1e-9


FEATURES_EXPECTED = "(expected distinct names among: landing_error, impact, fuel, tilt, habitat, array)"


@pytest.mark.parametrize(
    ("names", "problem"),
    [
        ('["habitat", "lava"]', f"'lava' is not a feature of this scene {FEATURES_EXPECTED}"),
        ('["lava", "water", "lava"]', f"'lava', 'water' are not features of this scene {FEATURES_EXPECTED}"),
        ('["array", "habitat", "array"]', f"'array' given more than once {FEATURES_EXPECTED}"),
        ('"habitat"', """expected a list of feature names, e.g. ["habitat"] (got the string 'habitat')"""),
        ("{habitat = 1}", "expected a list of feature names (got {'habitat': 1})"),
    ],
)
def test_seed_zeroed_names_must_be_distinct_features_of_the_scene(names, problem):
    with pytest.raises(ScenarioError) as info:
        load_scenario("lander", [f"domain.params.planning.seed_zeroed={names}"])
    assert str(info.value).endswith(f"domain.params.planning.seed_zeroed: {problem}")


@pytest.mark.parametrize("name", SCENES)
def test_each_scene_params_names_the_features_its_scene_computes(name):
    """``planning.seed_zeroed`` is checked against the params class's ``feature_names`` and
    applied by the scene's: the two must be the same names in the same order."""
    spec = get_domain(name)
    assert spec.params.feature_names == spec.scene.feature_names
    assert len(spec.params.feature_names) >= 2


def test_a_scene_domain_checks_seed_zeroed_before_any_planning(case, monkeypatch):
    """Built directly (not through a scenario's params), the domain refuses an unknown name
    before it plans anything."""
    from mjsuff.scenes import domain as domain_module
    from mjsuff.scenes.planning import PlanningSettings

    domain, _ = case
    monkeypatch.setattr(domain_module.SamplingPlanner, "plan", lambda *a, **k: pytest.fail("planned"))
    with pytest.raises(ValueError, match=re.escape("planning.seed_zeroed: 'bogus' is not a feature")):
        domain_module.SceneDomain(
            domain.scene,
            domain.true_weights,
            np.random.default_rng(0),
            planning=PlanningSettings(seed_zeroed=["bogus"]),
            expert=domain.expert,
        )


@pytest.mark.parametrize("revisit_cosine", [0.98, 0.999])
def test_a_direction_near_one_planned_reuses_its_plan(case, revisit_cosine):
    """``planning.revisit_cosine`` (shipped 0.98 on both scenes, stop 57): a (sample, start)
    within that cosine of a direction already planned from the start is not planned again (the
    library's best for it is the nearby plan's); one outside it is. Directions at cosine 0.99
    (about 8°) and 0.95 (about 18°) to a planned one."""
    domain, _ = case
    probe = copy.deepcopy(domain)
    with_planning(probe, revisit_cosine=revisit_cosine)
    rng = np.random.default_rng(13)
    w = domain.sample_prior(rng, 1)[0]
    u = rng.standard_normal(w.shape)
    u -= (u @ w) * w
    u /= np.linalg.norm(u)
    starts = range(len(domain.scene.starts))

    def planned_from_every_start(direction) -> bool:
        before = [probe.library.size(s) for s in starts]
        probe.vstar.plan_samples(direction[None])
        grew = [probe.library.size(s) > before[s] for s in starts]
        assert len(set(grew)) == 1  # every start alike: all have the same directions planned
        return grew[0]

    assert planned_from_every_start(w)
    assert planned_from_every_start(0.99 * w + np.sqrt(1 - 0.99**2) * u) == (revisit_cosine > 0.99)
    assert planned_from_every_start(0.95 * w - np.sqrt(1 - 0.95**2) * u)


@pytest.mark.parametrize("replan_cosine", [None, 0.98])
def test_pi_for_a_reward_near_one_planned_gets_the_refinement_budget(case, replan_cosine, monkeypatch):
    """``planning.replan_cosine``: π for a reward within that cosine of one π was already planned
    for is planned with the refiner's budget (warm-started from the library as always); one
    outside it, the first one, and every one when unset, with π's. Directions at cosine 0.99 and
    0.95 to the planned one."""
    domain, _ = case
    probe = copy.deepcopy(domain)
    with_planning(probe, replan_cosine=replan_cosine)
    probe._plan_directions = probe._plan_directions[:0]  # not the rewards other tests planned
    used = []
    for name in ("planner", "refiner"):
        planner = getattr(probe, name)
        monkeypatch.setattr(
            planner, "plan", lambda *a, _p=planner.plan, _n=name, **k: used.append(_n) or _p(*a, **k)
        )
    rng = np.random.default_rng(14)
    w = domain.sample_prior(rng, 1)[0]
    u = rng.standard_normal(w.shape)
    u -= (u @ w) * w
    u /= np.linalg.norm(u)
    for direction in (w, 0.99 * w + np.sqrt(1 - 0.99**2) * u, 0.95 * w - np.sqrt(1 - 0.95**2) * u):
        knots = probe.plan(3.0 * direction)  # the scale does not matter
        assert knots.shape == (len(domain.scene.starts), *domain.scene.spline.shape)
    near = "refiner" if replan_cosine else "planner"
    assert used == ["planner", near, "planner"]
    assert probe.replans == (1 if replan_cosine else 0)


@pytest.mark.parametrize("extra_gain", [1e-9, 0.99])
def test_extra_polish_rounds_run_only_while_the_round_before_raised_the_tail(case, extra_gain, monkeypatch):
    """``planning.polish_extra_rounds``: after ``polish_rounds`` rounds, another round runs only
    when the round before raised some tail (sample, start)'s V* by more than
    ``polish_extra_gain`` of its V* − V_rand, at most that many more. A gain of 0.99 is never
    reached (exactly ``polish_rounds`` rounds); 1e-9 is reached by every round that improves
    anything."""
    import mjsuff.scenes.vstar as vstar

    domain, _ = case
    probe = copy.deepcopy(domain)
    with_planning(
        probe, refine_rounds=0, polish_rounds=1, polish_extra_rounds=2, polish_extra_gain=extra_gain
    )
    gains, real = [], vstar.polish_library

    def measured(scene, library, starts, weights, *args):
        def values():
            pairs = zip(starts, weights, strict=True)
            return np.array([library.best(int(s), w[None])[0][0] for s, w in pairs])

        before = values()
        real(scene, library, starts, weights, *args)
        after = values()
        scale = after - np.einsum("nk,nk->n", weights, probe.vstar.random_mu[starts])
        gains.append(np.max((after - before) / scale))

    monkeypatch.setattr(vstar, "polish_library", measured)
    rng = np.random.default_rng(15)
    robot = domain.start_feature_expectations(domain.plan(domain.sample_prior(rng, 1)[0]))
    probe.optimal_start_values(domain.sample_prior(rng, 60), robot=robot)
    extra = len(gains) - 1
    assert probe.vstar.extra_polish_rounds == extra
    assert all(g > extra_gain for g in gains[:extra])  # every extra round followed a raise
    assert extra == 2 or gains[extra] <= extra_gain  # and they stopped at the first round without one
    if extra_gain > 0.5:
        assert extra == 0
    else:
        assert extra >= 1  # the first round raises something on these instances


def test_tolerances_define_unchanged_and_matching(case):
    domain, demos = case
    policy = domain.plan(domain.true_weights)
    random_policy = domain.scene.spline.uniform(np.random.default_rng(8), 3)
    assert domain.same_policy(policy, policy.copy())
    assert not domain.same_policy(policy, random_policy)
    demo = demos[0]
    # A demo is matched from its own (pool) start: the policy's plan from there.
    gap = np.abs(domain.pool_features(policy)[demo.start] - demo.data["features"]).max()
    saved = domain.match_tolerance
    try:
        domain.match_tolerance = gap * 1.01 + 1e-9
        assert domain.agrees_with_demo(policy, demo)
        domain.match_tolerance = gap * 0.99
        assert not domain.agrees_with_demo(policy, demo)
    finally:
        domain.match_tolerance = saved


def test_ground_truth_scores_planned_and_random_policies(case):
    domain, _ = case
    truth = domain.true_optimal_start_values()
    assert truth.shape == (3,) and np.all(np.isfinite(truth))
    assert truth is domain.true_optimal_start_values()  # computed once
    random_policy = domain.scene.spline.uniform(np.random.default_rng(9), 3)
    # The module's small planner against a truth of three searches at 4x the shipped kinds'
    # budgets: near-optimal from some start, where a random policy is from none.
    assert domain.policy_optimality(domain.plan(domain.true_weights)) >= 1 / 3
    assert domain.policy_optimality(random_policy) == 0.0


def test_ground_truth_leaves_the_learner_untouched_and_includes_the_expert():
    domain = small_domain("lava_reacher", seed=14)
    sizes = [domain.library.size(s) for s in range(3)]
    refined = [r.copy() for r in domain.vstar.refined]
    truth = domain.true_optimal_start_values()
    # Nothing of w* reaches the learner's library or its record of refined directions.
    assert [domain.library.size(s) for s in range(3)] == sizes
    assert all(np.array_equal(a, b) for a, b in zip(refined, domain.vstar.refined, strict=True))
    # The truth is at least what the expert shows from every evaluation start (where it is never
    # asked in a run): up to the expert's own randomness (its refinement draws), 0.5% of
    # V* - V_rand.
    rng = np.random.default_rng(15)
    w = domain.true_weights
    shown = [domain.expert.demonstrate(domain.scene.starts[s], w, rng).features @ w for s in range(3)]
    scale = truth - domain.random_start_feature_expectations() @ domain.true_weights
    assert np.all(truth >= np.array(shown) - 0.005 * scale)


def test_ground_truth_is_not_beaten_by_the_learners_plans_near_w_star():
    # The truth's searches (wide, broad-step, local; 4 x the budgets) from the library's best:
    # the learner's own planner, for w* and for rewards within ~10 degrees of it, finds nothing
    # better from any evaluation start (up to 1% of V* - V_rand: the searches are stochastic).
    domain = small_domain("lava_reacher", seed=21)
    truth = domain.true_optimal_start_values()
    w = domain.true_weights
    scale = truth - domain.random_start_feature_expectations() @ w
    rng = np.random.default_rng(22)
    near = [w] + [w + 0.15 * d for d in random_unit_vectors(rng, 3, len(w))]
    for v in near:
        v = -np.abs(v) / np.linalg.norm(v)  # inside the prior's orthant
        values = domain.start_feature_expectations(domain.plan(v)) @ w
        assert np.all(values <= truth + 0.01 * scale), (v, values - truth)


def test_final_truth_without_searches_is_the_best_simulated():
    domain = small_domain("lava_reacher", seed=21)
    truth = domain.true_optimal_start_values().copy()
    domain.plan(domain.true_weights)  # the learner's plans join its library
    final = domain.final_true_start_values()
    best = domain.best_simulated_start_values(domain.true_weights)
    np.testing.assert_array_equal(final.values, np.maximum(truth, best))
    assert (final.passes, final.last_gain) == (0, 0.0)


@pytest.mark.parametrize("name", SCENES)
def test_final_truth_searches_again_until_it_settles(name):
    """``planning.truth_passes``: when the replicate ends, the truth searches again from its own
    plans and the learner's best until a search raises no start by more than TRUTH_SETTLED. A
    further search from the truth's own plans, with randomness of its own, then gains at most 1%
    of V* − V_rand at any start (the tolerance of the truth-against-learner test above: the
    searches are stochastic, and one quiet search is no proof of a fixed point). The passes plan
    the cloud around w* as the scene's scenario file ships it (the lander: in the first only)."""
    shipped = tomllib.loads((SCENARIOS / f"{name}.toml").read_text())["domain"]["params"]["planning"]
    planning = {
        **SMALL_PLANNING,
        "truth_passes": 4,
        "truth_cloud_every_pass": shipped.get("truth_cloud_every_pass", True),
    }
    domain = small_domain(name, seed=23, planning=planning)
    w = domain.true_weights
    first = domain.true_optimal_start_values().copy()
    library = domain._truth_library  # the searches at the end add to it; the domain then frees it
    domain.plan(w)
    best = domain.best_simulated_start_values(w)
    final = domain.final_true_start_values()
    assert final is domain.final_true_start_values() and domain._truth_library is None
    assert np.all(final.values >= np.maximum(first, best))
    assert 1 <= final.passes <= 4
    assert final.last_gain <= TRUTH_SETTLED or final.passes == 4
    scale = final.values - domain.random_start_feature_expectations() @ w
    again = search_truth(
        domain.scene,
        copy.deepcopy(library),
        w,
        domain.planner.config,
        domain.planning,
        None,
        np.random.default_rng(24),
    )
    assert np.all(again <= final.values + 0.01 * scale), (again - final.values) / scale


@pytest.mark.parametrize("every_pass", [True, False])
def test_final_truth_plans_the_cloud_in_the_passes_its_setting_asks(every_pass, monkeypatch):
    """``planning.truth_cloud_every_pass``: the searches at the end plan the rewards around w*
    first in every pass, or (false) only in the first. Searches here are stand-ins that raise
    every start by its whole V* − V_rand, so no pass settles and all ``truth_passes`` run."""
    planning = {**SMALL_PLANNING, "truth_passes": 3, "truth_cloud_every_pass": every_pass}
    domain = small_domain("lava_reacher", seed=21, planning=planning)
    truth = domain.true_optimal_start_values().copy()
    v_rand = domain.random_start_feature_expectations() @ domain.true_weights
    clouds = []

    def search(scene, library, true_weights, planner, planning, expert, rng, cloud=TRUTH_CLOUD):
        clouds.append(cloud)
        return truth + (2 ** len(clouds)) * np.abs(truth - v_rand)

    monkeypatch.setattr("mjsuff.scenes.truth.search_truth", search)
    final = domain.final_true_start_values()
    assert final.passes == 3 and final.last_gain > TRUTH_SETTLED
    assert clouds == ([TRUTH_CLOUD] * 3 if every_pass else [TRUTH_CLOUD, 0, 0])


@pytest.mark.parametrize("cloud", [TRUTH_CLOUD, 0])
def test_truth_search_plans_its_cloud_only_when_asked(cloud, monkeypatch):
    """``search_truth(cloud=0)`` plans no rewards around w* and draws no randomness for them: its
    planners are stand-ins that record the problems they get and draw nothing."""
    domain = small_domain("lava_reacher", seed=21)
    starts = len(domain.scene.starts)
    planned = []

    class Recording:
        def __init__(self, scene, config, library):
            pass

        def plan(self, problems, directions, rng, warm_knots=None):
            planned.append(len(problems))

    monkeypatch.setattr("mjsuff.scenes.truth.SamplingPlanner", Recording)
    monkeypatch.setattr("mjsuff.scenes.truth.polish_library", lambda *args, **kwargs: None)
    rng = np.random.default_rng(5)
    library = copy.deepcopy(domain.library)
    w = domain.true_weights
    search_truth(domain.scene, library, w, domain.planner.config, domain.planning, None, rng, cloud=cloud)
    assert planned == ([cloud * starts] if cloud else []) + [starts] * 3
    untouched = np.random.default_rng(5)
    assert (rng.random() == untouched.random()) is (cloud == 0)


def test_bad_demo_features_are_a_clear_error(case):
    domain, _ = case
    with pytest.raises(ValueError, match="features must be"):
        domain.log_likelihood(
            domain.true_weights[None], [Demo(start=0, data={"features": np.array([np.nan] * 2)})], BETA
        )


def test_mcmc_matches_the_exact_posterior_on_the_reacher():
    """k = 4: the sampler against the posterior of the same trajectory likelihood tabulated on
    400,000 uniform sphere points."""
    domain = small_domain("lava_reacher", seed=12)
    rng = np.random.default_rng(13)
    demos = [domain.demonstrate(s, rng) for s in range(3)]

    def problem(w):
        return domain.log_likelihood(w, demos, 2.0)

    exact = grid_posterior(problem, num_points=400_000, k=4, rng=np.random.default_rng(14))
    assert np.linalg.norm(exact.mean) > 0.3  # informative, or agreement would prove nothing
    post = sample_posterior(
        problem, 4, SamplerConfig(num_samples=12_000, chains=8, burn_in=400, thin=2), np.random.default_rng(0)
    )
    # The same tolerances as the tabular check (tests/test_sampler.py): about four Monte Carlo
    # standard errors for ~1500 draws per chain.
    np.testing.assert_allclose(post.samples.mean(axis=0), exact.mean, atol=0.04)
    np.testing.assert_allclose(np.cov(post.samples.T), exact.covariance, atol=0.025)
    assert post.rhat < 1.05
