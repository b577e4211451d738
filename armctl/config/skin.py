"""The ``skin:`` section: one triangle mesh for the whole arm, each vertex bound to one link.

This is the humanoid of L. Kavan, *Metody skeletální animace* (2002): a single mesh modelled in
a bind pose, every vertex bound rigidly to one bone (here a link). A vertex ``v`` bound to link
``b`` is drawn at ``T_b(q) · T_b(q_bind)^-1 · v``, where ``T_b`` is the link's forward-kinematics
pose; the part ``T_b(q_bind)^-1 · v`` depends on the model alone and is computed once.

The mesh file is a NumPy ``.npz`` archive with four arrays (see ``docs/config.md``):

``vertices``
    ``(V, 3)`` floats, the vertex positions in the base frame in the bind pose [m].
``faces``
    ``(F, 3)`` integers, the vertex indices of each triangle, counter-clockwise seen from outside.
``bones``
    ``(B,)`` strings, the link names the vertices are bound to.
``vertex_bone``
    ``(V,)`` integers, for each vertex the index into ``bones`` of its link.
"""

from __future__ import annotations

import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import numpy.typing as npt

from armctl.config.source import Section
from armctl.errors import ConfigError, KeyPath
from armctl.typing import Array

__all__ = ["SKIN_ARRAYS", "SkinSpec", "parse_skin", "read_skin_file"]

#: The arrays a skin file holds.
SKIN_ARRAYS = ("vertices", "faces", "bones", "vertex_bone")


@dataclass(frozen=True)
class SkinSpec:
    """A skin mesh bound rigidly to the links, read and checked.

    Attributes:
        path: The mesh file (``.npz``).
        bind_pose: The named pose the mesh was modelled in; ``None``: the zero pose (every
            coordinate at its neutral value).
        vertices: ``(V, 3)`` vertex positions in the base frame, in the bind pose [m].
        faces: ``(F, 3)`` vertex indices of each triangle.
        vertex_link: ``(V,)`` the link each vertex is bound to, by name (or a named frame
            of a link: a link folded into its parent by a fixed joint is one).
        where: Where the section is in the arm file.
    """

    path: Path
    bind_pose: str | None
    vertices: Array = field(compare=False, repr=False)
    faces: npt.NDArray[np.int64] = field(compare=False, repr=False)
    vertex_link: tuple[str, ...] = field(compare=False, repr=False)
    where: KeyPath = field(default=KeyPath(), compare=False)


