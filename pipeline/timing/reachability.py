"""TOPP-RA's two passes over a grid, compiled: the time-optimal x = sd^2 at every grid point.

The problem is toppra's (Pham and Pham, "A new approach to time-optimal path parameterization based on
reachability analysis", IEEE T-RO 2018): on a grid s_0 < ... < s_N, a constant path acceleration u_i on
interval i takes x_i = sd_i^2 to x_{i+1} = x_i + 2 (s_{i+1} - s_i) u_i, and every constraint of stage i
is a row ``alpha u_i + beta x_i <= gamma``. The backward pass finds each stage's controllable set K_i,
the x_i from which some u_i satisfies the stage's rows and lands in K_{i+1} (K_N = {0}: at rest at the
end); the forward pass starts at rest and takes the largest such u_i at every stage (greedy, optimal).

toppra solves each stage's two-variable LP with Seidel's algorithm in Cython, but steps from stage to
stage in Python: 17-19 us per grid point for both passes on this machine kind (GP7, joint speed and
acceleration limits, 1001 grid points). Here u is eliminated exactly (Fourier-Motzkin: every pair of a row
bounding u from above and one bounding it from below gives a row in x alone), so a stage costs a few
hundred multiply-adds, compiled: 0.41-0.50 us per grid point on the same grids, about 40x less. The rows
come from toppra's own constraint objects (``canonical_rows``) or are built directly (``toppra_backend``);
the answer on the same grid and constraints is toppra's (tests/timing/test_timing.py compares the two).
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: A stage whose x-interval is empty by no more than this (relative to its size, 1 in the solver's units)
#: is round-off, not infeasibility: the interval closes to a point [1].
ROUNDOFF = 1e-9
#: What ``controllable_sets`` returns when every stage has a controllable set (else the first empty stage).
FEASIBLE = -1


@njit(cache=True)
def _x_interval(alpha, beta, gamma, lo, hi):
    """The interval [lo, hi] of x (already within the given [lo, hi]) for which some u satisfies every
    row ``alpha[r] u + beta[r] x <= gamma[r]``: u eliminated pairwise; lo > hi when none does."""
    for p in range(alpha.size):
        a_p = alpha[p]
        if a_p == 0.0:
            lo, hi = _bounded(beta[p], gamma[p], lo, hi)
        elif a_p > 0.0:
            for q in range(alpha.size):
                if alpha[q] < 0.0:
                    b_q = -alpha[q]
                    lo, hi = _bounded(a_p * beta[q] + b_q * beta[p], b_q * gamma[p] + a_p * gamma[q], lo, hi)
    return lo, hi


@njit(cache=True)
def _bounded(slope, const, lo, hi):
    """[lo, hi] cut by ``slope x <= const``."""
    if slope > 0.0:
        hi = min(hi, const / slope)
    elif slope < 0.0:
        lo = max(lo, const / slope)
    elif const < 0.0:
        lo, hi = 1.0, 0.0
    return lo, hi


@njit(cache=True)
def controllable_sets(ds, alpha, beta, gamma, x_lo, x_hi, K):
    """The backward pass: K (N+1, 2) the controllable interval of x at every grid point, from rows
    ``alpha, beta, gamma`` (N, m) of the N stages (step ``ds`` (N,)), the x bounds ``x_lo, x_hi`` (N+1,).
    Returns FEASIBLE, or the stage whose set is empty."""
    n = ds.size
    K[n, 0], K[n, 1] = 0.0, 0.0
    m = alpha.shape[1]
    a = np.empty(m + 2)
    b = np.empty(m + 2)
    g = np.empty(m + 2)
    for i in range(n - 1, -1, -1):
        a[:m], b[:m], g[:m] = alpha[i], beta[i], gamma[i]
        # x + 2 ds u in K_{i+1}
        a[m], b[m], g[m] = 2.0 * ds[i], 1.0, K[i + 1, 1]
        a[m + 1], b[m + 1], g[m + 1] = -2.0 * ds[i], -1.0, -K[i + 1, 0]
        lo, hi = _x_interval(a, b, g, max(x_lo[i], 0.0), x_hi[i])
        if lo > hi:
            if lo - hi > ROUNDOFF * max(1.0, abs(hi)):
                return i
            lo = hi
        K[i, 0], K[i, 1] = lo, hi
    return FEASIBLE


@njit(cache=True)
def greedy_forward(ds, alpha, beta, gamma, K, x):
    """The forward pass: x (N+1,) from rest, the largest path acceleration at every stage that keeps the
    stage's rows (to ROUNDOFF: a row whose u coefficient is nearly 0 bounds x, not u) and lands in K."""
    n = ds.size
    x[0] = 0.0
    for i in range(n):
        xi = x[i]
        u = (K[i + 1, 1] - xi) / (2.0 * ds[i])
        for r in range(alpha.shape[1]):
            if alpha[i, r] > 0.0:
                slack = gamma[i, r] - beta[i, r] * xi
                u = min(u, (slack + ROUNDOFF * (abs(gamma[i, r]) + abs(beta[i, r] * xi))) / alpha[i, r])
        x[i + 1] = min(max(xi + 2.0 * ds[i] * u, K[i + 1, 0]), K[i + 1, 1])
    return x


def solve_rows(s: np.ndarray, alpha: np.ndarray, beta: np.ndarray, gamma: np.ndarray, x_lo: np.ndarray,
               x_hi: np.ndarray) -> tuple[np.ndarray | None, int]:
    """(x (N+1,), FEASIBLE) the time-optimal sd^2 on grid ``s`` (N+1,) at rest at both ends, or (None, the
    first stage found empty) when no timing meets the rows (N, m) and x bounds (N+1,)."""
    ds = np.diff(s)
    K = np.empty((len(s), 2))
    arrays = [np.ascontiguousarray(v, dtype=float) for v in (alpha, beta, gamma)]       # copies only if needed
    failed = controllable_sets(ds, *arrays, np.asarray(x_lo, dtype=float), np.asarray(x_hi, dtype=float), K)
    if failed != FEASIBLE:
        return None, int(failed)
    if K[0, 0] > ROUNDOFF:                      # cannot start from rest
        return None, 0
    return greedy_forward(ds, *arrays, K, np.empty(len(s))), FEASIBLE


def canonical_rows(constraint, path, s: np.ndarray):
    """A toppra constraint's canonical form (``a u + b x + c = v``, ``F v <= g``, bounds on u and x) at grid
    ``s`` as rows ``alpha u + beta x <= gamma`` of stages 0..N-1 (N, m) (None: no rows) and x bounds (N+1, 2)."""
    a, b, c, F, g, ubound, xbound = constraint.compute_constraint_params(path, s)
    rows = []
    if a is not None:
        F = np.broadcast_to(F, (len(s), *np.shape(F)[-2:]))
        g = np.broadcast_to(g, (len(s), np.shape(g)[-1]))
        rows.append((np.einsum("nmk,nk->nm", F, a), np.einsum("nmk,nk->nm", F, b), g - np.einsum("nmk,nk->nm", F, c)))
    if ubound is not None:
        ones, zeros = np.ones((len(s), 1)), np.zeros((len(s), 1))
        rows.append((np.hstack([ones, -ones]), np.hstack([zeros, zeros]),
                     np.column_stack([ubound[:, 1], -ubound[:, 0]])))
    stacked = None if not rows else tuple(np.hstack([r[k] for r in rows])[:-1] for k in range(3))
    return stacked, xbound
