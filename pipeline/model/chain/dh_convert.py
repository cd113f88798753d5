"""Rewrite a standard-DH RobotSpec in modified (Craig) DH with exactly the same kinematics.

Standard: ``prod_i Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``. Because ``Tx(a) Rx(alpha)`` of row i
commutes into the front of row i + 1, the same chain reads
``prod_i Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i)`` with ``a_0 = alpha_0 = 0``, followed by
``Tx(a_n) Rx(alpha_n)``, which joins the tool transform.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ...errors import ConfigurationError
from ...files.robot_spec import RobotSpec


def _tx_rx(a: float, alpha: float) -> np.ndarray:
    """``Tx(a) Rx(alpha)`` as a 4x4 [m, rad]."""
    c, s = np.cos(alpha), np.sin(alpha)
    return np.array([[1.0, 0, 0, a], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def standard_to_modified(spec: RobotSpec) -> RobotSpec:
    """The modified-DH RobotSpec whose FK equals ``spec``'s for every q (joint variables unchanged)."""
    if spec.convention != "standard":
        raise ConfigurationError(f"{spec.name}: expected a standard-DH spec, got {spec.convention!r}")
    previous = [(0.0, 0.0)] + [(j.a, j.alpha) for j in spec.joints[:-1]]
    joints = tuple(
        dataclasses.replace(joint, a=a_prev, alpha=alpha_prev)
        for joint, (a_prev, alpha_prev) in zip(spec.joints, previous)
    )
    last = spec.joints[-1]
    return dataclasses.replace(
        spec,
        name=f"{spec.name}_modified",
        convention="modified",
        joints=joints,
        X_DnE=_tx_rx(last.a, last.alpha) @ spec.X_DnE,
    )
