"""Posterior over reward weights: the MCMC sampler, its diagnostics, and an exact grid check."""

from mjsuff.posterior.diagnostics import split_rhat
from mjsuff.posterior.exact import GridPosterior, grid_posterior
from mjsuff.posterior.sampler import LogLikelihood, Posterior, SamplerConfig, sample_posterior

__all__ = [
    "GridPosterior",
    "LogLikelihood",
    "Posterior",
    "SamplerConfig",
    "grid_posterior",
    "sample_posterior",
    "split_rhat",
]
