"""Smooth perturbations of a trajectory's per-step controls.

Both sides of a demonstration use the same family of nearby motions: the likelihood compares a
demo with its own perturbations (``SceneDomain.candidate_features``), and an expert corrects its
demo against them (``Expert.correct``). A perturbation adds to the controls ``u_t`` an offset
that is piecewise linear over the spline's knot instants (hat functions, zero at t = 0 so the
motion starts where it did), Gaussian at each knot with standard deviation ``size`` × the
control range, and is clipped to the range the controls already span or the spline allows.
"""

from __future__ import annotations

import numpy as np

from mjsuff.scenes.spline import ControlSpline

#: Perturbed copies per size; the sizes as shares of the control range (64 copies in all).
PERTURBATIONS = 16
PERTURBATION_SIZES = (0.02, 0.05, 0.1, 0.2)


def perturb_controls(
    spline: ControlSpline,
    controls: np.ndarray,
    rng: np.random.Generator,
    count: int = PERTURBATIONS,
    sizes: tuple[float, ...] = PERTURBATION_SIZES,
) -> np.ndarray:
    """``count`` smooth perturbations per size of per-step controls ``(T, nu)`` -> ``(count ·
    len(sizes), T, nu)`` (same units as the controls)."""
    controls = np.asarray(controls, dtype=float)
    knots = spline.num_knots + 1
    basis = np.clip(
        1.0
        - np.abs(np.linspace(0, 1, len(controls))[:, None] - np.linspace(0, 1, knots)[None, :]) * (knots - 1),
        0.0,
        None,
    )
    spread = np.repeat(np.asarray(sizes, dtype=float), count)
    noise = rng.standard_normal((len(spread), knots, spline.num_controls))
    noise[:, 0] = 0.0
    offsets = np.einsum("tk,bku->btu", basis, noise * spread[:, None, None])
    low = np.minimum(spline.low, controls.min(axis=0))
    high = np.maximum(spline.high, controls.max(axis=0))
    return np.clip(controls + offsets * (spline.high - spline.low), low, high)
