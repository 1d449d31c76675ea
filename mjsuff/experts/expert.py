"""Scripted kinesthetic experts: candidate task-space paths, mink IK, execution in MuJoCo, choice.

An expert demonstrates from a start the way a person guiding the robot by hand would: it considers a
family of task-space paths (its *candidates*), turns each into joint motion with mink, executes it
in MuJoCo, and judges the executed trajectories by the hidden reward ``w* · φ``. A perfectly rational
expert shows the best one; a Boltzmann expert with rationality ``β_E`` picks candidate ``c`` with
probability ∝ ``exp(β_E w*·φ_c)``; a deliberately poor demo is drawn uniformly from the worse half of
the candidates. The executed rollout (never the plan) is the demonstration.

*Correction* (``correction_rounds`` > 0; not for poor or Boltzmann demos): the expert then corrects
its chosen motion by hand the way the learner's likelihood probes it — smooth perturbations of the
executed controls (``mjsuff.scenes.perturbation``), simulated; the best one replaces the demo when
``w*`` values it higher — until ``correction_patience`` rounds in a row improve nothing. A demo
the likelihood compares with its own perturbations is then (locally) what the likelihood assumes:
not beaten by them under ``w*``. Without it, the mink path family's systematic shortfall (a few
knots of a fitted path) is beaten under ``w*`` by some perturbations in a direction shared by all of
an instance's demos, and more demos make the posterior surer of a reward that is not ``w*``
(docs/issue-17-history.md, "Why the bound misses").
"""

from __future__ import annotations

import abc
from dataclasses import dataclass, field

import numpy as np

from mjsuff.scenes.params import ExpertSettings
from mjsuff.scenes.perturbation import perturb_controls
from mjsuff.scenes.scene import Scene
from mjsuff.scenes.simulate import Rollouts


class ExpertError(RuntimeError):
    """The expert could not produce a demonstration (e.g. every candidate path failed IK)."""


@dataclass(frozen=True)
class ExecutedPaths:
    """Candidate paths as intended and as executed.

    Attributes:
        params: ``(C, p)`` path parameters.
        intended: ``(C, T, d)`` the task-space path each candidate meant to follow (m), at the end
            of every simulated step.
        executed: ``(C, T, d)`` the path MuJoCo executed, at the same instants.
        rollouts: The executed trajectories (``None`` when there are none).
        features: ``(C, k)`` their features (NaN where diverged).
        tracking_error: ``(C,)`` largest distance between intended and executed path (m).
        knots: ``(C, K, nu)`` the spline knots that were executed, when the expert acts through
            the robot's own control spline (the reacher); None when its controls are not a
            spline (the lander's closed-loop thrust controller).
    """

    params: np.ndarray
    intended: np.ndarray
    executed: np.ndarray
    rollouts: Rollouts | None
    features: np.ndarray
    tracking_error: np.ndarray
    knots: np.ndarray | None = None

    @classmethod
    def empty(cls) -> ExecutedPaths:
        """No candidate could be executed."""
        return cls(
            np.empty((0, 0)), np.empty((0, 0, 0)), np.empty((0, 0, 0)), None, np.empty((0, 0)), np.empty(0)
        )


@dataclass(frozen=True)
class ExpertDemo:
    """One executed demonstration and how it was chosen.

    Attributes:
        start_qpos: ``(nq,)`` the start configuration.
        qpos, qvel: ``(T, nq)``, ``(T, nv)`` executed states after each step.
        controls: ``(T, nu)`` applied controls.
        features: ``(k,)`` features of the executed trajectory.
        intended: ``(T, d)`` the task-space path the expert meant (m).
        executed: ``(T, d)`` the task-space path MuJoCo executed (m).
        tracking_error: Largest distance between them (m).
        params: The chosen path's parameters.
        value: ``w* · φ`` of the demo; ``best_value``: of the best candidate.
        candidates: Candidates executed; ``ik_failures``: candidates mink could not follow.
        poor: Whether it was a deliberately poor demo.
        corrections: Correction rounds that improved the demo (see the module docs).
    """

    start_qpos: np.ndarray
    qpos: np.ndarray
    qvel: np.ndarray
    controls: np.ndarray
    features: np.ndarray
    intended: np.ndarray
    executed: np.ndarray
    tracking_error: float
    params: np.ndarray
    value: float
    best_value: float
    candidates: int
    ik_failures: int
    poor: bool = False
    failures: list[str] = field(default_factory=list)
    corrections: int = 0


