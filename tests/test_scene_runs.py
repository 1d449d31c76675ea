"""`mjsuff run` on the MuJoCo scenes end to end (issue #5), and saved demo sets served to it (#4).

Tiny budgets (3 evaluation starts, 3 demos, short plans) so each run takes seconds; what is
checked is the pipeline, not the figures (those are in the README's measured run).
"""

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from mjsuff.cli import main
from mjsuff.domain import TRUTH_SETTLED
from mjsuff.experiment.run_summary import RECORDING
from mjsuff.recording import Recording
from mjsuff.scenes.domain import SceneDomain

SCENARIOS = Path(__file__).parent.parent / "scenarios"
TINY = [
    "--replicates",
    "1",
    "--quiet",
    "--set",
    "domain.params.eval_starts=3",
    "--set",
    "demos.max_demos=3",
    "--set",
    "posterior.num_samples=100",
    "--set",
    "domain.params.planning.planner.iterations=4",
    "--set",
    "domain.params.planning.refine_rounds=0",
    "--set",
    "domain.params.planning.seed_directions=1",
    "--set",
    "domain.params.planning.truth_scale=1.0",
    "--set",
    "domain.params.planning.truth_passes=2",
    "--set",
    "rules.validation_intervals=[2]",
    "--set",
    "rules.patience=[1]",
]


def run(name, out, *extra):
    code = main(["run", str(SCENARIOS / f"{name}.toml"), "--out", str(out), *TINY, *extra])
    return code, (pd.read_parquet(out / "steps.parquet") if code == 0 else None)


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    """The tiny run of a scene, made once per module: two tests read the same command's output
    (the reacher's live run is the saved demo set's reference). Read it, never write into it."""
    made = {}

    def get(name):
        if name not in made:
            out = tmp_path_factory.mktemp(name) / "run"
            made[name] = (out, *run(name, out))
        return made[name]

    return get


@pytest.mark.parametrize("name", ["lava_reacher", "lander"])
def test_scene_run_is_complete_and_sound(name, tiny_run):
    first, code, steps = tiny_run(name)
    assert code == 0
    assert sorted(steps["step"].unique()) == [1, 2, 3]
    assert set(steps["rule"]) == {"nevd", "piob", "patience", "validation"}
    nevd = steps[steps["rule"] == "nevd"]
    assert np.isfinite(nevd["bound"]).all() and (nevd["bound"] >= 0).all()
    assert (steps["true_nevd"] >= 0).all() and (steps["true_nevd"] <= 1.5).all()
    assert steps["policy_optimality"].between(0, 1).all()
    # The run reports what it simulated: running counts per step, totals in run.json.
    counts = steps.drop_duplicates("step").sort_values("step")
    assert counts["simulated_steps"].is_monotonic_increasing and counts["simulated_steps"].iloc[0] > 0
    assert (counts["diverged_rollouts"] >= 0).all()
    report = json.loads((first / "run.json").read_text())
    assert report["simulated_steps"] == counts["simulated_steps"].iloc[-1]
    assert report["diverged_rollouts"] == counts["diverged_rollouts"].iloc[-1]
    # ... and how its ground truth was raised and searched again (one replicate: its row values).
    last = steps.iloc[-1]
    assert 1 <= last["truth_passes"] <= 2
    assert report["truth"] == {
        "raised_replicates": int(last["truth_raised_starts"] > 0),
        "raised_starts": int(last["truth_raised_starts"]),
        "largest_raise": float(last["truth_raise"]),
        "searches": int(last["truth_passes"]),
        "unsettled_replicates": int(last["truth_last_gain"] > TRUTH_SETTLED),
    }
    # The run's recording shows the scene, each demo (playable on sim_time) and π_MAP.
    recording = Recording(first / RECORDING)
    paths = recording.entity_paths()
    assert {"/r0/scene/pi_map", "/r0/scene/demos/1", "/r0/scene/demos/3"} <= paths
    assert any(p.startswith("/r0/scene/bodies/") for p in paths)
    assert {"demo", "sim_time"} <= recording.timelines()


