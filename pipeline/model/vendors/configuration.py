"""Each vendor's configuration data from joint values, as integer fields, and as the text its language writes.

Computed for N configurations at once from the controller's axis angles (``axes``) and the geometric
shoulder and elbow sides (``sides``). The fields, their sources and the readings we follow where
open implementations disagree (models/SOURCES.md, "Controller axis angles and configuration data", says the same):

ABB ``confdata`` [cf1, cf4, cf6, cfx] (RAPID reference manual, data type confdata): cf1, cf4, cf6 the
quadrant of axes 1, 4, 6, quadrant 0 from 0 to 90 deg, 1 from 90 to 180 deg, -1 from 0 to -90 deg, ...,
i.e. floor(angle / 90 deg) (RoboDK's ABB post and ARTE compute it the same way); cfx of 8-solution arms
(such as the IRB 1600) = 4 a + 2 b + c, a = 1 when the wrist centre is behind axis 1, b = 1 when it is
behind the lower arm, c = 1 when axis 5 is negative (RoboDK's published ABB test pair has c = 1 at
axis 5 = -24.4 deg).

FANUC ``CONFIG 'F/N U/D T/B, t1, t4, t6'``: F when J5 >= 0, else N (RoboDK's FANUC post and Tesseract:
F for J5 >= 0; a third-party page says the opposite, unverified); U elbow up, else D; T the wrist centre
in front of J1, else B; t1, t4, t6 how many turns J1, J4, J6 lie out of the window (-180, 180] deg:
t = ceil((angle - 180 deg) / 360 deg), so 180 -> 0, 181 -> 1, -180 -> -1, 400 -> 1. RoboDK's formula
differs only at exactly +180 deg (it gives 1): we keep the half-open window the issue and FANUC's
turn-number definition state, so that each 360 deg interval has one turn number.

Yaskawa ``///RCONF l,m,n,o,p,q`` (NX100 operator's manual, "Manipulator types", p. 3-76; DX100 manual
section 4.1; field order as these manuals print it, not RoboDK's Motoman post, which writes rear, lower
arm, flip first): l = 0 Flip, 1 No flip, which the NX100 manual defines by the R axis alone, Flip for
-90 < R <= 90 deg (and 270 < R <= 360, -360 < R <= -270), No flip for 90 < R <= 270 (and -270 < R <=
-90); m = 0 upper arm (elbow up), 1 lower arm; n = 0 front, 1 rear (wrist centre against the S axis);
o, p, q = 1 when R, T, S are ">= 180 deg", which we read as |angle| >= 180 deg: the manual's flip
ranges need exactly that split to tell -90..90 from 270..360 and -360..-270 with one bit, and it makes
the bit pick one 2 pi variant of a +-360 deg axis (the literal signed reading cannot tell T = -200
from T = 160).

KUKA ``S`` and ``T`` (KUKA's Status and Turn; Siemens SINUMERIK programming manual, STAT and TU of
the KUKA-compatible robot transformation): Status bit 0 = 1 when the wrist centre is behind axis 1
(x < 0 in the A1 frame, "overhead"), bit 1 = 1 elbow up (A3 >= phi, phi the A3 angle that puts the wrist
centre on the line through A2 and A3: the side of the robot file's elbow-up pose, KUKA's mastering pose A2 =
-90, A3 = +90 deg, ``sides``), bit 2 = 1 when A5 < 0 (the Sinumerik manual's reading; Beckhoff/ISG's
KUKA-compatible documentation counts A5 > 0 instead, not followed); Turn bit i = 1 when axis i + 1 < 0 (TU =
'B010011': A1, A2 and A5 negative).

The elbow fields of every vendor ("up" above) mean the side of the controller section's ``elbow_up`` pose
(q = 0 without a section), and the axis angles are the section's (``axes``).
"""

from __future__ import annotations

import re
from collections.abc import Sequence

import numpy as np

from ...errors import VendorConfigurationError, shown
from .axes import ABB, FANUC, KUKA, YASKAWA, axis_angles, check_vendor
from .sides import arm_sides

