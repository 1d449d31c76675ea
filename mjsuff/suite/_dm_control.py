"""dm_control's classes, imported once with its import-time noise silenced.

Without a display, GLFW warns on import (``X11: The DISPLAY environment variable is missing``);
nothing here renders, and rendering, when asked for, falls back to EGL or OSMesa (``MUJOCO_GL``).
"""

import warnings

with warnings.catch_warnings():
    warnings.filterwarnings("ignore", message=".*DISPLAY.*")
    from dm_control.mujoco import Physics
    from dm_control.mujoco.wrapper import MjModel
    from dm_control.rl import control
    from dm_control.suite import base

__all__ = ["MjModel", "Physics", "base", "control"]