def test_same_seed_same_learner_and_the_truths_searches_only_raise(tmp_path, tiny_run):
    """MuJoCo rollouts, experts and samplers are all seeded, and the truth's searches at the end
    have randomness of their own (run "b" has none of them), so only the truth's columns differ,
    and only upwards. On the reacher: the replicate loop and the searches at the end are the same
    code for both scenes, and the lander's learner is held to its seed bit for bit by its golden
    record (``tests/test_golden.py``); its second run cost the suite ~80 s."""
    name = "lava_reacher"
    _, code, steps = tiny_run(name)
    assert code == 0
    code, again = run(name, tmp_path / "b", "--set", "domain.params.planning.truth_passes=0")
    assert code == 0
    truth = ["true_value", "true_nevd", "policy_optimality", *[c for c in steps if c.startswith("truth_")]]
    learner = [c for c in steps if c not in truth and c not in ("simulated_steps", "diverged_rollouts")]
    pd.testing.assert_frame_equal(steps[learner], again[learner])
    assert (again["truth_passes"] == 0).all()
    assert (steps["truth_raise"] >= again["truth_raise"]).all()
    assert (steps["truth_raised_starts"] >= again["truth_raised_starts"]).all()
    assert (steps["simulated_steps"] >= again["simulated_steps"]).all()
    assert steps["truth_passes"].between(1, 2).all()  # TINY allows 2


def test_saved_demo_set_reproduces_the_live_run(tmp_path, monkeypatch, tiny_run):
    name = "lava_reacher"
    demos = tmp_path / "d.npz"
    sets = ["--set", "domain.params.eval_starts=3"]
    assert (
        main(
            ["demos", str(SCENARIOS / f"{name}.toml"), "--count", "3", "--out", str(demos), "--quiet", *sets]
        )
        == 0
    )
    _, code, live = tiny_run(name)
    assert code == 0
    # The served run must not ask the live expert at all.
    monkeypatch.setattr(SceneDomain, "demonstrate", lambda *a, **k: pytest.fail("expert asked"))
    code, served = run(name, tmp_path / "served", "--demos", str(demos))
    assert code == 0
    # Everything but the simulation counts, which the live expert's candidates add to.
    counts = ["simulated_steps", "diverged_rollouts"]
    pd.testing.assert_frame_equal(live.drop(columns=counts), served.drop(columns=counts))
    assert (served["simulated_steps"] < live["simulated_steps"]).all()


def test_demo_set_of_another_instance_or_replicate_is_refused(tmp_path, capsys):
    name = "lava_reacher"
    demos = tmp_path / "d.npz"
    assert (
        main(
            [
                "demos",
                str(SCENARIOS / f"{name}.toml"),
                "--count",
                "1",
                "--out",
                str(demos),
                "--quiet",
                "--set",
                "domain.params.eval_starts=3",
                "--seed",
                "5",
            ]
        )
        == 0
    )
    capsys.readouterr()
    code, _ = run(name, tmp_path / "o", "--demos", str(demos))
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1
    assert "d.npz: field 'meta.seed': expected 0, got 5" in err
    assert not (tmp_path / "o").exists()
    other = tmp_path / "r3.npz"
    assert (
        main(
            [
                "demos",
                str(SCENARIOS / f"{name}.toml"),
                "--count",
                "1",
                "--out",
                str(other),
                "--quiet",
                "--set",
                "domain.params.eval_starts=3",
                "--replicate",
                "3",
            ]
        )
        == 0
    )
    capsys.readouterr()
    code, _ = run(name, tmp_path / "o", "--demos", str(other))
    err = capsys.readouterr().err
    assert code == 2 and "field 'meta.replicate': expected a replicate in 0..0, got 3" in err


def test_demo_set_that_is_short_or_made_otherwise_is_refused_before_work(tmp_path, capsys):
    demos = tmp_path / "short.npz"
    assert (
        main(
            [
                "demos",
                str(SCENARIOS / "lava_reacher.toml"),
                "--count",
                "1",
                "--out",
                str(demos),
                "--quiet",
                "--set",
                "domain.params.eval_starts=3",
            ]
        )
        == 0
    )
    cases = {
        (): "the run asks for 3 demos in passive order but the file has none left from start",
        ("--set", "domain.params.horizon=1.0"): "field 'meta.scene_params'",
        ("--set", "domain.params.expert.rationality=2.0"): "field 'meta.expert'",
        ("--set", 'demos.selection="active"'): "saved demos follow the passive order",
    }
    for extra, message in cases.items():
        capsys.readouterr()
        code, _ = run("lava_reacher", tmp_path / "o", "--demos", str(demos), *extra)
        err = capsys.readouterr().err.strip()
        assert code == 2 and len(err.splitlines()) == 1 and "Traceback" not in err, err
        assert "short.npz" in err and message in err, err
        assert not (tmp_path / "o").exists()
