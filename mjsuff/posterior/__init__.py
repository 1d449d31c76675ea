"""Posterior over reward weights: the likelihood (Eq. 1 with a lapse rate), the MCMC sampler, its
diagnostics, an exact grid check, and the likelihood's calibration (β, and the lapse rate)."""

from mjsuff.posterior.calibration import BetaFit, CalibrationError, LapseFit, fit_beta, fit_lapse
from mjsuff.posterior.diagnostics import (
    ChainDiagnostics,
    chain_diagnostics,
    effective_sizes,
    quantile_ess,
    rank_rhat,
)
from mjsuff.posterior.exact import GridPosterior, grid_posterior
from mjsuff.posterior.likelihood import lapse_log_likelihood
from mjsuff.posterior.sampler import LogLikelihood, Posterior, SamplerConfig, sample_posterior

__all__ = [
    "BetaFit",
    "CalibrationError",
    "ChainDiagnostics",
    "GridPosterior",
    "LapseFit",
    "LogLikelihood",
    "Posterior",
    "SamplerConfig",
    "chain_diagnostics",
    "effective_sizes",
    "fit_beta",
    "fit_lapse",
    "grid_posterior",
    "lapse_log_likelihood",
    "quantile_ess",
    "rank_rhat",
    "sample_posterior",
]
