"""mjsuff: a testbed for demonstration sufficiency (Bayesian IRL + high-confidence regret bounds).

The pipeline, one subpackage per stage: ``domains`` (tabular MDPs; MuJoCo scenes) behind the
``Domain`` seam → ``posterior`` (Bayesian IRL by MCMC on the sphere) → ``bounds`` (α-VaR bounds
on nEVD and PIOB) → ``stopping`` (ours and the baselines) → ``experiment`` (the loop, measures,
results) → ``cli``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"

__all__ = ["Demo", "Domain", "FinalTruth", "Policy", "__version__"]

if TYPE_CHECKING:  # type checkers see the names themselves (and a misspelt one is an error)
    from mjsuff.domain import Demo, Domain, FinalTruth, Policy
else:

    def __getattr__(name: str) -> Any:
        """``Demo``, ``Domain``, ``FinalTruth`` and ``Policy`` are imported on first use, so that ``import
        mjsuff`` (and the command line's entry point, :mod:`mjsuff.cli.entry`) imports nothing
        heavy."""
        if name in ("Demo", "Domain", "FinalTruth", "Policy"):
            import mjsuff.domain

            return getattr(mjsuff.domain, name)
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
