"""Random kinematic trees written as URDF text, for cross-checks against other libraries."""

from __future__ import annotations

import numpy as np


def random_tree_urdf(rng: np.random.Generator, n_joints: int = 9, branch: float = 0.3) -> str:
    """A URDF of a random tree: revolute, continuous, prismatic and fixed joints, random origins
    and axes, some links with several children."""
    links = ["base"]
    lines = ['<robot name="random">', '  <link name="base"/>']
    kinds = ["revolute", "revolute", "continuous", "prismatic", "fixed"]
    for i in range(n_joints):
        parent = links[-1] if rng.random() > branch else links[int(rng.integers(len(links)))]
        child = f"l{i}"
        kind = kinds[int(rng.integers(len(kinds)))]
        xyz = " ".join(f"{v:.17g}" for v in rng.uniform(-0.3, 0.3, 3))
        rpy = " ".join(f"{v:.17g}" for v in rng.uniform(-np.pi, np.pi, 3))
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        ax = " ".join(f"{v:.17g}" for v in axis)
        lines.append(f'  <link name="{child}"/>')
        lines.append(f'  <joint name="j{i}" type="{kind}">')
        lines.append(f'    <parent link="{parent}"/><child link="{child}"/>')
        lines.append(f'    <origin xyz="{xyz}" rpy="{rpy}"/>')
        if kind != "fixed":
            lines.append(f'    <axis xyz="{ax}"/>')
        if kind in ("revolute", "prismatic"):
            lines.append('    <limit lower="-2" upper="2" velocity="1" effort="1"/>')
        lines.append("  </joint>")
        links.append(child)
    lines.append("</robot>")
    return "\n".join(lines)
