"""Lander (analog of Gym's LunarLander): a planar craft lands on a pad under lunar gravity, past
the keep-out zone of the surface asset on its side.

The craft has slide joints x and z and a pitch hinge; controls are the set-point of its speed along
its body axis in [−4, 2] m/s, tracked by the main engine's climb-rate loop (thrust = weight +
25 N s/m × error, 0 to 40 N along the body axis; the craft weighs 17.8 N on the Moon), and the
attitude servo's pitch set-point in [−0.8, 0.8] rad (tracked with at most 3 N m, in about 0.5 s),
as a flight controller would take them. Its two legs carry touch sensors; a sensor reads the
engine's thrust.

Features (k = 6), from the simulated states and touch sensors:

* ``landing_error`` — at the end of the horizon, horizontal distance to the pad centre plus height
  above resting on the ground, divided by ``LANDING_SCALE`` (5 m); range [0, ~6] (random controls
  can fly far).
* ``impact`` — vertical speed at the first step either foot touches the ground; if the craft
  has not touched down by the end, the speed it would hit the ground with if the engine were cut
  then (``√(v_z² + 2 g h)``), so hovering does not dodge it; divided by ``IMPACT_SCALE``
  (5 m/s); range [0, ~3].
* ``fuel`` — mean thrust over the horizon as a share of the engine's 40 N; range [0, 1].
* ``tilt`` — mean |pitch| (wrapped to [0, π]) divided by π/2; range [0, 2].
* ``habitat`` — the craft's penetration into the keep-out hemisphere around the habitat (on the
  ground to the pad's right, radius 1.1–1.4 m, where the engine's plume would blast regolith at
  it): ``max(0, r − ‖p − c‖) / r`` for the craft's position ``p`` (x, z) and the zone's centre
  ``c``, its mean over the horizon divided by ``ZONE_SCALE`` (0.05); 0 outside the zone. Crossing
  the zone low costs about 1–4, several times a slow landing's fuel, so a reward that weighs it
  goes over it (slower, dearer in fuel) and one that ignores it cuts through.
* ``array`` — the same for the solar array's zone, to the pad's left.

A zone's shape is ``zone_shape`` (``LanderParams``; unset, ``ZONE_SHAPE``): the module's default
``"hemisphere"`` above, or ``"column"``, which the shipped scenario (``scenarios/lander.toml``,
issue #17, stop 45) uses: no overflight of the asset at any height, ``max(0, r − |x − c|) / r``
with ``r`` its half-width (0.4–0.6 m there), its MJCF geom redrawn as a box ``COLUMN_HEIGHT`` tall
(visual only). With the starts 2.5–3.5 m out, a column stands between each side's starts and the
pad, so a reward decides between crossing it (zone, tilt) and landing short (landing error), and
a demo from one side says nothing of the other side's column. ``zone_radii`` and
``start_offsets`` set the ranges drawn below (unset, ``ZONE_RADII`` and ``START_OFFSETS``).

The scales make the features comparable where policies differ, so that weights drawn uniformly
from the all-negative orthant trade them off: cut through a zone (a quick, cheap descent) or fly
over it (holding height: more fuel, a later and often harder touchdown), and how softly to land.

Instances randomize the pad (x in [−0.5, 0.5] m), the two zones (centres 1.2–1.5 m from the pad's
centre on either side, where the cheap descents from that side's starts pass; the craft resting on
the pad stays 0.15 m outside them) and two start regions, one on each side (2–3 m from the pad by
default, ``start_offsets``; height 4–6 m, pitch ±0.2 rad, at rest). From a start on the right the
habitat's zone is in the way and the array's beyond the pad; from the left, the reverse. So a
demonstration from one side says how the demonstrator trades fuel and a soft landing against that
side's zone, and nothing about the other's: the learner needs demos from both sides. The evaluation
starts alternate sides; the demonstration pool's sides are a balanced random order. True weights
are drawn uniformly from the all-negative part of the sphere: every feature is a cost.
"""

from __future__ import annotations

from typing import Annotated, Literal

import mujoco
import numpy as np
from pydantic import Field, model_validator

from mjsuff.scenes.params import SceneParams
from mjsuff.scenes.planner_config import PlannerConfig
from mjsuff.scenes.scene import Scene, load_model
from mjsuff.scenes.simulate import Rollouts
from mjsuff.scenes.spline import ControlSpline

