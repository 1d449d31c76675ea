"""Hoeffding-style sample-complexity bounds from prior IRL theory (paper §4.4.3, Table 1)."""

from __future__ import annotations

import math


def abbeel_ng_demos(epsilon: float, gamma: float = 0.95, k: int = 4, delta: float = 0.05) -> int:
    """Smallest ``m`` with ``(1/(1−γ))·√(2k/m·ln(2k/δ)) ≤ ε`` (Abbeel & Ng, 2004)."""
    return math.ceil((2 * k * math.log(2 * k / delta)) / ((epsilon * (1 - gamma)) ** 2) - 1e-9)


def syed_schapire_demos(epsilon: float, gamma: float = 0.95, k: int = 4, delta: float = 0.05) -> int:
    """Smallest ``m`` with ``(3/(1−γ))·√(2/m·ln(2k/δ)) ≤ ε`` (Syed & Schapire, 2007)."""
    return math.ceil((2 * 9 * math.log(2 * k / delta)) / ((epsilon * (1 - gamma)) ** 2) - 1e-9)
