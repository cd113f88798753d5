"""A compiled (Numba) broad phase for the planner's collision checks: conservative, Drake stays the judge.

``BroadPhase(model, checker)`` (made by ``CollisionModel.broad_phase(extra_m, self_m)``, for the checker of
``padded_checker(extra_m, self_m)``, or the plain one) gives a verdict on many configurations per compiled
call: FREE means every pair that checker checks has a distance whose lower bound exceeds the pair's padding plus
DRAKE_TOLERANCE_M, so the checker finds the configuration free; HIT means a pair whose shapes are exact here
(link capsules, a tool sphere or capsule, a capsule inside a tool box or cylinder, and a link capsule by the tool
box or cylinder itself; box, sphere and capsule obstacles; a tool box's corners or a cylinder's rim by a box)
comes PADDED_HIT_DEPTH_M inside its padding (or overlaps by HIT_DEPTH_M), so the checker finds it colliding;
MAYBE: ask Drake.

The geometry, all in the robot's base frame B (obstacles moved there once):

* robot primitives: the link capsules (``link_capsules``), exact; each tool shape on the last link by the
  capsules containing it (a sphere or capsule: itself; a cylinder or box: one per TOOL_SHORTENING along its
  axis, the box's longest; a pair is clear when one of them is) and, against link capsules, also by itself
  (a box or a cylinder, as an obstacle below: exact at the flat ends, where a capsule bulges), against
  obstacles by the gaps of their projections on the two shapes' axes (``_separation``: exact where a flat end
  faces a box). Each primitive is a core segment (p, r) fixed in a frame of the chain and a radius.
* obstacles: box (exact segment-to-box distance: the squared distance is a convex piecewise quadratic in the
  segment parameter, minimised piece by piece), sphere and capsule (exact), cylinder (its containing capsule,
  then its containing box, then the distance to the cylinder itself, convex in the segment parameter:
  golden-section search less what its last bracket can hide, a lower bound within 1e-8 m).
* pairs and paddings from Drake itself: a robot body pair or robot-obstacle pair is checked when the
  checker's ``GetFilteredCollisionMatrix()`` has 0 for it, against its ``GetPaddingMatrix()`` entry.

Per configuration: the chain, then one pass over every pair's bounding spheres (most pairs stop there), the
others tested exactly, in the order of how often each pair was not clear at ORDER_SAMPLES seeded random
configurations (a colliding configuration stops early). Edges: the configurations Drake's
``CheckEdgeCollisionFree`` checks (``edge_maybes_into``), each pair tested only where the slack it kept at another
of them, less how far its distance can change in between (``_axis_reach``: per joint, how far a primitive's points
can be from the joint's axis), does not clear it: the same verdicts, 1.8-2.2x quicker an edge.

The link frames come from the chain of ``pipeline.model.chain.compiled`` (``moved_pose``): after joint i
the chain is at ``x_i = K_0 M_1 K_1 ... M_i K_i``, a constant transform from link i's body frame (DH frame
i), so each capsule is stored in the frame x_i (the base's in B, the tool's in the end frame x_n).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..model.chain.compiled import base_pose, inner, moved_pose
from ..model.chain.geometry import link_capsules

#: What every lower bound must exceed its padding by [m]: Drake computes capsule-box, capsule-capsule and
#: capsule-cylinder distances with FCL's GJK (``distance_tolerance`` 1e-6), whose errors its own
#: characterisation test bounds by 2e-5 m (geometry/proximity/test/distance_to_shape_characterize_test.cc).
DRAKE_TOLERANCE_M = 1e-4
#: A configuration's verdicts: certainly free, maybe colliding (ask Drake), certainly colliding.
FREE, MAYBE, HIT = 1, 0, -1
#: How far two exact shapes must overlap for a certain hit [m] (ten times DRAKE_TOLERANCE_M).
HIT_DEPTH_M = 1e-3
#: Or, where the pair's padding is larger, how far within it they must be [m]: Drake's verdict there is its
#: distance between separate shapes (GJK's, which may exceed the exact one: by 0.48 mm at one configuration in
#: 3 x 10^7, a capsule 20 mm from a thin box), so six times that.
PADDED_HIT_DEPTH_M = 3e-3
#: An axis reach (``_axis_reach``) that would be infinite (a prismatic joint without limits) [m].
MAX_REACH_M = 1e9
#: How far a bound on a pair's slack between two coarse configurations of an edge must clear it for the pair to
#: be passed over there (``_due_pairs``) [m]: far above the round-off of each configuration's own bound.
DUE_MARGIN_M = 1e-9
#: A pair's slack (how far it keeps beyond its padding) where it is not certainly clear.
NOT_CLEAR = -1.0
#: Obstacle kinds as the kernels take them.
BOX, SPHERE, CAPSULE, CYLINDER = 0, 1, 2, 3
_KINDS = {"box": BOX, "sphere": SPHERE, "capsule": CAPSULE, "cylinder": CYLINDER}
#: Columns of an obstacle row: kind, centre (3), rotation R_BO row by row (9), half sizes (3: a box's half
#: sides; a sphere's radius; a capsule's or cylinder's radius and half length), bounding radius.
OBSTACLE_COLUMNS = 17
#: Columns of a primitive row: frame (0: B, i: after joint i), p (3), r (3), radius, half length, and the
#: number of rows from this one that contain the same shape (1 for a capsule; a tool shape's first row has
#: one per TOOL_SHORTENING, the rows after it 0): a pair is clear when one of them is.
#: Then the row of its shape in the tool shapes (a tool box or cylinder as an obstacle row; -1: none), which
#: bounds its distance to link capsules too; and the row of a capsule inside its shape (a link capsule's, a tool
#: sphere's or capsule's: itself; a tool box's or cylinder's: a row of its own, ``inscribed_capsule``; -1: none),
#: by which a hit is certain.
PRIMITIVE_COLUMNS = 12
RADIUS, HALF, ALTERNATIVES, TOOL_BOX, INSCRIBED = 7, 8, 9, 10, 11
#: A tool cylinder's or box's containing capsules: its axis (the box's longest) shortened at each end by
#: these fractions of its half width w (never past its middle), radius sqrt(w^2 + shortening^2).
TOOL_SHORTENING = (0.0, 0.5, 1.0)
#: Pair kinds (the first column of a pair row): robot-obstacle (primitive, obstacle), link-link (two primitives).
ENV, SELF = 0, 1
#: Seeded random configurations that order the pairs (most often not clear first).
ORDER_SAMPLES = 500
#: Golden-section steps of the segment-to-cylinder distance (the bracket shrinks to 0.618^40 = 4e-9 of the
#: segment), and the golden ratio's fraction.
GOLDEN_STEPS = 40
GOLDEN = 0.6180339887498949
#: Segments d, e with |d x e|^2 at most this fraction of |d|^2 |e|^2 are parallel (or points).
_PARALLEL = 1e-12


# -- distances (squared, between cores) -------------------------------------------------------------
@inner()
def _point_segment_sq(px, py, pz, ax, ay, az, dx, dy, dz):
    """Squared distance from point p to the segment a + t d, t in [0, 1]."""
    wx, wy, wz = px - ax, py - ay, pz - az
    dd = dx * dx + dy * dy + dz * dz
    t = 0.0
    if dd > 0.0:
        t = min(max((wx * dx + wy * dy + wz * dz) / dd, 0.0), 1.0)
    ex, ey, ez = wx - t * dx, wy - t * dy, wz - t * dz
    return ex * ex + ey * ey + ez * ez


@inner()
def _segment_segment_sq(s, i, u, j):
    """Squared distance between segment rows s[i] and u[j] (p: columns 0-2, r: 3-5): the closest pair of
    Ericson's Real-Time Collision Detection 5.1.9 (the parameter of one segment clamped, the other's best for
    it, clamped, and the first's again), or for parallel segments (or points) the least of the four
    endpoint-to-segment distances."""
    ax, ay, az = s[i, 0], s[i, 1], s[i, 2]
    dx, dy, dz = s[i, 3] - ax, s[i, 4] - ay, s[i, 5] - az
    bx, by, bz = u[j, 0], u[j, 1], u[j, 2]
    ex, ey, ez = u[j, 3] - bx, u[j, 4] - by, u[j, 5] - bz
    a = dx * dx + dy * dy + dz * dz
    e = ex * ex + ey * ey + ez * ez
    b = dx * ex + dy * ey + dz * ez
    denom = a * e - b * b
    if not denom > _PARALLEL * a * e:
        return min(_point_segment_sq(ax, ay, az, bx, by, bz, ex, ey, ez),
                   _point_segment_sq(ax + dx, ay + dy, az + dz, bx, by, bz, ex, ey, ez),
                   _point_segment_sq(bx, by, bz, ax, ay, az, dx, dy, dz),
                   _point_segment_sq(bx + ex, by + ey, bz + ez, ax, ay, az, dx, dy, dz))
    rx, ry, rz = ax - bx, ay - by, az - bz
    c, f = dx * rx + dy * ry + dz * rz, ex * rx + ey * ry + ez * rz
    s_ = min(max((b * f - c * e) / denom, 0.0), 1.0)
    t_ = (b * s_ + f) / e
    if t_ < 0.0:
        t_, s_ = 0.0, min(max(-c / a, 0.0), 1.0)
    elif t_ > 1.0:
        t_, s_ = 1.0, min(max((b - c) / a, 0.0), 1.0)
    wx, wy, wz = rx + s_ * dx - t_ * ex, ry + s_ * dy - t_ * ey, rz + s_ * dz - t_ * ez
    return wx * wx + wy * wy + wz * wz


@inner()
def _box_excess_sq(cx, cy, cz, hx, hy, hz):
    """Squared distance from the point c (box frame) to the box of half sides h."""
    ex, ey, ez = max(abs(cx) - hx, 0.0), max(abs(cy) - hy, 0.0), max(abs(cz) - hz, 0.0)
    return ex * ex + ey * ey + ez * ez


@inner()
def _segment_box_sq(c, d, h, breaks):
    """Squared distance from the segment c + t d, t in [0, 1] (c, d (3,) in the box frame) to the box of half
    sides h (3,): the convex piecewise quadratic in t is minimised on each piece between the parameters where
    a coordinate crosses a face plane (``breaks``: scratch of 8)."""
    n = 0
    breaks[n] = 0.0
    n += 1
    for k in range(3):
        if d[k] != 0.0:
            for side in (-h[k], h[k]):
                t = (side - c[k]) / d[k]
                if 0.0 < t < 1.0:
                    m = n                              # insertion sort
                    while m > 0 and breaks[m - 1] > t:
                        breaks[m] = breaks[m - 1]
                        m -= 1
                    breaks[m] = t
                    n += 1
    breaks[n] = 1.0
    n += 1
    best = _box_excess_sq(c[0] + d[0], c[1] + d[1], c[2] + d[2], h[0], h[1], h[2])
    for piece in range(n - 1):
        t0, t1 = breaks[piece], breaks[piece + 1]
        mid = 0.5 * (t0 + t1)
        num, den = 0.0, 0.0                            # the piece's quadratic: sum over active k of (e_k + d_k t)^2
        for k in range(3):
            x = c[k] + mid * d[k]
            if x > h[k]:
                num += (c[k] - h[k]) * d[k]
                den += d[k] * d[k]
            elif x < -h[k]:
                num += (c[k] + h[k]) * d[k]
                den += d[k] * d[k]
        t = t0
        if den > 0.0:
            t = min(max(-num / den, t0), t1)
        best = min(best, _box_excess_sq(c[0] + t * d[0], c[1] + t * d[1], c[2] + t * d[2], h[0], h[1], h[2]))
    return best


@inner(inline="always")
def _point_cylinder(c, d, t, radius, half):
    """Distance from the point c + t d (cylinder frame) to the cylinder of ``radius`` and ``half`` length along z."""
    x, y, z = c[0] + t * d[0], c[1] + t * d[1], c[2] + t * d[2]
    out, over = max(math.sqrt(x * x + y * y) - radius, 0.0), max(abs(z) - half, 0.0)
    return math.sqrt(out * out + over * over)


@inner()
def _segment_cylinder_lower(c, d, radius, half):
    """A lower bound of the distance from the segment c + t d, t in [0, 1] (c, d (3,) in the cylinder frame) to
    the cylinder (``_segment_cylinder``)."""
    best, hidden = _segment_cylinder(c, d, radius, half)
    return best - hidden


@inner()
def _segment_cylinder(c, d, radius, half):
    """The distance from the segment c + t d, t in [0, 1] (c, d (3,) in the cylinder frame) to the cylinder, to
    within what the search can hide: (the least found, at a point of the segment: an upper bound; how much less it
    may be) [m]. The distance is convex in t, GOLDEN_STEPS of golden-section search bracket its minimum, and |d|
    (its Lipschitz constant) times the bracket's width bounds what the bracket hides."""
    a, b = 0.0, 1.0
    x1, x2 = b - GOLDEN * (b - a), a + GOLDEN * (b - a)
    f1, f2 = _point_cylinder(c, d, x1, radius, half), _point_cylinder(c, d, x2, radius, half)
    for _ in range(GOLDEN_STEPS):
        if f1 <= f2:
            b, x2, f2 = x2, x1, f1
            x1 = b - GOLDEN * (b - a)
            f1 = _point_cylinder(c, d, x1, radius, half)
        else:
            a, x1, f1 = x1, x2, f2
            x2 = a + GOLDEN * (b - a)
            f2 = _point_cylinder(c, d, x2, radius, half)
    return min(f1, f2), math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) * (b - a)