#: Field names per vendor, in the order of the integer rows and of the text (FANUC's flip, up and front
#: are 1 for the letters F, U, T and 0 for N, D, B).
FIELDS = {
    ABB: ("cf1", "cf4", "cf6", "cfx"),
    FANUC: ("flip", "up", "front", "t1", "t4", "t6"),
    YASKAWA: ("l", "m", "n", "o", "p", "q"),
    KUKA: ("S", "T"),
}
#: An axis this close to a configuration field's boundary [rad] is on it: either side describes it (an IK answer on a
#: boundary carries round-off: axis 1 at 4e-9 rad for a target at y = 0 was refused at 1e-9; a file's rounding of
#: joint values, 0.0001 deg, is 1.7e-6 rad).
BOUNDARY_RAD = 1e-6
#: FANUC's letters for fields flip, up, front: (value 1, value 0).
FANUC_LETTERS = (("F", "N"), ("U", "D"), ("T", "B"))


def configurations(robot, Q, vendor: str) -> np.ndarray:
    """The vendor's configuration fields (N, len(FIELDS[vendor])) as integers for configurations Q
    (N, 6) [rad] (a single (6,) gives one row)."""
    check_vendor(vendor)
    single = np.ndim(Q) == 1
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    angles = axis_angles(robot, Q, vendor)
    sides = arm_sides(robot, Q)
    rows = _COMPUTE[vendor](angles, sides.behind.astype(int), sides.elbow_down.astype(int))
    return rows[0] if single else rows


def mismatched_field(robot, q, vendor: str, fields) -> int | None:
    """The index of the first of ``fields`` (a vendor configuration's integers) that does not describe the
    joint values q (6,) [rad]: neither q's own value nor, for an axis on the field's boundary to within
    BOUNDARY_RAD (an axis at 0 or at a multiple of 90 deg by round-off, where both sides describe q and a
    writer writes the side its rounded target selects), the other side's. None when every field does."""
    q = np.asarray(q, dtype=float)
    own, moved = configurations(robot, q, vendor), None
    for f, (written, wanted) in enumerate(zip(fields, own)):
        if int(written) == int(wanted):
            continue
        if moved is None:
            moved = configurations(robot, q + BOUNDARY_RAD * np.vstack([np.eye(q.size), -np.eye(q.size)]), vendor)
        if int(written) not in moved[:, f]:
            return f
    return None


def _abb(angles, behind, down):
    quadrants = np.floor(angles[:, [0, 3, 5]] / 90.0).astype(int)
    cfx = 4 * behind + 2 * down + (angles[:, 4] < 0.0)
    return np.column_stack([quadrants, cfx])


def fanuc_turns(angles) -> np.ndarray:
    """FANUC turn numbers of angles [deg]: how many turns out of (-180, 180] (180 -> 0, -180 -> -1)."""
    return np.ceil((np.asarray(angles) - 180.0) / 360.0).astype(int)


def _fanuc(angles, behind, down):
    return np.column_stack([angles[:, 4] >= 0.0, 1 - down, 1 - behind, fanuc_turns(angles[:, [0, 3, 5]])])


def _yaskawa(angles, behind, down):
    r = np.mod(angles[:, 3] + 90.0, 360.0)                     # Flip: R in (-90, 90] + k 360 deg
    no_flip = (r > 180.0) | (r == 0.0)
    at_least_180 = np.abs(angles[:, [3, 5, 0]]) >= 180.0       # R, T, S
    return np.column_stack([no_flip, down, behind, at_least_180]).astype(int)


def _kuka(angles, behind, down):
    status = behind + 2 * (1 - down) + 4 * (angles[:, 4] < 0.0)
    turn = ((angles < 0.0) * (1 << np.arange(6))).sum(axis=1)
    return np.column_stack([status, turn])


_COMPUTE = {ABB: _abb, FANUC: _fanuc, YASKAWA: _yaskawa, KUKA: _kuka}


def format_configuration(vendor: str, fields) -> str:
    """The text a vendor's program writes for one row of fields: ABB "[0,0,-1,1]", FANUC
    "N U T, 0, 0, 0", Yaskawa "0,0,0,0,0,0", KUKA "S 'B010', T 'B000010'"."""
    f = [int(v) for v in parse_configuration(vendor, fields)]
    if vendor == ABB:
        return "[" + ",".join(map(str, f)) + "]"
    if vendor == FANUC:
        letters = " ".join(pair[0] if v else pair[1] for pair, v in zip(FANUC_LETTERS, f[:3]))
        return f"{letters}, {f[3]}, {f[4]}, {f[5]}"
    if vendor == YASKAWA:
        return ",".join(map(str, f))
    return f"S 'B{f[0]:03b}', T 'B{f[1]:06b}'"


