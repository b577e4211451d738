"""Build the skin of the bundled human figure: one triangle mesh, each vertex bound to one bone.

The mesh is made in the figure's bind pose (the T-pose, every joint at zero) from one
ellipsoid per bone, placed from the joint origins of ``armctl/configs/figure.yaml`` (each
ellipsoid spans its bone from joint to joint, with some overlap so that the body stays closed
when a joint bends). Every vertex of a bone's ellipsoid is bound to that bone: the rigid binding
of L. Kavan, *Metody skeletální animace* (2002). The result is written, compressed, to
``armctl/configs/figure_skin.npz`` (the format is described in docs/config.md, ``skin:``).

Usage::

    python tools/make_figure_mesh.py            # rewrite armctl/configs/figure_skin.npz
    python tools/make_figure_mesh.py -o FILE    # write elsewhere

The output is deterministic: the same figure.yaml gives the same file.
"""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parent.parent
CONFIG = ROOT / "armctl" / "configs" / "figure.yaml"
OUT = ROOT / "armctl" / "configs" / "figure_skin.npz"


def joint_positions(config: Path) -> dict[str, np.ndarray]:
    """World position [m] of every link's origin in the bind pose (all joint origins are
    translations only, so the positions add up along the path from the base)."""
    doc = yaml.safe_load(config.read_text(encoding="utf-8"))
    pos = {doc["base"]: np.zeros(3)}
    pending = list(doc["joints"])
    while pending:
        rest = []
        for j in pending:
            if j["parent"] not in pos:
                rest.append(j)
                continue
            origin = j.get("origin", {})
            if any(float(a) != 0.0 for a in origin.get("rpy", [0, 0, 0])):
                raise SystemExit(f"joint {j['name']}: the mesh builder expects no rpy in origins")
            pos[j["child"]] = pos[j["parent"]] + np.array(origin.get("xyz", [0, 0, 0]), float)
        if len(rest) == len(pending):
            raise SystemExit("the joints do not form a tree from the base")
        pending = rest
    return pos


def ellipsoid(centre: np.ndarray, radii: tuple[float, float, float], axis: np.ndarray,
              n_lat: int, n_lon: int) -> tuple[np.ndarray, np.ndarray]:
    """A closed ellipsoid mesh: ``radii[2]`` along ``axis`` (unit), the others across it.

    Returns:
        Vertices ``(n, 3)`` and counter-clockwise (seen from outside) faces ``(m, 3)``.
    """
    axis = axis / np.linalg.norm(axis)
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
    u = np.cross(axis, helper)
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    theta = np.linspace(0.0, math.pi, n_lat + 1)[1:-1]
    phi = np.linspace(0.0, 2.0 * math.pi, n_lon, endpoint=False)
    tt, pp = np.meshgrid(theta, phi, indexing="ij")
    local = np.stack([np.sin(tt) * np.cos(pp), np.sin(tt) * np.sin(pp), np.cos(tt)], -1)
    local = local.reshape(-1, 3)
    local = np.vstack([[0.0, 0.0, 1.0], local, [0.0, 0.0, -1.0]]) * np.array(radii)
    basis = np.stack([u, v, axis], 1)
    verts = local @ basis.T + centre
    faces = []
    rings = n_lat - 1
    top, bottom = 0, 1 + rings * n_lon

    def idx(r: int, k: int) -> int:
        return 1 + r * n_lon + k % n_lon

    for k in range(n_lon):
        faces.append((top, idx(0, k), idx(0, k + 1)))
        for r in range(rings - 1):
            faces.append((idx(r, k), idx(r + 1, k), idx(r + 1, k + 1)))
            faces.append((idx(r, k), idx(r + 1, k + 1), idx(r, k + 1)))
        faces.append((idx(rings - 1, k), bottom, idx(rings - 1, k + 1)))
    return verts, np.array(faces, dtype=np.int64)


def limb(a: np.ndarray, b: np.ndarray, r_across: tuple[float, float], overlap: float
         ) -> tuple[np.ndarray, tuple[float, float, float], np.ndarray]:
    """An ellipsoid from joint ``a`` to joint ``b``, reaching ``overlap`` [m] past each end."""
    d = b - a
    length = float(np.linalg.norm(d))
    return (a + b) / 2.0, (r_across[0], r_across[1], length / 2.0 + overlap), d / length


