"""Independent forward kinematics for the render tests: the arm YAML read with PyYAML, transforms
composed with plain numpy (no armctl code), following the URDF conventions."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml


def rot_x(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rot_z(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def rodrigues(axis: np.ndarray, angle: float) -> np.ndarray:
    k = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * kx + (1 - np.cos(angle)) * kx @ kx


def origin_matrix(origin: dict | None) -> np.ndarray:
    """URDF origin: translate, then rotate by Rz(yaw) Ry(pitch) Rx(roll)."""
    origin = origin or {}
    r, p, y = origin.get("rpy", [0.0, 0.0, 0.0])
    t = np.eye(4)
    t[:3, :3] = rot_z(y) @ rot_y(p) @ rot_x(r)
    t[:3, 3] = origin.get("xyz", [0.0, 0.0, 0.0])
    return t


class IndependentArm:
    """Link and frame poses of a YAML arm (single-DOF joints only), computed from scratch."""

    def __init__(self, path: Path):
        self.doc = yaml.safe_load(path.read_text())
        self.joints = {j["child"]: j for j in self.doc["joints"]}
        self.actuated = [j["name"] for j in self.doc["joints"] if j["type"] != "fixed"]
        self.links = {lk["name"]: lk for lk in self.doc.get("links", [])}

    def link_pose(self, link: str, q: np.ndarray) -> np.ndarray:
        if link == self.doc["base"]:
            return np.eye(4)
        j = self.joints[link]
        t = self.link_pose(j["parent"], q) @ origin_matrix(j.get("origin"))
        if j["type"] == "fixed":
            return t
        v = q[self.actuated.index(j["name"])]
        m = np.eye(4)
        axis = np.asarray(j["axis"], dtype=float)
        if j["type"] == "prismatic":
            m[:3, 3] = axis / np.linalg.norm(axis) * v
        else:
            m[:3, :3] = rodrigues(axis, v)
        return t @ m

    def frame_pose(self, name: str, q: np.ndarray) -> np.ndarray:
        for f in self.doc.get("frames", []):
            if f["name"] == name:
                return self.link_pose(f["parent"], q) @ origin_matrix(f.get("origin"))
        return self.link_pose(name, q)
