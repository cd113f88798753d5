"""The clearance certificate of a profile: the smallest distance to every obstacle and between links
over the whole motion, proven between the configurations it evaluates (no Drake here: the distances
come from a ``CollisionModel``).

Between two profile samples the true joint motion stays within ``A dt^2 / 8`` of the straight line
between them, per joint (A: the joint's acceleration bound: its limit, or where the robot has none the
largest sampled |qdd|, which makes the proof rest on the samples), and any point of the robot moves at most
``sum_j |dq_j| * lever_j`` when the joints move by dq (``CollisionModel.lever_arms``). So from an
evaluated configuration whose margin (distance minus the clearance) is m, the next ``m - tube`` of
that displacement measure is certified without looking (conservative advancement): the evaluations
crowd where the robot is close to something and thin out where it is far, and nothing can pass
between them. A margin below zero at an evaluation is a measured violation and ends the check; a
margin within the interpolation tube cannot prove the stretch ahead, so the check goes on sample by
sample from there (to find a violation if there is one) and fails as "not certified" otherwise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: The smallest advance [m of the displacement measure]: a margin below it (but not below zero) is
#: reported as not certified rather than crawled through.
MIN_ADVANCE_M = 1e-5
#: ``min_distance_m`` is the smallest robot-obstacle distance over the samples to within this [m].
MIN_DISTANCE_TOLERANCE_M = 1e-6


@dataclass(frozen=True)
class ClearanceReport:
    """What the clearance check found: ``clearance_m`` (required to obstacles), the smallest
    robot-obstacle distance over the profile's samples ``min_distance_m`` (to within
    MIN_DISTANCE_TOLERANCE_M; after a failure, over the samples before it: ``_smallest_at_samples``)
    with its ``pair`` (robot body, obstacle) and time ``t_s`` (inf/None when no obstacle was within
    reach), the smallest link-link distance among the evaluated configurations ``self_min_distance_m``
    with its ``self_pair`` and ``self_t_s`` (the evaluations lie on the straight lines between samples,
    more sparsely where the links are far apart), ``tube_m`` (how far the true motion may stray from the
    evaluated one between samples), ``evaluations`` (distance queries of the certificate;
    ``sample_evaluations``: those made to find ``min_distance_m``), and ``passed``: the margin stayed
    above zero everywhere. ``reason`` says why not ("" when passed) and ``failed_at_s`` where [s]."""

    clearance_m: float
    min_distance_m: float
    pair: tuple[str, str] | None
    t_s: float | None
    self_min_distance_m: float
    self_pair: tuple[str, str] | None
    self_t_s: float | None
    tube_m: float
    evaluations: int
    passed: bool
    reason: str = ""
    failed_at_s: float | None = None
    sample_evaluations: int = 0

    def __str__(self) -> str:
        verdict = "PASS" if self.passed else f"FAIL ({self.reason})"
        closest = ("no obstacle in reach" if self.pair is None else f"closest {self.pair[0]} - {self.pair[1]} "
                   f"{self.min_distance_m * 1e3:.1f} mm at t = {self.t_s:.3f} s")
        return (f"clearance {self.clearance_m * 1e3:g} mm: {verdict}; {closest}; links "
                f"{self.self_min_distance_m * 1e3:.1f} mm apart at the closest evaluated "
                f"({self.evaluations} evaluations)")

    def to_dict(self) -> dict:
        def finite(value: float) -> float | None:
            return value if math.isfinite(value) else None

        return {"passed": self.passed, "reason": self.reason, "clearance_m": self.clearance_m,
                "min_distance_m": finite(self.min_distance_m), "pair": None if self.pair is None else list(self.pair),
                "t_s": self.t_s, "self_min_distance_m": finite(self.self_min_distance_m),
                "self_pair": None if self.self_pair is None else list(self.self_pair), "self_t_s": self.self_t_s,
                "tube_m": self.tube_m, "evaluations": self.evaluations,
                "sample_evaluations": self.sample_evaluations, "failed_at_s": self.failed_at_s,
                "method": "conservative advancement on the sampled motion with a lever-arm displacement bound"}


def interpolation_tube(model, t: np.ndarray, qdd_bound: np.ndarray) -> float:
    """How far any robot point may be from where the straight-line interpolation of the samples puts it
    [m]: per joint the interpolation error bound ``A dt^2 / 8``, through the lever arms."""
    dt = float(np.max(np.diff(t))) if len(t) > 1 else 0.0
    return float(np.sum(qdd_bound * dt**2 / 8.0 * model.lever_arms))


def certify_clearance(model, t: np.ndarray, q: np.ndarray, qdd_bound: np.ndarray) -> ClearanceReport:
    """Check samples ``t`` (N,) [s], ``q`` (N, dof) of a motion whose joint accelerations stay within
    ``qdd_bound`` (dof,) between samples against ``model``'s clearance (see the module docstring)."""
    tube = interpolation_tube(model, t, qdd_bound)
    steps = np.abs(np.diff(q, axis=0)) @ model.lever_arms
    along = np.concatenate([[0.0], np.cumsum(steps)])          # the displacement measure at the samples
    best_self = (math.inf, None, None)
    evaluated = []                                              # (s, obstacle distance) of each evaluation
    s, end, verdict, uncertain = 0.0, float(along[-1]), (True, "", None), None
    while True:
        q_s, t_s = _at(along, t, q, s)
        margin, c = model.margin(q_s)
        evaluated.append((s, c.obstacle))
        if c.self < best_self[0]:
            best_self = (c.self, c.self_pair, t_s)
        if margin < 0.0:
            verdict = (False, f"{model.why_not_free(q_s)} at t = {t_s:.4f} s", t_s)
            break
        if s >= end:
            break
        if margin - tube >= MIN_ADVANCE_M:
            s = min(s + margin - tube, end)
            continue
        if uncertain is None:   # too close to prove the stretch ahead: go on sample by sample
            uncertain = (False, f"{model.why_not_free(q_s)} at t = {t_s:.4f} s, within the {tube * 1e3:.3f} mm the "
                         "motion may stray between samples: not certified (a smaller dt certifies it)", t_s)
        s = float(along[min(int(np.searchsorted(along, s, side="right")), len(along) - 1)])
    if verdict[0] and uncertain is not None:
        verdict = uncertain
    *closest, sample_evaluations = _smallest_at_samples(model, t, q, along, np.array(evaluated))
    return ClearanceReport(model.clearance_m, *closest, *best_self, tube, len(evaluated), *verdict,
                           sample_evaluations=sample_evaluations)


