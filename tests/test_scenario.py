"""Scenario files: the shipped ones load; bad ones fail with one line naming file, key, expectation."""

import tomllib
from pathlib import Path

import pytest

from mjsuff.experiment.scenario import (
    ScenarioError,
    load_scenario,
    resolve_scenario,
)

SCENARIOS = sorted(Path(__file__).parent.parent.joinpath("scenarios").glob("*.toml"))
GOOD = """
name = "x"
[domain]
name = "gridworld"
"""


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.name)
def test_shipped_scenarios_load_and_round_trip(path):
    scenario = load_scenario(path)
    again = tomllib.loads(scenario.to_toml())
    assert again["domain"]["name"] == scenario.domain.name
    assert again["posterior"] == scenario.posterior.model_dump(exclude_none=True)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        (GOOD + "colour = 3\n", "colour: unknown key"),
        (
            GOOD + "[posterior]\nnum_samples = 'many'\n",
            "posterior.num_samples: input should be a valid integer",
        ),
        (
            GOOD + "[rules]\nnevd_thresholds = [0.1, 1.5]\n",
            "rules.nevd_thresholds.1: input should be less than or equal to 1",
        ),
        (
            GOOD + "[rules]\nnevd_thresholds = [0.0]\n",
            "rules.nevd_thresholds.0: input should be greater than 0",
        ),
        (
            GOOD + "[domain.params]\nrows = 1\n",
            "domain.params.rows: input should be greater than or equal to 2",
        ),
        (GOOD + "[domain.params]\nwalls = 1\n", "domain.params.walls: unknown key"),
        ('name = "x"\n[domain]\nname = "chess"\n', "domain.name: expected one of"),
        ("name = \n", "not valid TOML"),
        ('[domain]\nname = "gridworld"\n', "name: missing required key"),
        # Issue #19: a name becomes a file name; duplicates would run and count twice.
        ('name = "../escaped"\n[domain]\nname = "gridworld"\n', "name: expected letters, digits"),
        ('name = "a/b"\n[domain]\nname = "gridworld"\n', "name: expected letters, digits"),
        ('name = ".hidden"\n[domain]\nname = "gridworld"\n', "name: expected letters, digits"),
        (
            GOOD + "[rules]\nnevd_thresholds = [0.1, 0.2, 0.1]\n",
            "rules.nevd_thresholds: 0.1 given more than once",
        ),
        (GOOD + "[rules]\npatience = [2, 2]\n", "rules.patience: 2 given more than once"),
        ("replicates = 100001\n" + GOOD, "replicates: input should be less than or equal to 100000"),
        (
            "replicates = 60000\n" + GOOD + "[sweep]\n'demos.beta' = [1.0, 2.0]\n",
            "replicates: 2 sweep cells × 60,000 replicates plan more than 100,000",
        ),
    ],
)
def test_bad_scenarios_name_file_key_and_expectation(tmp_path, text, expected):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    message = str(info.value)
    assert message.startswith(str(path)) and expected in message and "\n" not in message


def test_a_leading_bom_is_read_and_other_encodings_are_named(tmp_path):
    """Issue #19, item 7: a UTF-8 BOM is accepted; Latin-1 is called what it is, not UTF-8."""
    bom = tmp_path / "bom.toml"
    bom.write_bytes(b"\xef\xbb\xbf" + GOOD.encode())
    assert load_scenario(bom).domain.name == "gridworld"
    latin = tmp_path / "latin.toml"
    latin.write_bytes(GOOD.replace('name = "x"', 'name = "x"  # café').encode("latin-1"))
    with pytest.raises(ScenarioError, match=r"latin.toml: not UTF-8 text \(byte 0xe9 at offset \d+\)"):
        load_scenario(latin)


def test_missing_file(tmp_path):
    with pytest.raises(ScenarioError, match="file not found"):
        load_scenario(tmp_path / "nope.toml")


