"""Seeded fuzz of ``retime``: every profile is judged by this file's own NumPy checks, never by
``pipeline.timing.profile.certify``, for every method (toppra, ruckig, topp3) and path shape.

Waypoint families (each case seeded with ``np.random.default_rng(seed)``): random in-limit paths of
2-10 waypoints over 80 % of each range; waypoints exactly on the limits; chains of sub-1e-6 rad
steps; sets spanning up to 2e-5 rad; back-and-forth A-B-A-B... (9 waypoints); a tiny total motion
(1e-7 .. 1e-5 rad); one joint moving only; repeated (and nearly repeated) waypoints; and joint by
joint (each waypoint moves one joint, so every interior waypoint is a corner where the joints that
moved stop and another starts). Speed scales are log-uniform in [0.001, 1]; dt is one of 1, 2, 4,
10 ms, raised on long slow motions to keep about TARGET_SAMPLES samples. Limits without torques
(``tau_max=None``) keep it fast; about one case in eight uses the robot's own limits (``limits`` not
given; no preset has torque limits), and a few toppra cases time the torque-limited two-link arm of
tests/data through Drake.

Checks on every profile (``check_profile``; the limits are the caller's scaled here by s, s^2, s^3):

- finite samples, strictly increasing t from 0, the timed limits those asked for;
- starts exactly at the first waypoint and ends exactly at the last (1e-9 rad); at rest at both ends:
  |qd| <= 1e-9 qd_max, and |qdd| <= 1e-9 qdd_max for the jerk-limited methods (ruckig, topp3). toppra
  is a second-order (bang-bang acceleration) profile: it starts and stops with zero velocity, but its
  acceleration jumps to the limit at t = 0 by design, so its end accelerations are only bounded;
- passes every waypoint that survives duplicate merging, in order: ruckig exactly (1e-9 rad: it stops
  at every waypoint, at a sample time), toppra and topp3 (whose samples lie on a path through the
  waypoints) at some sample within |q_j - w_j| <= qd_max_j h_max / 2 per joint (the waypoint is passed
  at some instant, the nearest sample is at most h_max / 2 away in time, and no joint moves faster than
  qd_max_j), plus blend / 2 x the shorter neighbouring chord for an interior waypoint of the
  ``linear`` shape (its corner blend; at the knot q = w + (m_out - m_in) b / 4, |m| = path length);
  every waypoint merged away within 2 x DUPLICATE_DISTANCE more (it was within DUPLICATE_DISTANCE of a
  kept one, or of one the last waypoint then replaced; not for ``linear``, whose corners are blended);
  ruckig never merges: every waypoint, exactly;
- never beyond a position limit (1e-12 rad);
- |qd| <= qd_max (1 + 1e-6), |qdd| <= qdd_max (1 + 1e-6), and |qddd| <= qddd_max (1 + 1e-6) for ruckig and
  topp3 (toppra's qddd is a finite difference of qdd and is not limited);
- toppra and topp3 follow the path, measured both ways against the JointPath built from the same
  waypoints (``path_deviations``): every sample within 1e-6 rad + the chord error of a fine polyline of
  the path, and every point of the path within the per-joint h_max / 2 x qd_max_j bound of a sample;
- the columns agree with each other (``consistency``), per sample interval h, per joint:
  q vs qd by the trapezoid rule, |dq - h (qd_k + qd_k+1) / 2| <= h^2 / 4 qdd_max (qd is Lipschitz with
  constant qdd_max: the error is |int (t - t_mid) qdd dt| <= qdd_max h^2 / 4) and, for the jerk-limited
  methods, also <= h^3 / 12 qddd_max (the trapezoid's Peano kernel (t - a)(b - t) / 2 integrates to
  h^3 / 12 against |d2 qd / dt2| = |qddd| <= qddd_max); qd vs qdd likewise, |dqd - h (qdd_k + qdd_k+1) / 2|
  <= h^2 / 4 qddd_max (ruckig, topp3); and |dqdd| <= h qddd_max (ruckig, topp3). toppra's qdd jumps
  wherever its path acceleration does (between grid points), so for it only the mean-value bound
  |dqd| <= h qdd_max holds (the acceleration limit between samples): documented, not tightened. Each
  bound gets round-off room of 1e-12 x max(1, the largest |value| of the column), and q vs qd for
  ruckig 2 x RUCKIG_POSITION_PRECISION more (Ruckig ends a segment within 1e-8 rad of its target);
- a refusal is a PipelineError subclass with a message, and only a documented one: topp3 on the
  ``linear`` shape ("needs a C2 path") and a ``spline`` that "leaves the limits" (a ``PathError``: the
  waypoints make no path of that shape, refused before any method times them). Anything else
  (another PipelineError, ValueError, ...) is a failure, and so is a result that is not a Profile or has
  non-finite samples. The tally counts the spline's own refusals as "no path", apart from the methods'
  refusals ("refused"): a method that times every path there is refuses none (topp3 on the slow run's 160
  monotone and spline cases: 14 spline cases leave the limits, 0 refused).

The default run times a few hundred profiles; the ``slow`` variants thousands (topp3 takes ~0.1-0.3 s
a path, so it gets fewer). A run collects every failing case and reports them together, each with
its robot, seed, family, method, shape, speed scale, dt and waypoints (full precision) and the
numbers, so that a case can be replayed with ``run_case(make_case(seed, ...), method, shape)``.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import numpy as np
import pytest
from scipy.spatial import cKDTree

from pipeline.errors import PipelineError
from pipeline.model.robot import load_robot
from pipeline.timing import retime
from pipeline.timing.joint_path import (
    DEFAULT_BLEND,
    DUPLICATE_DISTANCE,
    NO_MOTION_DISTANCE,
    PathError,
    kept_indices,
    make_path,
)
from pipeline.timing.profile import Profile
from pipeline.timing.ruckig_backend import RUCKIG_POSITION_PRECISION

from ..conftest import DATA_DIR

ROBOT_NAMES = ("arm5", "arm6", "gp7", "irb1600", "lrmate200id")
FAMILIES = ("random", "on_limits", "tiny_steps", "tiny_span", "back_and_forth", "tiny_motion", "one_joint",
            "repeated", "joint_by_joint")
#: Relative room of a limit (round-off of the samples; certify's own tolerance is the same number) [1].
LIMIT_TOLERANCE = 1e-6
#: Ends: position [rad] and rest (velocity, acceleration as fractions of their limits) [1].
END_TOLERANCE = 1e-9
#: Position limits [rad].
POSITION_TOLERANCE = 1e-12
#: Waypoints of the exact (ruckig) method [rad].
EXACT_TOLERANCE = 1e-9
#: Distance of a toppra / topp3 sample from the path, before the polyline's chord error [rad].
PATH_TOLERANCE = 1e-6
#: Points of the polyline the path is measured against (plus every breakpoint of the path).
PATH_GRID = 20_001
#: Round-off room of the consistency checks, times max(1, largest |value| of the column).
ROUND_OFF = 1e-12
#: About this many samples per profile at most (dt is raised on long, slow motions) [1].
TARGET_SAMPLES = 1500
#: One case in this many uses the robot's own limits (limits=None).
OWN_LIMITS_EVERY = 8

#: (method, shape, default count, slow count): topp3 is ~0.1-0.3 s a path, toppra ~10-50 ms, ruckig fast.
RUNS = [
    ("toppra", "monotone", 18, 500),
    ("toppra", "spline", 18, 250),
    ("toppra", "linear", 18, 250),
    ("ruckig", "monotone", 300, 1500),       # ruckig goes waypoint to waypoint: the shape does not apply
    ("topp3", "monotone", 9, 100),
    ("topp3", "spline", 12, 60),
    ("topp3", "linear", 12, 24),            # always the documented refusal (a C1 path)
]
#: The slow run's seeds start here (the default run's at 0), so it adds cases rather than repeating them.
SLOW_SEED_BASE = 1_000_000
TORQUE_COUNTS = (4, 20)

_ROBOTS: dict = {}


def robot_named(name):
    if name not in _ROBOTS:
        _ROBOTS[name] = load_robot(name) if name in ROBOT_NAMES else load_robot(DATA_DIR / name)
    return _ROBOTS[name]


# -- cases --------------------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class Case:
    seed: int
    robot: str
    family: str
    waypoints: np.ndarray
    speed_scale: float
    dt: float
    own_limits: bool

    def describe(self) -> str:
        w = np.array2string(self.waypoints, precision=17, separator=", ", max_line_width=100_000, threshold=100_000)
        return (f"robot={self.robot} seed={self.seed} family={self.family} speed_scale={self.speed_scale!r} "
                f"dt={self.dt!r} own_limits={self.own_limits} waypoints=np.array({w})")


def unscaled_limits(robot, own: bool):
    return robot.limits if own else dataclasses.replace(robot.limits, tau_max=None)


def scaled(limits, s: float) -> dict:
    """The limits at speed scale s, computed here: qd s, qdd s^2, qddd s^3."""
    return {"q_min": limits.q_min, "q_max": limits.q_max, "qd_max": limits.qd_max * s,
            "qdd_max": limits.qdd_max * s**2,
            "qddd_max": None if limits.qddd_max is None else limits.qddd_max * s**3,
            "tau_max": limits.tau_max}


def _inside(rng, lo, hi, count, margin=0.1):
    span = hi - lo
    return rng.uniform(lo + margin * span, hi - margin * span, size=(count, lo.size))


def _tiny_offsets(rng, dof, count, largest):
    """count offsets (count, dof) of norm up to ``largest`` in random directions."""
    direction = rng.normal(size=(count, dof))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    return direction * rng.uniform(0.0, largest, size=(count, 1))


def _base_near_limits(rng, lo, hi):
    """A configuration over 80 % of each range, some joints (sometimes) exactly on a limit."""
    base = _inside(rng, lo, hi, 1)[0]
    if rng.random() < 0.3:
        on = rng.random(lo.size) < 0.5
        base = np.where(on, np.where(rng.random(lo.size) < 0.5, lo, hi), base)
    return base


def _clip_inward(points, lo, hi):
    return np.minimum(np.maximum(points, lo), hi)


def family_waypoints(rng, family: str, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    dof = lo.size
    if family == "random":
        return _inside(rng, lo, hi, int(rng.integers(2, 11)))
    if family == "on_limits":
        count = int(rng.integers(2, 11))
        inner = _inside(rng, lo, hi, count, margin=0.0)
        pick = rng.random((count, dof))
        return np.where(pick < 0.35, lo, np.where(pick < 0.7, hi, inner))
    if family == "tiny_steps":                  # a chain of steps each below DUPLICATE_DISTANCE
        count = int(rng.integers(2, 31))
        base = _base_near_limits(rng, lo, hi)
        steps = _tiny_offsets(rng, dof, count - 1, 0.999e-6)
        return _clip_inward(base + np.concatenate([np.zeros((1, dof)), np.cumsum(steps, axis=0)]), lo, hi)
    if family == "tiny_span":                   # scattered points spanning up to 2e-5 rad
        count = int(rng.integers(2, 11))
        base = _base_near_limits(rng, lo, hi)
        span = 10.0 ** rng.uniform(-7.0, np.log10(2e-5))
        return _clip_inward(base + rng.uniform(-span / 2, span / 2, size=(count, dof)), lo, hi)
    if family == "back_and_forth":
        a, b = _inside(rng, lo, hi, 2)
        b = _clip_inward(a + (b - a) * 10.0 ** rng.uniform(-5.0, 0.0), lo, hi)
        return np.array([a, b] * 4 + [a])
    if family == "tiny_motion":
        count = int(rng.integers(2, 6))
        base = _base_near_limits(rng, lo, hi)
        total = 10.0 ** rng.uniform(-7.0, -5.0)
        direction = rng.normal(size=dof)
        direction *= np.where((base <= lo) & (direction < 0) | (base >= hi) & (direction > 0), -1.0, 1.0)
        direction /= np.linalg.norm(direction)
        fractions = np.concatenate([[0.0], np.sort(rng.uniform(0.0, 1.0, count - 2)), [1.0]])
        return _clip_inward(base + fractions[:, None] * total * direction, lo, hi)
    if family == "one_joint":
        count = int(rng.integers(2, 11))
        joint = int(rng.integers(dof))
        waypoints = np.repeat(_inside(rng, lo, hi, 1), count, axis=0)
        waypoints[:, joint] = _inside(rng, lo[joint:joint + 1], hi[joint:joint + 1], count)[:, 0]
        return waypoints
    if family == "joint_by_joint":              # each waypoint moves one joint: the others stop at a corner
        count = int(rng.integers(3, 11))
        waypoints = np.repeat(_inside(rng, lo, hi, 1), count, axis=0)
        for k in range(1, count):
            joint = int(rng.integers(dof))
            waypoints[k:, joint] = _inside(rng, lo[joint:joint + 1], hi[joint:joint + 1], 1)[0, 0]
        return waypoints
    if family == "repeated":
        distinct = _inside(rng, lo, hi, int(rng.integers(2, 6)))
        rows = []
        for q in distinct:
            for _ in range(int(rng.integers(1, 5))):
                near = rng.random() < 0.3         # a near repeat, well inside DUPLICATE_DISTANCE
                rows.append(_clip_inward(q + _tiny_offsets(rng, dof, 1, 5e-7)[0], lo, hi) if near else q.copy())
        return np.array(rows)
    raise AssertionError(family)


def duration_bound(waypoints: np.ndarray, limits: dict) -> float:
    """A rough duration [s] of stopping at every waypoint: per segment the slowest joint's
    d / v + v / a + a / j (for choosing dt only)."""
    d = np.abs(np.diff(waypoints, axis=0))
    v, a = limits["qd_max"], limits["qdd_max"]
    j = limits["qddd_max"] if limits["qddd_max"] is not None else np.full_like(v, np.inf)
    per_joint = np.where(d > 0, d / v + v / a + a / j, 0.0)
    return float(per_joint.max(axis=1).sum())


def make_case(seed: int, robots=ROBOT_NAMES, families=FAMILIES) -> Case:
    """The case of a seed: robot, family (cycling with the seed), waypoints, speed scale, dt."""
    rng = np.random.default_rng(seed)
    name = robots[int(rng.integers(len(robots)))]
    family = families[seed % len(families)]
    robot = robot_named(name)
    own = rng.integers(OWN_LIMITS_EVERY) == 0
    limits = unscaled_limits(robot, own)
    lo, hi = limits.q_min, limits.q_max
    while True:
        waypoints = family_waypoints(rng, family, lo, hi)
        if np.linalg.norm(waypoints[-1] - waypoints[0]) > 10 * NO_MOTION_DISTANCE or \
                np.ptp(waypoints, axis=0).max() > 1e-6:
            break
    speed_scale = float(10.0 ** rng.uniform(-3.0, 0.0))
    dt = float(max(rng.choice([0.001, 0.002, 0.004, 0.01]),
                   duration_bound(waypoints, scaled(limits, speed_scale)) / TARGET_SAMPLES))
    return Case(seed, name, family, waypoints, speed_scale, dt, bool(own))


# -- checks -------------------------------------------------------------------------------------

def _worst(ratio: np.ndarray):
    k, j = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
    return float(ratio[k, j]), int(k), int(j)


def _limit_failures(name, values, limit, tolerance, t):
    ratio = np.abs(values) / limit
    worst, k, j = _worst(ratio)
    if worst > 1.0 + tolerance:
        return [f"|{name}| over its limit: joint {j + 1} at t = {t[k]:.6g} s (sample {k}): {abs(values[k, j]):.9g} "
                f"= {worst:.9f} x limit {limit[j]:.6g}"]
    return []


def _consistency(name, error, bound, scale_values, t):
    """error, bound (n - 1, dof): each interval's error against its bound plus round-off room."""
    room = bound + ROUND_OFF * max(1.0, float(np.abs(scale_values).max()))
    ratio = np.abs(error) / room
    worst, k, j = _worst(ratio)
    if worst > 1.0:
        return [f"{name}: joint {j + 1} on [{t[k]:.9g}, {t[k + 1]:.9g}] s (h = {t[k + 1] - t[k]:.3g}): error "
                f"{abs(error[k, j]):.3e} > bound {bound[k, j]:.3e} (+ round-off {room[k, j] - bound[k, j]:.1e})"]
    return []


