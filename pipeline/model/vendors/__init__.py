"""Robot controllers' own conventions: axis angles and configuration data of ABB, FANUC, Yaskawa and KUKA
controllers, from our joint values and back: IK branches named as a controller names them (the writers and
readers of ``pipeline.outputs.controllers`` use these).

* ``axes``: each vendor's axis angles [deg] from our q [rad] (zero offset, direction, FANUC's J3 coupling);
* ``pendant``: FANUC's J2/J3 coupling and joint lists as teach pendants show them;
* ``sides``: the shoulder and elbow sides of a configuration, from our FK;
* ``configuration``: ABB confdata, FANUC CONFIG, Yaskawa RCONF, KUKA S/T from joint values, and as text;
* ``selection``: a pose plus a vendor configuration -> the one closed-form solution it names.
"""

from __future__ import annotations

from .axes import VENDORS, AxisMap, axis_angles, axis_map
from .configuration import FIELDS, configurations, format_configuration, parse_configuration
from .selection import select_solution, select_solutions

__all__ = ["FIELDS", "VENDORS", "AxisMap", "axis_angles", "axis_map", "configurations", "format_configuration",
           "parse_configuration", "select_solution", "select_solutions"]
