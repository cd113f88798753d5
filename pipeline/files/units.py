"""File units and their SI factors: the one table every reader converts with (files say mm/m, deg/rad;
memory is always metres and radians)."""

from __future__ import annotations

import math

#: Length unit in a file -> metres per unit.
LENGTH_UNITS = {"mm": 1e-3, "m": 1.0}
#: Angle unit in a file -> radians per unit.
ANGLE_UNITS = {"deg": math.pi / 180.0, "rad": 1.0}
