"""Scenario files: the shipped ones load; bad ones fail with one line naming file, key, expectation."""

import tomllib
from pathlib import Path

import pytest

from mjsuff.experiment.scenario import ScenarioError, load_scenario

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
    assert again["posterior"] == scenario.posterior.model_dump()


@pytest.mark.parametrize(("text", "expected"), [
    (GOOD + "colour = 3\n", "colour: unknown key"),
    (GOOD + "[posterior]\nnum_samples = 'many'\n", "posterior.num_samples: input should be a valid integer"),
    (GOOD + "[rules]\nnevd_thresholds = [0.1, 1.5]\n",
     "rules.nevd_thresholds.1: input should be less than or equal to 1"),
    (GOOD + "[rules]\nnevd_thresholds = [0.0]\n", "rules.nevd_thresholds.0: input should be greater than 0"),
    (GOOD + "[domain.params]\nrows = 1\n", "domain.params.rows: input should be greater than or equal to 2"),
    (GOOD + "[domain.params]\nwalls = 1\n", "domain.params.walls: unknown key"),
    ('name = "x"\n[domain]\nname = "chess"\n', "domain.name: expected one of"),
    ("name = \n", "not valid TOML"),
    ('[domain]\nname = "gridworld"\n', "name: missing required key"),
])
def test_bad_scenarios_name_file_key_and_expectation(tmp_path, text, expected):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    message = str(info.value)
    assert message.startswith(str(path)) and expected in message and "\n" not in message


def test_missing_file(tmp_path):
    with pytest.raises(ScenarioError, match="file not found"):
        load_scenario(tmp_path / "nope.toml")


def test_overrides_are_parsed_as_toml_values(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(GOOD)
    s = load_scenario(path, ["sufficiency.alpha=0.9", "rules.patience=[2, 3]",
                             "demos.selection=active"])
    assert s.sufficiency.alpha == 0.9 and s.rules.patience == [2, 3]
    assert s.demos.selection == "active"
    with pytest.raises(ScenarioError, match=r"sufficiency\.alpha: input should be less than 1"):
        load_scenario(path, ["sufficiency.alpha=2"])
    with pytest.raises(ScenarioError, match="expected KEY=VALUE"):
        load_scenario(path, ["alpha"])