def consistency(p: Profile, limits: dict, jerk_limited: bool, position_floor: float = 0.0) -> list[str]:
    """The columns agree (module docstring): trapezoid rule for q vs qd and qd vs qdd, mean-value bounds;
    ``position_floor`` [rad]: how exactly the back end places a segment's end (Ruckig's precision)."""
    h = np.diff(p.t)[:, None]
    qdd_max = limits["qdd_max"] * (1.0 + LIMIT_TOLERANCE)
    out = []
    q_error = np.diff(p.q, axis=0) - h * (p.qd[1:] + p.qd[:-1]) / 2.0
    q_bound = h**2 / 4.0 * qdd_max
    if jerk_limited:
        qddd_max = limits["qddd_max"] * (1.0 + LIMIT_TOLERANCE)
        q_bound = np.minimum(q_bound, h**3 / 12.0 * qddd_max)
        qd_error = np.diff(p.qd, axis=0) - h * (p.qdd[1:] + p.qdd[:-1]) / 2.0
        out += _consistency("qd vs qdd (trapezoid, qdd Lipschitz by qddd_max)", qd_error, h**2 / 4.0 * qddd_max,
                            p.qd, p.t)
        out += _consistency("qdd vs qddd (|dqdd| <= h qddd_max)", np.diff(p.qdd, axis=0), h * qddd_max, p.qdd, p.t)
    else:
        out += _consistency("qd vs qdd (|dqd| <= h qdd_max)", np.diff(p.qd, axis=0), h * qdd_max, p.qd, p.t)
    out += _consistency("q vs qd (trapezoid)", q_error, q_bound + position_floor, p.q, p.t)
    return out