def _smallest_at_samples(model, t: np.ndarray, q: np.ndarray, along: np.ndarray,
                         evaluated: np.ndarray) -> tuple[float, tuple[str, str] | None, float | None, int]:
    """(distance [m], pair, time [s], samples evaluated): the smallest robot-obstacle distance over the
    samples the check got to (all of them when it passed), to within MIN_DISTANCE_TOLERANCE_M. No point
    of the robot moves farther than the displacement measure, so a sample's distance is at least an
    evaluation's less the measure between them (``evaluated``: (s, distance) rows in order of s): samples
    are evaluated from the lowest such bound up, until no bound is below the smallest found."""
    s_e, d_e = evaluated[:, 0], evaluated[:, 1]
    checked = int(np.searchsorted(along, s_e[-1], side="right"))     # the samples the check got to
    along = along[:checked]
    after = np.minimum(np.searchsorted(s_e, along), len(s_e) - 1)
    before = np.maximum(after - 1, 0)
    bound = np.maximum(d_e[before] - np.abs(along - s_e[before]), d_e[after] - np.abs(s_e[after] - along))
    best, count = (math.inf, None, None), 0
    for k in np.argsort(bound, kind="stable"):
        if not bound[k] < best[0] - MIN_DISTANCE_TOLERANCE_M:
            break
        c = model.clearance(q[k])
        count += 1
        if c.obstacle < best[0]:
            best = (c.obstacle, c.obstacle_pair, float(t[k]))
    return (*best, count)


def _at(along: np.ndarray, t: np.ndarray, q: np.ndarray, s: float) -> tuple[np.ndarray, float]:
    """The straight-line interpolation of the samples at displacement measure ``s``: (q, t)."""
    if len(t) == 1:
        return q[0], float(t[0])
    k = min(int(np.searchsorted(along, s, side="right")) - 1, len(t) - 2)
    width = along[k + 1] - along[k]
    f = 0.0 if width <= 0.0 else min((s - along[k]) / width, 1.0)
    return q[k] + f * (q[k + 1] - q[k]), float(t[k] + f * (t[k + 1] - t[k]))
