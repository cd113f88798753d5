"""Time-parameterised joint profiles and their certification against the limits.

``certify(profile, limits)`` is the one judge of every profile this package makes: per-joint
peak/limit ratios of q, qd, qdd and qddd (and torques) on the profile's samples, the TCP's speed and
acceleration ratios when the limits bound them, the worst sample, and in a cell the clearance
(``pipeline.timing.clearance``), pass/fail. A profile's ``schedule`` (limits that change move by move) is judged
too: each sample's qd and TCP speed and acceleration against the limit that applied at its time.
A position ratio is the peak distance from the middle of the range over half the range, so 1 is
"on a limit" for every quantity; a continuous joint (no position limits) has position ratio 0.
The columns are also judged against each other between consecutive samples (``ColumnAgreement``): q
with qd, qd with qdd, qdd with qddd, each within what the limits allow between two samples.
In JSON (``limit_values``) an infinite limit, a continuous joint's q_min and q_max, is null, as a
quantity without limits is.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..errors import ConfigurationError
from ..files.robot_spec import Limits
from .clearance import ClearanceReport, certify_clearance
from .schedule import LimitSchedule

#: A peak/limit ratio up to 1 + this passes (round-off of the samples) [1].
CERTIFY_TOLERANCE = 1e-6
QUANTITIES = ("q", "qd", "qdd", "qddd", "tau", "tcp_speed", "tcp_accel")
#: Quantities of the TCP, not of a joint (their ratios have one entry).
TCP_QUANTITIES = ("tcp_speed", "tcp_accel")
#: Each column and its time derivative's column, with the names of the limits that bound the derivative
#: and the derivative's own derivative (None: no such limit), judged against each other between samples.
COLUMN_PAIRS = (("q", "qd", "qd_max", "qdd_max"), ("qd", "qdd", "qdd_max", "qddd_max"),
                ("qdd", "qddd", "qddd_max", None))
#: The round-off a column agreement allows, in units of the double epsilon x the column's largest magnitude
#: and the latest time x the derivative column's largest magnitude (a sample's time is rounded too) [1].
ROUNDOFF_ULPS = 64
#: A change of q between two samples that qd need not explain [rad or m]: twice the precision with which a
#: timing back end meets a waypoint (Ruckig ends a segment within 1e-8 of its target, and the profile then
#: holds the target itself: measured 6.8e-9 rad on 1e-9..1e-5 rad moves). Far below any physical meaning.
POSITION_PRECISION = 2e-8


@dataclass(frozen=True)
class TimingDetails:
    """Base of what a timing back end reports it did: named numbers and flags only (no prose), each
    back end's subclass documenting its fields and their units."""

    def to_dict(self) -> dict:
        """The fields as a JSON-ready dict."""
        return dataclasses.asdict(self)


@dataclass(frozen=True, eq=False)
class TcpSamples:
    """The TCP at a profile's samples: ``position`` (N, 3) [m], ``speed`` (N,) [m/s], ``accel`` (N,)
    [m/s^2] (the norms of its velocity and acceleration vectors)."""

    position: np.ndarray
    speed: np.ndarray
    accel: np.ndarray


