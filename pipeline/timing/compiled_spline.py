"""The C2 spline of ``make_path``'s "spline" shape, compiled, for the planner's trial splines.

A planned path's vertices are tried in many splines per query (a detour brought in, vertices thinned): each is
timed (``time_estimate``) and its configurations checked for collisions. SciPy's CubicSpline, its PPoly
derivatives and ``make_path``'s sampled limit check took about 1.9 ms a spline on this machine kind; these
kernels take microseconds. The program still times SciPy's spline (``make_path``); the two agree to round-off
(tests/timing/test_compiled_spline.py).

The same curve as ``make_path``: duplicate waypoints merged (``merge_duplicates``), knots at the cumulative
chord length over the whole, not-a-knot ends (SciPy's banded system, solved here by Thomas' algorithm), the
parabola through three waypoints, the straight line through two. Piece k (knots s_k, s_k+1) is, as in SciPy's
PPoly, q(s) = c0 x^3 + c1 x^2 + c2 x + c3 with x = s - s_k. The limit check is exact (each piece's extremes
where its derivative vanishes), so it refuses every spline ``make_path``'s sampled check refuses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from .joint_path import DUPLICATE_DISTANCE, LIMIT_SLACK, chord_knots, chords_of, merge_duplicates


@njit(cache=True)
def spline_coefficients(s, y):
    """(4, K - 1, dof) piece coefficients of the not-a-knot spline through y (K, dof) at knots s (K,),
    increasing (K = 3: the parabola; K = 2: the line)."""
    count, dof = y.shape
    h = s[1:] - s[:-1]
    c = np.zeros((4, count - 1, dof))
    slope = np.empty((count - 1, dof))
    for i in range(count - 1):
        for j in range(dof):
            slope[i, j] = (y[i + 1, j] - y[i, j]) / h[i]
            c[3, i, j] = y[i, j]
    if count == 2:
        c[2, 0, :] = slope[0]
        return c
    if count == 3:
        for j in range(dof):
            bend = (slope[1, j] - slope[0, j]) / (s[2] - s[0])
            c[1, 0, j] = c[1, 1, j] = bend
            c[2, 0, j], c[2, 1, j] = slope[0, j] - bend * h[0], slope[0, j] + bend * h[0]
        return c
    sub, diag, sup = np.zeros(count), np.zeros(count), np.zeros(count)
    rhs = np.empty((count, dof))
    for i in range(1, count - 1):
        sub[i], diag[i], sup[i] = h[i], 2.0 * (h[i - 1] + h[i]), h[i - 1]
        rhs[i] = 3.0 * (h[i] * slope[i - 1] + h[i - 1] * slope[i])
    first, last = s[2] - s[0], s[-1] - s[-3]
    diag[0], sup[0] = h[1], first
    rhs[0] = ((h[0] + 2.0 * first) * h[1] * slope[0] + h[0] ** 2 * slope[1]) / first
    diag[-1], sub[-1] = h[-2], last
    rhs[-1] = (h[-1] ** 2 * slope[-2] + (2.0 * last + h[-1]) * h[-2] * slope[-1]) / last
    for i in range(1, count):                          # Thomas' algorithm: eliminate below the diagonal
        w = sub[i] / diag[i - 1]
        diag[i] -= w * sup[i - 1]
        rhs[i] -= w * rhs[i - 1]
    m = np.empty((count, dof))
    m[-1] = rhs[-1] / diag[-1]
    for i in range(count - 2, -1, -1):
        m[i] = (rhs[i] - sup[i] * m[i + 1]) / diag[i]
    for i in range(count - 1):                         # SciPy's CubicHermiteSpline from the knot slopes m
        for j in range(dof):
            t = (m[i, j] + m[i + 1, j] - 2.0 * slope[i, j]) / h[i]
            c[0, i, j] = t / h[i]
            c[1, i, j] = (slope[i, j] - m[i, j]) / h[i] - t
            c[2, i, j] = m[i, j]
    return c


@njit(cache=True)
def spline_values(c, s, at, order):
    """(n, dof): the spline's values (order 0), first (1) or second (2) derivative at ``at`` (n,) in [s0, s-1]."""
    out = np.empty((at.shape[0], c.shape[2]))
    piece = 0
    for k in range(at.shape[0]):
        x = at[k]
        if not (s[piece] <= x < s[piece + 1]):
            piece = min(max(np.searchsorted(s, x, side="right") - 1, 0), s.shape[0] - 2)
        x -= s[piece]
        for j in range(c.shape[2]):
            c0, c1, c2 = c[0, piece, j], c[1, piece, j], c[2, piece, j]
            if order == 0:
                out[k, j] = ((c0 * x + c1) * x + c2) * x + c[3, piece, j]
            elif order == 1:
                out[k, j] = (3.0 * c0 * x + 2.0 * c1) * x + c2
            else:
                out[k, j] = 6.0 * c0 * x + 2.0 * c1
    return out


