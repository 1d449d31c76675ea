"""The MuJoCo scenes: physics, features and planning, and the Domain seam over them.

* ``scene`` — the ``Scene`` base: an MJCF model, randomized instances, starts, trajectory features.
* ``lava_reacher``, ``lander`` — the two scenes, each with its parameter model (``params``: what
  every scene domain takes besides its physics, the expert's settings included).
* ``spline``, ``simulate`` — control knots, batched rollouts through ``mujoco.rollout``.
* ``planner`` (with ``planner_config``, ``cma``), ``planning``, ``surrogate``, ``library``,
  ``perturbation`` — trajectory optimization, budgets, ``V*`` polishing, per-start libraries.
* ``domain`` — ``SceneDomain``: a scene instance as a ``mjsuff.domain.Domain``.

Nothing is imported here: importing a submodule must not pull in the others.
"""
