"""Drake vs analytic (NumPy) vs central finite differences: FK and Jacobian, per block, as a report."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ConfigurationError
from .chain.drake_model import DrakeRobot, build_drake_robot
from .chain.kinematics import finite_difference_jacobian
from .robot import Robot

#: Analytic vs Drake must agree to round-off [m, rad, m/rad, 1].
EXACT_TOLERANCE = 1e-12
#: Either vs central finite differences (step 1e-6) [m/rad, 1].
FINITE_DIFFERENCE_TOLERANCE = 1e-6
FINITE_DIFFERENCE_STEP = 1e-6

_BLOCKS = ("fk_position", "fk_rotation", "jacobian_linear", "jacobian_angular")


@dataclass(frozen=True)
class Comparison:
    """Worst absolute difference of one pair of implementations, per block, and where it happened."""

    pair: str
    tolerance: float
    max_error: dict[str, float]
    worst_configuration: dict[str, tuple[float, ...]]

    @property
    def worst(self) -> float:
        return max(self.max_error.values())

    @property
    def passed(self) -> bool:
        return self.worst <= self.tolerance


@dataclass(frozen=True)
class JacobianCheckReport:
    """Result of `check_robot`: one Comparison per pair, over ``samples`` seeded configurations."""

    robot: str
    samples: int
    seed: int
    comparisons: tuple[Comparison, ...]

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.comparisons)

    def format(self) -> str:
        """A plain-text table of max errors per block, with pass/fail per pair."""
        head = f"{'pair':<28}" + "".join(f"{b:>18}" for b in _BLOCKS) + f"{'tolerance':>11}  result"
        lines = [f"{self.robot}: {self.samples} seeded in-limit configurations (seed {self.seed})", head]
        for c in self.comparisons:
            errors = "".join(
                f"{c.max_error[b]:>18.2e}" if b in c.max_error else f"{'-':>18}" for b in _BLOCKS
            )
            lines.append(f"{c.pair:<28}{errors}{c.tolerance:>11.0e}  {'PASS' if c.passed else 'FAIL'}")
        for c in self.comparisons:
            if not c.passed:
                block = max(c.max_error, key=c.max_error.get)
                q = ", ".join(f"{v:.6f}" for v in c.worst_configuration[block])
                lines.append(f"  worst {c.pair} {block} at q = [{q}]")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {
            "robot": self.robot,
            "samples": self.samples,
            "seed": self.seed,
            "passed": self.passed,
            "comparisons": [
                {
                    "pair": c.pair,
                    "tolerance": c.tolerance,
                    "passed": c.passed,
                    "max_error": c.max_error,
                    "worst_configuration": c.worst_configuration,
                }
                for c in self.comparisons
            ],
        }


class _Tracker:
    """Keeps the worst error per block and the configuration it came from."""

    def __init__(self, pair: str, tolerance: float):
        self.pair, self.tolerance = pair, tolerance
        self.max_error: dict[str, float] = {}
        self.where: dict[str, tuple[float, ...]] = {}

    def add(self, block: str, error: float, q: np.ndarray) -> None:
        if error >= self.max_error.get(block, -1.0):
            self.max_error[block] = float(error)
            self.where[block] = tuple(float(v) for v in q)

    def add_poses(self, X1: np.ndarray, X2: np.ndarray, q: np.ndarray) -> None:
        self.add("fk_position", np.abs(X1[:3, 3] - X2[:3, 3]).max(), q)
        self.add("fk_rotation", np.abs(X1[:3, :3] - X2[:3, :3]).max(), q)

    def add_jacobians(self, J1: np.ndarray, J2: np.ndarray, q: np.ndarray) -> None:
        self.add("jacobian_linear", np.abs(J1[:3] - J2[:3]).max(), q)
        self.add("jacobian_angular", np.abs(J1[3:] - J2[3:]).max(), q)

    def result(self) -> Comparison:
        return Comparison(self.pair, self.tolerance, dict(self.max_error), dict(self.where))


def check_robot(robot: Robot, samples: int = 200, seed: int = 0, drake: DrakeRobot | None = None) -> JacobianCheckReport:
    """Compare analytic, Drake and finite-difference FK/Jacobians on seeded random in-limit configurations."""
    if samples < 1:
        raise ConfigurationError(f"samples must be >= 1, got {samples}")
    drake = drake or build_drake_robot(robot.spec)
    configurations = robot.random_configurations(np.random.default_rng(seed), samples)
    exact = _Tracker("analytic vs Drake", EXACT_TOLERANCE)
    fd_analytic = _Tracker("analytic vs finite diff", FINITE_DIFFERENCE_TOLERANCE)
    fd_drake = _Tracker("Drake vs finite diff", FINITE_DIFFERENCE_TOLERANCE)
    for q in configurations:
        J_analytic, J_drake = robot.jacobian(q), drake.jacobian(q)
        J_fd = finite_difference_jacobian(robot.fk, q, FINITE_DIFFERENCE_STEP)
        exact.add_poses(robot.fk(q), drake.fk(q), q)
        exact.add_jacobians(J_analytic, J_drake, q)
        fd_analytic.add_jacobians(J_analytic, J_fd, q)
        fd_drake.add_jacobians(J_drake, J_fd, q)
    comparisons = tuple(t.result() for t in (exact, fd_analytic, fd_drake))
    return JacobianCheckReport(robot.name, samples, seed, comparisons)
