"""README tables that restate the code are checked against it (issue #18, item 5).

The scenario table (README, "Scenario files") must name every key of the scenario's models and of
every registered scene's parameters; the steps.parquet table is generated (``test_step_row.py``).
"""

from pathlib import Path

from pydantic import BaseModel

from mjsuff.domains import REGISTRY
from mjsuff.experiment.scenario import Scenario

README = (Path(__file__).parent.parent / "README.md").read_text()
SCENARIO_TABLE = README[README.index("## Scenario files") : README.index("## Output files")]


def dotted_keys(model: type[BaseModel], prefix: str = "") -> list[str]:
    """Every leaf key of ``model`` (nested models expanded), dotted."""
    keys = []
    for name, field in model.model_fields.items():
        kind = field.annotation
        if isinstance(kind, type) and issubclass(kind, BaseModel):
            keys += dotted_keys(kind, f"{prefix}{name}.")
        else:
            keys.append(prefix + name)
    return keys


def test_the_scenario_table_names_every_key():
    keys = dotted_keys(Scenario)
    for spec in REGISTRY.values():
        if spec.kind == "scene":  # tabular domains' parameters are listed per domain, inline
            keys += dotted_keys(spec.params, "domain.params.")
    missing = sorted(
        {k for k in keys if f"`{k}`" not in SCENARIO_TABLE and f"`{k.split('.')[-1]}`" not in SCENARIO_TABLE}
    )
    assert not missing, f"README's scenario table lacks {missing}"