@inner()
def _segment_shape_upper(seg, i, ob, o, local, breaks):
    """An upper bound of the distance from primitive i's core segment (row of ``seg``, in B) to the box or cylinder
    of obstacle row o [m]: exact for a box, the least a cylinder's search found (``_segment_cylinder``)."""
    p = _to_obstacle(ob, o, seg[i, 0], seg[i, 1], seg[i, 2])
    r = _to_obstacle(ob, o, seg[i, 3], seg[i, 4], seg[i, 5])
    local[3, 0], local[3, 1], local[3, 2] = p
    local[4, 0], local[4, 1], local[4, 2] = r[0] - p[0], r[1] - p[1], r[2] - p[2]
    if ob[o, 0] == BOX:
        local[2, 0], local[2, 1], local[2, 2] = ob[o, 13], ob[o, 14], ob[o, 15]
        return math.sqrt(_segment_box_sq(local[3], local[4], local[2], breaks))
    best, _ = _segment_cylinder(local[3], local[4], ob[o, 13], ob[o, 14])
    return best


@inner()
def _to_obstacle(ob, o, x, y, z):
    """The point (x, y, z) in B expressed in obstacle o's frame."""
    x, y, z = x - ob[o, 1], y - ob[o, 2], z - ob[o, 3]
    return (ob[o, 4] * x + ob[o, 7] * y + ob[o, 10] * z, ob[o, 5] * x + ob[o, 8] * y + ob[o, 11] * z,
            ob[o, 6] * x + ob[o, 9] * y + ob[o, 12] * z)


