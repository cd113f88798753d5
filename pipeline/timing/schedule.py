"""Limits that change along a motion, move by move: ``LimitSchedule``.

A program's moves have their own speeds: a joint move a percentage of the joint speed limits, a tool
move its own TCP speed (and the job's TCP acceleration) on the parts of its line or arc outside its
zones. Along one timed path these are intervals of the path parameter s; on a profile, intervals of
its time t. On interval k, ``[bounds[k], bounds[k + 1]]``, the joint speed limits are multiplied by
``joint_speed[k]`` in (0, 1] and the TCP's speed and acceleration are at most ``tcp_speed[k]`` [m/s]
and ``tcp_accel[k]`` [m/s^2] (``inf``: not limited there). The intervals are closed: at a bound two
intervals share, the stricter of their limits holds (a tool move's TCP speed holds at the point where
its line begins, though the blend before it is not limited). These limits come on top of the profile's
``Limits`` (which a schedule never loosens: a job's safety TCP limit holds everywhere).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class LimitSchedule:
    """Per-interval limits along s or t (see the module docstring): ``bounds`` (m + 1,) increasing;
    ``joint_speed``, ``tcp_speed``, ``tcp_accel`` (m,) [1, m/s, m/s^2]."""

    bounds: np.ndarray
    joint_speed: np.ndarray
    tcp_speed: np.ndarray
    tcp_accel: np.ndarray

    def __post_init__(self):
        m = len(self.bounds) - 1
        if m < 1 or any(len(a) != m for a in (self.joint_speed, self.tcp_speed, self.tcp_accel)):
            raise ValueError("a LimitSchedule needs m + 1 bounds and m values of each limit")
        if np.any(np.diff(self.bounds) < 0.0):
            raise ValueError("the bounds of a LimitSchedule must not decrease")

    @classmethod
    def uniform(cls, start: float, end: float, joint_speed: float = 1.0, tcp_speed: float = np.inf,
                tcp_accel: float = np.inf) -> "LimitSchedule":
        """One interval [start, end] with the given limits."""
        return cls(np.array([start, end], dtype=float), np.array([joint_speed], dtype=float),
                   np.array([tcp_speed], dtype=float), np.array([tcp_accel], dtype=float))

    def at(self, x) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(joint_speed, tcp_speed, tcp_accel) (n,) at x (n,): the stricter of two intervals at a shared
        bound; outside the bounds, the first or last interval's."""
        x = np.atleast_1d(np.asarray(x, dtype=float))
        last = len(self.bounds) - 2
        right = np.clip(np.searchsorted(self.bounds, x, side="right") - 1, 0, last)   # interval starting at or before x
        left = np.clip(np.searchsorted(self.bounds, x, side="left") - 1, 0, last)     # interval ending at or after x
        return tuple(np.minimum(values[left], values[right])
                     for values in (self.joint_speed, self.tcp_speed, self.tcp_accel))

    def mapped(self, bounds: np.ndarray) -> "LimitSchedule":
        """The same intervals with new ``bounds`` (e.g. the times at which a profile passes the s bounds)."""
        return LimitSchedule(np.asarray(bounds, dtype=float), self.joint_speed, self.tcp_speed, self.tcp_accel)

    def shifted(self, offset: float) -> "LimitSchedule":
        """The schedule with every bound moved by ``offset``."""
        return self.mapped(self.bounds + offset)

    @property
    def limits_tcp(self) -> bool:
        """Whether some interval limits the TCP's speed or acceleration."""
        return bool(np.isfinite(self.tcp_speed).any() or np.isfinite(self.tcp_accel).any())


def joined_schedules(schedules: list[LimitSchedule]) -> LimitSchedule:
    """Schedules one after the other (each starts where the previous one ends) as one."""
    return LimitSchedule(np.concatenate([schedules[0].bounds[:1]] + [s.bounds[1:] for s in schedules]),
                         *(np.concatenate([getattr(s, name) for s in schedules])
                           for name in ("joint_speed", "tcp_speed", "tcp_accel")))
