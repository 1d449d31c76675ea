"""How each kind of domain is drawn in a recording.

A view logs the instance once (``log_instance``) and, per demo step, the new demo and the robot's
policy (``log_step``) under a replicate's root entity path. A domain's spec names its view
(``DomainSpec.view``); the recorder never asks what kind of domain it holds.
"""

from __future__ import annotations

import numpy as np
import rerun as rr

from mjsuff.domain import Demo, Domain, Policy
from mjsuff.domains.tabular import TabularDomain
from mjsuff.recording.scene_logger import SceneLogger
from mjsuff.scenes.domain import SceneDomain

#: Colours of up to 10 one-hot features (RGB), e.g. gridworld terrain, driving lanes.
FEATURE_COLOURS = np.array(
    [
        [70, 130, 180],
        [240, 200, 80],
        [120, 180, 90],
        [200, 80, 80],
        [150, 110, 200],
        [90, 200, 200],
        [230, 140, 60],
        [160, 160, 160],
        [100, 60, 40],
        [250, 120, 200],
    ],
    dtype=np.uint8,
)
DEMO_COLOUR = [30, 90, 255]
POOR_DEMO_COLOUR = [255, 60, 60]
POLICY_COLOUR = [20, 170, 60]


class DomainView:
    """Draws one domain instance under ``root`` on the ``demo`` and ``sim_time`` timelines."""

    def __init__(self, domain: Domain, recording: rr.RecordingStream, root: str) -> None:
        self.domain = domain
        self.recording = recording
        self.root = root

    def log_instance(self) -> None:
        """The instance itself (static)."""

    def log_step(self, step: int, demo: Demo, policy: Policy) -> None:
        """The demo just shown and the robot's policy after it (timeline ``demo`` = ``step``)."""

    def eye(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Where the 3-D view's camera starts: (position, look target), or None for the default."""
        return None


class SceneView(DomainView):
    """MuJoCo scenes: geometry, each demo's executed path and motion, π_MAP's paths."""

    def __init__(self, domain: Domain, recording: rr.RecordingStream, root: str) -> None:
        if not isinstance(domain, SceneDomain):
            raise TypeError(f"SceneView draws a SceneDomain, not a {type(domain).__name__}")
        super().__init__(domain, recording, root)
        self.scene = domain.scene
        self.logger = SceneLogger(self.scene.model, recording, f"{root}/scene")
        self.horizon = self.scene.spline.num_steps * self.scene.model.opt.timestep

    def _lift(self, path: np.ndarray) -> np.ndarray:
        out = np.zeros((*path.shape[:-1], 3))
        out[..., list(self.scene.path_axes)] = path
        return out

    def eye(self) -> tuple[np.ndarray, np.ndarray]:
        """Framing the moving bodies and the sites (goal, pad) at the first start, from the side
        the motion is seen best: above a horizontal path, in front of a vertical one."""
        pos, _ = self.logger.body_poses(self.scene.starts[:1])
        points = np.concatenate([pos[0, 1:], self.logger.site_positions(self.scene.starts[0])])
        low, high = points.min(axis=0), points.max(axis=0)
        target = (low + high) / 2
        radius = max(float(np.linalg.norm(high - low)) / 2, 0.2)
        normal = ({0, 1, 2} - set(self.scene.path_axes)).pop()
        direction = np.array([0.0, -0.6, 1.0]) if normal == 2 else np.array([0.0, -1.0, 0.35])
        return target + 2.2 * radius * direction / np.linalg.norm(direction), target

    def log_instance(self) -> None:
        self.logger.log_geometry()
        rest = self.scene.starts[:1]
        self.logger.log_motion(rest, [rr.TimeColumn("sim_time", duration=[0.0])])

    def log_step(self, step: int, demo: Demo, policy: Policy) -> None:
        rec = self.recording
        colour = POOR_DEMO_COLOUR if demo.poor else DEMO_COLOUR
        rec.log(
            f"{self.root}/scene/demos/{step}",
            rr.LineStrips3D([self._lift(np.asarray(demo.data["executed"]))], radii=0.004, colors=[colour]),
        )
        rollouts, _ = self.scene.simulate(self.scene.starts, policy)
        rec.log(
            f"{self.root}/scene/pi_map",
            rr.LineStrips3D(self._lift(self.scene.path(rollouts)), radii=0.002, colors=[POLICY_COLOUR]),
        )
        # The demo's executed motion, played back on sim_time: demo n occupies
        # [(n - 1) · horizon, n · horizon).
        qpos = np.asarray(demo.data["qpos"])
        times = (step - 1) * self.horizon + np.arange(len(qpos)) * self.scene.model.opt.timestep
        self.logger.log_motion(
            qpos,
            [
                rr.TimeColumn("sim_time", duration=times),
                rr.TimeColumn("demo", sequence=np.full(len(qpos), step)),
            ],
        )


class TabularView(DomainView):
    """Tabular domains: the grid, cells coloured by their (largest) feature, the policy as arrows."""

    domain: TabularDomain

    def __init__(self, domain: Domain, recording: rr.RecordingStream, root: str) -> None:
        if not isinstance(domain, TabularDomain):
            raise TypeError(f"TabularView draws a TabularDomain, not a {type(domain).__name__}")
        super().__init__(domain, recording, root)

    def log_instance(self) -> None:
        layout = self.domain.layout
        feats = self.domain.mdp.features
        colours = FEATURE_COLOURS[np.argmax(feats, axis=1) % len(FEATURE_COLOURS)]
        self.recording.log(
            f"{self.root}/grid/cells",
            rr.Boxes3D(
                centers=self._xy(layout),
                half_sizes=[[0.48, 0.48, 0.01]] * len(layout),
                colors=colours,
                fill_mode="solid",
            ),
            static=True,
        )

    def eye(self) -> tuple[np.ndarray, np.ndarray]:
        xy = self._xy(self.domain.layout)
        target = (xy.min(axis=0) + xy.max(axis=0)) / 2
        size = float(np.ptp(xy, axis=0).max()) + 1
        return target + size * np.array([0.0, -0.9, 1.1]), target

    @staticmethod
    def _xy(layout: np.ndarray) -> np.ndarray:
        """Cells (row, col) -> points (x = col, y = -row, z = 0): row 0 on top."""
        return np.stack([layout[:, 1], -layout[:, 0], np.zeros(len(layout))], axis=1)

    def _moves(self) -> np.ndarray:
        """Expected displacement (S, A, 3) of every action on the drawn grid."""
        p = self.domain.mdp.transitions
        xy = self._xy(self.domain.layout)
        return np.einsum("sat,tk->sak", p, xy) - xy[:, None, :] * p.sum(axis=2, keepdims=True)

    def log_step(self, step: int, demo: Demo, policy: Policy) -> None:
        xy = self._xy(self.domain.layout)
        moves = self._moves()
        live = ~self.domain.mdp.terminal
        states = np.flatnonzero(live)
        vectors = 0.4 * moves[states, np.asarray(policy)[states]]
        self.recording.log(
            f"{self.root}/grid/pi_map",
            rr.Arrows3D(origins=xy[states] + [0, 0, 0.05], vectors=vectors, colors=[POLICY_COLOUR]),
        )
        if demo.action >= 0:
            colour = POOR_DEMO_COLOUR if demo.poor else DEMO_COLOUR
            self.recording.log(
                f"{self.root}/grid/demos/{step}",
                rr.Arrows3D(
                    origins=[xy[demo.start] + [0, 0, 0.1]],
                    vectors=[0.45 * moves[demo.start, demo.action]],
                    colors=[colour],
                    radii=0.05,
                ),
            )
