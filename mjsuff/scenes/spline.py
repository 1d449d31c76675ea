"""Control parameterization: piecewise-linear splines over a few knots.

A trajectory's controls are ``K`` knots per actuator, spread evenly over the horizon and linearly
interpolated at every simulation step, so a planner searches ``K · nu`` numbers instead of
``T · nu``. Interpolation is a product with a fixed ``(T, K)`` basis of hat functions, computed
from the two knots around each step.
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
        # A step weighs two neighbouring knots (a third only through a rounding residue of 1e-16):
        # where every step's weights sit on its two, the product without its zero terms is the
        # same sums, three times faster.
        steps = np.arange(num_steps)
        self._left = np.minimum(np.argmax(self.basis > 0, axis=1), total - 2)
        self._left_weight = self.basis[steps, self._left][None, :, None]
        self._right_weight = self.basis[steps, self._left + 1][None, :, None]
        self._two_knots = np.count_nonzero(self.basis, axis=1).max() <= 2 and np.array_equal(
            self.basis[steps, self._left] + self.basis[steps, self._left + 1], self.basis.sum(axis=1)
        )

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
        if not self._two_knots:
            return np.einsum("tk,bku->btu", self.basis, knots)
        return self._left_weight * knots[:, self._left] + self._right_weight * knots[:, self._left + 1]

    def uniform(self, rng: np.random.Generator, count: int) -> np.ndarray:
        """``count`` knot sets drawn uniformly within the bounds: the random policy's controls."""
        return rng.uniform(self.low, self.high, size=(count, *self.shape))
