"""``check_program(program, scene) -> ProgramCheck``: an existing controller program, as the controller runs it,
checked in a cell and timed.

The program (read by ``read_program``, its targets solved with its own configuration data, ``compile_job`` without
planning) is taken as written: every move with the zone the file gives it, an exact stop where it gives none
(``controller_motion.written_moves``), its waits as rests. The controller's path (joint interpolation, lines,
arcs, corners inside the zones: ``controller_motion.controller_path``) is timed at the robot's limits and the
program's speeds (``time_written``) and certified (``certify``: joint limits, the TCP limits, and with a scene the
clearance by Drake's distance queries). The check names the first move that leaves a limit or collides, the pair
and the time, and gives the cycle time per move.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...program.model import Program
from .controller_motion import ControllerPath, WrittenCertificate, WrittenTiming, written_moves, \
    written_program_certificate


@dataclass(frozen=True, eq=False)
class ProgramCheck:
    """What ``check_program`` found: the ``program``, the controller's modelled ``path``, its ``timing`` and
    ``certificate`` (limits and clearance of the motion as written)."""

    program: Program
    path: ControllerPath
    timing: WrittenTiming
    certificate: WrittenCertificate

    @property
    def passed(self) -> bool:
        return self.certificate.passed

    def move_at(self, t: float) -> int:
        """The program's move (1-based: the move into waypoint k is move k) running at time ``t`` [s]."""
        k = int(np.clip(np.searchsorted(self.timing.passages_s, t - 1e-9, side="left"), 0, len(self.path.moves) - 1))
        return int(self.path.moves[k].move.source)

    def problems(self) -> list[str]:
        """Why the program fails (empty when it passes): the limit left or the collision, with the move and time."""
        limits = self.certificate.limits
        out = []
        clearance = limits.clearance
        if clearance is not None and not clearance.passed:
            t = clearance.failed_at_s if clearance.failed_at_s is not None else 0.0
            k = self.move_at(t)
            out.append(f"move {k} ({self.program.moves[k - 1].kind}) fails the clearance at {t:.3f} s: "
                       f"{clearance.reason}")
        if limits.worst_ratio > 1.0 + limits.tolerance:
            t = limits.worst_time
            what = "the TCP" if limits.worst_quantity.startswith("tcp") else \
                f"joint {self.program.robot.joint_names[limits.worst_joint]}"
            out.append(f"move {self.move_at(t)} leaves a limit at {t:.3f} s: {limits.worst_quantity} of {what} "
                       f"at {limits.worst_ratio:.3f} x its limit")
        return out

    def move_times(self) -> list[dict]:
        """Per program move: its index, kind, duration [s] (from leaving its start to reaching its end, the rest for
        its start's waits excluded) and the rest at its end [s]."""
        ends = {w.move.source: float(t) for w, t in zip(self.path.moves, self.timing.passages_s)}
        out, before = [], 0.0
        for move in self.program.moves:
            end = ends.get(move.end, before)
            leave = before + self.program.rest_at(move.end - 1)
            out.append({"move": move.end, "kind": move.kind, "duration_s": end - leave,
                        "rest_s": self.program.rest_at(move.end)})
            before = end
        return out

    def to_dict(self) -> dict:
        return {"passed": self.passed, "problems": self.problems(), "cycle_s": self.timing.duration_s,
                "rests_s": float(sum(self.program.rests)),
                "moves": self.move_times(), "limits": self.certificate.limits.to_dict(),
                "min_clearance_m": self.certificate.min_clearance_m,
                "stops": [m.move.source for m in self.path.moves if m.stops]}

    def lines(self) -> list[str]:
        """What ``check-program`` prints."""
        lines = [f"  move {m['move']:<3} {m['kind']:<8} {m['duration_s']:.3f} s"
                 + (f"  then rests {m['rest_s']:.3f} s" if m["rest_s"] > 0.0 else "") for m in self.move_times()]
        limits = self.certificate.limits
        peaks = ", ".join(f"{name} {limits.max_ratio(name):.3f}" for name in ("q", "qd", "qdd", "tcp_speed")
                          if name in limits.ratios)
        lines.append(f"cycle as written {self.timing.duration_s:.3f} s; peak/limit {peaks}")
        clearance = limits.clearance
        if clearance is not None:
            closest = "no obstacle in reach" if clearance.pair is None else \
                f"closest {clearance.pair[0]} - {clearance.pair[1]} {clearance.min_distance_m * 1e3:.1f} mm at " \
                f"{clearance.t_s:.3f} s (move {self.move_at(clearance.t_s)})"
            lines.append(f"clearance {clearance.clearance_m * 1e3:g} mm: {'PASS' if clearance.passed else 'FAIL'}; "
                         f"{closest}")
        lines += [f"FAIL: {problem}" for problem in self.problems()]
        return lines


def check_program(program: Program, scene=None) -> ProgramCheck:
    """The program as written (module docstring) timed and certified; ``scene`` a CollisionModel (None: no cell)."""
    path, timing, certificate = written_program_certificate(program, written_moves(program), None, scene)
    return ProgramCheck(program, path, timing, certificate)
