"""mjsuff: a testbed for demonstration sufficiency (Bayesian IRL + high-confidence regret bounds).

The pipeline, one subpackage per stage: ``domains`` (tabular MDPs; MuJoCo scenes) behind the
``Domain`` seam → ``posterior`` (Bayesian IRL by MCMC on the sphere) → ``bounds`` (α-VaR bounds
on nEVD and PIOB) → ``stopping`` (ours and the baselines) → ``experiment`` (the loop, measures,
results) → ``cli``.
"""

__version__ = "0.1.0"

from mjsuff.domain import Demo, Domain, Policy

__all__ = ["Demo", "Domain", "Policy", "__version__"]