def read_skin_file(path: Path, links: list[str], where: KeyPath) -> tuple[
        Array, npt.NDArray[np.int64], tuple[str, ...]]:
    """Read and check a skin file.

    Args:
        path: The ``.npz`` file.
        links: The arm's link and frame names (every bone must be one of them).
        where: The ``skin.mesh`` key, for error messages.

    Returns:
        The vertices ``(V, 3)`` [m], the faces ``(F, 3)`` and each vertex's link name.

    Raises:
        ConfigError: If the file is missing or unreadable, misses an array, has arrays of the
            wrong shape (a binding whose length is not the number of vertices, faces that
            point past the last vertex) or names a bone that is not a link of the arm.
    """
    fix = "rebuild the file (tools/make_figure_mesh.py shows how) or fix the path"
    try:
        with np.load(path, allow_pickle=False) as data:
            missing = [k for k in SKIN_ARRAYS if k not in data.files]
            if missing:
                raise ConfigError(f"skin file {path.name!r} has no array {missing[0]!r} (a "
                                  f"skin file holds {', '.join(SKIN_ARRAYS)})", where, fix)
            arrays = {k: np.asarray(data[k]) for k in SKIN_ARRAYS}
    except ConfigError:
        raise
    except FileNotFoundError:
        raise ConfigError(f"skin file {str(path)!r} not found", where,
                          "give the path relative to the arm file") from None
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        raise ConfigError(f"cannot read the skin file {path.name!r}: {exc}", where, fix) from None
    vertices, faces = arrays["vertices"], arrays["faces"]
    bones, vertex_bone = arrays["bones"], arrays["vertex_bone"]
    if vertices.ndim != 2 or vertices.shape[1] != 3 or not np.issubdtype(vertices.dtype,
                                                                         np.floating):
        raise ConfigError(f"skin 'vertices' must be (V, 3) floats, found {vertices.shape} "
                          f"{vertices.dtype}", where, fix)
    if not np.all(np.isfinite(vertices)):
        raise ConfigError("skin 'vertices' has NaN or infinite values", where, fix)
    n = len(vertices)
    if faces.ndim != 2 or faces.shape[1] != 3 or not np.issubdtype(faces.dtype, np.integer):
        raise ConfigError(f"skin 'faces' must be (F, 3) integers, found {faces.shape} "
                          f"{faces.dtype}", where, fix)
    if len(faces) and (faces.min() < 0 or faces.max() >= n):
        raise ConfigError(f"skin 'faces' refers to vertex {int(faces.max())} (or a negative "
                          f"index) but the mesh has {n} vertices", where, fix)
    if vertex_bone.ndim != 1 or not np.issubdtype(vertex_bone.dtype, np.integer):
        raise ConfigError("skin 'vertex_bone' must be a list of integers, one per vertex",
                          where, fix)
    if len(vertex_bone) != n:
        raise ConfigError(f"skin 'vertex_bone' binds {len(vertex_bone)} vertices but the mesh "
                          f"has {n}: every vertex is bound to exactly one bone", where, fix)
    if bones.ndim != 1 or bones.dtype.kind != "U":
        raise ConfigError("skin 'bones' must be a list of link names", where, fix)
    if len(vertex_bone) and (vertex_bone.min() < 0 or vertex_bone.max() >= len(bones)):
        raise ConfigError(f"skin 'vertex_bone' refers to bone {int(vertex_bone.max())} (or a "
                          f"negative index) but 'bones' lists {len(bones)}", where, fix)
    for b in bones:
        if str(b) not in links:
            import difflib

            close = difflib.get_close_matches(str(b), links, n=1)
            raise ConfigError(
                f"skin bone {str(b)!r} is not a link of the arm", where,
                f"did you mean {close[0]!r}?" if close else
                f"bind vertices to links of the arm: {', '.join(links)}")
    names = tuple(str(bones[i]) for i in vertex_bone)
    return vertices.astype(float), faces.astype(np.int64), names


def parse_skin(sec: Section, file: Path | None, links: list[str], poses: list[str]) -> SkinSpec:
    """Read the ``skin:`` section and its mesh file.

    Args:
        sec: The section (a mapping with ``mesh`` and optional ``bind_pose``).
        file: The arm file (mesh paths are relative to its folder).
        links: The arm's link and frame names.
        poses: The arm's named poses.

    Returns:
        The checked skin.

    Raises:
        ConfigError: For an unknown key, a bad file, or an unknown bind pose.
    """
    sec.check_keys(["mesh"], ["bind_pose"])
    raw = Path(sec.string("mesh"))
    path = raw if raw.is_absolute() or file is None else file.parent / raw
    if path.suffix.lower() != ".npz":
        raise sec.error(f"skin mesh {raw.name!r} is not a .npz file", "mesh",
                        fix="write the mesh and its binding as a .npz archive "
                            "(see docs/config.md, skin)")
    bind: str | None = None
    if sec.has("bind_pose"):
        bind = sec.string("bind_pose")
        if bind not in poses:
            raise sec.error(f"bind pose {bind!r} is not a named pose", "bind_pose",
                            fix=f"name one of the poses: {', '.join(poses)}" if poses else
                            "add it under 'poses:', or remove 'bind_pose' for the zero pose")
    vertices, faces, names = read_skin_file(path, links, sec.where("mesh"))
    return SkinSpec(path, bind, vertices, faces, names, sec.where())
