"""Demo-set files: round trip, and clear errors for corrupt, truncated or mismatched files."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mjsuff.experiment.demo_generation import generate_demos, instance_meta, scene_instance
from mjsuff.experiment.scenario import load_scenario
from mjsuff.experts.demo_set import DemoFileError, load_demo_set, truth_path

ROOT = Path(__file__).resolve().parents[1]
OVERRIDES = ["domain.params.eval_starts=3", "domain.params.expert.refine_rounds=0"]


@pytest.fixture(scope="module")
def scenario():
    return load_scenario(ROOT / "scenarios" / "lava_reacher.toml", OVERRIDES)


@pytest.fixture(scope="module")
def saved(scenario, tmp_path_factory):
    demo_set = generate_demos(scenario, 2)
    path = demo_set.save(tmp_path_factory.mktemp("demos") / "set.npz")
    return demo_set, path


def test_round_trip_gives_identical_arrays(saved, scenario):
    demo_set, path = saved
    scene, weights = scene_instance(scenario)
    loaded = load_demo_set(path, expect=instance_meta(scenario, 0, scene), truth=True)
    assert set(loaded.arrays) == set(demo_set.arrays)
    for name, array in demo_set.arrays.items():
        np.testing.assert_array_equal(loaded.arrays[name], array, err_msg=name)
    np.testing.assert_array_equal(loaded.true_weights, weights)
    assert loaded.meta["mujoco_version"]
    assert loaded.meta["feature_names"] == ["distance", "lava", "water", "motion"]
    # The learner's file does not hold the true weights.
    with np.load(path) as data:
        assert not any("weight" in name for name in data.files)
        assert "true_weights" not in str(data["meta"])


def test_demos_are_for_the_instance_and_weights_a_run_uses(scenario):
    from mjsuff.experiment.replicate import make_instance

    domain = make_instance(scenario, 0)
    scene, weights = scene_instance(scenario, 0)
    np.testing.assert_array_equal(domain.true_weights, weights)
    np.testing.assert_array_equal(domain.scene.starts, scene.starts)


def test_generation_is_reproducible(saved, scenario):
    again = generate_demos(scenario, 2)
    for name, array in saved[0].arrays.items():
        np.testing.assert_array_equal(again.arrays[name], array, err_msg=name)


def test_corrupt_and_truncated_files_are_named(saved, tmp_path):
    _, path = saved
    garbage = tmp_path / "garbage.npz"
    garbage.write_bytes(b"not a zip file at all")
    with pytest.raises(DemoFileError, match=r"garbage\.npz: not a readable demo-set file"):
        load_demo_set(garbage)
    truncated = tmp_path / "truncated.npz"
    truncated.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    with pytest.raises(DemoFileError, match=r"truncated\.npz"):
        load_demo_set(truncated)
    with pytest.raises(DemoFileError, match="no such demo file"):
        load_demo_set(tmp_path / "absent.npz")


def rewrite(path, out, **changes):
    with np.load(path) as data:
        contents = {name: data[name] for name in data.files}
    contents.update(changes)
    for name in [n for n, v in changes.items() if v is None]:
        del contents[name]
    np.savez(out, **contents)
    return out


def test_wrong_shapes_missing_arrays_and_nan_are_named(saved, tmp_path):
    demo_set, path = saved
    bad = rewrite(path, tmp_path / "shape.npz", qpos=demo_set.arrays["qpos"][:, :-1])
    with pytest.raises(DemoFileError, match=r"shape\.npz: array 'qpos': expected shape \(2, 150, 3\)"):
        load_demo_set(bad)
    bad = rewrite(path, tmp_path / "missing.npz", controls=None)
    with pytest.raises(DemoFileError, match=r"missing arrays \['controls'\]"):
        load_demo_set(bad)
    features = demo_set.arrays["features"].copy()
    features[0, 1] = np.nan
    with pytest.raises(DemoFileError, match="array 'features': non-finite"):
        load_demo_set(rewrite(path, tmp_path / "nan.npz", features=features))
    with pytest.raises(DemoFileError, match="field 'meta' is not valid JSON"):
        load_demo_set(rewrite(path, tmp_path / "meta.npz", meta=np.array("{oops")))


@pytest.mark.parametrize(
    ("array", "change", "expected"),
    [
        (
            "start_index",
            lambda a: np.array([10**12, 0]),
            r"array 'start_index': expected pool starts 0\.\.\d+, got 10+",
        ),
        (
            "start_index",
            lambda a: np.array([-1, 0]),
            r"array 'start_index': expected pool starts 0\.\.\d+, got -1",
        ),
        ("start_qpos", lambda a: a + 0.1, r"array 'start_qpos': not the postures of the pool starts"),
        ("controls", lambda a: a * 100.0, r"array 'controls': outside the actuators' ranges"),
        ("tracking_error", lambda a: -a - 1e-3, r"array 'tracking_error': negative values"),
    ],
)
def test_values_outside_the_scene_are_named_with_file_and_array(
    saved, scenario, tmp_path, array, change, expected
):
    """Issue #19, item 2: a start index of 10**12 allocated 7 TiB; -1 failed in numpy."""
    from mjsuff.experiment.recorded_demos import load_recorded_demos

    demo_set, path = saved
    bad = rewrite(path, tmp_path / "range.npz", **{array: change(demo_set.arrays[array])})
    with pytest.raises(DemoFileError, match=r"range\.npz: " + expected):
        load_recorded_demos([bad], scenario)