@inner()
def _beyond(squared, threshold):
    """How far a distance whose square is ``squared`` exceeds ``threshold`` (> 0) [m]; NOT_CLEAR when it does not."""
    return math.sqrt(squared) - threshold if squared > threshold * threshold else NOT_CLEAR


@inner()
def _pair_slack(seg, i, ob, o, threshold, local, breaks):
    """How far primitive i's core segment (row of ``seg``, in B) keeps beyond ``threshold`` (its radius, the padding
    and the tolerance) from obstacle o's core (a sphere's or capsule's radius is added here), a lower bound [m]
    (NOT_CLEAR: not beyond it): exact (a cylinder: its capsule, its box, then ``_segment_cylinder_lower``)."""
    kind = int(ob[o, 0])
    p = _to_obstacle(ob, o, seg[i, 0], seg[i, 1], seg[i, 2])
    r = _to_obstacle(ob, o, seg[i, 3], seg[i, 4], seg[i, 5])
    if kind != BOX:                                    # sphere, capsule: exact; cylinder: its capsule
        local[0, 0], local[0, 1], local[0, 2] = p
        local[0, 3], local[0, 4], local[0, 5] = r
        local[1, 0], local[1, 1], local[1, 2] = 0.0, 0.0, -ob[o, 14]
        local[1, 3], local[1, 4], local[1, 5] = 0.0, 0.0, ob[o, 14]
        slack = _beyond(_segment_segment_sq(local, 0, local, 1), threshold + ob[o, 13])
        if slack > 0.0 or kind != CYLINDER:
            return slack
        local[2, 0], local[2, 1], local[2, 2] = ob[o, 13], ob[o, 13], ob[o, 14]
    else:
        local[2, 0], local[2, 1], local[2, 2] = ob[o, 13], ob[o, 14], ob[o, 15]
    local[3, 0], local[3, 1], local[3, 2] = p
    local[4, 0], local[4, 1], local[4, 2] = r[0] - p[0], r[1] - p[1], r[2] - p[2]
    slack = _beyond(_segment_box_sq(local[3], local[4], local[2], breaks), threshold)
    if slack > 0.0 or kind != CYLINDER:
        return slack
    lower = _segment_cylinder_lower(local[3], local[4], ob[o, 13], ob[o, 14]) - threshold
    return lower if lower > 0.0 else NOT_CLEAR


# -- the chain: every primitive's core segment in B -------------------------------------------------
@inner(inline="always")
def _place(x, prims, first, stop, seg):
    """seg rows first..stop-1 = primitives first..stop-1 (given in the frame of the Pose x) in B: p, r and
    their midpoint."""
    for i in range(first, stop):
        for e in range(2):
            px, py, pz = prims[i, 1 + 3 * e], prims[i, 2 + 3 * e], prims[i, 3 + 3 * e]
            seg[i, 3 * e] = x[0] * px + x[1] * py + x[2] * pz + x[3]
            seg[i, 3 * e + 1] = x[4] * px + x[5] * py + x[6] * pz + x[7]
            seg[i, 3 * e + 2] = x[8] * px + x[9] * py + x[10] * pz + x[11]
        for k in range(3):
            seg[i, 6 + k] = 0.5 * (seg[i, k] + seg[i, 3 + k])


@inner(inline="always")
def _segments(chain, prims, starts, boxes, q, seg, moved):
    """seg (P, 9) = the primitives' core segments in B and their midpoints at q (primitives sorted by frame;
    ``starts`` (dof + 2,): the first primitive of each frame); moved (T, OBSTACLE_COLUMNS) = the tool boxes
    ``boxes`` (obstacle rows in the end frame) in B."""
    _place((1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0), prims, starts[0], starts[1], seg)
    x = base_pose(chain)
    for j in range(q.shape[0]):
        x = moved_pose(chain, x, q, j, j + 1)
        _place(x, prims, starts[j + 1], starts[j + 2], seg)
    for t in range(boxes.shape[0]):
        moved[t, 0], moved[t, 13], moved[t, 14], moved[t, 15], moved[t, 16] = boxes[t, 0], boxes[t, 13], \
            boxes[t, 14], boxes[t, 15], boxes[t, 16]
        for row in range(3):
            moved[t, 1 + row] = (x[4 * row] * boxes[t, 1] + x[4 * row + 1] * boxes[t, 2]
                                 + x[4 * row + 2] * boxes[t, 3] + x[4 * row + 3])
            for col in range(3):
                moved[t, 4 + 3 * row + col] = (x[4 * row] * boxes[t, 4 + col] + x[4 * row + 1] * boxes[t, 7 + col]
                                               + x[4 * row + 2] * boxes[t, 10 + col])


@inner(inline="always")
def _near_slack(seg, i, half, ob, o, threshold):
    """The quick tests of ``_pair_slack``: primitive i's segment lies within ``half`` of its midpoint
    (``seg[i, 6:9]``), so a midpoint farther than ``threshold + half`` from obstacle o's bounding sphere, or
    from its (containing) box, clears it, by that much less [m] (NOT_CLEAR: neither does)."""
    reach = threshold + half
    gx, gy, gz = seg[i, 6] - ob[o, 1], seg[i, 7] - ob[o, 2], seg[i, 8] - ob[o, 3]
    slack = _beyond(gx * gx + gy * gy + gz * gz, reach + ob[o, 16])
    kind = ob[o, 0]
    if slack > 0.0 or (kind != BOX and kind != CYLINDER):
        return slack
    m = _to_obstacle(ob, o, seg[i, 6], seg[i, 7], seg[i, 8])
    side = ob[o, 13]
    if kind == CYLINDER:
        return _beyond(_box_excess_sq(m[0], m[1], m[2], side, side, ob[o, 14]), reach)
    return _beyond(_box_excess_sq(m[0], m[1], m[2], side, ob[o, 14], ob[o, 15]), reach)


