"""The planner's budget and search settings."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field


class PlannerConfig(BaseModel):
    """CEM budget: ``population × iterations`` rollouts per problem."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True, allow_inf_nan=False)

    population: int = Field(64, ge=4, description="trajectories sampled per iteration")
    elites: int = Field(6, ge=1, description="best trajectories the Gaussian is refit to")
    iterations: int = Field(32, ge=1, description="CEM iterations")
    initial_std: float = Field(0.35, gt=0.0, description="initial s.d., as a share of the control range")
    min_std: float = Field(0.01, gt=0.0, description="s.d. floor, as a share of the control range")
    smoothing: float = Field(0.0, ge=0.0, lt=1.0, description="weight of the old mean/s.d. in a refit")
    restarts: int = Field(1, ge=1, description="independent CEM runs per problem (best kept)")

    @property
    def budget(self) -> int:
        """Rollouts per problem."""
        return self.population * self.iterations * self.restarts

    def scaled(self, factor: float) -> PlannerConfig:
        """The same planner with ``factor`` times the population (and elites): ``factor`` × budget."""
        return self.model_copy(update={"population": int(self.population * factor),
                                       "elites": int(self.elites * factor)})
