"""The shipped scenarios: every file in ``scenarios/``, named, with its domain and description."""

from pathlib import Path

from mjsuff.experiment.scenario import load_scenario
from mjsuff.experiment.shipped_scenarios import shipped_scenarios

SCENARIOS = sorted(Path(__file__).parent.parent.joinpath("scenarios").glob("*.toml"))


def test_shipped_scenarios_are_the_scenario_files():
    shipped = shipped_scenarios()
    assert [s.path.resolve() for s in shipped] == [p.resolve() for p in SCENARIOS]
    for s in shipped:
        assert s.name == s.path.stem == load_scenario(s.path).name
        assert s.domain == load_scenario(s.path).domain.name
        assert s.description.endswith(".") and "\n" not in s.description
    # The first sentence of the leading comment, even when it runs over two comment lines.
    sweep = next(s for s in shipped if s.name == "gridworld_sweep")
    assert sweep.description.endswith("a growing share of poor demos, passive and active.")