@inner(inline="always")
def _env_slack(seg, prims, i, ob, o, padding, moved, local, breaks):
    """How far one of primitive i's containing rows keeps beyond its radius plus ``padding`` from obstacle o [m]
    (their quick tests tried for all of them first: most pairs stop there), or a tool shape's own separation
    (``_separation``: flat ends where its capsules bulge; NOT_CLEAR: none does)."""
    alternatives = int(prims[i, ALTERNATIVES])
    for a in range(i, i + alternatives):
        slack = _near_slack(seg, a, prims[a, HALF], ob, o, prims[a, RADIUS] + padding)
        if slack > 0.0:
            return slack
    for a in range(i, i + alternatives):
        slack = _pair_slack(seg, a, ob, o, prims[a, RADIUS] + padding, local, breaks)
        if slack > 0.0:
            return slack
    shape = int(prims[i, TOOL_BOX])
    if shape >= 0:
        slack = _separation(moved, shape, ob, o) - padding
        if slack > 0.0:
            return slack
    return NOT_CLEAR


@inner(inline="always")
def _axis(ob, o, c):
    """Column c of obstacle row o's rotation: its local axis c in B."""
    return ob[o, 4 + c], ob[o, 7 + c], ob[o, 10 + c]


@inner()
def _extent(ob, o, ux, uy, uz):
    """Half the width of obstacle row o's shape along the unit vector u [m]: a box's half sides, a capsule's or a
    cylinder's half length along its axis (z) and radius across it."""
    kind = ob[o, 0]
    if kind == SPHERE:
        return ob[o, 13]
    if kind == BOX:
        width = 0.0
        for c in range(3):
            ax, ay, az = _axis(ob, o, c)
            width += ob[o, 13 + c] * abs(ax * ux + ay * uy + az * uz)
        return width
    ax, ay, az = _axis(ob, o, 2)
    along = min(abs(ax * ux + ay * uy + az * uz), 1.0)
    if kind == CAPSULE:
        return ob[o, 13] + ob[o, 14] * along
    return ob[o, 14] * along + ob[o, 13] * math.sqrt(1.0 - along * along)


@inner()
def _gap(a, i, b, j, ux, uy, uz):
    """How far apart the shapes of rows a[i] and b[j] project onto the unit vector u: a lower bound of their
    distance [m] (negative where the projections overlap)."""
    centres = (b[j, 1] - a[i, 1]) * ux + (b[j, 2] - a[i, 2]) * uy + (b[j, 3] - a[i, 3]) * uz
    return abs(centres) - _extent(a, i, ux, uy, uz) - _extent(b, j, ux, uy, uz)


@inner()
def _point_box(ob, o, x, y, z):
    """The distance from the point (x, y, z) in B to the box of obstacle row o [m]."""
    m = _to_obstacle(ob, o, x, y, z)
    return math.sqrt(_box_excess_sq(m[0], m[1], m[2], ob[o, 13], ob[o, 14], ob[o, 15]))


@inner()
def _shape_box_upper(t, i, ob, o):
    """An upper bound of the distance from the tool box or cylinder of row t[i] to the box of obstacle row o [m]:
    the least distance from points of the shape, a box's corners; a cylinder's rim at each flat end, on the side
    of the box's point nearest the end's centre (where its capsules bulge out of it and the capsule inside misses)."""
    best = np.inf
    if t[i, 0] == BOX:
        for corner in range(8):
            x, y, z = t[i, 1], t[i, 2], t[i, 3]
            for c in range(3):
                ax, ay, az = _axis(t, i, c)
                h = t[i, 13 + c] if (corner >> c) & 1 else -t[i, 13 + c]
                x, y, z = x + h * ax, y + h * ay, z + h * az
            best = min(best, _point_box(ob, o, x, y, z))
        return best
    ax, ay, az = _axis(t, i, 2)
    half = t[i, 14]
    low = _to_obstacle(ob, o, t[i, 1] - half * ax, t[i, 2] - half * ay, t[i, 3] - half * az)   # in the box's frame
    high = _to_obstacle(ob, o, t[i, 1] + half * ax, t[i, 2] + half * ay, t[i, 3] + half * az)
    dx, dy, dz = (high[0] - low[0]) / (2.0 * half), (high[1] - low[1]) / (2.0 * half), (high[2] - low[2]) / (2.0 * half)
    for ex, ey, ez in (low, high):                          # the flat ends' centres
        wx = min(max(ex, -ob[o, 13]), ob[o, 13]) - ex       # towards the box's point nearest the end's centre
        wy = min(max(ey, -ob[o, 14]), ob[o, 14]) - ey
        wz = min(max(ez, -ob[o, 15]), ob[o, 15]) - ez
        along = wx * dx + wy * dy + wz * dz
        wx, wy, wz = wx - along * dx, wy - along * dy, wz - along * dz       # across the axis
        norm = math.sqrt(wx * wx + wy * wy + wz * wz)
        if norm > 0.0:
            scale = t[i, 13] / norm
            ex, ey, ez = ex + scale * wx, ey + scale * wy, ez + scale * wz
        best = min(best, math.sqrt(_box_excess_sq(ex, ey, ez, ob[o, 13], ob[o, 14], ob[o, 15])))
    return best


@inner()
def _separation(a, i, b, j):
    """A lower bound of the distance between the shapes of obstacle rows a[i] and b[j] [m]: the widest gap between
    their projections onto their own axes (a box's three, a capsule's or a cylinder's) and the line through their
    centres (separating axes; exact where a face or a cylinder's flat end faces the other)."""
    gx, gy, gz = b[j, 1] - a[i, 1], b[j, 2] - a[i, 2], b[j, 3] - a[i, 3]
    norm = math.sqrt(gx * gx + gy * gy + gz * gz)
    best = _gap(a, i, b, j, gx / norm, gy / norm, gz / norm) if norm > 0.0 else NOT_CLEAR
    for row, o in ((a, i), (b, j)):
        kind = row[o, 0]
        if kind == SPHERE:
            continue
        for c in range(3 if kind == BOX else 1):
            ax, ay, az = _axis(row, o, c if kind == BOX else 2)
            best = max(best, _gap(a, i, b, j, ax, ay, az))
    return best


@inner(inline="always")
def _capsules_slack(seg, prims, i, j, padding):
    """How far one containing capsule of primitive i and one of j keep beyond their radii plus ``padding`` apart
    [m] (bounding spheres first; NOT_CLEAR: none do)."""
    for a in range(i, i + int(prims[i, ALTERNATIVES])):
        for b in range(j, j + int(prims[j, ALTERNATIVES])):
            threshold = prims[a, RADIUS] + prims[b, RADIUS] + padding
            gx, gy, gz = seg[a, 6] - seg[b, 6], seg[a, 7] - seg[b, 7], seg[a, 8] - seg[b, 8]
            slack = _beyond(gx * gx + gy * gy + gz * gz, threshold + prims[a, HALF] + prims[b, HALF])
            if slack <= 0.0:
                slack = _beyond(_segment_segment_sq(seg, a, seg, b), threshold)
            if slack > 0.0:
                return slack
    return NOT_CLEAR


