"""Posterior over reward weights: the MCMC sampler, its diagnostics, an exact grid check, and the
likelihood's β calibration."""

from mjsuff.posterior.calibration import BetaFit, CalibrationError, fit_beta
from mjsuff.posterior.diagnostics import split_rhat
from mjsuff.posterior.exact import GridPosterior, grid_posterior
from mjsuff.posterior.sampler import LogLikelihood, Posterior, SamplerConfig, sample_posterior

__all__ = [
    "BetaFit",
    "CalibrationError",
    "GridPosterior",
    "LogLikelihood",
    "Posterior",
    "SamplerConfig",
    "fit_beta",
    "grid_posterior",
    "sample_posterior",
    "split_rhat",
]
