"""Monte Carlo standard errors: one formula for every total a run reports (the tracer's tallies, images,
ray-record sums)."""
from __future__ import annotations

import numpy as np


def standard_error(s1, s2, n):
    """Standard error of a sum of n independent per-ray contributions with sums s1 and s2 (squares)."""
    if n <= 1:
        return 0.0
    var = np.maximum(np.asarray(s2) / n - (np.asarray(s1) / n) ** 2, 0.0)
    return np.sqrt(var * n * n / (n - 1))
