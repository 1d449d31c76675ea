"""MuJoCo scenes: models, randomization, features, physics sanity, divergence, behaviour."""

import tomllib
from pathlib import Path

import mujoco
import numpy as np
import pytest

from mjsuff.domains import REGISTRY
from mjsuff.scenes import lander
from mjsuff.scenes.lander import REST_HEIGHT, ZONE_SCALE, Lander, LanderParams
from mjsuff.scenes.lava_reacher import (
    DISTANCE_SCALE,
    HAZARD_SCALE,
    REACH,
    LavaReacher,
    LavaReacherParams,
    fingertip_xy,
)
from mjsuff.scenes.planner import PlannerConfig, SamplingPlanner
from mjsuff.scenes.scene import MODELS, load_model, model_path

ROOT = Path(__file__).parent.parent

#: Every registered scene: (scene type, parameter model), from the one registry.
SCENES = {n: (spec.scene, spec.params) for n, spec in REGISTRY.items() if spec.scene is not None}
#: Documented feature ranges (see the scene modules' docstrings).
RANGES = {
    "lava_reacher": [(0, 2 * REACH / DISTANCE_SCALE), (0, 1 / HAZARD_SCALE), (0, 1 / HAZARD_SCALE), (0, 40)],
    "lander": [(0, 6), (0, 3), (0, 1), (0, 2), (0, 1 / ZONE_SCALE), (0, 1 / ZONE_SCALE)],
}


def make(name, seed=0, **params):
    scene_type, params_type = SCENES[name]
    return scene_type(params_type(eval_starts=4, **params), np.random.default_rng(seed))


def test_the_shipped_scenes_are_registered_with_their_parameters():
    assert SCENES == {"lava_reacher": (LavaReacher, LavaReacherParams), "lander": (Lander, LanderParams)}
    assert all(REGISTRY[name].kind == "scene" and REGISTRY[name].expert for name in SCENES)


@pytest.mark.parametrize("name", sorted(SCENES))
def test_model_compiles_in_radians(name):
    model = load_model(f"{name}.xml")
    hinge = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    # Joint ranges are set in radians (degrees would shrink them 57-fold).
    limited = [j for j in hinge if model.jnt_limited[j]]
    assert all(model.jnt_range[j, 1] > 2.0 for j in limited)
    assert model.nu >= 2


def test_model_path_names_the_shipped_file_or_the_shipped_models():
    assert model_path("lander.xml") == MODELS / "lander.xml" and model_path("lander.xml").is_file()
    with pytest.raises(FileNotFoundError) as missing:
        model_path("nonesuch.xml")
    message = str(missing.value)
    assert message.startswith("nonesuch.xml: no such MJCF model in ")
    assert "(models: lander.xml, lava_reacher.xml)" in message and "pip install" not in message


@pytest.mark.parametrize("name", sorted(SCENES))
def test_randomization_is_seeded_and_varies(name):
    a, b, c = make(name, 1), make(name, 1), make(name, 2)
    np.testing.assert_array_equal(a.starts, b.starts)
    np.testing.assert_array_equal(a.model.geom_pos, b.model.geom_pos)
    assert not np.array_equal(a.model.geom_pos, c.model.geom_pos)
    assert not np.array_equal(a.starts, c.starts)


@pytest.mark.parametrize("name", sorted(SCENES))
def test_random_controls_give_finite_features_in_range(name):
    scene = make(name)
    knots = scene.spline.uniform(np.random.default_rng(3), 256)
    rollouts, features = scene.simulate(np.repeat(scene.starts, 64, axis=0), knots)
    assert rollouts.valid.all() and np.isfinite(features).all()
    for j, (low, high) in enumerate(RANGES[name]):
        assert low <= features[:, j].min() and features[:, j].max() <= high, scene.feature_names[j]


@pytest.mark.parametrize("name", sorted(SCENES))
def test_diverged_rollouts_are_flagged_and_not_scored(name):
    scene = make(name)
    knots = scene.spline.uniform(np.random.default_rng(4), 3)
    controls = scene.spline.controls(knots, scene.anchor(scene.starts[:1]) if scene.spline.anchored else None)
    controls[1, 5:] = np.nan
    before = scene.simulator.diverged
    rollouts = scene.simulator.run(scene.start_states(scene.starts[:1]), controls)
    assert rollouts.valid.tolist() == [True, False, True]
    assert scene.simulator.diverged == before + 1  # counted for the run's report


