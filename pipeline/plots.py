"""Figures at the edge: a profile's q, qd, qdd, jerk (and torque) against time, limits dashed.

Figures are ``matplotlib.figure.Figure`` objects made without pyplot, so no global backend is chosen:
they save headless anywhere, and a notebook shows a returned figure inline.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from .profile import Profile

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
    joint, its limits dashed in the same colour (q: min and max; the others: +-limit, the limits the
    profile was timed against: the robot's x the speed scale, as the legend says)."""
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