FEATURE_NAMES = ("landing_error", "impact", "fuel", "tilt", "habitat", "array")
#: Keep-out zones, in feature order after ``tilt``: the habitat right of the pad, the array left.
ZONES = ("habitat", "array")
#: A zone's mean penetration (a share of its radius) that counts as 1.
ZONE_SCALE = 0.05
#: "hemisphere" (on the ground, radius r) or "column" (|x − c| < r at any height; module docs).
ZONE_SHAPE = "hemisphere"
COLUMN_HEIGHT = 8.0  # m, how tall a column zone is drawn (its feature has no top)
#: Touchdown speed (m/s) and landing error (m) that count as 1.
IMPACT_SCALE = 5.0
LANDING_SCALE = 5.0
#: Range of a zone's radius (m) and of its centre's distance from the pad's centre (m).
ZONE_RADII = (1.1, 1.4)
ZONE_OFFSETS = (1.2, 1.5)
#: Range of a start's horizontal distance from the pad (m) and of its height (m).
START_OFFSETS = (2.0, 3.0)
START_HEIGHTS = (4.0, 6.0)
#: Height of the craft's body origin when it stands on its legs (m).
REST_HEIGHT = 0.53
TOUCH_THRESHOLD = 1e-6
#: The main engine's largest thrust (N), as in the MJCF file.
MAX_THRUST = 40.0


#: A (low, high) range a scene draws from uniformly (m); TOML arrays are accepted.
Range = Annotated[tuple[float, float], Field(strict=False)]
ZoneShape = Literal["hemisphere", "column"]


class LanderParams(SceneParams):
    """Instance parameters of the lander. The zones' shape and sizes and the starts' distance
    are the scene's design: unset, they are the module's ``ZONE_SHAPE``, ``ZONE_RADII`` and
    ``START_OFFSETS`` (resolved on validation, so a resolved scenario says what ran)."""

    feature_names = FEATURE_NAMES

    horizon: float = Field(4.0, gt=0.5, le=20.0, description="trajectory length (s)")
    knots: int = Field(5, ge=2, le=20, description="control knots per actuator")
    # Unset, the design is the module's constants, read when a scenario is validated (so a design
    # probe's override reaches it) and written into the resolved scenario, which says what ran.
    zone_shape: ZoneShape = Field(
        default_factory=lambda: ZONE_SHAPE,
        validate_default=True,
        description='a keep-out zone: "hemisphere" on the ground or "column" at any height',
    )
    zone_radii: Range = Field(
        default_factory=lambda: ZONE_RADII,
        validate_default=True,
        description="range of a zone's radius or half-width (m), each capped so that the craft "
        "resting on the pad stays 0.15 m outside",
    )
    start_offsets: Range = Field(
        default_factory=lambda: START_OFFSETS,
        validate_default=True,
        description="range of a start's horizontal distance from the pad (m)",
    )

    @model_validator(mode="after")
    def _scene_defaults(self) -> LanderParams:
        for name in ("zone_radii", "start_offsets"):
            low, high = getattr(self, name)
            if not 0.0 < low <= high:
                raise ValueError(f"{name}: expected 0 < low <= high (m), got ({low}, {high})")
        if self.zone_shape == "column":  # a column has no top: no start may stand inside one
            far = ZONE_OFFSETS[1]
            reach = far + min(self.zone_radii[1], far - 0.15)
            if self.start_offsets[0] <= reach:
                raise ValueError(
                    f"start_offsets: a start {self.start_offsets[0]} m from the pad can stand inside a "
                    f"column zone reaching {reach:.2f} m out (zone_radii up to {self.zone_radii[1]} m, "
                    f"centres up to {far} m out); expected start_offsets low > {reach:.2f} (m)"
                )
        # Unset budgets become the scene's tested ones, so a resolved scenario says what ran.
        self.planning = self.planning.resolved(
            Lander.planner_config, Lander.refine_config, Lander.seed_config
        )
        return self


