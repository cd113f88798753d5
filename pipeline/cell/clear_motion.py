"""Motion in a cell: IK answers that collide are skipped (``collision_free_ik``), configurations
checked (``check_samples``), and a planned path timed through its vertices with its clearance
certified (``time_clear``); a profile below the clearance is an error (``ClearanceError``), never a file.

``time_clear`` times the path shape through the planner's vertices, which bends the polyline between
them; where the certificate then finds the profile too close, the polyline edge nearest the failing
configuration gets its midpoint as one more vertex and the path is timed again (at most
MAX_REFINEMENTS times), so the timed path hugs the checked polyline where it must. (A job's program
rounds the planner's vertices with blends instead: ``pipeline.program``.)
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..errors import CollisionError
from ..timing.profile import Profile, certify

class ClearanceError(CollisionError):
    """A profile that does not keep the clearance: its clearance ``report`` and the ``profile`` it was
    found on, both in job time (the profile's times plus the start of its piece); ``first`` and ``last``
    (None: the job's last): the job's waypoints that profile runs between, for the caller to name the
    move."""

    def __init__(self, report, profile: Profile, hint: str = "", first: int = 0, last: int | None = None):
        self.report, self.profile, self.first, self.last = report, profile, first, last
        super().__init__(f"the profile does not keep the clearance: {report.reason}{hint}")


#: Most vertices added to a planned piece to bring its timed path within the clearance.
MAX_REFINEMENTS = 8
#: Numeric IK methods are restarted from this many random seeds when every answer collides.
IK_COLLISION_RESTARTS = 20


def free_solutions(model, result):
    """``result`` (an IkResult) with only its collision-free solutions (None when none is)."""
    free = tuple(s for s in result.solutions if model.is_free(s.q))
    return dataclasses.replace(result, solutions=free) if free else None


def collision_free_ik(robot, model, X_target, q_seed, method: str, target_kind: str, options: dict, rng):
    """(IkResult, why): a successful result keeps only its collision-free solutions ("" why); a failed
    solve comes back as it is (the caller reports its reason); when every answer collides, (None, why
    naming the closest pair). The closed form checks every branch it returns; numeric methods are
    restarted from IK_COLLISION_RESTARTS random seeds while every answer collides."""
    result = robot.ik(X_target, q_seed=q_seed, method=method, target_kind=target_kind, **options)
    if not result.success:
        return result, ""
    free = free_solutions(model, result)
    numeric = result.method not in ("analytic",)
    for _ in range(IK_COLLISION_RESTARTS if numeric and free is None else 0):
        retry = robot.ik(X_target, q_seed=robot.random_configurations(rng, 1)[0], method=method,
                         target_kind=target_kind, **options)
        free = free_solutions(model, retry) if retry.success else None
        if free is not None:
            return free, ""
    if free is None:
        tried = f"{len(result.solutions)} solution(s)" + (f" and {IK_COLLISION_RESTARTS} restarts" if numeric else "")
        return None, f"every IK answer collides ({tried}); the nearest: {model.why_not_free(result.q)}"
    return free, ""


def _refined(vertices: np.ndarray, q_fail: np.ndarray) -> np.ndarray:
    """``vertices`` with the midpoint of the edge nearest ``q_fail`` added."""
    a, b = vertices[:-1], vertices[1:]
    d = b - a
    f = np.clip(np.einsum("ij,ij->i", q_fail - a, d) / np.maximum(np.einsum("ij,ij->i", d, d), 1e-300), 0.0, 1.0)
    k = int(np.argmin(np.linalg.norm(a + f[:, None] * d - q_fail, axis=1)))
    return np.insert(vertices, k + 1, (a[k] + b[k]) / 2.0, axis=0)


def time_clear(model, vertices: np.ndarray, time, refine: bool, t_start: float = 0.0) -> tuple[Profile, int]:
    """``time(vertices)`` -> a profile certified with its clearance, refining the vertices (``refine``:
    planned paths) while the certificate fails; returns (profile, vertices added). The profile starts at
    ``t_start`` [s] of the job: its clearance certificate gives job times. ClearanceError names the pair
    and the job time when it still fails."""
    for added in range(MAX_REFINEMENTS + 1):
        profile = time(vertices)
        in_job_time = _shifted(profile, t_start)
        report = certify(in_job_time, scene=model)
        clearance = report.clearance
        if clearance.passed:
            return dataclasses.replace(profile, certificate=report), added
        if not refine or added == MAX_REFINEMENTS or clearance.failed_at_s is None:
            break
        q_fail = np.array([np.interp(clearance.failed_at_s, in_job_time.t, column) for column in profile.q.T])
        vertices = _refined(vertices, q_fail)
    hint = "" if refine else " (plan: collision_free plans joint moves around obstacles)"
    raise ClearanceError(clearance, in_job_time, hint)


def _shifted(profile: Profile, t_start: float) -> Profile:
    """``profile`` with its times starting at ``t_start`` [s]."""
    return profile if t_start == 0.0 else dataclasses.replace(profile, t=profile.t + t_start)


def check_samples(model, Q: np.ndarray) -> int | None:
    """The index of the first configuration of Q (k, dof) that is not collision-free (None: all are)."""
    for k, q in enumerate(Q):
        if not model.is_free(q):
            return k
    return None



def compile_motion_kernels() -> float:
    """Compile into Numba's cache the kernels a planned and timed move compiles on its first call and the prebuilt IK
    kernels do not hold (the chain's FK and Jacobian, the closed form's derivation, the planner's position nudge and
    trial splines, toppra's reachability passes, the certificate's spline peaks), for the GP7 (the kernels' types are
    the same for any arm), so that no first job pays for them (10-15 s on a fresh install of this machine kind); the
    seconds taken."""
    import time

    from ..model.ik.analytic import nearest_analytic
    from ..model.ik.jacobian import nudged_position
    from ..model.robot import load_robot
    from ..timing import retime
    from ..timing.compiled_spline import trial_spline
    from .planning import NUDGE_DAMPING, NUDGE_ITERATIONS, NUDGE_TOLERANCE_M, SPLINE_TIME_SAMPLES

    began = time.perf_counter()
    robot = load_robot("gp7")
    q = (robot.limits.q_min + robot.limits.q_max) / 2.0
    X = robot.fk(q)
    robot.fk_and_jacobian(q)
    nearest_analytic(robot, X, q)
    nudged_position(robot, X[:3, 3] + 0.01, q, NUDGE_ITERATIONS, NUDGE_TOLERANCE_M, NUDGE_DAMPING)
    spline = trial_spline(np.array([q, q + 0.1, q + np.array([0.2, 0.1, 0.0, 0.0, 0.0, 0.0]), q + 0.3]),
                          robot.limits.q_min, robot.limits.q_max)
    spline(np.linspace(0.0, 1.0, 5))
    spline.time(robot.limits, SPLINE_TIME_SAMPLES)
    retime(robot, np.array([q, q + 0.1]))
    return time.perf_counter() - began
