"""What every MuJoCo scene domain takes besides its physics (``domain.params`` of a scene scenario).

``ExpertSettings`` (how the kinesthetic expert demonstrates, ``domain.params.expert``) is here, with
the scene's other settings, rather than in ``mjsuff.experts``: the experts read it; the scenes'
parameter models hold it.

A scene's parameter model (``LavaReacherParams``, ``LanderParams``) extends ``SceneParams`` with its
own trajectory length and control knots. Everything a scene run reads about the scene, its expert
and its trajectory comparisons lives here, so the generic scenario holds nothing a tabular run would
silently ignore.
"""

from __future__ import annotations

from typing import ClassVar, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from mjsuff.scenes.planning import PlanningSettings

Candidates = Literal["library", "family"]


class ExpertSettings(BaseModel):
    """How an expert demonstrates (a scene's ``domain.params.expert`` table)."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True, allow_inf_nan=False)

    rationality: float | None = Field(
        None, gt=0.0, description="Boltzmann rationality over candidates; none = always the best"
    )
    refine_rounds: int = Field(2, ge=0, le=10, description="local refinement rounds around the best path")
    refine_candidates: int = Field(16, ge=1, le=256, description="candidates per refinement round")
    correction_rounds: int = Field(
        0,
        ge=0,
        le=1000,
        description="most rounds of correcting the chosen demo by smooth control "
        "perturbations (64 rollouts each); 0 = none",
    )
    correction_patience: int = Field(
        3, ge=1, le=100, description="correction stops after this many rounds in a row without improvement"
    )


class SceneParams(BaseModel):
    """Settings shared by every scene domain (subclasses add ``horizon`` and ``knots``)."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)
    #: The scene's feature names (the names ``planning.seed_zeroed`` may give).
    feature_names: ClassVar[tuple[str, ...]] = ()

    eval_starts: int = Field(6, ge=1, le=256, description="fixed evaluation starts (never demonstrated)")
    pool_starts: int = Field(10, ge=1, le=256, description="starts a demonstration can be asked from")
    planning: PlanningSettings = Field(PlanningSettings(), description="planning budgets")
    expert: ExpertSettings = Field(ExpertSettings(), description="how the kinesthetic expert demonstrates")
    candidates: Candidates = Field(
        "library",
        description="what the likelihood compares a demo with besides random trajectories and "
        "its own perturbations: the library's optima for fixed reward directions, or the "
        "demonstrator's own first candidates (its path family) from the demo's start",
    )
    unchanged_tolerance: float = Field(
        0.05,
        gt=0.0,
        description="π_MAP counts as unchanged (patience) when its trajectory features from every "
        "evaluation start moved by at most this (feature units)",
    )
    match_tolerance: float = Field(
        0.1,
        gt=0.0,
        description="π_MAP matches a held-out demo (validation set) when its trajectory features "
        "from the demo's start are within this of the demo's (feature units)",
    )

    @model_validator(mode="after")
    def _known_features(self) -> SceneParams:
        self.planning.check_seed_zeroed(self.feature_names)
        return self