class Lander(Scene):
    """One lander instance drawn from ``rng``."""

    feature_names = FEATURE_NAMES
    path_axes = (0, 2)  # the craft moves in the world x-z plane
    # Touchdown makes the landscape multi-modal and ridged. π and V* refinement start from the
    # library's best for the reward (seed plans of prior draws, every plan since) and follow the
    # soft-landing ridge with CMA-ES; the seed plans need the global search: a wide CEM phase
    # picks the basin, CMA-ES polishes (tests/test_planner.py).
    planner_config = PlannerConfig(iterations=0, cma_population=24, cma_iterations=48, cma_sigma=0.1)
    refine_config = PlannerConfig(iterations=0, cma_population=16, cma_iterations=24, cma_sigma=0.1)
    seed_config = PlannerConfig(
        population=48,
        elites=6,
        iterations=10,
        initial_std=0.5,
        cma_population=16,
        cma_iterations=32,
        cma_sigma=0.1,
    )

    def __init__(self, params: LanderParams, rng: np.random.Generator, threads: int | None = None) -> None:
        self.params = params
        shape = params.zone_shape
        self.model = load_model("lander.xml")
        self.pad_x = float(rng.uniform(-0.5, 0.5))
        self.model.geom("pad").pos[0] = self.pad_x
        #: Centres (x, m; on the ground) and radii (m) of the keep-out zones: habitat, array.
        offsets = rng.uniform(*ZONE_OFFSETS, 2)
        self.zone_x = self.pad_x + np.array([1.0, -1.0]) * offsets
        # The craft resting on the pad stays 0.15 m outside both zones.
        reach = np.sqrt(offsets**2 + REST_HEIGHT**2) if shape == "hemisphere" else offsets
        clear = reach - 0.15
        self.zone_radii = np.minimum(rng.uniform(*params.zone_radii, 2), clear)
        for name, x, r in zip(ZONES, self.zone_x, self.zone_radii, strict=True):
            zone = self.model.geom(f"{name}_zone")
            zone.pos[0] = x
            zone.size[0] = r
            if shape == "column":  # drawn as a box up to COLUMN_HEIGHT (visual only)
                zone.type = mujoco.mjtGeom.mjGEOM_BOX
                zone.size[:] = (r, 0.6, COLUMN_HEIGHT / 2)
                zone.pos[2] = COLUMN_HEIGHT / 2
                zone.rbound = float(np.linalg.norm(zone.size))
            self.model.geom(name).pos[0] = x
        steps = round(params.horizon / self.model.opt.timestep)
        ctrl = self.model.actuator_ctrlrange
        self.spline = ControlSpline(params.knots, steps, ctrl[:, 0], ctrl[:, 1])
        #: Side of each evaluation start (0 right, 1 left): alternating.
        self.start_sides = np.arange(params.eval_starts) % 2
        #: Side of each pool start: a balanced random order.
        self.pool_sides = rng.permutation(np.arange(params.pool_starts) % 2)
        self.starts = self.sample_starts(rng, params.eval_starts, self.start_sides)
        self.pool_starts = self.sample_starts(rng, params.pool_starts, self.pool_sides)
        super().__init__(threads)

    def sample_starts(
        self, rng: np.random.Generator, count: int, sides: np.ndarray | None = None
    ) -> np.ndarray:
        """``count`` starts at rest on ``sides`` (0 right, 1 left; unset: each at random):
        ``params.start_offsets`` from the pad, ``START_HEIGHTS`` up, pitch ±0.2 rad."""
        sides = rng.integers(0, 2, count) if sides is None else np.asarray(sides)
        direction = np.where(sides == 0, 1.0, -1.0)
        return np.stack(
            [
                self.pad_x + direction * rng.uniform(*self.params.start_offsets, count),
                rng.uniform(*START_HEIGHTS, count),
                rng.uniform(-0.2, 0.2, count),
            ],
            axis=1,
        )

    def path(self, rollouts: Rollouts) -> np.ndarray:
        return rollouts.qpos[:, :, :2]

    def touchdown(self, rollouts: Rollouts) -> tuple[np.ndarray, np.ndarray]:
        """Whether each trajectory touches down, and the first step it does (0 if never)."""
        touching = (rollouts.sensordata[:, :, :2] > TOUCH_THRESHOLD).any(axis=2)
        return np.any(touching, axis=1), np.argmax(touching, axis=1)

    def step_features(self, rollouts: Rollouts, horizon: int | None = None) -> np.ndarray:
        """Fuel, tilt and the zones are shared over the horizon's steps (their sum is the mean);
        ``impact`` falls on the first step a foot touches (or, never touched, on the last step);
        the landing error on the last step."""
        b, t = rollouts.qpos.shape[:2]
        steps = horizon or t
        out = np.zeros((b, t, len(FEATURE_NAMES)))
        out[:, :, 2] = rollouts.sensordata[:, :, 2] / MAX_THRUST / steps
        pitch = np.angle(np.exp(1j * rollouts.qpos[:, :, 2]))  # wrapped to [-π, π]
        out[:, :, 3] = np.abs(pitch) / (np.pi / 2) / steps
        for j, (x, r) in enumerate(zip(self.zone_x, self.zone_radii, strict=True)):
            distance = np.abs(rollouts.qpos[:, :, 0] - x)
            if self.params.zone_shape == "hemisphere":
                distance = np.hypot(distance, rollouts.qpos[:, :, 1])
            out[:, :, 4 + j] = np.clip(r - distance, 0.0, None) / r / ZONE_SCALE / steps
        touched, first = self.touchdown(rollouts)
        # Speed just before contact (the step before the first touching step).
        rows = np.flatnonzero(touched)
        before = np.clip(first[rows] - 1, 0, None)
        out[rows, first[rows], 1] = np.abs(rollouts.qvel[rows, before, 1]) / IMPACT_SCALE
        if t == steps:  # the rollout is whole: the last step's terms
            x_end, z_end = rollouts.qpos[:, -1, 0], rollouts.qpos[:, -1, 1]
            height = np.clip(z_end - REST_HEIGHT, 0.0, None)
            out[:, -1, 0] = (np.abs(x_end - self.pad_x) + height) / LANDING_SCALE
            gravity = -self.model.opt.gravity[2]
            vz_cut = np.sqrt(rollouts.qvel[:, -1, 1] ** 2 + 2 * gravity * height)
            out[~touched, -1, 1] = vz_cut[~touched] / IMPACT_SCALE
        return out

    def baseline_knots(self) -> np.ndarray:
        """Sink at 1 m/s, held upright: a slow, unguided descent."""
        knots = np.zeros((len(self.starts), *self.spline.shape))
        knots[:, :, 0] = -1.0
        return knots
