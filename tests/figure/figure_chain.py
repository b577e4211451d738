"""An independent forward kinematics for the figure tests: a chain of 4x4 matrices per link.

Built straight from an arm file's joint origins and axes with scipy rotations, not from
armctl's kinematics, so the tests can check armctl against it.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation


def _origin(o: dict) -> np.ndarray:
    t = np.eye(4)
    t[:3, 3] = o.get("xyz", [0, 0, 0])
    t[:3, :3] = Rotation.from_euler("xyz", o.get("rpy", [0, 0, 0])).as_matrix()
    return t


def chain_poses(doc: dict, q: dict[str, float]) -> dict[str, np.ndarray]:
    """Pose of every link and named frame of an arm file, from the base outwards.

    Args:
        doc: The arm file as read by ``yaml.safe_load``.
        q: Joint name -> value [rad]; a three-axis ``spherical`` joint ``NAME`` reads
            ``NAME_1`` .. ``NAME_3``.
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
        elif j["type"] == "spherical":  # three axes meeting in one point, NAME_1..3
            for i, axis in enumerate(j["axes"], start=1):
                motion[:3, :3] = motion[:3, :3] @ Rotation.from_rotvec(
                    np.asarray(axis, float) * q[f"{j['name']}_{i}"]).as_matrix()
        poses[j["child"]] = poses[j["parent"]] @ _origin(j.get("origin", {})) @ motion
    for f in doc.get("frames", []):
        poses[f["name"]] = poses[f["parent"]] @ _origin(f.get("origin", {}))
    return poses
