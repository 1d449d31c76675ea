"""mink path tracking: a reachable path is followed, an unreachable one is a reported failure."""

import numpy as np
import pytest

from mjsuff.experts.ik import IKFailure, IKSettings, PathTracker
from mjsuff.scenes.lava_reacher import LavaReacher, LavaReacherParams, fingertip_xy

HOME = np.array([-1.2, 1.3, 0.9])  # a comfortable posture, fingertip near (0.23, 0)


@pytest.fixture(scope="module")
def scene():
    return LavaReacher(LavaReacherParams(eval_starts=2), np.random.default_rng(0))


def line(start, end, steps):
    s = np.linspace(0.0, 1.0, steps)[:, None]
    xy = (1 - s) * start + s * end
    return np.column_stack([xy, np.zeros(steps)])


def test_reachable_path_is_followed_within_a_millimetre(scene):
    tip = fingertip_xy(HOME)
    path = line(tip, tip + np.array([0.05, 0.08]), 101)
    ref = PathTracker(scene.model, "fingertip", "site").track(HOME, path, 0.01)
    assert ref.qpos.shape == (101, 3) and ref.qvel.shape == ref.qacc.shape == (101, 3)
    assert ref.residual.max() < 1e-3
    # Between IK samples the spline reference still traces the path (forward kinematics).
    assert np.linalg.norm(fingertip_xy(ref.qpos) - path[:, :2], axis=1).max() < 1e-3
    np.testing.assert_allclose(ref.qpos[0], HOME, atol=1e-9)


def test_unreachable_target_raises_with_the_step(scene):
    tip = fingertip_xy(HOME)
    path = line(tip, np.array([0.5, 0.0]), 101)  # the arm reaches 0.36 m
    with pytest.raises(IKFailure, match=r"missed by .* mm"):
        PathTracker(scene.model, "fingertip", "site").track(HOME, path, 0.01)


def test_settings_are_validated():
    with pytest.raises(ValueError, match="stride"):
        IKSettings(stride=0)
    with pytest.raises(ValueError, match="tolerance"):
        IKSettings(tolerance=0.0)