def build(config: Path) -> dict[str, np.ndarray]:
    """The skin arrays (see docs/config.md): vertices, faces, bones, vertex_bone."""
    p = joint_positions(config)
    x, y, z = np.eye(3)
    parts: list[tuple[str, tuple[np.ndarray, tuple[float, float, float], np.ndarray], int, int]]
    parts = [
        ("pelvis", (p["pelvis"] + [0, 0, 0.03], (0.17, 0.11, 0.10), z), 14, 24),
        ("abdomen", (p["abdomen"] + [0, 0, 0.09], (0.15, 0.10, 0.12), z), 12, 24),
        ("chest", (p["chest"] + [0, 0, 0.15], (0.19, 0.115, 0.18), z), 16, 28),
        ("neck", limb(p["neck"] - [0, 0, 0.02], p["head"], (0.055, 0.055), 0.02), 8, 16),
        ("head", (p["head"] + [0.01, 0, 0.045], (0.075, 0.09, 0.105), z), 14, 22),
    ]
    for side, s in (("left", 1.0), ("right", -1.0)):
        hand_end = p[f"{side}_hand"] + [0, s * 0.19, 0]
        toe_end = p[f"{side}_toe"] + [0.07, 0, 0]
        sole = p[f"{side}_foot"][2] - 0.068
        parts += [
            (f"{side}_upper_arm", limb(p[f"{side}_upper_arm"], p[f"{side}_forearm"],
                                       (0.052, 0.048), 0.03), 10, 16),
            (f"{side}_forearm", limb(p[f"{side}_forearm"], p[f"{side}_hand"],
                                     (0.042, 0.036), 0.025), 10, 16),
            (f"{side}_hand", (0.5 * (p[f"{side}_hand"] + hand_end), (0.05, 0.022, 0.10),
                              y), 8, 14),
            (f"{side}_thigh", limb(p[f"{side}_thigh"], p[f"{side}_shin"],
                                   (0.08, 0.075), 0.04), 12, 18),
            (f"{side}_shin", limb(p[f"{side}_shin"], p[f"{side}_foot"],
                                  (0.055, 0.05), 0.03), 12, 16),
            (f"{side}_foot", (np.array([p[f"{side}_foot"][0] + 0.05, p[f"{side}_foot"][1],
                                        sole + 0.045]), (0.045, 0.045, 0.11), x), 8, 14),
            (f"{side}_toe", (0.5 * (p[f"{side}_toe"] + toe_end) + [0, 0, -0.005],
                             (0.045, 0.02, 0.05), x), 6, 12),
        ]
    bones = [name for name, *_ in parts]
    verts, faces, vertex_bone = [], [], []
    offset = 0
    for b, (_name, (centre, radii, axis), n_lat, n_lon) in enumerate(parts):
        v, f = ellipsoid(np.asarray(centre, float), radii, np.asarray(axis, float), n_lat, n_lon)
        verts.append(v)
        faces.append(f + offset)
        vertex_bone.append(np.full(len(v), b, dtype=np.int32))
        offset += len(v)
    return {
        "vertices": np.vstack(verts).astype(np.float32),
        "faces": np.vstack(faces).astype(np.int32),
        "bones": np.array(bones),
        "vertex_bone": np.concatenate(vertex_bone).astype(np.int16),
    }


def main() -> None:
    """Write the skin file."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("-o", "--out", type=Path, default=OUT, help="output .npz file")
    parser.add_argument("--config", type=Path, default=CONFIG, help="the figure's arm file")
    args = parser.parse_args()
    arrays = build(args.config)
    import io

    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)  # type: ignore[arg-type]
    tmp = args.out.with_name(f".{args.out.name}.tmp")
    tmp.write_bytes(buf.getvalue())
    os.replace(tmp, args.out)
    print(f"{args.out}: {len(arrays['vertices'])} vertices, {len(arrays['faces'])} triangles, "
          f"{len(arrays['bones'])} bones, {len(buf.getvalue())} bytes")


if __name__ == "__main__":
    main()