def _segment_distances(points, starts, ends):
    """Distances (n, c) from points (n, dof) to segments starts/ends (n, c, dof)."""
    d = ends - starts
    length2 = np.einsum("ncj,ncj->nc", d, d)
    with np.errstate(invalid="ignore", divide="ignore"):
        u = np.where(length2 > 0, np.einsum("ncj,ncj->nc", points[:, None] - starts, d) / length2, 0.0)
    closest = starts + np.clip(u, 0.0, 1.0)[..., None] * d
    return np.linalg.norm(points[:, None] - closest, axis=2)


def polyline_distances(points: np.ndarray, vertices: np.ndarray, tree: cKDTree, enough: float) -> np.ndarray:
    """Distances (n,) from points to the polyline through vertices (m, dof), exact where above ``enough``.

    First the segments next to each point's 8 nearest vertices (an upper bound); then, where that is above
    ``enough``, every segment with a vertex within (that bound + the longest segment) of the point: no
    other segment can be closer."""
    m = len(vertices)
    seg_len = np.linalg.norm(np.diff(vertices, axis=0), axis=1)
    _, nearest = tree.query(points, k=min(8, m))
    nearest = np.atleast_2d(nearest).reshape(len(points), -1)
    first = np.clip(np.concatenate([nearest - 1, nearest], axis=1), 0, m - 2)
    best = _segment_distances(points, vertices[first], vertices[first + 1]).min(axis=1)
    for i in np.flatnonzero(best > enough):
        near = np.array(tree.query_ball_point(points[i], best[i] + seg_len.max() + 1e-300), dtype=int)
        first = np.unique(np.clip(np.concatenate([near - 1, near]), 0, m - 2))
        exact = _segment_distances(points[i:i + 1], vertices[first][None], vertices[first + 1][None])
        best[i] = min(best[i], float(exact.min()))
    return best


