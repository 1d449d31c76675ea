"""``PlanningSettings`` (mjsuff/scenes/planning.py): the checks a scenario's planning section gets
before any instance is built. What the settings do to planning is tested with the scene domain
(tests/test_scene_domain.py)."""

import re

import pytest
from pydantic import ValidationError

from mjsuff.scenes.planning import PlanningSettings


def test_extra_polish_rounds_need_a_round_to_follow():
    with pytest.raises(ValidationError, match="needs polish_rounds"):
        PlanningSettings(polish_rounds=0, polish_extra_rounds=1)


def test_seed_zeroed_from_a_list_is_a_tuple_and_the_settings_stay_hashable():
    settings = PlanningSettings(seed_zeroed=["lava", "water"])  # as TOML gives it
    assert settings.seed_zeroed == ("lava", "water")
    assert hash(settings) == hash(PlanningSettings(seed_zeroed=("lava", "water")))
    assert settings.model_dump(mode="json")["seed_zeroed"] == ["lava", "water"]


@pytest.mark.parametrize(
    ("features", "problem"),
    [
        (("lava",), "a scene of one feature has no other weight to keep (expected it empty)"),
        ((), "this scene declares no feature names (expected it empty)"),
    ],
)
def test_seed_zeroed_needs_a_scene_of_two_or_more_declared_features(features, problem):
    settings = PlanningSettings(seed_zeroed=["lava"])
    PlanningSettings().check_seed_zeroed(features)  # nothing named: any scene
    with pytest.raises(ValueError, match=re.escape(f"planning.seed_zeroed: {problem}")):
        settings.check_seed_zeroed(features)


@pytest.mark.parametrize("names", [{"lava", "water"}, "lava", 3])
def test_seed_zeroed_takes_a_list_only(names):
    """A set would plan its directions in an order that varies between processes (string
    hashing), so runs with the same seed would differ; a string would be read letter by letter."""
    with pytest.raises(ValidationError, match="expected a list of feature names"):
        PlanningSettings(seed_zeroed=names)
