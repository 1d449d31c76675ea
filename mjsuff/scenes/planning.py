"""How a scene instance plans: the budgets of π_MAP, of ``V*`` refinement and of ground truth.

A scenario sets them under ``[domain.params.planning]``; they trade run time against how close
π_MAP and ``V*`` come to the true optimum (see benchmarks/scene_check.py for the cost).
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from mjsuff.scenes.planner_config import PlannerConfig


class PlanningSettings(BaseModel):
    """Planning budgets of a scene domain (``population × iterations`` rollouts per problem)."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True, allow_inf_nan=False)

    planner: PlannerConfig | None = Field(
        None, description="π for a reward vector (π_MAP); unset = the scene's tested default"
    )
    refine: PlannerConfig | None = Field(
        None,
        description="one warm-started refinement of V* for a group of reward vectors; "
        "unset = the scene's tested default",
    )
    refine_groups: int = Field(16, ge=0, description="most weight groups refined per start and round")
    refine_rounds: int = Field(2, ge=0, description="refinement rounds per V* call")
    tail_share: float = Field(
        0.15,
        gt=0.0,
        le=1.0,
        description="V*: the share of samples with the largest nEVD whose V* is refined (the "
        "upper tail decides the bound)",
    )
    decisive: PlannerConfig | None = Field(
        None,
        description="V*: the planner of the plan_samples stage (the samples that can move the "
        "bound, each warm-started from the library); a whole planner: keys left out take "
        "PlannerConfig's defaults, not π's; unset = π's planner",
    )
    decisive_second: PlannerConfig | None = Field(
        None,
        description="V*: a second search of each plan_samples (sample, start) with this planner, "
        "from the same warm start as the first (for another basin; both join the library); a "
        "whole planner as decisive is; unset = none",
    )
    plan_samples: int = Field(
        0,
        ge=0,
        description="V*: this many samples that can move the bound (from its order "
        "statistic down, after the groups' refinement) planned one "
        "by one with π's budget (or decisive's) from every evaluation start, warm-started "
        "from the library; 0: none",
    )
    polish_rounds: int = Field(
        2,
        ge=0,
        description="V*: rounds of the local quadratic model's proposals for the nEVD "
        "tail's samples from every evaluation start, after refinement "
        "(mjsuff.scenes.surrogate); π's plans are polished as many rounds",
    )
    polish_extra_rounds: int = Field(
        0,
        ge=0,
        description="V*: after those, up to this many more polish rounds, each only while the "
        "round before raised some tail sample's V* from some evaluation start by more than "
        "polish_extra_gain of its V* − V_rand there (a wide posterior's tail; π's plans get "
        "none); needs polish_rounds ≥ 1",
    )
    polish_extra_gain: float = Field(
        0.01,
        gt=0.0,
        lt=1.0,
        description="the raise (a share of V* − V_rand) above which an extra polish round runs",
    )
    polish_neighbours: int = Field(
        160,
        ge=60,
        description="library entries each of those models is fitted to (a quadratic "
        "in the knots has 1 + n + n(n+1)/2 coefficients: 55 for 9 knots)",
    )
    revisit_cosine: float = Field(
        0.999,
        gt=0.0,
        le=1.0,
        description="a group within this cosine of a direction already refined from the same "
        "start is not refined again",
    )
    replan_cosine: float | None = Field(
        None,
        gt=0.0,
        le=1.0,
        description="π from the evaluation starts for a reward within this cosine of any reward "
        "π was planned for earlier on the instance (every earlier MAP, full or held-out, "
        "whichever budget planned it) is planned with the refinement budget instead, "
        "warm-started from the library as always (pool plans keep π's budget); unset: always "
        "π's budget",
    )
    seed_directions: int = Field(
        8,
        ge=1,
        description="prior draws (all-negative reward directions) planned from every "
        "start up front: the random policy, and the library's seed",
    )
    seed_zeroed: tuple[str, ...] = Field(
        (),
        strict=False,
        description="feature names (a list): for each, one more direction planned from every "
        "start beside the seed_directions, that feature's weight 0 and every other −1/√(k−1) (the "
        "route a reward that ignores it takes, e.g. through a keep-out zone); empty: none. Setting "
        "it changes the instance's random stream (the seed plans draw from it)",
    )
    seed_planner: PlannerConfig | None = Field(
        None,
        description="budget of those plans (warm-started from the library); unset = the "
        "scene's tested default",
    )
    truth_scale: float = Field(
        4.0,
        ge=1.0,
        description="ground truth plans w* with about this × the planner's budget (PlannerConfig.stronger)",
    )
    truth_passes: int = Field(
        0,
        ge=0,
        le=16,
        description="when a replicate ends, ground truth searches again, from its own plans and the "
        "learner's best under w*, until a search raises no evaluation start by more than 0.001 of "
        "V* − V_rand, at most this many times (0: only raised to the best simulated)",
    )
    truth_cloud_every_pass: bool = Field(
        True,
        description="those searches plan the rewards around w* first in every pass; false: only "
        "in the first (after it the cloud is about 58% of a pass's steps and raised no start by "
        "more than 0.001 in 7 passes, stop 55, benchmarks/truth_phases.py)",
    )

    @field_validator("seed_zeroed", mode="before")
    @classmethod
    def _names_as_a_list(cls, value: object) -> object:
        if isinstance(value, str):
            raise ValueError(f'expected a list of feature names, e.g. ["{value}"] (got the string {value!r})')
        if not isinstance(value, list | tuple):  # a set's order would vary from run to run
            raise ValueError(f"expected a list of feature names (got {value!r})")
        return value

    @model_validator(mode="after")
    def _check(self) -> PlanningSettings:
        if self.polish_extra_rounds and not self.polish_rounds:
            raise ValueError(
                f"polish_extra_rounds ({self.polish_extra_rounds}) needs polish_rounds ≥ 1: an "
                "extra round runs only after a round that raised the tail's V*"
            )
        return self

    def resolved(
        self, planner: PlannerConfig, refine: PlannerConfig, seed: PlannerConfig
    ) -> PlanningSettings:
        """These settings with a scene's tested ``planner``, ``refine`` and ``seed_planner``
        where they are unset."""
        return self.model_copy(
            update={
                "planner": self.planner or planner,
                "refine": self.refine or refine,
                "seed_planner": self.seed_planner or seed,
            }
        )

    def check_seed_zeroed(self, features: tuple[str, ...]) -> None:
        """``ValueError`` unless ``seed_zeroed`` names distinct features among ``features`` (each
        extra direction zeroes one of them and keeps the others, so a scene needs two or more)."""
        names = self.seed_zeroed
        if not names:
            return
        if len(features) < 2:
            reason = (
                "this scene declares no feature names"
                if not features
                else "a scene of one feature has no other weight to keep"
            )
            raise ValueError(f"planning.seed_zeroed: {reason} (expected it empty)")
        unknown = list(dict.fromkeys(name for name in names if name not in features))
        twice = sorted({name for name in names if names.count(name) > 1})
        problem = None
        if unknown:
            verb = "is not a feature" if len(unknown) == 1 else "are not features"
            problem = f"{', '.join(map(repr, unknown))} {verb} of this scene"
        elif twice:
            problem = f"{', '.join(map(repr, twice))} given more than once"
        if problem:
            raise ValueError(
                f"planning.seed_zeroed: {problem} (expected distinct names among: {', '.join(features)})"
            )