class Expert(abc.ABC):
    """A scene's scripted demonstrator.

    Subclasses say which paths they consider (``coarse_params``, ``perturb``) and how one is
    turned into an executed trajectory (``execute``).
    """

    def __init__(self, scene: Scene, settings: ExpertSettings | None = None) -> None:
        self.scene = scene
        self.settings = settings or ExpertSettings()
        self._first: dict[bytes, tuple[ExecutedPaths, list[str]]] = {}

    @abc.abstractmethod
    def coarse_params(self, start_qpos: np.ndarray) -> np.ndarray:
        """The expert's first candidates from a start: path parameters ``(C, p)``."""

    @abc.abstractmethod
    def perturb(self, params: np.ndarray, rng: np.random.Generator, count: int, scale: float) -> np.ndarray:
        """``count`` candidates near ``params`` ``(p,)``, spread ``scale`` (1 = the coarse grid's)."""

    def primitives(self, start_qpos: np.ndarray) -> np.ndarray:
        """A reward-agnostic family of paths from a start ``(C, p)`` (default: the coarse grid):
        executed once per start, they seed the robot's trajectory library when the expert acts
        through the robot's spline (``ExecutedPaths.knots``)."""
        return self.coarse_params(start_qpos)

    def executed_primitives(self, start_qpos: np.ndarray) -> ExecutedPaths:
        """``primitives(start_qpos)`` executed; where they are the first candidates (the default),
        the execution :meth:`first_candidates` keeps."""
        params = self.primitives(start_qpos)
        if np.array_equal(params, self.coarse_params(start_qpos)):
            return self.first_candidates(start_qpos)[0]
        return self.execute(start_qpos, params)[0]

    @abc.abstractmethod
    def random_params(self, start_qpos: np.ndarray, rng: np.random.Generator, count: int) -> np.ndarray:
        """``count`` random goal-directed paths ``(count, p)`` of the family: parameters drawn
        uniformly over their ranges, each path ending at the goal (the scenes' random policy)."""

    @abc.abstractmethod
    def execute(self, start_qpos: np.ndarray, params: np.ndarray) -> tuple[ExecutedPaths, list[str]]:
        """Track and execute candidate paths; -> those mink could follow, and why the rest failed."""

    def first_candidates(self, start_qpos: np.ndarray) -> tuple[ExecutedPaths, list[str]]:
        """``execute(start_qpos, coarse_params(start_qpos))``, computed once per start.

        Tracking (mink, from the start's configuration) and simulation are deterministic, so the
        demo from a start and the learner's candidate set of that demo (``"family"``,
        ``mjsuff.scenes.candidates``) share one execution instead of running the same one twice
        (about 0.3 s on the lander and 0.4–0.9 s on the reacher per start; ~1 MB kept per start
        asked for). The failures are a fresh list each call.
        """
        key = np.asarray(start_qpos, dtype=float).tobytes()
        if key not in self._first:
            self._first[key] = self.execute(start_qpos, self.coarse_params(start_qpos))
        done, failures = self._first[key]
        return done, list(failures)

    @abc.abstractmethod
    def task_path(self, qpos: np.ndarray) -> np.ndarray:
        """The task-space path ``(B, T, d)`` (m) of joint positions ``(B, T, nq)``, as in
        ``ExecutedPaths``."""

    def correct(
        self,
        start_qpos: np.ndarray,
        controls: np.ndarray,
        value: float,
        weights: np.ndarray,
        rng: np.random.Generator,
    ) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None, int]:
        """Correct executed ``controls`` ``(T, nu)`` worth ``value`` under ``weights``: -> the best
        corrected ``(qpos, qvel, controls, features)`` (None if no round improved) and the
        rounds that improved."""
        best, improved, idle = None, 0, 0
        for _ in range(self.settings.correction_rounds):
            batch = perturb_controls(self.scene.spline, controls, rng)
            rollouts, features = self.scene.simulate_controls(start_qpos[None], batch)
            values = np.where(np.isfinite(features).all(axis=1), features @ weights, -np.inf)
            i = int(np.argmax(values))
            if values[i] > value:
                best = (rollouts.qpos[i], rollouts.qvel[i], rollouts.controls[i], features[i])
                controls, value, improved, idle = batch[i], float(values[i]), improved + 1, 0
            else:
                idle += 1
                if idle >= self.settings.correction_patience:
                    break
        return best, improved

    def demonstrate(
        self, start_qpos: np.ndarray, weights: np.ndarray, rng: np.random.Generator, poor: bool = False
    ) -> ExpertDemo:
        """A demonstration from ``start_qpos`` judged by hidden ``weights``; see the module docs."""
        weights = np.asarray(weights, dtype=float)
        done, failures = self.first_candidates(start_qpos)
        pools = [done]
        best = self._best(done, weights)
        for r in range(self.settings.refine_rounds):
            if best is None:
                break
            params = self.perturb(best[0], rng, self.settings.refine_candidates, 0.5 ** (r + 1))
            more, why = self.execute(start_qpos, params)
            pools.append(more)
            failures += why
            candidate = self._best(more, weights)
            if candidate is not None and candidate[1] > best[1]:
                best = candidate
        if best is None:
            raise ExpertError("no candidate path could be followed: " + "; ".join(failures[:3]))
        pools = [p for p in pools if len(p.params)]
        where = [(p, j) for p in pools for j in range(len(p.params))]  # flat index -> (pool, row)
        values = np.concatenate([p.features @ weights for p in pools])
        values = np.where(np.isfinite(values), values, -np.inf)
        usable = np.flatnonzero(np.isfinite(values))
        if poor:
            worse = usable[values[usable] <= np.median(values[usable])]
            pick = int(rng.choice(worse))
        elif self.settings.rationality is None:
            pick = int(np.argmax(values))
        else:
            logits = self.settings.rationality * (values[usable] - values[usable].max())
            p = np.exp(logits)
            pick = int(rng.choice(usable, p=p / p.sum()))
        chosen, j = where[pick]
        if chosen.rollouts is None:
            raise ExpertError("the chosen candidate was never executed")
        rollouts = chosen.rollouts  # copied out: ``first_candidates`` keeps its arrays
        qpos, qvel, controls = rollouts.qpos[j].copy(), rollouts.qvel[j].copy(), rollouts.controls[j].copy()
        features, executed = chosen.features[j].copy(), chosen.executed[j].copy()
        error = float(chosen.tracking_error[j])
        value, corrections = float(values[pick]), 0
        if not poor and self.settings.rationality is None:
            start_qpos = np.asarray(start_qpos, dtype=float)
            fixed, corrections = self.correct(start_qpos, controls, value, weights, rng)
            if fixed is not None:
                qpos, qvel, controls, features = fixed
                executed = self.task_path(qpos[None])[0]
                error = float(np.linalg.norm(executed - chosen.intended[j], axis=1).max())
                value = float(features @ weights)
        return ExpertDemo(
            start_qpos=np.asarray(start_qpos, dtype=float).copy(),
            qpos=qpos,
            qvel=qvel,
            controls=controls,
            features=features,
            intended=chosen.intended[j].copy(),
            executed=executed,
            tracking_error=error,
            params=chosen.params[j].copy(),
            value=value,
            best_value=max(value, float(values[usable].max())),
            candidates=len(values),
            ik_failures=len(failures),
            poor=poor,
            failures=failures,
            corrections=corrections,
        )

    @staticmethod
    def _best(paths: ExecutedPaths, weights: np.ndarray) -> tuple[np.ndarray, float] | None:
        if not len(paths.params):
            return None
        values = paths.features @ weights
        if not np.isfinite(values).any():
            return None
        i = int(np.nanargmax(values))
        return paths.params[i], float(values[i])