@inner()
def _self_slack(seg, prims, i, j, padding, moved, local, breaks):
    """How far primitives i and j keep beyond their radii plus ``padding`` apart [m]: a link capsule by a tool
    shape's box (``moved``: the tighter bound at the shape's flat ends, tried first), or by their containing
    capsules (NOT_CLEAR: neither)."""
    for a, b in ((i, j), (j, i)):
        box = int(prims[b, TOOL_BOX])
        if box >= 0 and prims[a, TOOL_BOX] < 0.0:
            threshold = prims[a, RADIUS] + padding
            slack = _near_slack(seg, a, prims[a, HALF], moved, box, threshold)
            if slack <= 0.0:
                slack = _pair_slack(seg, a, moved, box, threshold, local, breaks)
            if slack > 0.0:
                return slack
    return _capsules_slack(seg, prims, i, j, padding)


@inner()
def _config_verdict(model, q, work):
    """FREE when q is certainly free (every robot-obstacle and link-link pair beyond its padding, with the
    tolerance: ``padding``); else decided at the first pair not clear (the pairs most often not clear come
    first): HIT when that pair's shapes certainly collide (``_hit``), MAYBE otherwise. ``model``:
    BroadPhase._model; ``work``: _scratch's."""
    seg, moved = work[0], work[1]
    _segments(model[0], model[1], model[2], model[3], q, seg, moved)
    rows, spheres = model[7], model[8]
    for k in range(rows.shape[0]):                     # bounding spheres apart: most pairs stop here
        if _centres_sq(seg, rows, spheres, k) <= spheres[k, 3] and _slack(model, k, work) <= 0.0:
            return HIT if _hit(model, k, work) else MAYBE
    return FREE


@inner(inline="always")
def _slack(model, k, work):
    """How far pair k (``pairs`` row: SELF or ENV, primitive, primitive or obstacle) certainly keeps beyond its
    padding [m] (NOT_CLEAR: not certainly)."""
    prims, obstacles, pairs, padding = model[1], model[4], model[5], model[6]
    seg, moved, local, breaks = work
    if pairs[k, 0] == ENV:
        return _env_slack(seg, prims, pairs[k, 1], obstacles, pairs[k, 2], padding[k], moved, local, breaks)
    return _self_slack(seg, prims, pairs[k, 1], pairs[k, 2], padding[k], moved, local, breaks)


@inner()
def _hit(model, k, work):
    """Pair k (not clear) certainly collides for Drake's checker: a capsule inside each of its shapes (a link
    capsule, a tool sphere or capsule: itself; a tool box or cylinder: its ``inscribed_capsule``) and an exact
    obstacle (a box, sphere or capsule: not a cylinder, which is only bounded), a link capsule and the tool box or
    cylinder itself (``_segment_shape_upper``), or points of the tool box or cylinder and a box obstacle
    (``_shape_box_upper``) come within their padding less PADDED_HIT_DEPTH_M (Drake's distance between separate
    shapes is GJK's, which may exceed the exact one), or overlap by more than HIT_DEPTH_M where the padding is
    smaller (an overlap Drake finds with GJK's intersection test)."""
    prims, obstacles, pairs = model[1], model[4], model[5]
    seg, moved, local, breaks = work
    a, j = int(prims[pairs[k, 1], INSCRIBED]), pairs[k, 2]
    if a < 0:
        return False
    within = max(model[6][k] - PADDED_HIT_DEPTH_M, -HIT_DEPTH_M)        # [m]: a distance below it is a hit
    if pairs[k, 0] == ENV:
        threshold = prims[a, RADIUS] + within
        if obstacles[j, 0] != CYLINDER and threshold > 0.0 and \
                _pair_slack(seg, a, obstacles, j, threshold, local, breaks) <= 0.0:
            return True
        shape = int(prims[pairs[k, 1], TOOL_BOX])
        return shape >= 0 and obstacles[j, 0] == BOX and _shape_box_upper(moved, shape, obstacles, j) <= within
    b = int(prims[j, INSCRIBED])
    threshold = prims[a, RADIUS] + prims[b, RADIUS] + within
    if b >= 0 and threshold > 0.0 and _segment_segment_sq(seg, a, seg, b) <= threshold * threshold:
        return True
    for capsule, tool in ((pairs[k, 1], j), (j, pairs[k, 1])):       # a link capsule by a tool box or cylinder
        shape = int(prims[tool, TOOL_BOX])
        if shape >= 0 and prims[capsule, TOOL_BOX] < 0.0 and \
                _segment_shape_upper(seg, capsule, moved, shape, local, breaks) <= prims[capsule, RADIUS] + within:
            return True
    return False


@njit(cache=True)
def _scratch(model):
    """Work arrays of the kernels: segments, moved tool boxes, local rows, breaks."""
    return (np.empty((model[1].shape[0], 9)), np.empty((model[3].shape[0], OBSTACLE_COLUMNS)), np.empty((5, 6)),
            np.empty(8))


@njit(cache=True)
def verdicts_into(model, Q, out):
    """out[k] = FREE, MAYBE or HIT: configuration Q[k] certainly free, maybe colliding, certainly colliding (see
    BroadPhase.verdicts)."""
    work = _scratch(model)
    for k in range(Q.shape[0]):
        out[k] = _config_verdict(model, Q[k], work)


@njit(cache=True)
def pair_counts_into(model, Q, count):
    """count[k] += the configurations of Q at which pair k is not certainly clear."""
    work = _scratch(model)
    for n in range(Q.shape[0]):
        _segments(model[0], model[1], model[2], model[3], Q[n], work[0], work[1])
        for k in range(model[5].shape[0]):
            if _slack(model, k, work) <= 0.0:
                count[k] += 1


@njit(cache=True)
def segments_into(model, Q, out):
    """out (k, P, 9) = the primitives' core segments (p, r) in B and their midpoints at each configuration Q[k]."""
    chain, prims, starts, boxes = model[0], model[1], model[2], model[3]
    moved = np.empty((boxes.shape[0], OBSTACLE_COLUMNS))
    for k in range(Q.shape[0]):
        _segments(chain, prims, starts, boxes, Q[k], out[k], moved)


