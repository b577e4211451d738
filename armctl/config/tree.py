"""Checks that links and joints form one tree, and orders the joints parents-first."""

from __future__ import annotations

import difflib
from collections.abc import Sequence

from armctl.config.schema import FrameSpec, JointSpec
from armctl.errors import ConfigError, KeyPath

__all__ = ["MAX_FRAMES", "MAX_JOINTS", "check_arm_size", "order_tree"]

#: Most joints an arm may have (of every type, multi-DOF joints counted per axis). Beyond it,
#: the kinematic model's per-frame joint paths (frames x joints) would take too much memory.
MAX_JOINTS = 1000
#: Most named frames an arm may have besides its links.
MAX_FRAMES = 1000


def check_arm_size(joints: int, frames: int, where: KeyPath) -> None:
    """Refuse an arm with more than :data:`MAX_JOINTS` joints or :data:`MAX_FRAMES` frames.

    Args:
        joints: Number of joints.
        frames: Number of named frames besides the links.
        where: Where the joints (or frames) are listed, for the error.

    Raises:
        ConfigError: If either count is above its maximum.
    """
    if joints > MAX_JOINTS:
        raise ConfigError(f"the arm has {joints} joints; armctl supports arms of up to "
                          f"{MAX_JOINTS} joints", where,
                          "split the description, or model the repeated part as one joint")
    if frames > MAX_FRAMES:
        raise ConfigError(f"the arm has {frames} named frames; armctl supports up to "
                          f"{MAX_FRAMES}", where, "keep the frames you use")


def _suggest(name: str, known: Sequence[str]) -> str | None:
    close = difflib.get_close_matches(name, known, n=1)
    return f"did you mean {close[0]!r}?" if close else None


def order_tree(
    base: str,
    joints: Sequence[JointSpec],
    links: Sequence[str],
    frames: Sequence[FrameSpec] = (),
    where: KeyPath | None = None,
) -> tuple[list[JointSpec], list[str]]:
    """Validate the tree and return its joints and links in depth-first order from the base.

    Args:
        base: Name of the root link.
        joints: Every joint, in file order.
        links: Link names declared explicitly (links named only by joints are added).
        frames: Named frames, checked for unknown parents and name clashes.
        where: Location of the document, for errors that have no better place.

    Returns:
        ``(joints, links)``: joints parents-first (siblings in file order) and every link name.

    Raises:
        ConfigError: For duplicate names, an unknown parent, two roots, a link with two parent
            joints, a cycle, or a frame on an unknown link.
    """
    doc = where or KeyPath()
    by_name: dict[str, JointSpec] = {}
    for j in joints:
        if j.name in by_name:
            raise ConfigError(f"duplicate joint name {j.name!r}", j.where,
                              "give every joint its own name")
        by_name[j.name] = j
    parent_joint: dict[str, JointSpec] = {}
    for j in joints:
        if j.child == base:
            raise ConfigError(f"the base link {base!r} cannot be the child of joint {j.name!r}",
                              j.where, "a joint's child must be a link further from the base")
        if j.child in parent_joint:
            other = parent_joint[j.child].name
            raise ConfigError(
                f"link {j.child!r} is the child of two joints ({other!r} and {j.name!r})",
                j.where, "a link has exactly one parent joint; rename one of the children")
        if j.parent == j.child:
            raise ConfigError(f"joint {j.name!r} connects link {j.child!r} to itself", j.where)
        parent_joint[j.child] = j
    known = [base, *parent_joint]
    for name in links:
        if name != base and name not in parent_joint:
            raise ConfigError(
                f"link {name!r} is not connected to the tree: two roots ({base!r} and {name!r})",
                doc, f"add a joint with child {name!r}, or remove the link")
    for j in joints:
        if j.parent != base and j.parent not in parent_joint:
            raise ConfigError(
                f"joint {j.name!r} has unknown parent link {j.parent!r}", j.where,
                _suggest(j.parent, known) or f"use the base {base!r} or the child of another joint")
    # every link's chain of parents must reach the base: otherwise there is a cycle. Each link
    # is walked once: a walk stops at the first link already known to reach the base.
    reaches = {base}
    for link in parent_joint:
        walk: list[str] = []
        on_walk: set[str] = set()
        cur = link
        while cur not in reaches:
            if cur in on_walk:
                raise ConfigError(
                    f"the joints form a cycle through link {cur!r}", parent_joint[link].where,
                    "a kinematic tree has no loops: check the parent and child of these joints")
            walk.append(cur)
            on_walk.add(cur)
            cur = parent_joint[cur].parent
        reaches.update(walk)
    children: dict[str, list[JointSpec]] = {}
    for j in joints:
        children.setdefault(j.parent, []).append(j)
    # depth-first from the base; push children reversed so the first in file order comes first
    stack = [base]
    link_order: list[str] = []
    while stack:
        link = stack.pop()
        link_order.append(link)
        stack.extend(j.child for j in reversed(children.get(link, [])))
    link_index = {name: i for i, name in enumerate(link_order)}
    ordered = sorted(joints, key=lambda j: link_index[j.child])
    names = set(link_order)
    frame_names: set[str] = set()
    for f in frames:
        if f.name in names or f.name in frame_names:
            raise ConfigError(f"frame name {f.name!r} is already used by a link or another frame",
                              f.where, "give every frame and link its own name")
        frame_names.add(f.name)
        if f.parent not in names:
            raise ConfigError(f"frame {f.name!r} is attached to unknown link {f.parent!r}",
                              f.where, _suggest(f.parent, link_order))
    return ordered, link_order
