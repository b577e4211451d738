"""Errors of collision checking: a configuration or motion that would bring a link into contact."""

from __future__ import annotations

from armctl.collision.contact import Contact
from armctl.errors import ArmctlError, InputError, PlanningError

__all__ = ["CollisionError", "MissingExtraError", "SceneError"]


class CollisionError(PlanningError):
    """A configuration or a planned motion would bring a link into contact; nothing moved.

    Args:
        what: What was checked (``"move to pose"``, ``"IK solution"``, ...).
        contact: The first contact found.
        joint_names: The arm's joint names (to name the configuration).
        hint: How to get around it (a sentence).

    ``details``: ``pair`` ([a, b]), ``kind`` (``"self"``/``"scene"``), ``distance`` [m],
    ``depth`` [m], ``padding`` [m], ``time`` [s] or ``None``, ``q`` (joint name -> value),
    ``deepest`` (the pair's least distance along the motion [m]) and ``deepest_time`` [s].
    """

    def __init__(self, what: str, contact: Contact, joint_names: tuple[str, ...] = (),
                 hint: str = ""):
        self.contact = contact
        text = f"{what} collides: {contact.describe(joint_names)}; nothing was moved"
        if hint:
            text += f". {hint[:1].upper()}{hint[1:]}"
        q = [float(v) for v in contact.q]
        super().__init__(text, {
            "pair": [contact.a, contact.b], "kind": contact.kind, "distance": contact.distance,
            "depth": contact.depth, "padding": contact.padding, "time": contact.time,
            "q": dict(zip(joint_names, q, strict=True)) if len(joint_names) == len(q) else q,
            "deepest": contact.deepest, "deepest_time": contact.deepest_time,
        })


class SceneError(InputError):
    """A scene or collision matrix that cannot be used as given (names the object and the fix)."""


class MissingExtraError(ArmctlError):
    """An optional library that a feature needs is not installed.

    Args:
        feature: What needs it.
        package: The library.
        extra: The armctl extra that installs it.
    """

    exit_code = 2

    def __init__(self, feature: str, package: str, extra: str):
        super().__init__(f"{feature} needs {package}, which is not installed: "
                         f"pip install 'armctl[{extra}]'",
                         {"package": package, "extra": extra})
