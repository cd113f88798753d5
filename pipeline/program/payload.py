"""What the robot carries: the tool's load (always) and the parts it grips (from a ``grip`` action to the
``release`` of the same part).

A load is a rigid body fixed to the flange: ``mass`` [kg], ``com`` (3,) [m] its centre of mass in the flange frame
F, ``inertia`` (3, 3) [kg m^2] about the centre of mass in F's axes (zeros: a point mass), ``source`` the line saying
where the numbers come from. Loads carried together are one load (``combined``: masses add, the centre of mass is
the mass-weighted mean, the inertias move to it by the parallel-axis theorem), and one load taken from another is
the difference (``removed``), so a controller that holds only the total (KRL ``$LOAD``) reads back as the parts.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

#: The heaviest load a job may name [kg] (a guard against a unit slip: the largest industrial arms carry ~2.3 t).
MAX_PAYLOAD_KG = 5000.0
#: The largest radius of gyration a load's inertia may give about its centre of mass [m] (sqrt(I / m): 0.29 x the
#: length of a slender rod; a car body is about 1 m); an inertia in kg mm^2 gives a million times the kg m^2 one.
MAX_GYRATION_M = 3.0
#: Masses below this are no load [kg] (what is left when a part is taken from the total it was added to).
MASS_TOLERANCE_KG = 1e-9


@dataclass(frozen=True, eq=False)
class Payload:
    """A load fixed to the flange (module docstring): ``mass`` [kg], ``com`` (3,) [m] in the flange frame F,
    ``inertia`` (3, 3) [kg m^2] about the centre of mass in F's axes, ``source`` where the numbers come from, ``name``
    (the tool's load: ``tool``; a part: its name in the job)."""

    mass: float
    com: np.ndarray
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    source: str = ""
    name: str = "tool"

    @property
    def inertia_about_flange(self) -> np.ndarray:
        """(3, 3) [kg m^2] the inertia about the flange's origin, in F's axes (parallel-axis theorem)."""
        c = np.asarray(self.com, dtype=float)
        return self.inertia + self.mass * (float(c @ c) * np.eye(3) - np.outer(c, c))

    @property
    def inertia_six(self) -> list[float]:
        """[Ixx, Iyy, Izz, Ixy, Ixz, Iyz] [kg m^2] about the centre of mass (as job files and URScript write it)."""
        I = self.inertia
        return [float(I[0, 0]), float(I[1, 1]), float(I[2, 2]), float(I[0, 1]), float(I[0, 2]), float(I[1, 2])]

    def to_document(self, length_scale: float) -> dict:
        """The load as a job file writes it, lengths divided by ``length_scale`` [m per the file's unit]."""
        out = {"mass": float(self.mass), "com": [float(v) / length_scale for v in self.com]}
        if np.any(self.inertia):
            out["inertia"] = self.inertia_six
        if self.source:
            out["source"] = self.source
        return out

    def __str__(self) -> str:
        com = ", ".join(f"{v * 1e3:.1f}" for v in self.com)
        return f"{self.name} {self.mass:g} kg at ({com}) mm"


def physical_inertia_problem(inertia: np.ndarray) -> str | None:
    """Why (3, 3) ``inertia`` [kg m^2] about a centre of mass cannot be a body's, or None: it must be symmetric with
    principal moments >= 0 that meet the triangle inequality (each at most the sum of the other two)."""
    if not np.allclose(inertia, inertia.T, rtol=0.0, atol=1e-12):
        return "an inertia matrix is symmetric"
    moments = np.linalg.eigvalsh(inertia)
    scale = max(float(np.max(np.abs(moments))), 1e-12)
    if moments[0] < -1e-9 * scale:
        return f"its principal moments must be >= 0 (smallest {moments[0]:.4g} kg m^2)"
    if moments[2] > moments[0] + moments[1] + 1e-9 * scale:
        return (f"its principal moments {', '.join(f'{m:.4g}' for m in moments)} kg m^2 break the triangle inequality "
                "(the largest is at most the sum of the other two for any body)")
    return None


def combined(loads, name: str = "") -> Payload | None:
    """The loads carried together as one (None when there are none): mass sum, mass-weighted centre of mass, the
    inertias moved to it; the sources and names joined with ``+`` (``name`` replaces the joined names)."""
    loads = [load for load in loads if load is not None]
    if not loads:
        return None
    if len(loads) == 1 and not name:
        return loads[0]
    mass = sum(load.mass for load in loads)
    com = sum(load.mass * np.asarray(load.com, dtype=float) for load in loads) / mass
    inertia = sum(_moved(load.inertia, load.mass, np.asarray(load.com) - com) for load in loads)
    sources = " + ".join(load.source for load in loads if load.source)
    return Payload(float(mass), com, inertia, sources, name or " + ".join(load.name for load in loads))


def removed(total: Payload, part: Payload, name: str) -> Payload | None:
    """What is left of ``total`` without ``part`` (None: nothing, within MASS_TOLERANCE_KG), named ``name``."""
    mass = total.mass - part.mass
    if mass <= MASS_TOLERANCE_KG:
        return None
    com = (total.mass * np.asarray(total.com) - part.mass * np.asarray(part.com)) / mass
    about_total = total.inertia - _moved(part.inertia, part.mass, np.asarray(part.com) - total.com)
    inertia = _moved(about_total, -mass, com - total.com)
    return Payload(float(mass), com, inertia, total.source, name)


def same_load(a: Payload | None, b: Payload | None, mass_kg: float, com_m: float,
              inertia_kg_m2: float | None) -> bool:
    """Whether two loads (None: nothing) are one within these tolerances: mass [kg], each coordinate of the centre of
    mass [m], each element of the inertia [kg m^2] (None: the inertias are not compared)."""
    if a is None or b is None:
        return a is b
    return (abs(a.mass - b.mass) <= mass_kg and float(np.abs(np.asarray(a.com) - b.com).max()) <= com_m
            and (inertia_kg_m2 is None or float(np.abs(a.inertia - b.inertia).max()) <= inertia_kg_m2))


def principal_axes(payload: Payload) -> tuple[np.ndarray, np.ndarray]:
    """(moments (3,) [kg m^2], R (3, 3)): the principal moments of the load's inertia about its centre of mass and
    the rotation whose columns are their axes in F's axes (inertia = R diag(moments) R^T, det R = +1), as RAPID's
    ``loaddata`` (aom, ix, iy, iz) and KRL's ``$LOAD`` (CM's A, B, C, J) state an inertia. A diagonal inertia gives
    R = I and its diagonal in order; otherwise the eigenvectors are ordered and signed to lie nearest I (the largest
    trace of R), so that the axes turn as little as they can from F's."""
    inertia = np.asarray(payload.inertia, dtype=float)
    if not np.any(inertia - np.diag(np.diag(inertia))):
        return np.diag(inertia).copy(), np.eye(3)
    moments, vectors = np.linalg.eigh(inertia)
    best = None
    for order in itertools.permutations(range(3)):
        R = vectors[:, order] * np.where(np.diag(vectors[:, order]) < 0.0, -1.0, 1.0)
        if np.linalg.det(R) < 0.0:
            R[:, int(np.argmin(np.abs(np.diag(R))))] *= -1.0
        if best is None or np.trace(R) > np.trace(best[1]) + 1e-12:
            best = (moments[list(order)], R)
    return best


def expressed_in(payload: Payload, X_AB: np.ndarray) -> Payload:
    """The load given in frame B expressed in frame A, X_AB (4, 4) [m] B's pose in A: the centre of mass moved
    (X_AB com), the inertia turned (R_AB I R_AB^T); mass, source and name kept."""
    R = X_AB[:3, :3]
    com = R @ np.asarray(payload.com, dtype=float) + X_AB[:3, 3]
    return Payload(payload.mass, com, R @ payload.inertia @ R.T, payload.source, payload.name)


def _moved(inertia: np.ndarray, mass: float, offset: np.ndarray) -> np.ndarray:
    """Inertia about a point ``offset`` [m] away from the centre of mass it is given about (parallel axis)."""
    return inertia + mass * (float(offset @ offset) * np.eye(3) - np.outer(offset, offset))