def test_overrides_are_parsed_as_toml_values(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    s = load_scenario(path, ["sufficiency.alpha=0.9", "rules.patience=[2, 3]", "demos.selection=active"])
    assert s.sufficiency.alpha == 0.9 and s.rules.patience == [2, 3]
    assert s.demos.selection == "active"
    with pytest.raises(ScenarioError, match=r"sufficiency\.alpha: input should be less than 1"):
        load_scenario(path, ["sufficiency.alpha=2"])
    with pytest.raises(ScenarioError, match="expected KEY=VALUE"):
        load_scenario(path, ["alpha"])


@pytest.mark.parametrize(
    ("sets", "expected", "attributed"),
    [
        (
            ["domain.name='driving'", "domain.params.motorists=100"],
            "domain.params: motorists must be at most 15",
            False,
        ),
        (["demos.beta=inf"], "demos.beta: input should be a finite number", True),
        (["posterior.step_size=nan"], "posterior.step_size: input should be a finite number", True),
        (["rules.nevd_thresholds=['0.1']"], "rules.nevd_thresholds.0: input should be a valid number", True),
        (["domain.params.gamma='0.9'"], "domain.params.gamma: input should be a valid number", True),
        (
            [
                "rules.nevd_thresholds=[]",
                "rules.piob_thresholds=[]",
                "rules.patience=[]",
                "rules.validation_intervals=[]",
            ],
            "rules: at least one rule is needed",
            False,
        ),
        (["rules.nevd_thresholds=[]"], "rules.nevd_thresholds: the baselines are scored", False),
        (["posterior.num_samples=20"], "posterior.num_samples: at least 70 samples", False),
        (
            ["posterior.num_samples=40", 'sufficiency.quantile_method="binomial"'],
            "posterior.num_samples: at least 59 samples",
            False,
        ),
        (
            ["posterior.num_samples=100", "posterior.min_ess=200"],
            "posterior.min_ess: the kept draws' effective size cannot exceed num_samples (100)",
            False,
        ),
        (
            ["posterior.num_samples=60", "posterior.chains=80"],
            "posterior.num_samples: must be a multiple of chains (80)",
            False,
        ),
        (["posterior.rhat_target=1.0"], "posterior.rhat_target: input should be greater than 1", False),
        (
            ["posterior.min_ess=30"],
            "posterior.min_ess: the 0.95-confidence bound on the 0.95-VaR from "
            "500 samples needs an effective size of at least 54",
            False,
        ),
        (
            ["posterior.max_steps=50"],
            "posterior.max_steps: at least burn_in + num_samples / chains × thin",
            False,
        ),
        (
            ["posterior.max_steps=10000000"],
            "posterior.max_steps: input should be less than or equal to",
            False,
        ),
        (["domain.params.rows=40"], "domain.params.rows: input should be less than or equal to 12", True),
        (  # issue #19: a posterior that never converges keeps every draw (88 GB here)
            ["posterior.chains=1000", "posterior.max_steps=1000000", "posterior.num_samples=1000"],
            "posterior.max_steps: chains × max_steps = 1,000,000,000 exceeds 10,000,000",
            False,
        ),
    ],
)
def test_bad_overrides_are_clear(tmp_path, sets, expected, attributed):
    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path, sets)
    message = str(info.value)
    assert message.startswith(str(path)) and expected in message, message
    # Field errors also name the override they came from (cross-field checks name their key).
    if attributed:
        assert f"(--set {sets[0].split('=')[0]})" in message


def test_bare_names_resolve_to_shipped_scenarios_unless_a_file_has_that_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    lander = next(p for p in SCENARIOS if p.stem == "lander")
    assert resolve_scenario("lander").resolve() == lander.resolve()
    assert load_scenario("lander").domain.name == "lander"
    Path("lander").write_text(GOOD)
    assert resolve_scenario("lander") == Path("lander")
    assert load_scenario("lander").name == "x"
    # Paths are paths: no lookup for a directory part or a .toml suffix.
    for path in ("lava_reacher.toml", "sub/lava_reacher"):
        assert resolve_scenario(path) == Path(path)
        with pytest.raises(ScenarioError, match=f"^{path}: file not found$"):
            load_scenario(path)
    with pytest.raises(ScenarioError) as unknown:
        load_scenario("nonesuch")
    names = ", ".join(p.stem for p in SCENARIOS)
    assert str(unknown.value) == (
        f"nonesuch: no such scenario file, nor a shipped scenario (shipped: {names})"
    )


@pytest.mark.parametrize(
    ("text", "sets", "expected"),
    [
        ("[expert]\nrefine_rounds = 1\n", [], "sc.toml: expert: a scene setting, now domain.params.expert"),
        (
            "",
            ["demos.candidates=family"],
            "sc.toml (--set demos.candidates): demos.candidates: a scene setting, now "
            "domain.params.candidates",
        ),
        (
            "",
            ["expert.rationality=2.0"],
            "sc.toml (--set expert.rationality): expert: a scene setting, now domain.params.expert",
        ),
        ("[rules]\nmatch_tolerance = 0.3\n", [], "now domain.params.match_tolerance"),
    ],
)
def test_scene_settings_that_moved_name_their_new_key(tmp_path, text, sets, expected):
    """Issue #18 moved the scenes' settings into their parameters; an old file says where."""
    path = tmp_path / "sc.toml"
    path.write_text(f'name = "x"\n[domain]\nname = "lander"\n{text}')
    with pytest.raises(ScenarioError) as info:
        load_scenario(path, sets)
    assert expected in str(info.value) and "\n" not in str(info.value)


@pytest.mark.parametrize(
    ("key", "domain", "may_be_none"),
    [
        ("demos.lapse", "gridworld", False),  # added in stop 39: a run without it had 0.0
        ("domain.params.baseline", "gridworld", False),
        ("domain.params.planning.seed_zeroed", "lander", False),
        ("posterior.min_ess", "gridworld", True),  # None is left out of config.toml: absent may be None
        ("domain.params.planning.planner.population", "lander", True),  # inside a section that may be None
        ("demos.no_such_key", "gridworld", True),
    ],
)
def test_a_key_a_stored_config_lacks_is_filled_only_when_it_cannot_be_none(key, domain, may_be_none):
    """``stored_settings`` fills a key an older run's config.toml lacks with its default only when
    the absence cannot be a ``None`` the run had (``to_toml`` leaves ``None`` out), so a default
    that changes later does not stand in for it."""
    from mjsuff.experiment.scenario import _may_be_none

    assert _may_be_none(key, domain) is may_be_none
