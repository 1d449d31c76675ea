"""A domain from outside mjsuff runs end to end through ``mjsuff run`` (issue #18, item 6).

``examples/chain_domain.py`` is the README's "Add a domain" example; nothing inside ``mjsuff/`` knows
it. A scenario names it by import path; worker processes import it themselves.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from mjsuff import domains
from mjsuff.domains import REGISTRY, DomainSpec, get_domain, register
from mjsuff.recording import Recording

EXAMPLES = Path(__file__).parent.parent / "examples"


def mjsuff(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(EXAMPLES)}
    return subprocess.run(
        [sys.executable, "-m", "mjsuff.cli", *args], cwd=cwd, env=env, capture_output=True, text=True
    )


def test_a_domain_named_by_import_path_runs_records_and_reports(tmp_path):
    out = tmp_path / "chain"
    done = mjsuff("run", str(EXAMPLES / "chain.toml"), "--out", str(out), "--quiet", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    steps = pd.read_parquet(out / "steps.parquet")
    assert sorted(steps["replicate"].unique()) == [0, 1]
    assert sorted(steps["step"].unique()) == [1, 2, 3, 4]
    assert (steps["true_nevd"] >= -1e-12).all() and steps["policy_optimality"].between(0, 1).all()
    summary = json.loads((out / "summary.json").read_text())
    assert {e["rule"] for e in summary["entries"]} == {"nevd", "piob", "patience", "validation"}
    # Its spec's view draws it: the chain's cells, π_MAP and each demo, per replicate.
    paths = Recording(out / "recording.rrd").entity_paths()
    assert {"/r0/grid/cells", "/r0/grid/pi_map", "/r1/grid/cells"} <= paths
    # The resolved scenario reruns it: config.toml names the domain by the same path.
    assert 'name = "chain_domain:SPEC"' in (out / "config.toml").read_text()


def test_an_import_path_that_names_no_spec_is_one_line(tmp_path):
    for name, expected in [
        ("no_such_module:SPEC", "cannot import module 'no_such_module'"),
        ("chain_domain:make_chain", "expected a mjsuff.domains.DomainSpec, got function"),
    ]:
        scenario = tmp_path / "bad.toml"
        scenario.write_text(f'name = "bad"\n[domain]\nname = "{name}"\n')
        done = mjsuff("run", str(scenario), "--out", str(tmp_path / "out"), cwd=tmp_path)
        assert done.returncode == 2
        assert done.stderr.strip().count("\n") == 0 and expected in done.stderr
        assert f"{scenario}: domain.name:" in done.stderr
        assert not (tmp_path / "out").exists()


def test_register_adds_a_spec_once(monkeypatch):
    monkeypatch.setattr(domains, "REGISTRY", dict(REGISTRY))  # leave the real one alone
    gridworld = REGISTRY["gridworld"]
    spec = DomainSpec("my_grid", gridworld.params, gridworld.factory, view=gridworld.view)
    assert register(spec) is spec and get_domain("my_grid") is spec
    assert register(spec) is spec  # the same spec again is fine
    with pytest.raises(ValueError, match="'my_grid' is registered already"):
        register(DomainSpec("my_grid", gridworld.params, gridworld.factory))
    assert "my_grid" not in REGISTRY and "my_grid" in domains.REGISTRY


#: Sizes that keep the MuJoCo scene's run to seconds while every stage still runs.
SMALL_SCENE = [
    "domain.params.eval_starts=2",
    "domain.params.pool_starts=3",
    "demos.max_demos=2",
    "posterior.num_samples=100",
    "domain.params.planning.planner.iterations=2",
    "domain.params.planning.refine_rounds=0",
    "domain.params.planning.seed_directions=1",
    "domain.params.planning.truth_scale=1.0",
    "rules.validation_intervals=[2]",
    "rules.patience=[1]",
]


def test_a_mujoco_scene_from_outside_runs_records_and_demonstrates(tmp_path):
    """examples/effort_reacher.py: its own MJCF model and a fifth feature from its torque sensors."""
    sets = [x for s in SMALL_SCENE for x in ("--set", s)]
    out = tmp_path / "effort"
    scenario = str(EXAMPLES / "effort_reacher.toml")
    done = mjsuff("run", scenario, "--out", str(out), "--quiet", "--workers", "2", *sets, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    steps = pd.read_parquet(out / "steps.parquet")
    assert sorted(steps["replicate"].unique()) == [0, 1] and sorted(steps["step"].unique()) == [1, 2]
    assert (steps["true_nevd"] >= -1e-9).all() and steps["simulated_steps"].gt(0).all()
    # The scene view draws the outside model: its payload geom and the fingertip's path.
    paths = Recording(out / "recording.rrd").entity_paths()
    assert any(p.startswith("/r0/") and p.endswith("/geom_payload") for p in paths), sorted(paths)[:20]
    # mjsuff demos knows it too; the demos carry the model's fifth feature, from its sensors.
    demos = tmp_path / "effort.npz"
    done = mjsuff("demos", scenario, "--count", "2", "--out", str(demos), "--quiet", *sets, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    with np.load(demos) as saved:
        assert saved["features"].shape == (2, 5) and (saved["features"][:, 4] > 0).all()