def test_lander_climb_rate_loop_hovers_and_the_lowest_set_point_falls():
    scene = make("lander")
    hover = np.zeros((1, *scene.spline.shape))  # climb-rate set-point 0, upright
    rollouts, features = scene.simulate(scene.starts[:1], hover)
    z = rollouts.qpos[0, :, 1]
    assert np.abs(z - scene.starts[0, 1]).max() < 0.05  # the loop holds the height
    np.testing.assert_allclose(features[0, 2], 11 * 1.62 / 40, atol=0.01)  # thrust = weight
    fall = np.zeros((1, *scene.spline.shape))
    fall[:, :, 0] = scene.spline.low[0]  # sink at up to 4 m/s: the engine is off at first
    rollouts, features = scene.simulate(scene.starts[:1], fall)
    z = rollouts.qpos[0, :, 1]
    touched, first = scene.touchdown(rollouts)
    assert touched[0] and z[first[0]] < REST_HEIGHT + 0.1 < scene.starts[0, 1]
    assert (np.diff(z[: first[0]]) < 0).all()  # falling until touchdown
    assert rollouts.sensordata[0, first[0], :2].max() > 0  # the touch sensors read contact
    assert rollouts.sensordata[0, 0, 2] == 0.0  # no thrust while the craft is slower than 3.3 m/s
    assert features[0, 1] > 0.5  # a hard impact (> 2.5 m/s)
    assert features[0, 2] < 0.2  # little fuel


@pytest.mark.parametrize(("hazard", "column"), [("lava", 1), ("water", 2)])
def test_reacher_hazard_feature_only_inside_its_disk(hazard, column):
    scene = make("lava_reacher", 5)
    rng = np.random.default_rng(0)
    q = rng.uniform(-2.5, 2.5, size=(20_000, 3))
    tip = fingertip_xy(q)
    centre, radius = getattr(scene, f"{hazard}_centre"), getattr(scene, f"{hazard}_radius")
    depth = radius - np.linalg.norm(tip - centre, axis=1)
    inside, outside = q[depth > 0.5 * radius][:1], q[depth < -0.02][:1]
    for start, expect in ((inside, True), (outside, False)):
        hold = np.repeat(start[:, None, :], scene.spline.num_knots, axis=1)  # hold still there
        _, features = scene.simulate(start, hold)
        assert (features[0, column] > 0.3) == expect
        assert features[0, 3 - column] == 0.0  # the disks are apart: never in both
        assert features[0, 3] < 1e-6  # no motion


def test_reacher_starts_alternate_sides_and_each_side_faces_its_own_hazard():
    scene = make("lava_reacher", 2, pool_starts=10)
    assert scene.start_sides.tolist() == [0, 1, 0, 1] and sorted(scene.pool_sides) == [0] * 5 + [1] * 5
    for starts, sides in ((scene.starts, scene.start_sides), (scene.pool_starts, scene.pool_sides)):
        tip = fingertip_xy(starts)
        # Each start is nearer its own side's hazard than the other's.
        near = np.linalg.norm(tip - scene.hazard_centres[sides], axis=1)
        far = np.linalg.norm(tip - scene.hazard_centres[1 - sides], axis=1)
        assert (near < far).all()


def plan_features(scene, w, seed=0):
    w = np.asarray(w, dtype=float) / np.linalg.norm(w)
    starts = np.arange(len(scene.starts))
    plans = SamplingPlanner(scene, PlannerConfig(population=48, iterations=16)).plan(
        starts, np.tile(w, (len(starts), 1)), np.random.default_rng(seed)
    )
    return plans.features


def test_reacher_detours_around_lava_only_when_it_matters():
    scene = make("lava_reacher", 0)
    careful = plan_features(scene, [-0.3, -0.95, -0.95, -0.05])
    careless = plan_features(scene, [-0.95, -0.01, -0.01, -0.05])
    exposure = {k: f[:, 1:3].sum(axis=1).mean() for k, f in (("careful", careful), ("careless", careless))}
    assert exposure["careful"] < 0.25 * exposure["careless"]  # far less lava and water exposure
    assert careful[:, 0].mean() > careless[:, 0].mean()  # paid for with a longer way to the goal


