"""Points on the unit sphere ``S^{k−1}``, where reward weights live (``‖w‖₂ = 1``)."""

from __future__ import annotations

import numpy as np


def normalize(x: np.ndarray) -> np.ndarray:
    """Scale each row of ``x`` to unit Euclidean norm."""
    return x / np.linalg.norm(x, axis=-1, keepdims=True)


def near_any(directions: np.ndarray, direction: np.ndarray, cosine: float) -> bool:
    """Whether unit ``direction`` ``(k,)`` lies within ``cosine`` of any row of unit
    ``directions`` ``(m, k)`` (False when there are none)."""
    return bool(len(directions)) and bool((directions @ direction).max() >= cosine)


def random_unit_vectors(rng: np.random.Generator, n: int, k: int) -> np.ndarray:
    """``n`` independent uniform draws from the unit sphere in ``R^k`` -> ``(n, k)``."""
    return normalize(rng.standard_normal((n, k)))


def fibonacci_sphere(n: int) -> np.ndarray:
    """``n`` nearly equal-area points on the 2-sphere (``k = 3``) -> ``(n, 3)``."""
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    r = np.sqrt(1.0 - z * z)
    phi = np.pi * (3.0 - np.sqrt(5.0)) * i
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def random_negative_unit_vectors(rng: np.random.Generator, n: int, k: int) -> np.ndarray:
    """``n`` independent uniform draws from the all-negative orthant of the unit sphere -> ``(n, k)``."""
    return -np.abs(random_unit_vectors(rng, n, k))