def test_other_scene_or_instance_is_refused(saved, scenario):
    _, path = saved
    other = load_scenario(ROOT / "scenarios" / "lava_reacher.toml", [*OVERRIDES, "seed=5"])
    scene, _ = scene_instance(other)
    with pytest.raises(DemoFileError, match=r"field 'meta\.seed': expected 5, got 0"):
        load_demo_set(path, expect=instance_meta(other, 0, scene))
    with pytest.raises(DemoFileError, match=r"field 'meta\.scene': expected 'lander'"):
        load_demo_set(path, expect={"scene": "lander"})
    with pytest.raises(DemoFileError, match=r"field 'meta\.instance'"):
        load_demo_set(path, expect={"instance": "0" * 16})


def test_truth_file_problems_are_named(saved, tmp_path):
    _, path = saved
    copy = tmp_path / "copy.npz"
    copy.write_bytes(path.read_bytes())
    with pytest.raises(DemoFileError, match=r"copy\.truth\.json: not a readable truth file"):
        load_demo_set(copy, truth=True)
    truth_path(copy).write_text(json.dumps({"true_weights": [1.0], "values": None}))
    with pytest.raises(DemoFileError, match="field 'true_weights': expected 4 values"):
        load_demo_set(copy, truth=True)


def run_cli(*args, cwd):
    return subprocess.run(
        [sys.executable, "-m", "mjsuff.cli", *args], cwd=cwd, capture_output=True, text=True, timeout=300
    )


def test_cli_writes_a_loadable_set_and_refuses_bad_requests(tmp_path):
    out = tmp_path / "d.npz"
    sets = [a for o in OVERRIDES for a in ("--set", o)]
    done = run_cli(
        "demos",
        str(ROOT / "scenarios/lava_reacher.toml"),
        "--count",
        "1",
        "--out",
        str(out),
        "--quiet",
        *sets,
        cwd=tmp_path,
    )
    assert done.returncode == 0, done.stderr
    assert "demos/s" in done.stdout and len(load_demo_set(out)) == 1
    again = run_cli("demos", str(ROOT / "scenarios/lava_reacher.toml"), "--out", str(out), cwd=tmp_path)
    assert again.returncode == 2 and "exists; pass --overwrite" in again.stderr
    tabular = run_cli("demos", str(ROOT / "scenarios/gridworld.toml"), cwd=tmp_path)
    assert tabular.returncode == 2 and "MuJoCo scenes" in tabular.stderr
    assert len(tabular.stderr.strip().splitlines()) == 1