def path_deviations(p: Profile, path, limits: dict) -> list[str]:
    """Both ways between the samples and the path (module docstring)."""
    s = np.unique(np.concatenate([np.linspace(0.0, 1.0, PATH_GRID), path.breakpoints]))
    vertices = path(s)
    # Chord error of each polyline interval: a joint's linear interpolation misses it by at most
    # g^2 / 8 max|q''| on the interval (g its length in s). q'' is linear (spline) or constant (linear
    # shape's blends) between breakpoints, which are grid points, so the max of its two ends bounds it
    # there; on the septic monotone pieces max|q''| <= its ends' + g max|q'''| (ends'), up to a g^2 term.
    g = np.diff(s)[:, None]
    second = np.abs(path(s, 2))
    bound2 = np.maximum(second[:-1], second[1:])
    if path.continuity >= 2:
        third = np.abs(path(s, 3))
        bound2 = bound2 + g * np.maximum(third[:-1], third[1:])
    chord_error = float(np.linalg.norm(g**2 / 8.0 * bound2, axis=1).max())
    out = []
    distance = polyline_distances(p.q, vertices, cKDTree(vertices), PATH_TOLERANCE + chord_error)
    k = int(np.argmax(distance))
    if distance[k] > PATH_TOLERANCE + chord_error:
        out.append(f"sample {k} (t = {p.t[k]:.6g} s) is {distance[k]:.3e} rad from the path "
                   f"(bound {PATH_TOLERANCE:g} + chord error {chord_error:.2e})")
    # Path -> samples, per joint in units of time: the path point q(t*) is passed at some t*, the nearest
    # sample is within h_max / 2 of it, and no joint moves faster than qd_max_j.
    qd_max = limits["qd_max"] * (1.0 + LIMIT_TOLERANCE)
    h_max = float(np.diff(p.t).max())
    allowed = h_max / 2.0 + END_TOLERANCE / float(qd_max.min())
    gap, nearest = cKDTree(p.q / qd_max).query(vertices / qd_max, p=np.inf)
    i = int(np.argmax(gap))
    if gap[i] > allowed:
        j = int(np.argmax(np.abs(p.q[nearest[i]] - vertices[i]) / qd_max))
        dq = abs(p.q[nearest[i], j] - vertices[i, j])
        out.append(f"path point s = {s[i]:.9g} is {gap[i]:.6g} s of joint {j + 1}'s top speed from every sample "
                   f"(allowed h_max / 2 = {h_max / 2:.6g} s): |dq| = {dq:.3e} rad")
    return out


