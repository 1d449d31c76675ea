"""Rerun recordings (issue #6): read back with rerun.chunk.RrdReader and checked against the run."""

import shutil
import subprocess

import mujoco
import numpy as np
import pandas as pd
import pytest
import rerun as rr
from rerun.chunk import RrdReader

from mjsuff.domain import FinalTruth
from mjsuff.domains.tabular import TabularDomain
from mjsuff.experiment.run_summary import RECORDING
from mjsuff.experiment.runner import run_scenario
from mjsuff.recording import Recording, SceneLogger
from mjsuff.scenes.lander import Lander, LanderParams
from mjsuff.scenes.lava_reacher import LavaReacher, LavaReacherParams
from tests.conftest import small_scenario


@pytest.fixture(scope="module")
def grid_run(tmp_path_factory):
    directory = tmp_path_factory.mktemp("run")
    run_scenario(small_scenario(), directory)
    return directory, pd.read_parquet(directory / "steps.parquet")


def test_recording_has_the_expected_entities_and_timelines(grid_run):
    directory, steps = grid_run
    recording = Recording(directory / RECORDING)
    paths = recording.entity_paths()
    for r in steps["replicate"].unique():
        for entity in (
            "grid/cells",
            "grid/pi_map",
            "posterior/samples",
            "posterior/w_map",
            "posterior/w_true",
            "log",
            "rules/nevd_0.2/bound",
            "rules/nevd_0.2/threshold",
            "rules/patience_1/true_value",
        ):
            assert f"/r{r}/{entity}" in paths, entity
    assert "/run/scenario" in paths
    assert "demo" in recording.timelines()
    assert RrdReader(str(directory / RECORDING)).blueprints()  # opens on the default layout


def assert_true_values_recorded(recording: Recording, steps: pd.DataFrame) -> None:
    """Every rule's ``true_value`` series in ``recording`` is steps.parquet's, step for step."""
    for (r, rule, param), rows in steps.groupby(["replicate", "rule", "param"]):
        rows = rows.sort_values("step")
        table = recording.series(f"r{r}/rules/{rule}_{param:g}/true_value", "Scalars:scalars", "demo")
        assert table.column("demo").to_pylist() == rows["step"].tolist()
        np.testing.assert_array_equal(
            [v[0] for v in table.column(1).to_pylist()], rows["true_value"].to_numpy()
        )


def test_series_equal_the_values_in_steps_parquet(grid_run):
    directory, steps = grid_run
    recording = Recording(directory / RECORDING)
    assert_true_values_recorded(recording, steps)
    for (r, rule, param), rows in steps.groupby(["replicate", "rule", "param"]):
        rows = rows.sort_values("step")
        base = f"r{r}/rules/{rule}_{param:g}"
        if rule in ("nevd", "piob"):
            bound = recording.series(f"{base}/bound", "Scalars:scalars", "demo")
            finite = rows[np.isfinite(rows["bound"])]
            np.testing.assert_array_equal(
                [v[0] for v in bound.column(1).to_pylist()], finite["bound"].to_numpy()
            )


def test_true_values_are_those_the_replicate_ends_with(tmp_path, monkeypatch):
    """A scene's truth is raised when its replicate ends and every row is scored again: the
    recording's true values and stop lines must be those of steps.parquet, not the ones each step
    was first scored with. Gridworld's exact truth is raised here by hand (by a third of each
    start's V* - V_rand: every true nEVD moves, so the values first scored differ)."""

    def raised_truth(self):
        v_star = self.true_optimal_start_values()
        v_rand = self.random_start_feature_expectations() @ self.true_weights
        return FinalTruth(v_star + (v_star - v_rand) / 3)

    monkeypatch.setattr(TabularDomain, "final_true_start_values", raised_truth)
    run_scenario(small_scenario(replicates=1), tmp_path)
    steps = pd.read_parquet(tmp_path / "steps.parquet")
    assert (steps["truth_raised_starts"] > 0).all()
    recording = Recording(tmp_path / RECORDING)
    assert_true_values_recorded(recording, steps)
    log = recording.series("r0/log", "TextLog:text", "demo")
    lines = [str(v[0]) for v in log.column(1).to_pylist()]
    stops = [line for line in lines if line.startswith("STOP ")]
    decided = steps[steps["decision"]].sort_values("step").groupby(["rule", "param"]).head(1)
    assert not decided.empty and len(stops) == len(decided)  # one line per rule that stopped, at its first
    for first in decided.itertuples():
        bound = f"bound {first.bound:.3f}, " if np.isfinite(first.bound) else ""
        where = f"STOP {first.rule} {first.param:g} at demo {first.step}"
        expected = f"{where}: {bound}true {first.true_value:.3f}"
        assert expected in stops, (expected, stops)
    assert any(line.startswith("ground truth raised at the replicate's end") for line in lines)


def test_posterior_samples_and_marks(grid_run):
    directory, steps = grid_run
    recording = Recording(directory / RECORDING)
    samples = recording.series("r0/posterior/samples", "Points3D:positions", "demo")
    assert len(samples) == steps[steps.replicate == 0]["step"].nunique()
    points = np.array(samples.column(1)[0].as_py())
    assert points.shape == (100, 3) and np.all(np.isfinite(points))