def test_lander_saves_fuel_and_lands_harder_when_fuel_is_costly():
    scene = make("lander", 0)
    frugal = plan_features(scene, [-0.3, -0.2, -0.9, -0.2, -0.1, -0.1])
    lavish = plan_features(scene, [-0.3, -0.9, -0.02, -0.2, -0.1, -0.1])
    assert frugal[:, 2].mean() < lavish[:, 2].mean()  # less fuel
    assert frugal[:, 1].mean() > lavish[:, 1].mean()  # harder touchdown


@pytest.mark.parametrize("zone", [0, 1])
def test_lander_zone_feature_only_inside_its_zone(zone):
    scene = make("lander", 5)
    x, r = scene.zone_x[zone], scene.zone_radii[zone]
    hover = np.zeros((1, *scene.spline.shape))  # climb-rate set-point 0, upright: holds height
    for height, inside in ((0.7, True), (r + 0.3, False)):
        _, features = scene.simulate(np.array([[x, height, 0.0]]), hover)
        assert (features[0, 4 + zone] > 1.0) == inside
        assert features[0, 5 - zone] == 0.0  # the zones are apart: never in both


@pytest.mark.parametrize("shape", ["hemisphere", "column"])
def test_lander_zone_shape_column_counts_at_any_height_over_its_width(shape):
    # Zones wider than allowed: the clearance binds (the starts beyond the widest column).
    scene = make("lander", 5, zone_shape=shape, zone_radii=(3.0, 3.0), start_offsets=(3.0, 3.5))
    x, r = scene.zone_x[0], scene.zone_radii[0]
    reach = np.abs(scene.zone_x - scene.pad_x)
    if shape == "hemisphere":
        reach = np.hypot(reach, REST_HEIGHT)
    np.testing.assert_allclose(reach - scene.zone_radii, 0.15)  # resting on the pad: 0.15 m clear
    hover = np.zeros((1, *scene.spline.shape))  # holds its height
    for dx, inside in ((0.0, shape == "column"), (r + 0.3, False)):  # 5 m up: over a hemisphere
        _, features = scene.simulate(np.array([[x + dx, 5.0, 0.0]]), hover)
        assert (features[0, 4] > 1.0) == inside
    # The drawn zone (visual only) is the zone the feature counts: its half-width, its shape.
    geom = scene.model.geom("habitat_zone")
    assert geom.size[0] == pytest.approx(r)
    drawn = mujoco.mjtGeom.mjGEOM_BOX if shape == "column" else mujoco.mjtGeom.mjGEOM_SPHERE
    assert geom.type[0] == drawn


def test_lander_unknown_zone_shape_is_a_clear_error(monkeypatch):
    monkeypatch.setattr(lander, "ZONE_SHAPE", "cylinder")  # a design probe's --constant
    with pytest.raises(ValueError, match=r"zone_shape\n.*'hemisphere' or 'column'"):
        make("lander", 5)


def test_lander_columns_reaching_the_starts_are_a_clear_error():
    # Columns have no top: the module's default radii (1.1-1.4 m, centres up to 1.5 m out) reach
    # 2.85 m from the pad, past the default starts' 2 m.
    with pytest.raises(ValueError, match=r"start_offsets: .* expected start_offsets low > 2\.85 \(m\)"):
        LanderParams(zone_shape="column")
    LanderParams(zone_shape="column", start_offsets=(2.9, 3.5))  # clear of them
    LanderParams(zone_shape="hemisphere", start_offsets=(2.0, 3.0))  # the starts are high above


def test_lander_design_defaults_to_the_module_constants_and_is_set_per_scenario(monkeypatch):
    defaults = LanderParams()
    assert (defaults.zone_shape, defaults.zone_radii, defaults.start_offsets) == (
        lander.ZONE_SHAPE,
        lander.ZONE_RADII,
        lander.START_OFFSETS,
    )
    monkeypatch.setattr(lander, "START_OFFSETS", (4.0, 4.5))  # resolved on validation
    assert LanderParams().start_offsets == (4.0, 4.5)
    # A scenario's TOML arrays are accepted; the starts are drawn from the range set.
    params = LanderParams.model_validate({"eval_starts": 8, "start_offsets": [2.5, 2.6]})
    scene = Lander(params, np.random.default_rng(0))
    assert np.all(
        (np.abs(scene.starts[:, 0] - scene.pad_x) >= 2.5) & (np.abs(scene.starts[:, 0] - scene.pad_x) <= 2.6)
    )
    with pytest.raises(ValueError, match=r"zone_radii: expected 0 < low <= high \(m\)"):
        LanderParams.model_validate({"zone_radii": [0.6, 0.4]})


