"""Collision checking: an arm's links against each other, the table and the obstacles of a scene.

:class:`CollisionModel` (``CollisionModel.of(arm)``) checks configurations, straight joint-space
lines and sampled motions, continuously; :func:`generate_allowed` finds the allowed-collision
matrix by sampling. See ``docs/collision.md``.
"""

from __future__ import annotations

from armctl.collision.allowed import allowed_pairs, generate_allowed
from armctl.collision.contact import Clearance, Contact, ContactKind
from armctl.collision.errors import CollisionError, MissingExtraError, SceneError
from armctl.collision.model import CollisionModel, scene_of

__all__ = [
    "Clearance",
    "CollisionError",
    "CollisionModel",
    "Contact",
    "ContactKind",
    "MissingExtraError",
    "SceneError",
    "allowed_pairs",
    "generate_allowed",
    "scene_of",
]
