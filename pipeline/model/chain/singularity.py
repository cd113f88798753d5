"""Singularity measures of a geometric Jacobian: determinant, singular values, manipulability,
and which joint columns become dependent."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import ConfigurationError
from ...files.arrays import MAX_MAGNITUDE, float_array

#: A singular value below this (relative to the largest) counts as lost rank.
RELATIVE_RANK_TOLERANCE = 1e-9
#: A joint takes part in a dependency when its weight in a null-space vector exceeds this.
NULL_WEIGHT_THRESHOLD = 1e-6


@dataclass(frozen=True, eq=False)
class SingularityReport:
    """Singularity measures at one configuration.

    ``determinant``: det(J) for square J, else None. ``singular_values``: descending.
    ``manipulability``: Yoshikawa's sqrt(det(J J^T)) (sqrt(det(J^T J)) for fewer than 6 joints),
    the product of the singular values. ``dependent_joint_sets``: for each lost rank,
    the 0-based indices of the joints whose columns combine to zero (from the null space of J).
    The linear rows are in m/rad and the angular rows in 1, as in the Jacobian itself.
    """

    determinant: float | None
    singular_values: np.ndarray
    manipulability: float
    rank: int
    dependent_joint_sets: tuple[tuple[int, ...], ...]

    @property
    def smallest_singular_value(self) -> float:
        return float(self.singular_values[-1])

    @property
    def is_singular(self) -> bool:
        return self.rank < self.singular_values.size

    def __str__(self) -> str:
        det = "n/a (not square)" if self.determinant is None else f"{self.determinant:.3e}"
        sets = ", ".join("{" + ", ".join(f"J{i + 1}" for i in s) + "}" for s in self.dependent_joint_sets)
        return (
            f"det(J) = {det}, sigma_min = {self.smallest_singular_value:.3e}, "
            f"manipulability = {self.manipulability:.3e}, rank = {self.rank}, "
            f"dependent columns: {sets or 'none'}"
        )


def compute_singularity(J: np.ndarray) -> SingularityReport:
    """Singularity measures of a (6, dof) Jacobian."""
    J = float_array(J, "Jacobian", (6, None), MAX_MAGNITUDE)
    if J.shape[1] == 0:
        raise ConfigurationError("Jacobian must have at least one column")
    U, s, Vt = np.linalg.svd(J)
    tolerance = RELATIVE_RANK_TOLERANCE * max(s[0], 1.0)
    rank = int(np.sum(s > tolerance))
    # Null space of J: right singular vectors beyond the rank (including dof - 6 redundant ones).
    null_vectors = Vt[rank:]
    dependent = tuple(
        tuple(int(i) for i in np.flatnonzero(np.abs(v) > NULL_WEIGHT_THRESHOLD)) for v in null_vectors
    )
    rows, cols = J.shape
    determinant = float(np.linalg.det(J)) if rows == cols else None
    manipulability = float(np.prod(s))
    return SingularityReport(determinant, s, manipulability, rank, dependent)


#: A joint takes part in a near singularity when its weight in the weakest direction of J is above this
#: fraction of the largest weight.
NEAR_WEIGHT_FRACTION = 0.3


def near_singularity(J: np.ndarray) -> str:
    """Which joints nearly cancel at a near-singular (6, 6) Jacobian, named the way arm users name it:
    wrist (only wrist joints 4-6 take part), shoulder (joint 1 takes part), elbow (joints 2, 3, not 1),
    else the joints."""
    _, _, Vt = np.linalg.svd(float_array(J, "Jacobian", (6, None), MAX_MAGNITUDE))
    weights = np.abs(Vt[-1])
    joints = tuple(int(i) for i in np.flatnonzero(weights > NEAR_WEIGHT_FRACTION * weights.max()))
    names = ", ".join(f"J{i + 1}" for i in joints)
    if J.shape[1] == 6 and set(joints) <= {3, 4, 5}:
        return f"a wrist singularity (J4 and J6 nearly aligned, q5 near 0: {names} nearly cancel)"
    if 0 in joints:
        return f"a shoulder singularity (the wrist near the axis of J1: {names} nearly cancel)"
    if set(joints) & {1, 2}:
        return f"an elbow singularity (the arm nearly stretched or folded: {names} nearly cancel)"
    return f"a singularity ({names} nearly cancel)"
