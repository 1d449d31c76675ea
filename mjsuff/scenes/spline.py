"""Control parameterization: piecewise-linear splines over a few knots.

A trajectory's controls are ``K`` knots per actuator, spread evenly over the horizon and linearly
interpolated at every simulation step, so a planner searches ``K · nu`` numbers instead of
``T · nu``. Interpolation is one matrix product with a fixed ``(T, K)`` basis.
"""

from __future__ import annotations

import numpy as np


class ControlSpline:
    """Maps knot parameters ``(B, K, nu)`` to per-step controls ``(B, T, nu)``.

    Args:
        num_knots: ``K`` ≥ 2 knots; the first at t = 0, the last at the final step.
        num_steps: ``T`` simulation steps in the horizon.
        low, high: Control bounds per actuator (shape ``(nu,)``); knots are clipped to them.
        anchored: When True the control at t = 0 is not a parameter but given per trajectory
            (``controls(knots, anchor=...)``), e.g. a position servo's target = the start pose,
            so motion starts smoothly; the ``K`` knots then sit at t = T/K, 2T/K, …, T.
    """

    def __init__(
        self, num_knots: int, num_steps: int, low: np.ndarray, high: np.ndarray, anchored: bool = False
    ) -> None:
        if num_knots < 2 or num_steps < 2:
            raise ValueError(f"need >= 2 knots and steps, got {num_knots} and {num_steps}")
        low, high = np.asarray(low, dtype=float), np.asarray(high, dtype=float)
        if low.shape != high.shape or np.any(high <= low):
            raise ValueError("control bounds must have equal shapes and high > low")
        self.num_knots, self.num_steps = num_knots, num_steps
        self.low, self.high = low, high
        self.anchored = anchored
        total = num_knots + 1 if anchored else num_knots
        knot_t = np.linspace(0.0, 1.0, total)
        step_t = np.linspace(0.0, 1.0, num_steps)
        # basis[t, j]: weight of knot j at step t (hat functions); with an anchor, knot 0 is it.
        self.basis = np.clip(1.0 - np.abs(step_t[:, None] - knot_t[None, :]) * (total - 1), 0.0, None)

    @property
    def num_controls(self) -> int:
        return self.low.size

    @property
    def shape(self) -> tuple[int, int]:
        """Shape of one parameter set: ``(K, nu)``."""
        return self.num_knots, self.num_controls

    def clip(self, knots: np.ndarray) -> np.ndarray:
        return np.clip(knots, self.low, self.high)

    def controls(self, knots: np.ndarray, anchor: np.ndarray | None = None) -> np.ndarray:
        """Per-step controls ``(B, T, nu)`` for knots ``(B, K, nu)`` (clipped to the bounds);
        ``anchor`` ``(B or 1, nu)`` is the control at t = 0 of an anchored spline."""
        knots = self.clip(knots)
        if self.anchored:
            if anchor is None:
                raise ValueError("an anchored spline needs the control at t = 0")
            first = np.broadcast_to(self.clip(np.atleast_2d(anchor)), (len(knots), self.num_controls))
            knots = np.concatenate([first[:, None, :], knots], axis=1)
        return np.einsum("tk,bku->btu", self.basis, knots)

    def uniform(self, rng: np.random.Generator, count: int) -> np.ndarray:
        """``count`` knot sets drawn uniformly within the bounds: the random policy's controls."""
        return rng.uniform(self.low, self.high, size=(count, *self.shape))