def passes_in_order(q: np.ndarray, targets: np.ndarray, allowed: np.ndarray) -> tuple[int, float] | None:
    """The first target (index, its best ratio) that no sample at or after the previous target's first
    match passes within ``allowed`` (per target (n,) or per target and joint (n, dof)); None: all pass."""
    start = 0
    allowed = np.broadcast_to(allowed.reshape(len(targets), -1), targets.shape)
    for i, (w, tol) in enumerate(zip(targets, allowed)):
        ratio = (np.abs(q[start:] - w) / tol).max(axis=1)
        hits = np.flatnonzero(ratio <= 1.0)
        if hits.size == 0:
            return i, float(ratio.min()) if ratio.size else float("inf")
        start += int(hits[0])
    return None


def waypoint_failures(p: Profile, case: Case, method: str, shape: str, limits: dict) -> list[str]:
    w = case.waypoints
    if method == "ruckig":                    # stops at every waypoint, at a sample
        miss = passes_in_order(p.q, w, np.full(len(w), EXACT_TOLERANCE))
        if miss:
            return [f"waypoint {miss[0]} not reached exactly in order: best |q - w| = "
                    f"{miss[1] * EXACT_TOLERANCE:.3e} rad"]
        return []
    keep = kept_indices(w)
    qd_max = limits["qd_max"] * (1.0 + LIMIT_TOLERANCE)
    sampling = qd_max * float(np.diff(p.t).max()) / 2.0 + END_TOLERANCE             # (dof,)
    extra = np.zeros(len(keep))
    if shape == "linear" and len(keep) > 2:
        chords = np.linalg.norm(np.diff(w[keep], axis=0), axis=1)
        extra[1:-1] = DEFAULT_BLEND / 2.0 * np.minimum(chords[:-1], chords[1:])
    out = []
    miss = passes_in_order(p.q, w[keep], sampling[None, :] + extra[:, None])
    if miss:
        out.append(f"kept waypoint {keep[miss[0]]} not passed in order within h_max / 2 x qd_max per joint "
                   f"(+ blend {extra[miss[0]]:.3g}): best ratio {miss[1]:.6g}")
    others = np.setdiff1d(np.arange(len(w)), keep)
    if others.size and shape != "linear":
        # dropped within DUPLICATE_DISTANCE of a kept one, or of one the last waypoint then replaced: 2 x
        gap = (np.abs(p.q[None] - w[others][:, None]) / (sampling + 2 * DUPLICATE_DISTANCE)).max(axis=2).min(axis=1)
        if gap.max() > 1.0:
            out.append(f"merged-away waypoint {others[int(np.argmax(gap))]} not within 2 x DUPLICATE_DISTANCE + "
                       f"h_max / 2 x qd_max of a sample: ratio {gap.max():.6g}")
    return out


