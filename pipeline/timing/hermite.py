"""The largest |p(t)| of cubics through sampled values and slopes, compiled: where a timing strays from its
limits between samples (``toppra_backend.DenseCheck``).

Between two samples ``h`` apart with values r0, r1 and time derivatives r0', r1', the cubic Hermite
polynomial in x = t / h is p(x) = r0 + d0 x + a2 x^2 + a3 x^3 (d0 = h r0', d1 = h r1', a2 = 3 (r1 - r0) - 2 d0 - d1,
a3 = 2 (r0 - r1) + d0 + d1); its largest |p| on [0, 1] is at an end or where p'(x) = d0 + 2 a2 x + 3 a3 x^2 = 0.
It is exact for a cubic, so a smooth bulge between two samples is found, not sampled: its error is
h^4 / 384 times the largest fourth time derivative.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def _cubic_peak(r0, r1, d0, d1):
    """max |p(x)| for x in [0, 1] of the Hermite cubic with end values r0, r1 and end slopes d0, d1 (per unit x)."""
    a2 = 3.0 * (r1 - r0) - 2.0 * d0 - d1
    a3 = 2.0 * (r0 - r1) + d0 + d1
    peak = max(abs(r0), abs(r1))
    if a3 != 0.0:
        disc = a2 * a2 - 3.0 * a3 * d0
        if disc >= 0.0:
            root = math.sqrt(disc)
            for x in ((-a2 + root) / (3.0 * a3), (-a2 - root) / (3.0 * a3)):
                if 0.0 < x < 1.0:
                    peak = max(peak, abs(r0 + x * (d0 + x * (a2 + x * a3))))
    elif a2 != 0.0:
        x = -d0 / (2.0 * a2)
        if 0.0 < x < 1.0:
            peak = max(peak, abs(r0 + x * (d0 + x * a2)))
    return peak


@njit(cache=True)
def hermite_peaks(values, slopes, step, out):
    """out (N,): per row the largest |p| over the cubics between consecutive samples of ``values`` (N, k, m)
    with time derivatives ``slopes`` (N, k, m), samples ``step`` (N, k - 1) [s] apart."""
    n, k, m = values.shape
    for i in range(n):
        peak = 0.0
        for a in range(k - 1):
            h = step[i, a]
            for j in range(m):
                peak = max(peak, _cubic_peak(values[i, a, j], values[i, a + 1, j], h * slopes[i, a, j],
                                             h * slopes[i, a + 1, j]))
        out[i] = peak
    return out


def joint_peaks_between(s, qd, qdd, qddd, limits, rows: int, step) -> tuple[np.ndarray, np.ndarray]:
    """Per row of samples (``rows`` rows of k consecutive samples, in order: s, qd, qdd, qddd (rows k,) and
    (rows k, dof), ``step`` (rows, k - 1) [s] apart) the largest joint speed ratio (over qd_max x the joint speed
    factor of ``limits``, a PathLimits, at each sample) and acceleration ratio (over qdd_max) between them [1]:
    ``hermite_peaks`` with the acceleration and the jerk as the slopes."""
    speed_limit = limits.limits.qd_max * limits.at(s)[0][:, None]
    shape = (rows, len(s) // rows, -1)

    def peaks(values, slopes):
        return hermite_peaks(values.reshape(shape), slopes.reshape(shape), step, np.empty(rows))

    return peaks(qd / speed_limit, qdd / speed_limit), peaks(qdd / limits.limits.qdd_max, qddd / limits.limits.qdd_max)
