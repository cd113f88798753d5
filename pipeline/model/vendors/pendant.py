"""Vendor joint conventions: Fanuc's J2/J3 coupling, and joint lists as teach pendants show them.

Our model's q3 for the Fanuc LR Mate 200iD is the *serial* J3 angle (the forearm relative to the
upper arm). Fanuc pendants show J3 relative to the horizontal instead, so that moving J2 alone keeps
the forearm's attitude: ``J3_pendant = q3 - q2`` (models/SOURCES.md). The other joints agree.
"""

from __future__ import annotations

import numpy as np

from ...errors import ConfigurationError
from ...files.units import ANGLE_UNITS


def _unit_scale(unit: str) -> float:
    if not isinstance(unit, str) or unit not in ANGLE_UNITS:
        raise ConfigurationError(f"angle unit must be one of {', '.join(ANGLE_UNITS)}, got {unit!r}")
    return ANGLE_UNITS[unit]


def _six_angles(values, what: str) -> np.ndarray:
    values = np.asarray(values, dtype=float)
    if values.shape[-1:] != (6,) or not np.isfinite(values).all():
        raise ConfigurationError(f"{what} must be 6 finite joint angles (or rows of 6), got shape {values.shape}")
    return values


def fanuc_serial_to_pendant(q, unit: str = "deg") -> np.ndarray:
    """Serial joint angles q [rad] (model) -> Fanuc pendant angles in ``unit``: J3 = q3 - q2."""
    q = _six_angles(q, "q").copy()
    q[..., 2] = q[..., 2] - q[..., 1]
    return q / _unit_scale(unit)


def fanuc_pendant_to_serial(pendant, unit: str = "deg") -> np.ndarray:
    """Fanuc pendant angles in ``unit`` -> serial joint angles q [rad] (model): q3 = J3 + J2."""
    q = _six_angles(pendant, "pendant angles") * _unit_scale(unit)
    q[..., 2] = q[..., 2] + q[..., 1]
    return q


def pendant_list(q, unit: str = "deg", decimals: int = 3) -> str:
    """A joint list as a pendant shows it: ``J1 10.000  J2 -5.500 ... [deg]`` from q [rad]."""
    values = np.asarray(q, dtype=float) / _unit_scale(unit)
    return "  ".join(f"J{i + 1} {v:.{decimals}f}" for i, v in enumerate(values)) + f" [{unit}]"


def parse_pendant_list(values, unit: str = "deg") -> np.ndarray:
    """Joint values typed as on a pendant (numbers in ``unit``) -> q [rad]."""
    values = np.asarray(values, dtype=float)
    if values.ndim != 1 or not np.isfinite(values).all():
        raise ConfigurationError(f"a joint list must be finite numbers, got {values}")
    return values * _unit_scale(unit)