@njit(cache=True)
def spline_within(c, s, q_min, q_max):
    """Whether every piece stays within [q_min, q_max] (less LIMIT_SLACK), checked at its ends and where its
    derivative 3 c0 x^2 + 2 c1 x + c2 vanishes inside it."""
    for i in range(s.shape[0] - 1):
        h = s[i + 1] - s[i]
        for j in range(c.shape[2]):
            c0, c1, c2, c3 = c[0, i, j], c[1, i, j], c[2, i, j], c[3, i, j]
            low, high = q_min[j] - LIMIT_SLACK, q_max[j] + LIMIT_SLACK
            ends = (c3, ((c0 * h + c1) * h + c2) * h + c3)
            if not (low <= ends[0] <= high and low <= ends[1] <= high):
                return False
            a, b = 3.0 * c0, 2.0 * c1
            roots = (-1.0, -1.0)
            if a != 0.0:
                disc = b * b - 4.0 * a * c2
                if disc >= 0.0:
                    root = math.sqrt(disc)
                    roots = ((-b + root) / (2.0 * a), (-b - root) / (2.0 * a))
            elif b != 0.0:
                roots = (-c2 / b, -1.0)
            for x in roots:
                if 0.0 < x < h:
                    value = ((c0 * x + c1) * x + c2) * x + c3
                    if not low <= value <= high:
                        return False
    return True


@njit(cache=True)
def time_estimate(c, s, samples, qd_max, qdd_max):
    """An estimate of the time-optimal duration of the spline (parameter s) from rest to rest [s]: on ``samples``
    points the path speed each joint's speed limit allows and (qdd_max finite) the speed its curvature allows
    (|q''| sd^2 <= qdd_max), then a forward and a backward pass of the tangential acceleration
    (|q'| sdd <= qdd_max); the time is the integral of ds / sd by the trapezoid rule on sd."""
    at = np.linspace(s[0], s[-1], samples)
    slope, bend = spline_values(c, s, at, 1), spline_values(c, s, at, 2)
    top, push = np.empty(samples), np.empty(samples)
    for k in range(samples):
        speed, curve, rate = np.inf, np.inf, np.inf
        for j in range(c.shape[2]):
            magnitude, turn = abs(slope[k, j]), abs(bend[k, j])
            if magnitude > 0.0:
                speed = min(speed, qd_max[j] / magnitude)
                rate = min(rate, qdd_max[j] / magnitude)
            if turn > 0.0:
                curve = min(curve, qdd_max[j] / turn)
        top[k] = min(speed * speed, curve)
        push[k] = 2.0 * rate * (s[-1] - s[0]) / (samples - 1)
    top[0] = top[-1] = 0.0
    for k in range(1, samples):
        top[k] = min(top[k], top[k - 1] + push[k - 1])
    for k in range(samples - 2, -1, -1):
        top[k] = min(top[k], top[k + 1] + push[k + 1])
    total = 0.0
    for k in range(samples - 1):
        total += 2.0 * (s[-1] - s[0]) / (samples - 1) / max(math.sqrt(top[k]) + math.sqrt(top[k + 1]), 1e-12)
    return total


@dataclass(frozen=True, eq=False)
class TrialSpline:
    """``make_path``'s spline through a path's waypoints: ``knots`` (K,) in [0, 1], ``coefficients``
    (4, K - 1, dof) (``spline_coefficients``), ``length``: the joint-space chord length [rad or m]."""

    knots: np.ndarray
    coefficients: np.ndarray
    length: float

    def __call__(self, s: np.ndarray, order: int = 0) -> np.ndarray:
        """(n, dof) values (order 0) or derivatives (1, 2) by s at ``s`` (n,) in [0, 1]."""
        return spline_values(self.coefficients, self.knots, np.asarray(s, dtype=float), order)

    def time(self, limits, samples: int) -> float:
        """``time_estimate`` on ``samples`` points with the joint limits ``limits`` (no acceleration limits:
        the speed limits alone) [s]."""
        qdd = np.full(self.coefficients.shape[2], np.inf) if limits.qdd_max is None else limits.qdd_max
        return time_estimate(self.coefficients, self.knots, samples, limits.qd_max, qdd)


def trial_spline(waypoints: np.ndarray, q_min: np.ndarray, q_max: np.ndarray) -> TrialSpline | None:
    """The spline ``make_path(waypoints, q_min, q_max, "spline")`` would time, or None where it would refuse
    it (it leaves the limits, or there is no motion)."""
    waypoints = np.asarray(waypoints, dtype=float)
    chords = chords_of(waypoints)
    if (chords <= DUPLICATE_DISTANCE).any():
        waypoints = merge_duplicates(waypoints)
        if len(waypoints) < 2:
            return None
        chords = chords_of(waypoints)
    knots, length = chord_knots(chords)
    coefficients = spline_coefficients(knots, waypoints)
    if not spline_within(coefficients, knots, q_min, q_max):
        return None
    return TrialSpline(knots, coefficients, length)
