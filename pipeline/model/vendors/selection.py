"""The other way: a pose plus a vendor configuration -> the one joint vector it names.

Our closed-form IK (``pipeline.model.ik.solve_ik_batch``, method ``analytic``) gives every in-limit branch of
a pose; each is expanded into all its in-limit 2 pi variants (``ik.result.limit_variants``); the vendor
configuration of every candidate is computed as ``configuration.configurations`` computes it from joint
values, and the candidate whose configuration equals the one asked for is the answer; where none does, the
candidate it describes with an axis on a field's boundary to within round-off (``configuration.
mismatched_field``: KUKA's sign of an axis at 0 by round-off, ABB's quadrant at a multiple of 90 deg). None, or two
different joint vectors with it (a configuration that does not fix every 2 pi variant, e.g. KUKA's Turn
on an axis of more than +-360 deg), is a ``ConfigurationNotFoundError`` naming the pose, the
configuration asked for and the ones the pose's solutions have.
"""

from __future__ import annotations

import numpy as np

from ...errors import ConfigurationNotFoundError, OutputError, VendorConfigurationError
from ..ik import solve_ik_batch
from ..ik.result import check_targets, limit_variants
from .axes import check_vendor
from .configuration import configurations, format_configuration, mismatched_field, parse_configuration

#: Two candidates closer than this (largest joint difference [rad]) are one solution listed twice.
SAME_SOLUTION = 1e-6


def select_solution(robot, X_target, configuration, vendor: str) -> np.ndarray:
    """The joint values q (6,) [rad] of pose X_target (4, 4) [m, base frame to the robot's end frame]
    with the vendor configuration asked for (its text or integer fields). For a TCP pose, pass the robot
    with its tool (``pipeline.model.robot.robot_with_tool``): the configuration does not depend on the tool."""
    return select_solutions(robot, np.asarray(X_target, dtype=float)[None], [configuration], vendor)[0]


def select_solutions(robot, X_targets, configs, vendor: str) -> np.ndarray:
    """``select_solution`` for N poses (N, 4, 4) and N configurations -> Q (N, 6) [rad]."""
    check_vendor(vendor)
    X = check_targets(X_targets)
    wanted = np.array([parse_configuration(vendor, c) for c in configs], dtype=int).reshape(len(configs), -1)
    if len(wanted) != len(X):
        raise VendorConfigurationError(f"{len(X)} poses but {len(wanted)} configurations")
    candidates, owner = _candidates(robot, X)
    have = configurations(robot, candidates, vendor) if len(candidates) else np.empty((0, wanted.shape[1]), int)
    match = (have == wanted[owner]).all(axis=1)
    bounds = np.searchsorted(owner, np.arange(len(X) + 1))          # owner is sorted: pose n's rows
    out = np.empty((len(X), 6))
    for n in range(len(X)):
        rows = slice(bounds[n], bounds[n + 1])
        found = _distinct(candidates[rows][match[rows]])
        if not len(found):                         # an axis on a field's boundary by round-off: either side
            found = _distinct(np.array([q for q in candidates[rows]
                                        if mismatched_field(robot, q, vendor, wanted[n]) is None]).reshape(-1, 6))
        if len(found) != 1:
            raise _not_found(vendor, X[n], wanted[n], have[rows], found)
        out[n] = found[0]
    return out


def pose_solutions(robot, X_targets) -> list[np.ndarray]:
    """Every distinct in-limit IK solution of each pose X_targets (N, 4, 4) [m], 2 pi variants included: per
    pose, joint values (K, 6) [rad] (K = 0 where the pose is out of reach)."""
    X = check_targets(X_targets)
    candidates, owner = _candidates(robot, X)
    bounds = np.searchsorted(owner, np.arange(len(X) + 1))          # owner is sorted: pose n's rows
    return [_distinct(candidates[bounds[n]:bounds[n + 1]]) for n in range(len(X))]


def written_configuration(robot, X_written: np.ndarray, q: np.ndarray, vendor: str, tolerance: float,
                          what: str = "the target") -> np.ndarray:
    """The vendor configuration (fields) to write with a target whose file holds the pose X_written (4, 4)
    [m] (its pose as the file rounds it) and whose joint values are q (6,) [rad]: q's own when X_written with
    it selects a solution within ``tolerance`` [rad] of q, as a reader of the file would; else (an axis on a
    field's boundary, such as KUKA's sign of an axis at 0 or ABB's quadrant at a multiple of 90 deg, that
    round-off or the file's rounding moves across) that of X_written's in-limit solution (2 pi variants
    included) nearest q. OutputError naming ``what`` when none lies within ``tolerance`` of q (a singular
    pose that the rounding moves off its branch)."""
    own = configurations(robot, q, vendor)
    try:
        if np.abs(select_solution(robot, X_written, own, vendor) - q).max() <= tolerance:
            return own
    except ConfigurationNotFoundError:
        pass
    candidates, _ = _candidates(robot, np.asarray(X_written, dtype=float)[None])
    gaps = np.abs(candidates - q).max(axis=1) if len(candidates) else np.array([np.inf])
    if gaps.min() > tolerance:
        raise OutputError(f"{robot.name}: {what} of joint values {np.round(np.degrees(q), 4).tolist()} deg has no "
                          f"solution within {tolerance:g} rad of them (nearest {gaps.min():.3g} rad): a singular "
                          "pose?")
    return configurations(robot, candidates[int(np.argmin(gaps))], vendor)


def _candidates(robot, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every in-limit IK solution and 2 pi variant of the poses X (N, 4, 4): joint values (K, 6) [rad]
    and the index of the pose each belongs to (K,)."""
    results = solve_ik_batch(robot, X, method="analytic")
    rows, owner = [], []
    for n, result in enumerate(results):
        for solution in result.solutions:
            rows.append(solution.q)
            owner.append(n)
    if not rows:
        return np.empty((0, 6)), np.empty(0, dtype=int)
    limits = robot.limits
    shifted, valid = limit_variants(np.array(rows), robot.revolute_mask, limits.q_min, limits.q_max)
    owner = np.repeat(np.array(owner), shifted.shape[1]).reshape(valid.shape)
    return shifted[valid], owner[valid]


def _distinct(Q: np.ndarray) -> np.ndarray:
    """The rows of Q (K, 6) that are not within SAME_SOLUTION of an earlier row (the same solution twice)."""
    kept = []
    for q in Q:
        if not any(np.abs(q - other).max() <= SAME_SOLUTION for other in kept):
            kept.append(q)
    return np.array(kept).reshape(-1, 6)


def _not_found(vendor: str, X: np.ndarray, wanted, have: np.ndarray, found: np.ndarray) -> ConfigurationNotFoundError:
    """The error for a pose whose solutions have the configuration ``wanted`` none or several times."""
    requested = format_configuration(vendor, wanted)
    available = tuple(sorted({format_configuration(vendor, row) for row in have}))
    position = ", ".join(f"{v * 1000.0:.3f}" for v in X[:3, 3])
    rotation = np.array2string(X[:3, :3], precision=6, separator=", ").replace("\n", "")
    where = f"pose at ({position}) mm with rotation {rotation}"
    if len(found):
        q = "; ".join(np.array2string(np.degrees(q), precision=4, separator=", ") for q in found)
        problem = f"{len(found)} different in-limit solutions have it (joint values [deg]: {q})"
    else:
        problem = "no in-limit IK solution has it"
    listing = "; ".join(available) if available else "none (no in-limit IK solution)"
    return ConfigurationNotFoundError(f"{where}: {vendor} configuration {requested}: {problem}; the configurations "
                                      f"of its solutions: {listing}", X, requested, available)