#: Allowed range of each field [low, high], per vendor.
_RANGES = {
    ABB: ((-8, 7),) * 3 + ((0, 7),),
    FANUC: ((0, 1),) * 3 + ((-8, 7),) * 3,
    YASKAWA: ((0, 1),) * 6,
    KUKA: ((0, 7), (0, 63)),
}
_EXAMPLES = {ABB: "[0,0,-1,1]", FANUC: "'N U T, 0, 0, 0'", YASKAWA: "'0,0,0,0,0,0'", KUKA: "\"S 'B010', T 'B000010'\""}


def parse_configuration(vendor: str, value) -> tuple[int, ...]:
    """A vendor configuration as its text (``format_configuration``'s) or a sequence of its integer
    fields -> the fields; VendorConfigurationError names the vendor, the field and what it allows."""
    check_vendor(vendor)
    fields = _from_text(vendor, value) if isinstance(value, str) else _from_sequence(vendor, value)
    for name, v, (low, high) in zip(FIELDS[vendor], fields, _RANGES[vendor]):
        if not low <= v <= high:
            raise VendorConfigurationError(f"{vendor} configuration {shown(value)}: field {name} must be an integer "
                                           f"from {low} to {high}, got {v}")
    return fields


def _from_sequence(vendor: str, value) -> tuple[int, ...]:
    names = FIELDS[vendor]
    if isinstance(value, (bytes, dict)) or not isinstance(value, (Sequence, np.ndarray)) or len(value) != len(names):
        raise VendorConfigurationError(f"a {vendor} configuration is {len(names)} integers ({', '.join(names)}) or "
                                       f"its text, e.g. {_EXAMPLES[vendor]}; got {shown(value)}")
    fields = []
    for name, v in zip(names, value):
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer, float, np.floating)) \
                or not float(v).is_integer():
            raise VendorConfigurationError(f"{vendor} configuration {shown(value)}: field {name} must be an integer, "
                                           f"got {shown(v)}")
        fields.append(int(v))
    return tuple(fields)


_PATTERNS = {
    ABB: re.compile(r"^\s*\[?\s*([-+]?\d+)\s*,\s*([-+]?\d+)\s*,\s*([-+]?\d+)\s*,\s*([-+]?\d+)\s*\]?\s*$"),
    FANUC: re.compile(r"^\s*'?\s*([FN])\s*([UD])\s*([TB])\s*,\s*([-+]?\d+)\s*,\s*([-+]?\d+)\s*,\s*([-+]?\d+)\s*'?\s*$",
                      re.IGNORECASE),
    YASKAWA: re.compile(r"^\s*(?:///RCONF\s+)?" + r"\s*,\s*".join([r"([01])"] * 6) + r"(?:\s*,\s*0)*\s*$",
                        re.IGNORECASE),
    KUKA: re.compile(r"^\s*S\s+(?:'B([01]{1,3})'|(\d+))\s*,?\s*T\s+(?:'B([01]{1,6})'|(\d+))\s*$", re.IGNORECASE),
}


def _from_text(vendor: str, text: str) -> tuple[int, ...]:
    match = _PATTERNS[vendor].match(text)
    if match is None:
        raise VendorConfigurationError(f"not a {vendor} configuration: {shown(text)}; it reads like "
                                       f"{_EXAMPLES[vendor]} ({', '.join(FIELDS[vendor])})")
    groups = match.groups()
    if vendor == FANUC:
        letters = [int(g.upper() == pair[0]) for g, pair in zip(groups[:3], FANUC_LETTERS)]
        return tuple(letters + [int(g) for g in groups[3:]])
    if vendor == KUKA:
        status = int(groups[0], 2) if groups[0] is not None else int(groups[1])
        turn = int(groups[2], 2) if groups[2] is not None else int(groups[3])
        return status, turn
    return tuple(int(g) for g in groups)