@dataclass(frozen=True, eq=False)
class Profile:
    """Samples of a timed joint trajectory, time-major: ``t`` (N,) [s], ``q``, ``qd``, ``qdd``,
    ``qddd`` (N, dof) [rad, rad/s, rad/s^2, rad/s^3 (m for prismatic joints)].

    ``method``: what timed it; ``limits``: the limits it was timed against (after any speed scale;
    ``qddd_max`` None when jerk was not limited); ``details``: what the back end did and changed;
    ``tau`` (N, dof) [N m or N]: joint torques from Drake's inverse dynamics, when torques are limited;
    ``certificate``: the ``certify`` verdict ``retime`` attached (None on a profile made otherwise);
    ``speed_scale`` and ``unscaled_limits``: the limits before the speed scale (the robot's own, unless
    the caller gave others; None on a profile made otherwise); ``tcp``: the TCP's motion at the samples,
    when the profile was timed with TCP limits or for a tool; ``schedule``: the limits that change move by
    move (``pipeline.timing.schedule.LimitSchedule`` over t [s], on top of ``limits``; None: none).
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    qddd: np.ndarray
    method: str
    limits: Limits
    joint_names: tuple[str, ...]
    details: TimingDetails | None = None
    tau: np.ndarray | None = None
    certificate: LimitReport | None = None
    speed_scale: float = 1.0
    unscaled_limits: Limits | None = None
    tcp: "TcpSamples | None" = None
    schedule: LimitSchedule | None = None

    @property
    def duration(self) -> float:
        """[s]"""
        return float(self.t[-1] - self.t[0])

    @property
    def dof(self) -> int:
        return self.q.shape[1]

    def __str__(self) -> str:
        return (f"Profile [{self.method}]: {self.dof} joints, {self.duration:.4f} s, "
                f"{len(self.t)} samples")


@dataclass(frozen=True)
class ColumnAgreement:
    """How the columns agree with each other between consecutive samples k and k + 1 (h = t[k+1] - t[k]
    [s]), for each pair (x, xd) of ``COLUMN_PAIRS``, where L bounds |xd| and D bounds |d xd/dt| (the
    limits the profile is judged against; a test whose limit is absent is skipped):

    - ``mean value``: |x[k+1] - x[k]| <= h L (x cannot change faster than its derivative's limit allows);
    - ``trapezoid``: |x[k+1] - x[k] - h (xd[k] + xd[k+1]) / 2| <= h^2 D / 4 (the trapezoid rule's error
      bound for an integrand whose slope is at most D: the columns are each other's derivative).

    Each side gets ROUNDOFF_ULPS round-off (q's changes also POSITION_PRECISION). ``ratios`` (pair -> peak
    residual/allowance [1]); the worst: ``pair`` ("qdd/qddd"), ``test``, ``joint`` (0-based), ``sample`` k,
    ``time`` [s] of sample k,
    ``ratio`` [1], ``change`` and ``allowed`` [the unit of x] (x[k+1] - x[k], or the trapezoid residual, and
    its allowance); ``passed`` when ``ratio`` <= 1 + tolerance."""

    ratios: dict[str, float]
    pair: str
    test: str
    joint: int
    sample: int
    time: float
    ratio: float
    change: float
    allowed: float
    passed: bool

    def __str__(self) -> str:
        verdict = "agree" if self.passed else "disagree"
        return (f"columns {verdict}: worst {self.pair} ({self.test}) of joint {self.joint + 1} between samples "
                f"{self.sample} and {self.sample + 1} at t = {self.time:.4f} s: {self.change:.3g} against "
                f"{self.allowed:.3g} allowed ({self.ratio:.6f})")

    def to_dict(self) -> dict:
        return {"passed": self.passed, "ratios": dict(self.ratios),
                "worst": {"pair": self.pair, "test": self.test, "joint": self.joint + 1, "sample": self.sample,
                          "t_s": self.time, "ratio": self.ratio, "change": self.change, "allowed": self.allowed}}


@dataclass(frozen=True, eq=False)
class LimitReport:
    """Peak/limit ratios per quantity and joint (``ratios[name]`` (dof,), absent when no limit),
    the worst sample (quantity, joint index, sample index, time [s], ratio), ``columns`` (how the columns
    agree with each other between samples), and ``passed``."""

    ratios: dict[str, np.ndarray]
    worst_quantity: str
    worst_joint: int
    worst_index: int
    worst_time: float
    worst_ratio: float
    passed: bool
    tolerance: float
    clearance: ClearanceReport | None = None
    columns: ColumnAgreement | None = None

    def max_ratio(self, quantity: str) -> float:
        return float(self.ratios[quantity].max()) if quantity in self.ratios else float("nan")

    def __str__(self) -> str:
        peaks = ", ".join(f"{name} {self.max_ratio(name):.6f}" for name in QUANTITIES if name in self.ratios)
        verdict = "PASS" if self.passed else "FAIL"
        where = "the TCP" if self.worst_quantity in TCP_QUANTITIES else f"joint {self.worst_joint + 1}"
        text = (f"{verdict}: peak/limit {peaks}; worst {self.worst_quantity} of {where} "
                f"at t = {self.worst_time:.4f} s ({self.worst_ratio:.6f})")
        if self.columns is not None and not self.columns.passed:
            text = f"{text}; {self.columns}"
        return text if self.clearance is None else f"{text}; {self.clearance}"

    def to_dict(self) -> dict:
        return {
            "passed": self.passed,
            "tolerance": self.tolerance,
            "max_ratio": {name: self.max_ratio(name) for name in self.ratios},
            "ratios": {name: values.tolist() for name, values in self.ratios.items()},
            "worst": {"quantity": self.worst_quantity, "joint": self.worst_joint + 1,
                      "sample": self.worst_index, "t_s": self.worst_time, "ratio": self.worst_ratio},
            "clearance": None if self.clearance is None else self.clearance.to_dict(),
            "columns": None if self.columns is None else self.columns.to_dict(),
        }


def _normalised(profile: Profile, limits: Limits) -> dict[str, np.ndarray]:
    """|value| / limit per sample (N, dof) for every quantity that has a limit; qd and the TCP's speed and
    acceleration against the limit that applied at each sample (``limits_at``: the profile's schedule on
    top of ``limits``; a TCP ratio is 0 where neither limits it)."""
    joint_speed, tcp_speed, tcp_accel = limits_at(limits, profile.schedule, profile.t)
    half = (limits.q_max - limits.q_min) / 2.0            # +inf for a continuous joint: its ratio is 0
    out = {"q": np.abs(profile.q - limits.q_middle) / half,
           "qd": np.abs(profile.qd) / (limits.qd_max * joint_speed[:, None])}
    if limits.qdd_max is not None:
        out["qdd"] = np.abs(profile.qdd) / limits.qdd_max
    if limits.qddd_max is not None:
        out["qddd"] = np.abs(profile.qddd) / limits.qddd_max
    if limits.tau_max is not None:
        if profile.tau is None:
            raise ConfigurationError("the limits bound joint torques but the profile carries none to judge")
        out["tau"] = np.abs(profile.tau) / limits.tau_max
    for name, limit in (("tcp_speed", tcp_speed), ("tcp_accel", tcp_accel)):
        if np.isfinite(limit).any():
            if profile.tcp is None:
                raise ConfigurationError("the limits or the schedule bound the TCP but the profile carries no TCP "
                                         "samples to judge")
            out[name] = (getattr(profile.tcp, name[4:]) / limit)[:, None]
    return out


def limits_at(limits: Limits, schedule: LimitSchedule | None, x) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(joint speed factor [1], TCP speed [m/s], TCP acceleration [m/s^2]) (n,) that apply at x (n,) (the
    schedule's parameter: s along a path, t [s] on a profile): the schedule's values (``LimitSchedule.at``;
    1, inf, inf without one), the TCP's capped by ``limits.tcp_speed_max`` and ``tcp_accel_max``, which hold
    everywhere; inf: not limited."""
    x = np.atleast_1d(np.asarray(x, dtype=float))
    if schedule is None:
        joint_speed, tcp_speed, tcp_accel = np.ones(len(x)), np.full(len(x), np.inf), np.full(len(x), np.inf)
    else:
        joint_speed, tcp_speed, tcp_accel = schedule.at(x)
    for limit, values in ((limits.tcp_speed_max, tcp_speed), (limits.tcp_accel_max, tcp_accel)):
        if limit is not None:
            np.minimum(values, limit, out=values)
    return joint_speed, tcp_speed, tcp_accel


def scale_schedule(schedule: LimitSchedule | None, speed_scale: float) -> LimitSchedule | None:
    """The schedule for a speed scale, as ``scale_limits`` scales the TCP's limits: TCP speed x s and
    acceleration x s^2 (the joint speed factors are fractions of the limits, already scaled)."""
    if schedule is None:
        return None
    return LimitSchedule(schedule.bounds, schedule.joint_speed, schedule.tcp_speed * speed_scale,
                         schedule.tcp_accel * speed_scale**2)


def certify(profile: Profile, limits: Limits | None = None, tolerance: float = CERTIFY_TOLERANCE,
            scene=None) -> LimitReport:
    """Judge a profile against limits (default: the ones it was timed against) and its schedule (joint speeds
    and TCP limits that change move by move, ``profile.schedule``: each sample against the limit that applied
    at its time, see ``limits_at``) on all its samples, its
    columns against each other between samples (``ColumnAgreement``), and with ``scene`` (a
    ``pipeline.cell.collision.CollisionModel``) its clearance over the whole motion (``pipeline.timing.clearance``;
    between samples each joint's acceleration is bounded by its limit, or by the largest sampled |qdd|
    where the limits have none)."""
    limits = profile.limits if limits is None else limits
    clearance = None
    if scene is not None:
        qdd_bound = (np.abs(profile.qdd).max(axis=0) if limits.qdd_max is None
                     else limits.qdd_max * (1.0 + tolerance))
        clearance = certify_clearance(scene, profile.t, profile.q, qdd_bound)
    normalised = _normalised(profile, limits)
    ratios = {name: values.max(axis=0) for name, values in normalised.items()}
    worst_quantity = max(normalised, key=lambda name: ratios[name].max())
    index, joint = np.unravel_index(np.argmax(normalised[worst_quantity]), normalised[worst_quantity].shape)
    worst = float(normalised[worst_quantity][index, joint])
    columns = column_agreement(profile, limits, tolerance)
    passed = bool(worst <= 1.0 + tolerance) and columns.passed and (clearance is None or clearance.passed)
    return LimitReport(ratios, worst_quantity, int(joint), int(index), float(profile.t[index]), worst, passed,
                       tolerance, clearance, columns)


def column_agreement(profile: Profile, limits: Limits, tolerance: float = CERTIFY_TOLERANCE) -> ColumnAgreement:
    """The columns of ``profile`` judged against each other between consecutive samples within ``limits``
    (see ``ColumnAgreement``)."""
    tests = _column_tests(profile, limits)
    ratios = [_safe_ratio(residual, allowance) for _, _, residual, allowance in tests]
    peaks = [float(ratio.max()) if ratio.size else 0.0 for ratio in ratios]
    peak_of_pair = {}
    for (pair, *_), peak in zip(tests, peaks):
        peak_of_pair[pair] = max(peak_of_pair.get(pair, 0.0), peak)
    worst = int(np.argmax(peaks))
    pair, test, residual, allowance = tests[worst]
    if not ratios[worst].size:                      # a single sample: nothing between samples
        return ColumnAgreement(peak_of_pair, pair, test, 0, 0, float(profile.t[0]), 0.0, 0.0, 0.0, True)
    sample, joint = np.unravel_index(np.argmax(ratios[worst]), ratios[worst].shape)
    ratio = peaks[worst]
    return ColumnAgreement(peak_of_pair, pair, test, int(joint), int(sample), float(profile.t[sample]), ratio,
                           float(residual[sample, joint]), float(allowance[sample, joint]),
                           bool(ratio <= 1.0 + tolerance))


def _column_tests(profile: Profile, limits: Limits) -> list[tuple[str, str, np.ndarray, np.ndarray]]:
    """(pair, test, residual (N-1, dof), allowance (N-1, dof)) of every test ``ColumnAgreement`` names
    whose limit is given."""
    t = profile.t[:, None]
    h = np.diff(t, axis=0)
    tests = []
    for low, high, bound, slope_bound in COLUMN_PAIRS:
        x, xd = getattr(profile, low), getattr(profile, high)
        change = np.diff(x, axis=0)
        roundoff = ROUNDOFF_ULPS * np.finfo(float).eps * (np.abs(x).max(axis=0)
                                                          + np.abs(t).max() * np.abs(xd).max(axis=0))
        if low == "q":
            roundoff = roundoff + POSITION_PRECISION
        pair = f"{low}/{high}"
        if getattr(limits, bound) is not None:
            tests.append((pair, "mean value", np.abs(change), h * getattr(limits, bound) + roundoff))
        if slope_bound is not None and getattr(limits, slope_bound) is not None:
            residual = np.abs(change - h * (xd[:-1] + xd[1:]) / 2.0)
            tests.append((pair, "trapezoid", residual, h**2 * getattr(limits, slope_bound) / 4.0 + roundoff))
    return tests


def _safe_ratio(residual: np.ndarray, allowance: np.ndarray) -> np.ndarray:
    """residual / allowance elementwise: 0 where both are 0, inf where only the allowance is 0."""
    ratio = np.divide(residual, allowance, out=np.zeros_like(residual), where=allowance > 0.0)
    return np.where((allowance <= 0.0) & (residual > 0.0), np.inf, ratio)


#: A jerk reversal is a swing from beyond +this fraction of the jerk limit to beyond -this fraction
#: (or back): smaller wiggles around zero are not counted [1].
REVERSAL_THRESHOLD = 0.1


def jerk_reversal_rate(profile: Profile) -> np.ndarray:
    """Jerk sign reversals per second of each joint (dof,) [1/s]: swings of qddd between beyond
    +-REVERSAL_THRESHOLD x qddd_max (the limit the profile was timed against, else the largest |qddd|
    of the joint). A chattering profile (bang-bang jerk at the sample rate) scores tens per second."""
    scale = profile.limits.qddd_max if profile.limits.qddd_max is not None else np.abs(profile.qddd).max(axis=0)
    level = np.sign(profile.qddd) * (np.abs(profile.qddd) >= REVERSAL_THRESHOLD * scale)
    counts = [int(np.count_nonzero(np.diff(column[column != 0]))) for column in level.T]
    return np.array(counts) / max(profile.duration, 1e-300)


def limit_values(limits: Limits) -> dict:
    """The limit arrays as JSON-ready lists (None where a quantity is not limited, and for each infinite
    entry: a continuous joint's q_min and q_max) [SI units]."""
    return {name: _json_limit(value) for name, value in dataclasses.asdict(limits).items()}


def _json_limit(value) -> list | float | None:
    """A limit array (or number) as a list (or number), None for every infinite entry (JSON has no
    infinity) and for a limit not given."""
    if value is None:
        return None
    array = np.asarray(value, dtype=float)
    return np.where(np.isinf(array), None, array).tolist()


def limits_summary(profile: Profile) -> dict:
    """Both views of a certified profile's limits, JSON-ready: ``timed`` (the limits it was timed
    against, i.e. the unscaled ones x speed scale) and ``unscaled`` (the robot's own, unless the caller
    gave others, and the profile's schedule without the speed scale), each with its values and peak/limit
    ratios, and the speed scale. At speed scale 1 both are the same limits: the certificate is reused
    (without its clearance, which is the timed view's), not judged again."""
    timed = profile.certificate if profile.certificate is not None else certify(profile)
    unscaled = profile.unscaled_limits if profile.unscaled_limits is not None else profile.limits
    if profile.speed_scale == 1.0:
        own_report = dataclasses.replace(timed, clearance=None)
    else:
        own = dataclasses.replace(profile, schedule=scale_schedule(profile.schedule, 1.0 / profile.speed_scale))
        own_report = certify(own, unscaled)
    return {"speed_scale": profile.speed_scale,
            "timed": {**timed.to_dict(), "values": limit_values(profile.limits)},
            "unscaled": {**own_report.to_dict(), "values": limit_values(unscaled)}}


def scale_limits(limits: Limits, speed_scale: float) -> Limits:
    """Limits for a speed scale in (0, 1]: qd x s, qdd x s^2, qddd x s^3 (positions unchanged), and the
    TCP's speed x s and acceleration x s^2."""
    if not np.isfinite(speed_scale) or not 0.0 < speed_scale <= 1.0:
        raise ConfigurationError(f"speed_scale must be in (0, 1], got {speed_scale}")
    return Limits(
        q_min=limits.q_min,
        q_max=limits.q_max,
        qd_max=limits.qd_max * speed_scale,
        qdd_max=None if limits.qdd_max is None else limits.qdd_max * speed_scale**2,
        qddd_max=None if limits.qddd_max is None else limits.qddd_max * speed_scale**3,
        tau_max=limits.tau_max,
        tcp_speed_max=None if limits.tcp_speed_max is None else limits.tcp_speed_max * speed_scale,
        tcp_accel_max=None if limits.tcp_accel_max is None else limits.tcp_accel_max * speed_scale**2,
    )