def scenario_design(name: str) -> dict:
    """The scene design keys a shipped scenario file sets."""
    params = tomllib.loads((ROOT / "scenarios" / f"{name}.toml").read_text())["domain"]["params"]
    return {k: params[k] for k in ("zone_shape", "zone_radii", "start_offsets") if k in params}


@pytest.mark.parametrize("design", ["module", "scenario"])
def test_lander_starts_alternate_sides_and_each_side_faces_its_own_zone(design):
    scene = make("lander", 2, pool_starts=10, **(scenario_design("lander") if design == "scenario" else {}))
    assert design == "module" or scene.params.zone_shape == "column"  # the shipped design
    assert scene.start_sides.tolist() == [0, 1, 0, 1] and sorted(scene.pool_sides) == [0] * 5 + [1] * 5
    assert scene.zone_x[1] < scene.pad_x < scene.zone_x[0]  # habitat right, array left
    for starts, sides in ((scene.starts, scene.start_sides), (scene.pool_starts, scene.pool_sides)):
        own, other = scene.zone_x[sides], scene.zone_x[1 - sides]
        # The own side's zone lies between the start and the pad, the other beyond the pad.
        assert ((starts[:, 0] - own) * (own - scene.pad_x) > 0).all()
        assert ((other - scene.pad_x) * (scene.pad_x - starts[:, 0]) > 0).all()
        # Every start is outside both zones (a column counts at any height).
        for x, r in zip(scene.zone_x, scene.zone_radii, strict=True):
            dx = starts[:, 0] - x
            distance = np.abs(dx) if scene.params.zone_shape == "column" else np.hypot(dx, starts[:, 1])
            assert (distance > r).all()
    # Resting on the pad keeps the craft outside both zones.
    reach = np.abs(scene.zone_x - scene.pad_x)
    if scene.params.zone_shape == "hemisphere":
        reach = np.hypot(reach, REST_HEIGHT)
    assert (reach > scene.zone_radii).all()


def test_lander_flies_over_its_zone_only_when_it_matters():
    scene = make("lander", 0)
    careful = plan_features(scene, [-0.4, -0.3, -0.3, -0.1, -0.8, -0.8])
    careless = plan_features(scene, [-0.4, -0.3, -0.3, -0.1, -0.01, -0.01])
    exposure = {k: f[:, 4:].sum(axis=1).mean() for k, f in (("careful", careful), ("careless", careless))}
    assert exposure["careful"] < 0.25 * exposure["careless"]  # far less exposure
    # Paid for with a harder touchdown or more fuel (over the zone, the descent comes later).
    assert careful[:, 1:3].sum(axis=1).mean() > careless[:, 1:3].sum(axis=1).mean()


def test_reacher_primitives_move_in_joint_space_toward_goal_postures():
    # Scene.primitive_knots: straight joint-space moves toward the analytic IK's goal postures.
    # The whole moves that are done before the last knot end with the fingertip at the goal
    # (stiff servos: within 1 cm by the end of the horizon); nothing leaves the control range.
    scene = make("lava_reacher", seed=5)
    start = scene.starts[0]
    knots = scene.primitive_knots(start)
    assert knots.shape[1:] == scene.spline.shape and len(knots) >= 4 * 3 * 2
    assert np.all(knots >= scene.spline.low) and np.all(knots <= scene.spline.high)
    rollouts, features = scene.simulate(start[None], knots)
    assert np.isfinite(features).all()
    # Every knot lies on the straight joint-space line from the start through the final knot.
    move = knots[:, -1] - start
    for k, m in zip(knots, move, strict=True):
        share = (k - start) @ m / max(m @ m, 1e-12)
        assert np.allclose(k, start + share[:, None] * m, atol=1e-9)
    whole = np.array([np.allclose(fingertip_xy(k[-1]), scene.goal, atol=1e-6) for k in knots])
    assert whole.sum() >= 3  # at least one goal posture, at every pace
    reach = np.linalg.norm(rollouts.sensordata[:, -1, :2] - scene.goal, axis=1)
    done_early = whole & np.array([np.allclose(k[-2], k[-1]) for k in knots])
    assert done_early.sum() >= 2  # the fast and the mid-way pace
    assert np.all(reach[done_early] < 0.01), reach[done_early]
