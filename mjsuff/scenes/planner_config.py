"""The planner's budget and search settings."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field, model_validator


class PlannerConfig(BaseModel):
    """Budget of the sampling planner: a CEM phase (``population × iterations`` rollouts per
    problem), then optionally a CMA-ES phase (``cma_population × cma_iterations``) from its best."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True, allow_inf_nan=False)

    population: int = Field(64, ge=4, description="CEM: trajectories sampled per iteration")
    elites: int = Field(6, ge=1, description="CEM: best trajectories the Gaussian is refit to")
    iterations: int = Field(32, ge=0, description="CEM iterations (0: CMA-ES alone, from the warm start)")
    initial_std: float = Field(0.35, gt=0.0, description="CEM: initial s.d., as a share of the control range")
    min_std: float = Field(0.01, gt=0.0, description="CEM: s.d. floor, as a share of the control range")
    smoothing: float = Field(0.0, ge=0.0, lt=1.0, description="CEM: weight of the old mean/s.d. in a refit")
    cma_population: int = Field(0, ge=0, description="CMA-ES: samples per generation (0: no CMA-ES phase)")
    cma_iterations: int = Field(0, ge=0, description="CMA-ES generations after the CEM phase")
    cma_sigma: float = Field(
        0.1, gt=0.0, le=1.0, description="CMA-ES: initial step size, as a share of the control range"
    )

    @model_validator(mode="after")
    def _check(self) -> PlannerConfig:
        if self.elites > self.population:
            raise ValueError(f"elites ({self.elites}) exceed the population ({self.population})")
        if (self.cma_population > 0) != (self.cma_iterations > 0):
            raise ValueError(
                "cma_population and cma_iterations must both be 0 (no CMA-ES phase) "
                f"or both > 0, got {self.cma_population} and {self.cma_iterations}"
            )
        if self.budget == 0:
            raise ValueError("a planner needs CEM iterations or a CMA-ES phase (both are 0)")
        if 0 < self.cma_population < 4:
            raise ValueError(f"cma_population must be at least 4, got {self.cma_population}")
        return self

    @property
    def budget(self) -> int:
        """Rollouts per problem."""
        return self.population * self.iterations + self.cma_population * self.cma_iterations

    def stronger(self, factor: float) -> PlannerConfig:
        """The same planner with about ``factor`` × the budget, half from larger populations and
        half from more iterations (each × √factor): wider and longer search."""
        root = factor**0.5
        return self.scaled(root).model_copy(
            update={
                "iterations": round(self.iterations * root),
                "cma_iterations": round(self.cma_iterations * root),
            }
        )

    def scaled(self, factor: float) -> PlannerConfig:
        """The same planner with ``factor`` times the populations (and elites): ``factor`` × budget."""
        return self.model_copy(
            update={
                "population": int(self.population * factor),
                "elites": int(self.elites * factor),
                "cma_population": int(self.cma_population * factor),
            }
        )
