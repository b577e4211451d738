"""An independent forward kinematics for the figure tests: a chain of 4x4 matrices per link.

Built straight from an arm file's joint origins and axes with scipy rotations, not from
armctl's kinematics, so the tests can check armctl against it.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation


def _origin(o: dict) -> np.ndarray:
    t = np.eye(4)
    t[:3, 3] = o.get("xyz", [0, 0, 0])
    t[:3, :3] = Rotation.from_euler("xyz", o.get("rpy", [0, 0, 0])).as_matrix()
    return t


def by_name(model: Any, q: np.ndarray) -> dict[str, Any]:
    """Joint name -> value of a joint vector (a ball joint's four quaternion numbers)."""
    out: dict[str, Any] = {}
    for j in model.spec.actuated_joints:
        v = np.asarray(q, float)[model.q_index(j.name)]
        out[j.name] = float(v[0]) if len(v) == 1 else v
    return out


def chain_poses(doc: dict, q: dict[str, Any]) -> dict[str, np.ndarray]:
    """Pose of every link and named frame of an arm file, from the base outwards.

    Args:
        doc: The arm file as read by ``yaml.safe_load``.
        q: Joint name -> value: an angle [rad] for a revolute joint, the unit quaternion
            ``(w, x, y, z)`` for a ``ball`` joint (its rotation of the child from rest).
    """
    poses = {doc["base"]: np.eye(4)}
    pending = list(doc["joints"])
    while pending:
        j = pending.pop(0)
        if j["parent"] not in poses:
            pending.append(j)
            continue
        motion = np.eye(4)
        if j["type"] == "revolute":
            motion[:3, :3] = Rotation.from_rotvec(
                np.asarray(j["axis"], float) * q[j["name"]]).as_matrix()
        elif j["type"] == "ball":
            w, x, y, z = np.asarray(q[j["name"]], float)
            motion[:3, :3] = Rotation.from_quat([x, y, z, w]).as_matrix()
        else:
            assert j["type"] == "fixed", j
        poses[j["child"]] = poses[j["parent"]] @ _origin(j.get("origin", {})) @ motion
    for f in doc.get("frames", []):
        poses[f["name"]] = poses[f["parent"]] @ _origin(f.get("origin", {}))
    return poses
