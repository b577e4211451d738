"""``--scene FILE`` of the motion, IK and FK commands, and the clearance line they print.

A scene file (format in docs/config.md, "Scene") replaces the ``scene:`` section of the arm's
config for one command: the table, the obstacles and the padding that plans are checked
against. Without ``--scene`` the arm's own section applies (else a table at the base).
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from armctl.collision import Clearance
    from armctl.config.scene import SceneSpec
    from armctl.kinematics.model import KinematicModel

__all__ = ["add_scene_option", "clearance_data", "clearance_text", "scene_arg",
           "scene_clearance", "self_checked"]


def add_scene_option(p: argparse.ArgumentParser) -> None:
    """Add ``--scene FILE`` (the scene that replaces the config's ``scene:`` section)."""
    p.add_argument("--scene", metavar="FILE", default=None,
                   help="scene file (table, obstacles, padding; docs/config.md) used instead of "
                        "the config's 'scene:' section for collision checks")


def scene_arg(args: argparse.Namespace, arm: KinematicModel) -> SceneSpec | None:
    """The scene of ``--scene FILE``, read and checked; ``None`` without the option.

    Raises:
        ConfigError: A missing or malformed scene file (names the file, line, key and fix).
    """
    path = getattr(args, "scene", None)
    if path is None:
        return None
    from armctl.config.scene_yaml import load_scene

    return load_scene(path, [lk.name for lk in arm.spec.links])


def scene_clearance(arm: KinematicModel, q: Any, scene: SceneSpec | None,
                    sample: bool = True) -> Clearance | None:
    """The pair with the least room at ``q`` in ``scene`` (the arm's own scene for ``None``).

    Computed by the interpreted kernels: one configuration costs milliseconds and loads no
    compiler.

    Args:
        arm: The arm.
        q: Joint values ``(dof,)`` [rad]/[m].
        scene: The scene; ``None``: the arm's.
        sample: For an arm without a ``collision:`` section, find its allowed-collision matrix
            by sampling (compiled kernels, about a second) as motions do; ``False``: check only
            its links against the table and the obstacles (see :func:`self_checked`).
    """
    from armctl.collision import CollisionModel
    from armctl.collision.single import clearance_once

    allowed = None
    if not sample and not self_checked(arm):
        from armctl.config.scene import AllowedPair, AllowReason, CollisionSpec

        links = [lk.name for lk in arm.spec.links]
        allowed = CollisionSpec(tuple(
            AllowedPair(a, b, AllowReason.USER, "no collision matrix: link pairs not checked")
            for i, a in enumerate(links) for b in links[i + 1:]))
    return clearance_once(CollisionModel.of(arm, scene, allowed), q)


def self_checked(arm: KinematicModel) -> bool:
    """Whether :func:`scene_clearance` with ``sample=False`` checks link pairs too.

    Only for an arm with an allowed-collision matrix (a ``collision:`` section).
    """
    return arm.spec.collision is not None


def clearance_text(c: Clearance | None, links: bool = True) -> str:
    """``clearance: 34.9 mm (gripper_link - table)``, and whether the pair is in contact.

    ``links``: whether pairs of links were checked (else the line says they were not).
    """
    if not links:
        return (clearance_text(c) + "\n  (link pairs not checked: the arm has no collision "
                "matrix; 'armctl collisions CONFIG --generate' finds one)")
    if c is None:
        return "clearance: no pair is checked (no scene object and no link pair)"
    text = f"clearance: {c.distance * 1000:.1f} mm ({c.a} - {c.b})"
    if c.margin < 0.0:
        if c.distance < 0.0:
            return f"{text}: IN CONTACT (they overlap by {-c.distance * 1000:.1f} mm)"
        return f"{text}: IN CONTACT (inside the {c.padding * 1000:.1f} mm padding)"
    if c.padding > 0.0:
        text += f", {c.margin * 1000:.1f} mm beyond the {c.padding * 1000:.1f} mm padding"
    return text


def clearance_data(c: Clearance | None) -> dict[str, Any] | None:
    """The clearance as JSON fields (lengths in [m]); ``None`` when no pair is checked."""
    if c is None:
        return None
    return {"distance": c.distance, "padding": c.padding, "margin": c.margin,
            "pair": [c.a, c.b], "kind": c.kind.value, "in_contact": c.margin < 0.0}