def check_profile(p, case: Case, method: str, shape: str, limits: dict) -> list[str]:
    """Every check of the module docstring on one profile -> failure messages (empty: it passed)."""
    if not isinstance(p, Profile):
        return [f"retime returned {type(p).__name__}, not a Profile"]
    w = case.waypoints
    n, dof = len(p.t), w.shape[1]
    columns = {"q": p.q, "qd": p.qd, "qdd": p.qdd, "qddd": p.qddd}
    bad = [name for name, x in columns.items() if np.shape(x) != (n, dof)]
    if bad or n < 2:
        return [f"sample arrays of the wrong shape ({bad}) for {n} samples of {dof} joints"]
    bad = [name for name, x in {"t": p.t, **columns}.items() if not np.all(np.isfinite(x))]
    if bad:
        return [f"non-finite samples in {bad}"]
    out = []
    if p.t[0] != 0.0 or not np.all(np.diff(p.t) > 0.0):
        out.append(f"times do not increase from 0 (t[0] = {p.t[0]}, min step {np.diff(p.t).min():.3g})")
    if p.method != method:
        out.append(f"profile.method {p.method!r}, asked {method!r}")
    for name in ("qd_max", "qdd_max") + (("qddd_max",) if method != "toppra" else ()):
        if not np.allclose(getattr(p.limits, name), limits[name], rtol=1e-12, atol=0.0):
            out.append(f"timed {name} {getattr(p.limits, name)} is not the limit x speed scale {limits[name]}")
    # ends
    for where, k, target in (("start", 0, w[0]), ("end", -1, w[-1])):
        off = float(np.abs(p.q[k] - target).max())
        if off > END_TOLERANCE:
            out.append(f"{where} is {off:.3e} rad from the {'first' if k == 0 else 'last'} waypoint")
        moving = float((np.abs(p.qd[k]) / limits["qd_max"]).max())
        if moving > END_TOLERANCE:
            out.append(f"not at rest at the {where}: |qd| = {moving:.3e} x qd_max")
        if method != "toppra":
            accelerating = float((np.abs(p.qdd[k]) / limits["qdd_max"]).max())
            if accelerating > END_TOLERANCE:
                out.append(f"not at rest at the {where}: |qdd| = {accelerating:.3e} x qdd_max")
    # position limits
    below, above = limits["q_min"] - p.q, p.q - limits["q_max"]
    excess = np.maximum(below, above)
    worst, k, j = _worst(excess)
    if worst > POSITION_TOLERANCE:
        out.append(f"joint {j + 1} passes its position limit by {worst:.3e} rad at t = {p.t[k]:.6g} s "
                   f"(q = {p.q[k, j]!r}, limits [{limits['q_min'][j]!r}, {limits['q_max'][j]!r}])")
    # kinematic limits
    out += _limit_failures("qd", p.qd, limits["qd_max"], LIMIT_TOLERANCE, p.t)
    out += _limit_failures("qdd", p.qdd, limits["qdd_max"], LIMIT_TOLERANCE, p.t)
    if method != "toppra":
        out += _limit_failures("qddd", p.qddd, limits["qddd_max"], LIMIT_TOLERANCE, p.t)
    if limits["tau_max"] is not None:
        if p.tau is None or np.shape(p.tau) != (n, dof) or not np.all(np.isfinite(p.tau)):
            out.append("torque limits given but the profile carries no finite torques")
        else:
            out += _limit_failures("tau", p.tau, limits["tau_max"], LIMIT_TOLERANCE, p.t)
    out += waypoint_failures(p, case, method, shape, limits)
    if method in ("toppra", "topp3"):
        path = make_path(w, limits["q_min"], limits["q_max"], shape)
        out += path_deviations(p, path, limits)
    out += consistency(p, limits, jerk_limited=method != "toppra",
                       position_floor=2.0 * RUCKIG_POSITION_PRECISION if method == "ruckig" else 0.0)
    return out


