"""An independent forward kinematics for tests: a chain of 4x4 matrices per link.

Built straight from an arm file's joint origins and axes with scipy rotations, not from
armctl's kinematics, so that tests can check armctl against it. Joints: revolute, continuous,
prismatic, universal (about ``axes[0]``, then ``axes[1]`` in the moved frame), ball (the unit
quaternion ``w, x, y, z`` of the child's rotation from rest) and fixed.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation


def origin(o: dict | None) -> np.ndarray:
    """The 4x4 transform of an ``origin: {xyz, rpy}`` mapping (``None``: identity)."""
    o = o or {}
    t = np.eye(4)
    t[:3, 3] = o.get("xyz", [0, 0, 0])
    t[:3, :3] = Rotation.from_euler("xyz", o.get("rpy", [0, 0, 0])).as_matrix()
    return t


def motion(j: dict, value: Any) -> np.ndarray:
    """The 4x4 motion of joint ``j`` (its file mapping) at ``value``."""
    v = np.atleast_1d(np.asarray(value, dtype=float))
    m = np.eye(4)
    kind = j.get("type", "revolute")
    if kind == "ball":
        w, x, y, z = v
        m[:3, :3] = Rotation.from_quat([x, y, z, w]).as_matrix()
    elif kind == "universal":
        a1, a2 = (np.asarray(a, float) for a in j.get("axes", [[1, 0, 0], [0, 1, 0]]))
        m[:3, :3] = (Rotation.from_rotvec(a1 * v[0]) * Rotation.from_rotvec(a2 * v[1])).as_matrix()
    elif kind in ("revolute", "continuous"):
        m[:3, :3] = Rotation.from_rotvec(np.asarray(j.get("axis", [0, 0, 1]), float)
                                         * v[0]).as_matrix()
    elif kind == "prismatic":
        m[:3, 3] = np.asarray(j.get("axis", [0, 0, 1]), float) * v[0]
    else:
        assert kind == "fixed", j
    return m


def by_name(model: Any, q: np.ndarray) -> dict[str, Any]:
    """Joint name -> value of a joint vector (a ball joint's four quaternion numbers)."""
    out: dict[str, Any] = {}
    for name in model.joint_names:
        v = np.asarray(q, float)[model.q_index(name)]
        out[name] = float(v[0]) if len(v) == 1 else v
    return out


def chain_poses(doc: dict, q: dict[str, Any]) -> dict[str, np.ndarray]:
    """Pose of every link and named frame of an arm file, from the base outwards.

    Args:
        doc: The arm file as read by ``yaml.safe_load``.
        q: Joint name -> value (:func:`by_name`).
    """
    poses = {doc["base"]: np.eye(4)}
    pending = list(doc["joints"])
    while pending:
        j = pending.pop(0)
        if j["parent"] not in poses:
            pending.append(j)
            continue
        t = poses[j["parent"]] @ origin(j.get("origin"))
        if j.get("type") != "fixed":
            t = t @ motion(j, q[j["name"]])
        poses[j["child"]] = t
    for f in doc.get("frames", []):
        poses[f["name"]] = poses[f["parent"]] @ origin(f.get("origin"))
    return poses