@pytest.mark.skipif(shutil.which("rerun") is None, reason="the rerun CLI is not on PATH")
def test_rerun_verifies_the_file(grid_run):
    directory, _ = grid_run
    done = subprocess.run(
        ["rerun", "rrd", "verify", str(directory / RECORDING)], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr


def test_no_record_writes_no_recording(tmp_path):
    run_scenario(small_scenario(replicates=1), tmp_path / "o", record=False)
    assert not (tmp_path / "o" / RECORDING).exists()


@pytest.mark.parametrize("scene_type, params", [(LavaReacher, LavaReacherParams), (Lander, LanderParams)])
def test_geom_poses_in_the_file_equal_mujocos(tmp_path, scene_type, params):
    scene = scene_type(params(eval_starts=2), np.random.default_rng(0))
    model = scene.model
    knots = scene.spline.uniform(np.random.default_rng(1), 1)
    rollouts, _ = scene.simulate(scene.starts[:1], knots)
    qpos = rollouts.qpos[0, ::10]
    times = np.arange(len(qpos)) * 0.1
    path = tmp_path / "scene.rrd"
    rec = rr.RecordingStream(application_id="test")
    rec.save(str(path))
    logger = SceneLogger(model, rec, "scene")
    logger.log_geometry()
    logger.log_motion(qpos, [rr.TimeColumn("sim_time", duration=times)])
    rec.flush()
    rec.disconnect()

    recording = Recording(path)
    frame = len(qpos) // 2
    data = mujoco.MjData(model)
    data.qpos[:] = qpos[frame]
    mujoco.mj_kinematics(model, data)
    checked = 0
    for g in range(model.ngeom):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) or str(g)
        body = logger.body_paths[model.geom_bodyid[g]]
        local = f"{body}/geom_{name}"
        offset = recording.static(local, "Transform3D:translation")
        if offset is None:
            continue
        quat = recording.static(local, "Transform3D:quaternion")[0]
        if model.geom_bodyid[g] == 0:
            b_pos, b_rot = np.zeros(3), np.eye(3)
        else:
            when = np.timedelta64(round(times[frame] * 1e9), "ns")
            b_pos = np.array(recording.latest_at(body, "Transform3D:translation", "sim_time", when)[0])
            bq = recording.latest_at(body, "Transform3D:quaternion", "sim_time", when)[0]
            b_rot = _rotation(bq)
        world_pos = b_pos + b_rot @ np.array(offset[0])
        world_rot = b_rot @ _rotation(quat)
        np.testing.assert_allclose(world_pos, data.geom_xpos[g], atol=1e-5)
        np.testing.assert_allclose(world_rot, data.geom_xmat[g].reshape(3, 3), atol=1e-5)
        checked += 1
    assert checked == model.ngeom


def _rotation(xyzw):
    """Rotation matrix of an (x, y, z, w) quaternion."""
    wxyz = np.array([xyzw[3], xyzw[0], xyzw[1], xyzw[2]], dtype=float)
    mat = np.zeros(9)
    mujoco.mju_quat2Mat(mat, wxyz / np.linalg.norm(wxyz))
    return mat.reshape(3, 3)


ALL_GEOMS = """
<mujoco>
  <asset>
    <mesh name="tetra" vertex="0 0 0  0.1 0 0  0 0.1 0  0 0 0.1"/>
  </asset>
  <worldbody>
    <geom name="floor" type="plane" size="0 0 0.1"/>
    <body name="thing" pos="0.1 0.2 0.3" euler="0.3 0.2 0.1">
      <freejoint/>
      <geom name="box" type="box" size="0.1 0.2 0.05"/>
      <geom name="ball" type="sphere" size="0.05" pos="0.2 0 0"/>
      <geom name="pill" type="capsule" fromto="0 0 0 0.2 0.1 0" size="0.02"/>
      <geom name="can" type="cylinder" size="0.03 0.04" pos="0 0.2 0"/>
      <geom name="egg" type="ellipsoid" size="0.03 0.04 0.05" pos="0 0 0.2"/>
      <geom name="tetra" type="mesh" mesh="tetra" pos="0.1 0.1 0.1"/>
      <site name="tip" pos="0.3 0 0" size="0.01"/>
    </body>
  </worldbody>
</mujoco>
"""


def test_every_geom_type_is_drawn(tmp_path):
    model = mujoco.MjModel.from_xml_string(ALL_GEOMS)
    path = tmp_path / "all.rrd"
    rec = rr.RecordingStream(application_id="test")
    rec.save(str(path))
    logger = SceneLogger(model, rec, "s")
    logger.log_geometry()
    rec.disconnect()
    recording = Recording(path)
    shapes = {
        "world/geom_floor": "Boxes3D:half_sizes",
        "thing/geom_box": "Boxes3D:half_sizes",
        "thing/geom_ball": "Ellipsoids3D:half_sizes",
        "thing/geom_pill": "Capsules3D:radii",
        "thing/geom_can": "Cylinders3D:radii",
        "thing/geom_egg": "Ellipsoids3D:half_sizes",
        "thing/geom_tetra": "Mesh3D:vertex_positions",
        "thing/site_tip": "Ellipsoids3D:half_sizes",
    }
    for entity, component in shapes.items():
        assert recording.static(f"s/bodies/{entity}", component) is not None, entity
    np.testing.assert_allclose(
        recording.static("s/bodies/thing/geom_box", "Boxes3D:half_sizes"), [[0.1, 0.2, 0.05]]
    )
    # The capsule keeps its MuJoCo length (fromto: 0.2 x 0.1) and radius.
    assert recording.static("s/bodies/thing/geom_pill", "Capsules3D:lengths")[0] == pytest.approx(
        np.hypot(0.2, 0.1), rel=1e-6
    )
    assert len(recording.static("s/bodies/thing/geom_tetra", "Mesh3D:vertex_positions")) == 4
