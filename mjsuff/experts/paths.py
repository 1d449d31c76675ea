"""Time scalings and curves for scripted task-space paths."""

from __future__ import annotations

import numpy as np


def minimum_jerk(tau: np.ndarray) -> np.ndarray:
    """Minimum-jerk progress ``10τ³ − 15τ⁴ + 6τ⁵`` for ``τ`` clipped to [0, 1]: rest to rest."""
    tau = np.clip(tau, 0.0, 1.0)
    return tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)


def quadratic_bezier(p0: np.ndarray, p1: np.ndarray, p2: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Points ``(..., d)`` of the Bézier curve with control points ``p0, p1, p2`` at progress ``s``."""
    s = np.asarray(s)[..., None]
    return (1 - s) ** 2 * p0 + 2 * (1 - s) * s * p1 + s**2 * p2


def fall_and_brake(
    t: np.ndarray, height: float, fall: float, brake: float, touchdown_speed: float
) -> tuple[np.ndarray, np.ndarray, float]:
    """A vertical descent from rest over ``height`` (m): accelerate down at ``fall`` (m/s²), then
    brake at ``brake`` (m/s²) to arrive at ``touchdown_speed`` (m/s); at rest on arrival after.

    Returns the drop below the start ``(T,)`` (m), the downward acceleration ``(T,)`` (m/s²; ``fall``,
    then ``−brake``, then 0) and the arrival time (s). A touchdown speed above what falling the whole
    way reaches is a pure fall.
    """
    free = np.sqrt(2.0 * fall * height)
    if touchdown_speed >= free:
        peak, fall_time, brake_time = free, free / fall, 0.0
    else:
        peak = np.sqrt((height + touchdown_speed**2 / (2 * brake)) / (1 / (2 * fall) + 1 / (2 * brake)))
        fall_time, brake_time = peak / fall, (peak - touchdown_speed) / brake
    arrival = fall_time + brake_time
    tb = np.clip(t - fall_time, 0.0, brake_time)
    tf = np.minimum(t, fall_time)
    drop = 0.5 * fall * tf**2 + peak * tb - 0.5 * brake * tb**2
    landed = t >= arrival
    acceleration = np.where(landed, 0.0, np.where(t < fall_time, fall, -brake))
    return np.where(landed, height, drop), acceleration, float(arrival)