def refusal_allowed(error: PipelineError, method: str, shape: str) -> bool:
    """The documented refusals: topp3 on the C1 linear shape; no path of the spline shape (it leaves the
    limits: a PathError, before any method times it)."""
    from pipeline.errors import TimingError

    message = str(error)
    if not isinstance(error, TimingError):
        return False
    if method == "topp3" and shape == "linear":
        return "needs a C2 path" in message
    return shape == "spline" and method != "ruckig" and isinstance(error, PathError) and "leaves the limits" in message


def run_case(case: Case, method: str, shape: str, drake=None) -> tuple[str, list[str]]:
    """("profile" | "no path" | "refused" | "crashed", failures) for one case: "no path" when the waypoints
    make no path of the shape (a documented PathError), "refused" when the method refused."""
    robot = robot_named(case.robot)
    unscaled = unscaled_limits(robot, case.own_limits)
    limits = scaled(unscaled, case.speed_scale)
    kwargs = {} if case.own_limits else {"limits": unscaled}
    try:
        profile = retime(robot, case.waypoints.copy(), method=method, speed_scale=case.speed_scale, dt=case.dt,
                         shape=shape, drake=drake, **kwargs)
    except PipelineError as error:
        if not str(error).strip():
            return "refused", [f"{type(error).__name__} without a message"]
        if refusal_allowed(error, method, shape):
            return ("no path" if isinstance(error, PathError) else "refused"), []
        return "refused", [f"undocumented refusal {type(error).__name__}: {error}"]
    except Exception as error:                                            # noqa: BLE001 - that is the finding
        return "crashed", [f"untyped {type(error).__name__}: {error}"]
    return "profile", check_profile(profile, case, method, shape, limits)


