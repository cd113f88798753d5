"""Arrays handed to the public API, checked once at the boundary: numbers only, the right shape,
finite. Anything else is a ConfigurationError naming the argument, never a NumPy exception."""

from __future__ import annotations

import sys

import numpy as np

from ..errors import ConfigurationError, shown

#: Joint values, twists and the like beyond this magnitude are refused [SI units]: no joint turns or
#: slides that far, no tool moves that fast, and products of such values overflow.
MAX_MAGNITUDE = 1e6


def is_whole_number(value, low: int, high: int | None = None) -> bool:
    """True when ``value`` is an integer (Python or NumPy, not a bool) in [``low``, ``high``] (``high``
    None: no upper bound): the check of a count handed to the public API."""
    return (not isinstance(value, bool) and isinstance(value, (int, np.integer)) and low <= value
            and (high is None or value <= high))


def float_array(value, what: str, shape: tuple[int | None, ...] | None = None,
                max_abs: float = sys.float_info.max) -> np.ndarray:
    """``value`` as a finite float array; ``shape`` entries of None match any size; every entry within
    +-``max_abs``. (A float64 array passes through without a copy: this sits on hot paths.)"""
    array = value if isinstance(value, np.ndarray) and value.dtype == np.float64 else _as_floats(value, what)
    if shape is not None and (array.ndim != len(shape)
                              or any(want is not None and want != got for want, got in zip(shape, array.shape))):
        expected = "(" + ", ".join("N" if n is None else str(n) for n in shape) + ("," if len(shape) == 1 else "") + ")"
        raise ConfigurationError(f"{what} must have shape {expected}, got {array.shape}")
    if array.size and not np.abs(array).max() <= max_abs:        # NaN fails the comparison too
        if not np.isfinite(array).all():
            raise ConfigurationError(f"{what} has non-finite values")
        raise ConfigurationError(f"{what} has values beyond {max_abs:g} (SI units)")
    return array


def _as_floats(value, what: str) -> np.ndarray:
    """Any array-like of numbers as float64; ConfigurationError for text, objects, booleans, ragged lists."""
    try:
        array = np.asarray(value)
    except (TypeError, ValueError) as exc:          # ragged nesting, unconvertible objects
        raise ConfigurationError(f"{what} must be an array of numbers ({exc})") from exc
    if array.dtype.kind not in "iuf":
        raise ConfigurationError(f"{what} must hold numbers, got {array.dtype} values ({shown(value)})")
    return array.astype(float)


def inertia_matrix(six) -> np.ndarray:
    """[Ixx, Iyy, Izz, Ixy, Ixz, Iyz] [kg m^2] -> the symmetric (3, 3) inertia matrix."""
    ixx, iyy, izz, ixy, ixz, iyz = (float(v) for v in six)
    return np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