@njit(cache=True)
def edge_maybes_into(model, a, b, step, stride, out):
    """The configurations Drake's CheckEdgeCollisionFree checks on the edge a -> b at edge step ``step`` (b, then
    a (1 - t/n) + b t/n for t = 0..n-1, n = max(1, ceil(|b - a| / step)): Drake's
    LinearDistanceAndInterpolationProvider, weights 1), every ``stride``-th of them first (a blocked edge shows
    there): -1 when one certainly collides (HIT), else how many are MAYBE, written in that order into out.

    Each verdict is ``_config_verdict``'s, but a pair is only tested where its slack (how far it keeps beyond its
    padding) found at another configuration of the edge, less the most its distance can change between the two
    (``drift`` per step: the pair's ``rates`` times each joint's step), does not clear it: the last configuration
    it was tested at and, between the coarse configurations, the two around it (their slacks kept in ``known``;
    between two coarse configurations only the pairs they do not clear all the way are looked at, ``_due_pairs``)."""
    work = _scratch(model)
    pairs, rows, spheres, rates = model[5], model[7], model[8], model[9]
    dof, count_pairs = a.shape[0], pairs.shape[0]
    q = np.empty(dof)
    squares = 0.0
    for j in range(dof):
        squares += (b[j] - a[j]) ** 2
    n = int(max(1.0, math.ceil(math.sqrt(squares) / step)))
    drift = np.zeros(count_pairs)                      # [m] per step of the edge
    for k in range(count_pairs):
        for j in range(dof):
            drift[k] += rates[k, j] * abs(b[j] - a[j]) / n
    # slack bounds at each coarse configuration c (t: ``_coarse_t``), for the fine ones between them (stride > 1)
    known = np.empty((n // stride + 1 if stride > 1 else 0, count_pairs))
    last, last_t = np.full(count_pairs, -np.inf), np.zeros(count_pairs)
    due, count_due, interval = np.arange(count_pairs), count_pairs, -1     # the pairs to look at: all, at first
    count = 0
    for coarse in (True, False):
        for i in range(n + 1):
            if (i % stride == 0) != coarse:
                continue
            t = n if i == 0 else i - 1
            ratio = t / n
            for j in range(dof):
                q[j] = b[j] if i == 0 else a[j] * (1.0 - ratio) + b[j] * ratio
            below, above = i // stride, i // stride + 1   # the coarse configurations around a fine one
            if above * stride > n:
                above = 0
            if not coarse and below != interval:
                interval = below
                count_due = _due_pairs(known, below, above, stride, n, drift, due)
            verdict, placed = FREE, False
            for m in range(count_due):
                k = due[m]
                bound = last[k] - abs(t - last_t[k]) * drift[k]
                if not coarse:
                    if below > 0:
                        bound = max(bound, known[below, k] - abs(t - _coarse_t(below, stride, n)) * drift[k])
                    bound = max(bound, known[above, k] - abs(t - _coarse_t(above, stride, n)) * drift[k])
                if verdict == FREE and bound <= 0.0:
                    if not placed:
                        _segments(model[0], model[1], model[2], model[3], q, work[0], work[1])
                        placed = True
                    bound = _sphere_slack(work[0], rows, spheres, k)
                    if bound <= 0.0:
                        bound = _slack(model, k, work)
                    if bound > 0.0:
                        last[k], last_t[k] = bound, t
                    elif _hit(model, k, work):
                        return -1
                    else:
                        verdict = MAYBE
                if coarse and stride > 1:
                    known[i // stride, k] = bound
                elif verdict != FREE:
                    break
            if verdict == MAYBE:
                out[count] = q
                count += 1
    return count


@inner()
def _due_pairs(known, below, above, stride, n, drift, due):
    """The pairs that the slacks ``known`` at coarse configurations ``below`` and ``above`` (less their drift) do
    not clear at every fine configuration between the two, into ``due`` (in order); how many. Where both bound a
    pair, the larger of the two is at least their mean, the same all the way; from ``a`` (below = 0), only the
    one above does, least at ``a``."""
    t_below, t_above = _coarse_t(below, stride, n), _coarse_t(above, stride, n)
    count = 0
    for k in range(known.shape[1]):
        if below > 0:
            least = 0.5 * (known[below, k] + known[above, k] - (t_above - t_below) * drift[k])
        else:
            least = known[above, k] - t_above * drift[k]
        if not least > DUE_MARGIN_M:
            due[count] = k
            count += 1
    return count


@inner(inline="always")
def _coarse_t(c, stride, n):
    """The edge parameter t of coarse configuration c (the c * stride-th Drake checks: b first)."""
    return n if c == 0 else c * stride - 1


@inner(inline="always")
def _sphere_slack(seg, rows, spheres, k):
    """How far pair k's bounding spheres keep apart [m] (NOT_CLEAR: they touch)."""
    return _beyond(_centres_sq(seg, rows, spheres, k), spheres[k, 4])


@inner(inline="always")
def _centres_sq(seg, rows, spheres, k):
    """The squared distance between the centres of pair k's bounding spheres [m^2]."""
    a, b = rows[k, 0], rows[k, 1]
    if b < 0:
        gx, gy, gz = seg[a, 6] - spheres[k, 0], seg[a, 7] - spheres[k, 1], seg[a, 8] - spheres[k, 2]
    else:
        gx, gy, gz = seg[a, 6] - seg[b, 6], seg[a, 7] - seg[b, 7], seg[a, 8] - seg[b, 8]
    return gx * gx + gy * gy + gz * gz


# -- the model in arrays --------------------------------------------------------------------------
def tool_capsules(shape) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Capsules each containing a tool shape: their segments (p, r) in the shape's parent frame [m] and radii
    [m] (a sphere or capsule: itself; a cylinder or box: one per TOOL_SHORTENING)."""
    R, centre = shape.X[:3, :3], shape.X[:3, 3]
    if shape.kind == "sphere":
        return [(centre, centre, shape.size[0])]
    if shape.kind == "capsule":
        radius, length = shape.size
        return [(centre - R[:, 2] * length / 2.0, centre + R[:, 2] * length / 2.0, radius)]
    if shape.kind == "box":
        sides = np.asarray(shape.size, dtype=float)
        axis = int(np.argmax(sides))
        width, half = float(np.linalg.norm(np.delete(sides, axis))) / 2.0, sides[axis] / 2.0
    else:
        axis, (width, half) = 2, (shape.size[0], shape.size[1] / 2.0)
    out = []
    for fraction in TOOL_SHORTENING:
        shortening = min(fraction * width, half)
        core = R[:, axis] * (half - shortening)
        out.append((centre - core, centre + core, math.hypot(width, shortening)))
    return out


def inscribed_capsule(shape) -> tuple[np.ndarray, np.ndarray, float]:
    """A capsule inside a tool box or cylinder: its segment (p, r) in the shape's parent frame [m] and radius [m]
    (along the box's longest side or the cylinder's axis, as wide as the box's narrower other side or the
    cylinder, its ends' half spheres within the shape's ends)."""
    R, centre = shape.X[:3, :3], shape.X[:3, 3]
    if shape.kind == "box":
        sides = np.asarray(shape.size, dtype=float)
        axis = int(np.argmax(sides))
        half, radius = sides[axis] / 2.0, float(np.delete(sides, axis).min()) / 2.0
    else:
        axis, radius, half = 2, shape.size[0], shape.size[1] / 2.0
    radius = min(radius, half)
    core = R[:, axis] * (half - radius)
    return centre - core, centre + core, radius


def _obstacle_row(shape, X_BW: np.ndarray) -> np.ndarray:
    """One obstacle as a kernel row (see OBSTACLE_COLUMNS), its pose moved into B."""
    X = X_BW @ shape.X
    row = np.zeros(OBSTACLE_COLUMNS)
    row[0], row[1:4], row[4:13] = _KINDS[shape.kind], X[:3, 3], X[:3, :3].ravel()
    size = np.asarray(shape.size, dtype=float)
    if shape.kind == "box":
        row[13:16] = size / 2.0
    elif shape.kind == "sphere":
        row[13] = size[0]
    else:
        row[13], row[14] = size[0], size[1] / 2.0
    row[16] = shape.bounding_radius
    return row


def _primitive_rows(model) -> tuple[list[tuple], list[np.ndarray]]:
    """The robot's primitives, sorted by frame (0: B, i: after joint i, dof: the end frame), each (frame, p, r
    in that frame, radius, alternatives, Drake body index, Drake geometry name (an inscribed capsule's: its
    shape's, marked), tool box row or -1, inscribed row or -1), and the tool boxes' obstacle rows in the end
    frame."""
    robot = model.robot
    after = [robot._K[0]]                              # x_i(0) = K_0 K_1 ... K_i in B (M_i(0) = I)
    for K in robot._K[1:]:
        after.append(after[-1] @ K)
    X_BD = robot.fk_all(np.zeros(robot.dof))           # DH frames at q = 0
    rows, boxes = [], []
    for k, c in enumerate(link_capsules(robot)):
        p, r = c.p, c.r
        if c.body > 0:
            C = np.linalg.inv(after[c.body]) @ X_BD[c.body]              # DH frame i in x_i: constant
            p, r = C[:3, :3] @ p + C[:3, 3], C[:3, :3] @ r + C[:3, 3]
        rows.append((c.body, p, r, c.radius, 1, int(model.bodies[c.body].index()), f"capsule{k}", -1, k, k))
    if model.tool_shapes:
        tool = int(model.plant.GetBodyByName("tool").index())
        for shape in model.tool_shapes:
            capsules = tool_capsules(shape)
            box, first = -1, len(rows)
            if shape.kind in ("box", "cylinder"):
                box = len(boxes)
                boxes.append(_obstacle_row(shape, np.eye(4)))
            inside = first if len(capsules) == 1 else first + len(capsules)
            rows += [(robot.dof, p, r, radius, len(capsules) if n == 0 else 0, tool, shape.name, box, first + n,
                      inside if n == 0 else -1) for n, (p, r, radius) in enumerate(capsules)]
            if inside != first:
                p, r, radius = inscribed_capsule(shape)
                rows.append((robot.dof, p, r, radius, 0, tool, f"{shape.name} (inscribed)", -1, inside, -1))
    rows.sort(key=lambda row: row[0])                  # stable: the capsules keep their order
    position = {row[8]: n for n, row in enumerate(rows)}
    return [(*row[:8], position.get(row[9], -1)) for row in rows], boxes


def _axis_reach(robot, prims: np.ndarray) -> np.ndarray:
    """(P, dof): for each primitive row and joint J (counted from 1 here) that moves it, an upper bound of how far a
    point of the primitive's core segment (of a tool box's or cylinder's rows: of the shape itself, the radius
    added) can be from J's axis at any configuration, and for a prismatic J: 1 [m, or m per m]. J's axis is the
    z axis of the chain pose before J (``pipeline.model.chain.compiled``: x_J = x_J-1 M_J K_J); a point p of frame
    f is at M_J K_J w, w = M_J+1 K_J+1 ... M_f K_f p, from that pose's origin: for J = f exactly the distance of
    K_f p from the z axis, else at most |K_J's translation across z| + |w|, and |w| at most the sum of the later
    K's translations, the farthest each later prismatic joint slides and |p| (rotations keep lengths)."""
    K = np.array(robot._K)
    shifts, across = np.linalg.norm(K[:, :3, 3], axis=1), np.linalg.norm(K[:, :2, 3], axis=1)
    revolute = robot.revolute_mask
    slides = np.where(revolute, 0.0, np.maximum(np.abs(robot.limits.q_min), np.abs(robot.limits.q_max)))
    reach = np.zeros((len(prims), robot.dof))
    for row, prim in enumerate(prims):
        frame, ends = int(prim[0]), (prim[1:4], prim[4:7])
        solid = prim[RADIUS] if prim[TOOL_BOX] >= 0 else 0.0
        if frame == 0:
            continue
        w = max(np.linalg.norm(end) for end in ends)
        reach[row, frame - 1] = max(np.linalg.norm((K[frame, :3, :3] @ end + K[frame, :3, 3])[:2]) for end in ends)
        for joint in range(1, frame):                  # joint J moves frames J..dof
            reach[row, joint - 1] = across[joint] + shifts[joint + 1: frame + 1].sum() + slides[joint: frame].sum() + w
        reach[row, :frame] += solid
        reach[row, :frame] = np.where(revolute[:frame], reach[row, :frame], 1.0)
    return np.where(np.isfinite(reach), reach, MAX_REACH_M)


class BroadPhase:
    """The conservative compiled check of a CollisionModel's robot against ``checker`` (``model.checker`` or a
    ``model.padded_checker``: its filtered pairs and paddings): ``free(Q)``, ``edge_free(q_a, q_b, step)`` and
    ``edges_free(A, B, step)``."""

    def __init__(self, model, checker):
        self.checker = checker
        #: Drake's edge step of that checker [rad]: ``edge_free``'s default.
        self.step = float(checker.edge_step_size())
        robot = model.robot
        self.dof = robot.dof
        self._chain = robot._chain
        rows, boxes = _primitive_rows(model)
        self._prims = np.array([[f, *p, *r, radius, np.linalg.norm(r - p) / 2.0, alternatives, box, inside]
                                for f, p, r, radius, alternatives, _, _, box, inside in rows], dtype=float)
        self._boxes = np.array(boxes, dtype=float).reshape(-1, OBSTACLE_COLUMNS)
        #: Each primitive's Drake geometry name (``capsule<k>`` or the tool shape's), in kernel order.
        self.names = [row[6] for row in rows]
        frames = np.array([row[0] for row in rows])
        self._starts = np.searchsorted(frames, np.arange(robot.dof + 2)).astype(np.int64)
        prim_bodies = [row[5] for row in rows]
        shapes = [i for i, row in enumerate(rows) if row[4] > 0]     # each shape's first row
        X_BW = np.linalg.inv(np.eye(4) if model.cell is None else model.cell.X_WB)
        objects = () if model.cell is None else model.cell.objects
        self._obstacles = np.array([_obstacle_row(s, X_BW) for s in objects], dtype=float).reshape(-1, OBSTACLE_COLUMNS)
        obstacle_bodies = [int(b.index()) for b in model.obstacles]
        filtered, padding = checker.GetFilteredCollisionMatrix(), checker.GetPaddingMatrix()
        pairs, pair_padding = [], []
        for i in shapes:
            for o, b in enumerate(obstacle_bodies):
                if filtered[prim_bodies[i], b] == 0:
                    pairs.append((ENV, i, o))
                    pair_padding.append(padding[prim_bodies[i], b] + DRAKE_TOLERANCE_M)
        for i in shapes:
            for j in shapes:
                a, b = prim_bodies[i], prim_bodies[j]
                if i < j and a != b and filtered[a, b] == 0:
                    pairs.append((SELF, i, j))
                    pair_padding.append(padding[a, b] + DRAKE_TOLERANCE_M)
        self._pairs = np.array(pairs, dtype=np.int64).reshape(-1, 3)
        self._padding = np.array(pair_padding, dtype=float)
        self._rates_of_pairs(robot)
        self._order_pairs(robot)

    def _order_pairs(self, robot) -> None:
        """Sort the pairs by how often they are not clear at ORDER_SAMPLES seeded random configurations, most
        often first: a colliding configuration is refused after fewer pairs."""
        count = np.zeros(len(self._pairs))
        self._spheres_of_pairs()
        Q = robot.random_configurations(np.random.default_rng(0), ORDER_SAMPLES)
        pair_counts_into(self._model, Q, count)
        order = np.argsort(-count, kind="stable")
        self._pairs, self._padding = np.ascontiguousarray(self._pairs[order]), self._padding[order]
        self._rates = self._rates[order]
        self._spheres_of_pairs()

    def _spheres_of_pairs(self) -> None:
        """Per pair, its bounding-sphere test: the rows (primitive, primitive or -1) whose midpoints it takes,
        a fixed centre (an obstacle's), the squared distance the midpoints must exceed and that distance. A tool shape
        takes the containing capsule of the smallest radius plus half length (any of them clear clears the pair)."""
        prims = self._prims

        def tightest(i):
            rows = range(i, i + int(prims[i, ALTERNATIVES]))
            return min(rows, key=lambda a: prims[a, RADIUS] + prims[a, HALF])

        self._sphere_rows = np.empty((len(self._pairs), 2), dtype=np.int64)
        self._spheres = np.zeros((len(self._pairs), 5))
        for k, ((kind, i, j), padding) in enumerate(zip(self._pairs, self._padding)):
            a = tightest(i)
            around = prims[a, RADIUS] + prims[a, HALF] + padding
            if kind == ENV:
                self._sphere_rows[k] = a, -1
                self._spheres[k, :3] = self._obstacles[j, 1:4]
                around += self._obstacles[j, 16]
            else:
                b = tightest(j)
                self._sphere_rows[k] = a, b
                around += prims[b, RADIUS] + prims[b, HALF]
            self._spheres[k, 3:] = around * around, around

    def _rates_of_pairs(self, robot) -> None:
        """Per pair and joint, the most the pair's distance changes per unit of that joint's motion [m per rad or
        m] (``edge_maybes_into``'s drift): the farthest a point of the pair's moving primitive (an obstacle pair's:
        its own; a link pair's: the one later in the chain, relative to the other's frame, so only the joints
        between them count) can be from the joint's axis (``_axis_reach``); 1 for a prismatic joint."""
        reach = _axis_reach(robot, self._prims)
        frames = self._prims[:, 0].astype(int)
        self._rates = np.zeros((len(self._pairs), robot.dof))
        for k, (kind, i, j) in enumerate(self._pairs):
            if kind == ENV:
                moving, after = i, 0
            else:
                fixed, moving = sorted((i, j), key=lambda p: frames[p])
                after = frames[fixed]
            rows = range(moving, moving + int(self._prims[moving, ALTERNATIVES]))
            for joint in range(after, frames[moving]):     # the joints after the fixed frame, up to the moving one
                self._rates[k, joint] = max(reach[row, joint] for row in rows)

    @property
    def _model(self):
        return (self._chain, self._prims, self._starts, self._boxes, self._obstacles, self._pairs, self._padding,
                self._sphere_rows, self._spheres, self._rates)

    def _batch(self, Q) -> np.ndarray:
        """Q as the one array type the kernels are compiled for (C-contiguous, writeable float64: a read-only
        array is another type to Numba, and its first call would compile the kernel again, 5-10 s); such an array
        passes as it is (``np.require`` took twice the kernel's time on one configuration)."""
        if not (type(Q) is np.ndarray and Q.dtype == np.float64 and Q.flags.c_contiguous and Q.flags.writeable):
            Q = np.require(Q, dtype=float, requirements=("C", "W"))
        if Q.ndim != 2 or Q.shape[1] != self.dof or not np.isfinite(Q).all():
            raise ValueError(f"configurations must be finite, shape (k, {self.dof}), got shape {Q.shape}")
        return Q

    def verdicts(self, Q) -> np.ndarray:
        """Per configuration of Q (k, dof) [rad] (int8 (k,)): FREE only when Drake's checker with the same
        paddings certainly finds it free, HIT only when it certainly finds it colliding (a pair of exact shapes
        PADDED_HIT_DEPTH_M within its padding, ``_hit``), MAYBE otherwise (ask Drake)."""
        Q = self._batch(Q)
        out = np.empty(len(Q), dtype=np.int8)
        verdicts_into(self._model, Q, out)
        return out

    def free(self, Q) -> np.ndarray:
        """Per configuration of Q (k, dof) [rad]: certainly free (bool (k,); False: maybe colliding, ask Drake)."""
        return self.verdicts(Q) == FREE

    def edge_maybes(self, q_a, q_b, step: float | None = None, stride: int = 1) -> np.ndarray | None:
        """The edge q_a -> q_b ((dof,) each [rad]) at edge step ``step`` [rad] (default: the checker's), every
        ``stride``-th configuration first: None when a configuration Drake's CheckEdgeCollisionFree checks on it
        certainly collides, else those it may find colliding (k, dof), in that order (none: certainly free)."""
        (q_a,), (q_b,) = self._batch(np.asarray(q_a)[None]), self._batch(np.asarray(q_b)[None])
        step = self.step if step is None else float(step)
        if not step > 0.0:
            raise ValueError(f"edge step must be positive, got {step!r}")
        rows = int(np.ceil(float(np.linalg.norm(q_b - q_a)) / step)) + 3     # n + 1 and Eigen's rounding
        out = np.empty((rows, self.dof))
        count = edge_maybes_into(self._model, q_a, q_b, step, int(stride), out)
        return None if count < 0 else out[:count]

    def edges_free(self, A, B, step: float | None = None) -> np.ndarray:
        """Per edge A[k] -> B[k] ((k, dof) each [rad]): True only when every configuration Drake's
        CheckEdgeCollisionFree checks on it at edge step ``step`` [rad] (default: the checker's) is certainly
        free (bool (k,))."""
        A, B = np.asarray(A, dtype=float), np.asarray(B, dtype=float)
        if A.shape != B.shape:
            raise ValueError(f"edge ends of shapes {A.shape} and {B.shape}")
        maybes = [self.edge_maybes(a, b, step) for a, b in zip(A, B)]
        return np.array([m is not None and len(m) == 0 for m in maybes], dtype=bool)

    def edge_free(self, q_a, q_b, step: float | None = None) -> bool:
        """One edge q_a -> q_b (see ``edges_free``)."""
        maybes = self.edge_maybes(q_a, q_b, step)
        return maybes is not None and len(maybes) == 0

    def segments(self, Q) -> np.ndarray:
        """The primitives' core segments (k, P, 2, 3) in the robot base frame B [m] at configurations Q."""
        Q = self._batch(Q)
        out = np.empty((len(Q), len(self._prims), 9))
        segments_into(self._model, Q, out)
        return out[:, :, :6].reshape(len(Q), len(self._prims), 2, 3)