def run_fuzz(method: str, shape: str, seeds, robots=ROBOT_NAMES, families=FAMILIES, drake=None,
             own_limits=None) -> dict:
    """Time every seed's case, check it, and fail listing every failing case (up to 20, each once with its
    waypoints, then its failures). Returns the tally of outcomes."""
    tally = {"profile": 0, "no path": 0, "refused": 0, "crashed": 0}
    failing = []
    began = time.perf_counter()
    for seed in seeds:
        case = make_case(int(seed), robots, families)
        if own_limits is not None:
            case = dataclasses.replace(case, own_limits=own_limits)
        outcome, found = run_case(case, method, shape, drake)
        tally[outcome] += 1
        if found:
            failing.append(f"{case.describe()} method={method} shape={shape}\n" + "".join(f"  - {f}\n" for f in found))
    elapsed = time.perf_counter() - began
    print(f"\n{method}/{shape}: {len(seeds)} cases, {tally} in {elapsed:.1f} s, {len(failing)} failing")
    assert not failing, f"{len(failing)} of {len(seeds)} {method}/{shape} cases fail:\n" + "\n".join(failing[:20])
    return tally


def _runs(slow: bool):
    params = []
    for method, shape, quick, many in RUNS:
        count = many if slow else quick
        seeds = range(SLOW_SEED_BASE, SLOW_SEED_BASE + count) if slow else range(count)
        params.append(pytest.param(method, shape, seeds, id=f"{method}-{shape}-{count}",
                                   marks=[pytest.mark.slow] if slow else []))
    return params


def skip_slow_unless_selected(request) -> None:
    """The slow variants take minutes: they run only when the marker expression names them (``-m slow``,
    as ``make test-slow`` does), not in a plain ``pytest tests/timing/test_timing_fuzz.py``."""
    if request.node.get_closest_marker("slow") and "slow" not in (request.config.option.markexpr or ""):
        pytest.skip("slow fuzz run: select it with -m slow")


@pytest.mark.parametrize("method, shape, seeds", _runs(slow=False) + _runs(slow=True))
def test_fuzz_profiles(method, shape, seeds, request):
    skip_slow_unless_selected(request)
    tally = run_fuzz(method, shape, seeds)
    if method == "topp3" and shape == "linear":
        assert tally["profile"] == 0
    if shape == "monotone":                 # the default shape never refuses in-limit waypoints
        assert tally["refused"] == 0 and tally["crashed"] == 0


@pytest.mark.parametrize("count", [pytest.param(TORQUE_COUNTS[0], id=f"torque-{TORQUE_COUNTS[0]}"),
                                   pytest.param(TORQUE_COUNTS[1], id=f"torque-{TORQUE_COUNTS[1]}",
                                                marks=pytest.mark.slow)])
def test_fuzz_toppra_with_torque_limits(count, request):
    """The two-link arm with inertias and tau_max, its own limits: toppra limits torques (from Drake);
    the same checks, and |tau| <= tau_max, on four of the families."""
    skip_slow_unless_selected(request)
    from pipeline.model.chain.drake_model import build_drake_robot

    name = "arm2_dynamics.yaml"
    drake = build_drake_robot(robot_named(name).spec)
    families = ("random", "back_and_forth", "one_joint", "tiny_motion")
    base = 0 if count == TORQUE_COUNTS[0] else SLOW_SEED_BASE
    tally = run_fuzz("toppra", "monotone", range(base, base + count), robots=(name,), families=families, drake=drake,
                     own_limits=True)
    assert tally["profile"] == count


@pytest.mark.parametrize("method", ["toppra", "ruckig", "topp3"])
def test_the_checks_catch_broken_profiles(method):
    """The checker is not vacuous: a good profile passes, and each of these corruptions is caught."""
    case = make_case(9)                                      # family "random"
    assert case.family == "random"
    robot = robot_named(case.robot)
    limits = scaled(unscaled_limits(robot, False), case.speed_scale)
    profile = retime(robot, case.waypoints, method=method, speed_scale=case.speed_scale, dt=case.dt,
                     limits=unscaled_limits(robot, False))
    assert check_profile(profile, case, method, "monotone", limits) == []
    mid = len(profile.t) // 2
    bump = np.zeros_like(profile.q)
    bump[mid, 0] = 1e-4
    corruptions = {
        "q off the path / inconsistent": {"q": profile.q + bump},
        "qd inconsistent and too fast": {"qd": profile.qd * 1.01},
        "qdd over its limit": {"qdd": profile.qdd * 1.5},
        "cut short": {name: getattr(profile, name)[: mid + 1] for name in ("t", "q", "qd", "qdd", "qddd")},
        "time shifted": {"t": profile.t * 0.99},
        "a NaN": {"qd": np.where(np.arange(len(profile.t))[:, None] == mid, np.nan, profile.qd)},
    }
    if method != "toppra":
        corruptions["qddd over its limit"] = {"qddd": profile.qddd * 1.5}
    for what, change in corruptions.items():
        assert check_profile(dataclasses.replace(profile, **change), case, method, "monotone", limits), what
