"""The serial chain of a URDF from a base link to a tip link, posed at q = 0 in the base link frame.

Fixed joints are folded into the poses. Links welded to a moving link (by fixed joints, on the chain
or beside it) belong to its body, for the mass properties. Without a tip, the chain follows the
moving joints from the base and must not fork: a fork where moving joints lie on two sides is a
UrdfChainError naming the link and the joints (give ``tip``). Mimic, floating and planar joints on
the chain are UrdfChainErrors naming the joint. The links must form one tree: a link not below the
root (a kinematic loop) is a UrdfChainError. Every walk over the tree is a loop, not a recursion, so
a chain as long as the reader allows (``reader.MAX_URDF_LINKS``) takes linear time; a chain of more
than MAX_CHAIN_JOINTS moving joints is no arm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import UrdfChainError
from .reader import UrdfInertial, UrdfJoint, UrdfModel

#: The names ROS-Industrial gives the robot's mounting frame and its flange frame (REP 199).
ROS_BASE_LINK, ROS_TIP_LINK = "base_link", "tool0"
#: Most moving joints of an imported chain: arms have up to 7, humanoid limbs and snakes a few dozen.
MAX_CHAIN_JOINTS = 64


@dataclass(frozen=True, eq=False)
class ChainJoint:
    """A moving joint of the chain: ``X_BJ`` (4, 4) its frame in the base link frame at q = 0 [m],
    ``axis_B`` (3,) its unit axis in the base frame (the positive direction of q)."""

    joint: UrdfJoint
    X_BJ: np.ndarray

    @property
    def axis_B(self) -> np.ndarray:
        return self.X_BJ[:3, :3] @ self.joint.axis


@dataclass(frozen=True, eq=False)
class SerialChain:
    """``joints``: the moving joints from base to tip; ``X_BT`` (4, 4) the tip link frame in the base
    link frame at q = 0; ``bodies``: per moving joint, the (X_BL at q = 0, UrdfInertial) of every link
    welded to its child link; ``ignored``: joints that move but are off the chain."""

    model: UrdfModel
    base: str
    tip: str
    joints: tuple[ChainJoint, ...]
    X_BT: np.ndarray
    bodies: tuple[tuple[tuple[np.ndarray, UrdfInertial], ...], ...]
    ignored: tuple[str, ...]


class _Tree:
    """Parent and child joints of every link; checks there is one root and every link lies below it."""

    def __init__(self, model: UrdfModel):
        self.model = model
        self.children: dict[str, list[UrdfJoint]] = {name: [] for name in model.links}
        self.parent: dict[str, UrdfJoint] = {}
        for joint in model.joints:
            if joint.child in self.parent:
                self.fail(f"link[{joint.child}]", f"has two parent joints ({self.parent[joint.child].name}, "
                          f"{joint.name}): a URDF is a tree")
            self.parent[joint.child] = joint
            self.children[joint.parent].append(joint)
        roots = [name for name in model.links if name not in self.parent]
        if len(roots) != 1:
            self.fail("document", f"must have exactly one root link (one without a parent joint), has {len(roots)}",
                      roots)
        self.order = self._top_down(roots[0])
        self.moving_below = self._moving_below()

    def fail(self, field: str, problem: str, value=None):
        raise UrdfChainError(self.model.source, field, problem, value=value)

    def _top_down(self, root: str) -> list[UrdfJoint]:
        """Every joint, parents before children; a UrdfChainError when some link is not below the root
        (its joints close a kinematic loop)."""
        order = self.below(root)
        if len(order) != len(self.model.joints):
            reached = {j.name for j in order}
            loop = [j.name for j in self.model.joints if j.name not in reached]
            self.fail(f"joint[{loop[0]}]", "lies on a kinematic loop (its links are not below the root link "
                      f"{root!r}): a URDF is a tree", loop)
        return order

    def _moving_below(self) -> dict[str, bool]:
        """Per joint name: whether it or any joint below its child moves (children before parents)."""
        moving: dict[str, bool] = {}
        for joint in reversed(self.order):
            moving[joint.name] = joint.is_movable or any(moving[j.name] for j in self.children[joint.child])
        return moving

    def moves_below(self, joint: UrdfJoint) -> bool:
        """Whether ``joint`` or any joint below its child moves."""
        return self.moving_below[joint.name]

    def default_tip(self, base: str) -> str:
        """Follow the moving joints down from ``base``; the child of the last one is the tip."""
        link = base
        while True:
            moving = [j for j in self.children[link] if self.moves_below(j)]
            if len(moving) > 1:
                self.fail(f"link[{link}]", "the chain forks here: joints " + ", ".join(j.name for j in moving)
                          + " each lead to moving joints; name the tip link (--tip) to pick one")
            if not moving:
                return link
            link = moving[0].child

    def path(self, base: str, tip: str) -> list[UrdfJoint]:
        """The joints from ``base`` down to ``tip``."""
        joints, link = [], tip
        while link != base:
            if link not in self.parent:
                self.fail(f"link[{tip}]", f"is not below the base link {base!r}")
            joints.append(self.parent[link])
            link = self.parent[link].parent
        return joints[::-1]

    def welded(self, link: str, X_BL: np.ndarray) -> list[tuple[str, np.ndarray]]:
        """``link`` and every link attached below it by fixed joints, with their poses."""
        found, stack = [], [(link, X_BL)]
        while stack:
            name, X = stack.pop()
            found.append((name, X))
            stack += [(j.child, X @ j.X_PJ) for j in reversed(self.children[name]) if not j.is_movable]
        return found

    def below(self, link: str) -> list[UrdfJoint]:
        """Every joint below ``link``, depth first in file order (parents before children)."""
        found, stack = [], self.children[link][::-1]
        while stack:
            joint = stack.pop()
            found.append(joint)
            stack += self.children[joint.child][::-1]
        return found

    def path_exists(self, base: str, tip: str) -> bool:
        return any(joint.child == tip for joint in self.below(base))


def serial_chain(model: UrdfModel, base: str | None = None, tip: str | None = None) -> SerialChain:
    """The chain from ``base`` (default ``base_link`` if the file has it, else the root link) to ``tip``
    (default ``tool0`` if the file has it, else the end of the moving joints from the base)."""
    tree = _Tree(model)
    for role, name in (("base", base), ("tip", tip)):
        if name is not None and name not in model.links:
            tree.fail(f"link[{name}]", f"the {role} link names no <link> of this file", name)
    base = base or (ROS_BASE_LINK if ROS_BASE_LINK in model.links else
                    next(name for name in model.links if name not in tree.parent))
    tip = tip or (ROS_TIP_LINK if ROS_TIP_LINK in model.links and tree.path_exists(base, ROS_TIP_LINK)
                  else tree.default_tip(base))
    joints, X, bodies = [], np.eye(4), []
    path = tree.path(base, tip)
    for joint in path:
        X = X @ joint.X_PJ
        if not joint.is_movable:
            continue
        if joint.kind in ("floating", "planar"):
            tree.fail(f"joint[{joint.name}].type", "a DH chain has only revolute, continuous, prismatic and fixed "
                      "joints", joint.kind)
        if joint.mimic is not None:
            tree.fail(f"joint[{joint.name}].mimic", "a mimic joint is not an independent DH joint", joint.mimic)
        if len(joints) == MAX_CHAIN_JOINTS:
            tree.fail(f"joint[{joint.name}]", f"is the moving joint number {MAX_CHAIN_JOINTS + 1} from the base link "
                      f"{base!r}: a chain has at most {MAX_CHAIN_JOINTS} (name a nearer --tip)")
        joints.append(ChainJoint(joint, X.copy()))
        welded = tree.welded(joint.child, X)
        bodies.append(tuple((X_BL, model.links[name]) for name, X_BL in welded if model.links[name] is not None))
    if not joints:
        tree.fail(f"link[{tip}]", f"no moving joint lies between the base link {base!r} and this tip link")
    on_chain = {joint.name for joint in path}
    ignored = tuple(j.name for j in tree.below(base) if j.is_movable and j.name not in on_chain)
    return SerialChain(model, base, tip, tuple(joints), X, tuple(bodies), ignored)


def link_pose(model: UrdfModel, base: str, link: str) -> np.ndarray | None:
    """The pose (4, 4) [m] of ``link`` in the ``base`` link's frame with every joint at 0, or None when the
    file has no such link below ``base``."""
    tree = _Tree(model)
    if link not in model.links or (link != base and not tree.path_exists(base, link)):
        return None
    X = np.eye(4)
    for joint in tree.path(base, link):
        X = X @ joint.X_PJ
    return X
