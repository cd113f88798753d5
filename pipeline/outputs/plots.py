"""Figures at the edge: a profile's q, qd, qdd, jerk (and torque) against time, limits dashed; the TCP's
position, speed and acceleration.

Figures are ``matplotlib.figure.Figure`` objects made without pyplot, so no global backend is chosen:
they save headless anywhere, and a notebook shows a returned figure inline.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib
import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from ..timing.profile import Profile, limits_at

#: Axis label and unit per quantity, for revolute and for prismatic joints.
_AXES = {"q": ("q", "rad", "m"), "qd": ("qd", "rad/s", "m/s"), "qdd": ("qdd", "rad/s^2", "m/s^2"),
         "qddd": ("jerk", "rad/s^3", "m/s^3"), "tau": ("torque", "N m", "N")}


def _ylabel(quantity: str, revolute: Sequence[bool]) -> str:
    label, rotary, linear = _AXES[quantity]
    units = {rotary if r else linear for r in revolute}
    return f"{label} [{units.pop() if len(units) == 1 else f'{rotary} or {linear}'}]"


def _limit_lines(profile: Profile, quantity: str):
    """(lower, upper) per joint for a quantity, or None when the profile was not timed against one."""
    limits = profile.limits
    if quantity == "q":
        return limits.q_min, limits.q_max
    upper = {"qd": limits.qd_max, "qdd": limits.qdd_max, "qddd": limits.qddd_max, "tau": limits.tau_max}[quantity]
    return None if upper is None else (-upper, upper)


def profile_figure(profile: Profile, revolute: Sequence[bool], title: str) -> Figure:
    """Stacked axes q, qd, qdd, jerk (and torque when the profile has it) against t [s], one line per
    joint, its limits dashed in the same colour (q: min and max, none for a continuous joint; the
    others: +-limit, the limits the profile was timed against: the robot's x the speed scale, as the
    legend says)."""
    quantities = ("q", "qd", "qdd", "qddd") + (("tau",) if profile.tau is not None else ())
    figure = Figure(figsize=(10, 2.75 * len(quantities)), layout="constrained")
    axes = figure.subplots(len(quantities), 1, sharex=True)
    colours = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, quantity in zip(axes, quantities):
        values = getattr(profile, quantity)
        bounds = _limit_lines(profile, quantity)
        for j, name in enumerate(profile.joint_names):
            colour = colours[j % len(colours)]
            ax.plot(profile.t, values[:, j], color=colour, linewidth=1.2, label=f"{j + 1} {name}")
            if bounds is not None:
                for bound in (bounds[0][j], bounds[1][j]):
                    if np.isfinite(bound):           # a continuous joint has no q limits to draw
                        ax.axhline(bound, color=colour, linestyle="--", linewidth=0.7, alpha=0.6)
        ax.set_ylabel(_ylabel(quantity, revolute))
        if bounds is None:
            ax.text(0.99, 0.95, "not limited", transform=ax.transAxes, ha="right", va="top", fontsize=8)
        ax.grid(True, linewidth=0.3)
    handles, _ = axes[0].get_legend_handles_labels()
    scaled = "" if profile.speed_scale == 1.0 else f" (qd, qdd, jerk x speed scale {profile.speed_scale:g}^1,2,3)"
    handles.append(Line2D([], [], color="grey", linestyle="--", linewidth=0.7, label="limits" + scaled))
    axes[0].legend(handles=handles, loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=8, title="joint")
    axes[-1].set_xlabel("t [s]")
    figure.suptitle(title)
    return figure


def plot_profile(path: str | Path, profile: Profile, revolute: Sequence[bool], title: str) -> None:
    """Write ``profile_figure`` as a PNG."""
    profile_figure(profile, revolute, title).savefig(path, dpi=100, format="png")


def tcp_figure(profile: Profile, title: str) -> Figure:
    """The TCP against t [s] (as seed 003's figures 8-10): its position x, y, z [mm], its speed [mm/s] and
    its acceleration [mm/s^2] with their limits dashed where they apply (the limits x the speed scale:
    the job's safety limit everywhere, a tool move's own on its line or arc, ``limits_at``)."""
    tcp = profile.tcp
    _, speed_limit, accel_limit = limits_at(profile.limits, profile.schedule, profile.t)
    figure = Figure(figsize=(10, 8.25), layout="constrained")
    axes = figure.subplots(3, 1, sharex=True)
    for k, axis in enumerate("xyz"):
        axes[0].plot(profile.t, 1e3 * tcp.position[:, k], linewidth=1.2, label=axis)
    axes[0].legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=8)
    axes[0].set_ylabel("TCP position [mm]")
    for ax, values, limit, label in ((axes[1], tcp.speed, speed_limit, "TCP speed [mm/s]"),
                                     (axes[2], tcp.accel, accel_limit, "TCP acceleration [mm/s^2]")):
        ax.plot(profile.t, 1e3 * values, color="tab:blue", linewidth=1.2)
        if np.isfinite(limit).any():
            ax.plot(profile.t, np.where(np.isfinite(limit), 1e3 * limit, np.nan), color="tab:red", linestyle="--",
                    linewidth=0.8, label="limit")
            ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=8)
        else:
            ax.text(0.99, 0.95, "not limited", transform=ax.transAxes, ha="right", va="top", fontsize=8)
        ax.set_ylabel(label)
    for ax in axes:
        ax.grid(True, linewidth=0.3)
    axes[-1].set_xlabel("t [s]")
    figure.suptitle(title)
    return figure


def plot_tcp(path: str | Path, profile: Profile, title: str) -> None:
    """Write ``tcp_figure`` as a PNG."""
    tcp_figure(profile, title).savefig(path, dpi=100, format="png")
