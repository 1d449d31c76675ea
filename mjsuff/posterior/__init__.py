"""Posterior over reward weights: the MCMC sampler, its diagnostics, an exact grid check, and the
likelihood's β calibration."""

from mjsuff.posterior.calibration import BetaFit, CalibrationError, fit_beta
from mjsuff.posterior.diagnostics import (
    ChainDiagnostics,
    chain_diagnostics,
    effective_sizes,
    quantile_ess,
    rank_rhat,
)
from mjsuff.posterior.exact import GridPosterior, grid_posterior
from mjsuff.posterior.sampler import LogLikelihood, Posterior, SamplerConfig, sample_posterior

__all__ = [
    "BetaFit",
    "CalibrationError",
    "ChainDiagnostics",
    "GridPosterior",
    "LogLikelihood",
    "Posterior",
    "SamplerConfig",
    "chain_diagnostics",
    "effective_sizes",
    "fit_beta",
    "grid_posterior",
    "quantile_ess",
    "rank_rhat",
    "sample_posterior",
]
