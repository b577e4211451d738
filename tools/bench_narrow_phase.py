"""Exact collision libraries side by side: coal and python-fcl, on the shapes armctl uses.

For each library it measures, from Python:

* the cost of one signed-distance query between two placed shapes, including turning the two
  ``(4, 4)`` NumPy poses into the library's transforms (box, cylinder, sphere, capsule, a convex
  mesh, a non-convex triangle mesh from trimesh's primitives, and the table half-space);
* the error of the signed distance against closed forms: a sphere against a box, cylinder,
  capsule or sphere (the signed distance of the sphere's centre to the other shape, less the
  radius, exact for a convex shape whether they are apart or overlapping) and the half-space
  against a box, cylinder, capsule or sphere (the height of the lowest point), on random poses;
* the installed size of the library with everything it pulls in (from the installed files).

Each library runs in its own subprocess, so a crash in one (python-fcl's half-space distance
ends the process) is reported instead of ending the run.

Usage: ``python tools/bench_narrow_phase.py [--queries N] [--poses N] [--write]``.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
import time
from importlib import metadata
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

BOX = (0.10, 0.06, 0.04)
CYL = (0.03, 0.12)  # radius, length
SPH = 0.04
CAP = (0.03, 0.10)  # radius, length between the hemisphere centres
SHAPES = ("box", "cylinder", "sphere", "capsule", "convex mesh", "mesh (torus)")


def _meshes() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    import trimesh

    ico = trimesh.creation.icosphere(subdivisions=2, radius=0.05)
    torus = trimesh.creation.torus(major_radius=0.06, minor_radius=0.02)
    return {"convex mesh": (np.asarray(ico.vertices), np.asarray(ico.faces)),
            "mesh (torus)": (np.asarray(torus.vertices), np.asarray(torus.faces))}


def _random_rotation(rng: np.random.Generator) -> np.ndarray:
    q = rng.normal(size=4)
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _poses(rng: np.random.Generator, n: int, spread: float) -> np.ndarray:
    out = np.tile(np.eye(4), (n, 1, 1))
    for i in range(n):
        out[i, :3, :3] = _random_rotation(rng)
        out[i, :3, 3] = rng.uniform(-spread, spread, 3)
    return out


CHOICE = """\
Choice: coal, the exact narrow phase of `armctl.collision.exact` (the `collision` extra). Per
query from Python it is two to four times faster on primitives and convex meshes (about even
between two triangle meshes); it agrees with every closed form above to 1e-6 m but one; and its
half-space (the table) works, where python-fcl's distance to a half-space ends the process and
its distances between separated shapes are off by up to centimetres. The one wrong coal answer
comes from its dedicated sphere-cylinder routine, with the sphere's centre inside the cylinder
near a cap: armctl hands spheres to coal as zero-length capsules, which its general routine
answers correctly (the rows "sphere as a zero-length capsule"). Its costs: the installed size
(Boost and Assimp come along; the `test` extra pulls coal in through Pinocchio anyway) and no
Windows wheels, where the exact check is unavailable and the capsule checks remain."""


# closed forms ------------------------------------------------------------------------------------

def _point_sd(kind: str, p: np.ndarray) -> float:
    """Signed distance of a point (in the shape's frame) to a primitive [m]."""
    if kind == "box":
        q = np.abs(p) - np.asarray(BOX) / 2
        return float(np.linalg.norm(np.maximum(q, 0)) + min(q.max(), 0.0))
    if kind == "cylinder":
        r, length = CYL
        dr, dz = math.hypot(p[0], p[1]) - r, abs(p[2]) - length / 2
        return math.hypot(max(dr, 0), max(dz, 0)) + min(max(dr, dz), 0.0)
    if kind == "capsule":
        r, length = CAP
        z = min(max(p[2], -length / 2), length / 2)
        return float(np.linalg.norm(p - np.array([0, 0, z]))) - r
    if kind == "sphere":
        return float(np.linalg.norm(p)) - SPH
    raise ValueError(kind)


def _lowest_z(kind: str, pose: np.ndarray) -> float:
    """Height of a primitive's lowest point [m]."""
    r = pose[:3, :3]
    cz = pose[2, 3]
    if kind == "box":
        return cz - float(np.abs(r[2]) @ (np.asarray(BOX) / 2))
    if kind == "cylinder":
        az = abs(r[2, 2])
        return cz - az * CYL[1] / 2 - CYL[0] * math.sqrt(max(0.0, 1 - az * az))
    if kind == "capsule":
        return cz - abs(r[2, 2]) * CAP[1] / 2 - CAP[0]
    if kind == "sphere":
        return cz - SPH
    raise ValueError(kind)


# one library, in its own process -----------------------------------------------------------------

def _coal_backend():  # type: ignore[no-untyped-def]
    import coal

    def build(kind: str, meshes: dict) -> object:
        if kind == "box":
            return coal.Box(*BOX)
        if kind == "cylinder":
            return coal.Cylinder(*CYL)
        if kind == "sphere":
            return coal.Sphere(SPH)
        if kind == "point capsule":
            return coal.Capsule(SPH, 0.0)
        if kind == "capsule":
            return coal.Capsule(*CAP)
        if kind == "halfspace":
            return coal.Halfspace(np.array([0.0, 0.0, 1.0]), 0.0)
        v, f = meshes[kind]
        m = coal.BVHModelOBBRSS()
        m.beginModel(len(f), len(v))
        m.addVertices(v)
        m.addTriangles(f)
        m.endModel()
        if kind == "convex mesh":
            m.buildConvexHull(False, "Qt")
            return m.convex
        return m

    req = coal.DistanceRequest()
    req.enable_signed_distance = True
    res = coal.DistanceResult()

    def query(a: object, ta: np.ndarray, b: object, tb: np.ndarray) -> float:
        res.clear()
        return float(coal.distance(a, coal.Transform3s(ta[:3, :3], ta[:3, 3]),
                                   b, coal.Transform3s(tb[:3, :3], tb[:3, 3]), req, res))

    return build, query


def _fcl_backend():  # type: ignore[no-untyped-def]
    import fcl

    def build(kind: str, meshes: dict) -> object:
        if kind == "box":
            g = fcl.Box(*BOX)
        elif kind == "cylinder":
            g = fcl.Cylinder(*CYL)
        elif kind == "sphere":
            g = fcl.Sphere(SPH)
        elif kind == "point capsule":
            g = fcl.Capsule(SPH, 0.0)
        elif kind == "capsule":
            g = fcl.Capsule(*CAP)
        elif kind == "halfspace":
            g = fcl.Halfspace(np.array([0.0, 0.0, 1.0]), 0.0)
        elif kind == "convex mesh":
            import trimesh

            v, f = meshes[kind]
            hull = trimesh.Trimesh(v, f).convex_hull
            faces = np.hstack([np.full((len(hull.faces), 1), 3), hull.faces]).ravel()
            g = fcl.Convex(np.asarray(hull.vertices), len(hull.faces), faces)
        else:
            v, f = meshes[kind]
            g = fcl.BVHModel()
            g.beginModel(len(v), len(f))
            g.addSubModel(v, f)
            g.endModel()
        return fcl.CollisionObject(g, fcl.Transform())

    req = fcl.DistanceRequest(enable_signed_distance=True)

    def query(a: object, ta: np.ndarray, b: object, tb: np.ndarray) -> float:
        a.setTransform(fcl.Transform(ta[:3, :3], ta[:3, 3]))  # type: ignore[attr-defined]
        b.setTransform(fcl.Transform(tb[:3, :3], tb[:3, 3]))  # type: ignore[attr-defined]
        return float(fcl.distance(a, b, req, fcl.DistanceResult()))

    return build, query


def _run_library(lib: str, queries: int, poses: int, part: str) -> dict:
    build, query = _coal_backend() if lib == "coal" else _fcl_backend()
    meshes = _meshes()
    rng = np.random.default_rng(7)
    out: dict = {}
    if part == "sphere":
        for ball in ("sphere", "point capsule"):
            sph = build(ball, meshes)
            for kind in ("box", "cylinder", "capsule", "sphere"):
                other = build(kind, meshes)
                errs, pen_errs = [], []
                ps, po = _poses(rng, poses, 0.08), _poses(rng, poses, 0.08)
                for i in range(poses):
                    local = np.linalg.solve(po[i], ps[i][:, 3])[:3]
                    truth = _point_sd(kind, local) - SPH
                    got = query(sph, ps[i], other, po[i])
                    (pen_errs if truth < 0 else errs).append(abs(got - truth))
                label = "sphere" if ball == "sphere" else "sphere as a zero-length capsule"
                out[f"{label} / {kind}"] = [max(errs, default=0.0), max(pen_errs, default=0.0),
                                            len(pen_errs)]
    elif part == "halfspace":
        hs = build("halfspace", meshes)
        for kind in ("box", "cylinder", "capsule", "sphere"):
            other = build(kind, meshes)
            errs, pen_errs = [], []
            po = _poses(rng, poses, 0.08)
            for i in range(poses):
                truth = _lowest_z(kind, po[i])
                got = query(hs, np.eye(4), other, po[i])
                (pen_errs if truth < 0 else errs).append(abs(got - truth))
            out[f"half-space / {kind}"] = [max(errs, default=0.0), max(pen_errs, default=0.0),
                                           len(pen_errs)]
    return out


def _time_both(queries: int, blocks: int = 20) -> dict:
    """Per-query time of both libraries, interleaved block by block in one process.

    Each pair's queries are split into ``blocks``; the libraries take turns block by block and
    each keeps its fastest block, so load from other processes on the machine falls on both
    alike and mostly drops out.
    """
    backends = {"coal": _coal_backend(), "python-fcl": _fcl_backend()}
    meshes = _meshes()
    rng = np.random.default_rng(7)
    objs = {lib: {k: (build(k, meshes), build(k, meshes)) for k in SHAPES}
            for lib, (build, _) in backends.items()}
    ta, tb = _poses(rng, queries, 0.12), _poses(rng, queries, 0.12)
    size = max(1, queries // blocks)
    out: dict = {lib: {} for lib in backends}
    for ia, ka in enumerate(SHAPES):
        for kb in SHAPES[ia:]:
            best = dict.fromkeys(backends, math.inf)
            for start in range(0, size * blocks, size):
                for lib, (_, query) in backends.items():
                    a, b = objs[lib][ka][0], objs[lib][kb][1]
                    t0 = time.perf_counter()
                    for i in range(start, start + size):
                        query(a, ta[i], b, tb[i])
                    best[lib] = min(best[lib], (time.perf_counter() - t0) / size)
            for lib in backends:
                out[lib][f"{ka} / {kb}"] = best[lib]
    for lib, (build, _) in backends.items():
        t0 = time.perf_counter()
        for k in SHAPES:
            build(k, meshes)
        out[lib]["build all six shapes"] = time.perf_counter() - t0
    return out


def _in_subprocess(lib: str, queries: int, poses: int, part: str) -> dict | str:
    cmd = [sys.executable, __file__, "--child", lib, part, "--queries", str(queries),
           "--poses", str(poses)]
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if "ModuleNotFoundError" in done.stderr:
        return "not installed (pip install 'armctl[bench,collision]')"
    if done.returncode != 0:
        sig = -done.returncode if done.returncode < 0 else None
        return f"crashed ({'signal ' + str(sig) if sig else 'exit ' + str(done.returncode)})"
    return json.loads(done.stdout.strip().splitlines()[-1])


# installed size ----------------------------------------------------------------------------------

def _closure(dist: str) -> set[str]:
    from packaging.requirements import Requirement

    seen: set[str] = set()
    todo = [dist]
    while todo:
        name = todo.pop().lower().replace("_", "-")
        if name in seen:
            continue
        try:
            reqs = metadata.requires(name) or []
        except metadata.PackageNotFoundError:
            continue
        seen.add(name)
        for r in reqs:
            req = Requirement(r)
            if req.marker is None or req.marker.evaluate({"extra": ""}):
                todo.append(req.name)
    return seen


def _size_mb(names: set[str]) -> float:
    total = 0
    for n in names:
        for f in metadata.distribution(n).files or []:
            p = Path(str(f.locate()))
            if p.is_file():
                total += p.stat().st_size
    return total / 1e6


# wheels ------------------------------------------------------------------------------------------

PLATFORMS = ("manylinux_2_28_x86_64", "manylinux_2_28_aarch64", "macosx_14_0_arm64", "win_amd64")
PYTHONS = ("3.10", "3.11", "3.12", "3.13")


def _has_wheel(dist: str, python: str, platform: str) -> str:
    """Whether pip finds a wheel of ``dist`` for a Python version and platform (asks PyPI)."""
    with tempfile.TemporaryDirectory() as target:
        done = subprocess.run(
            [sys.executable, "-m", "pip", "install", "--dry-run", "--no-deps", "--only-binary",
             ":all:", "--python-version", python, "--platform", platform, "--target", target,
             "--quiet", "--report", "-", dist],
            capture_output=True, text=True, check=False)
    if done.returncode == 0:
        try:
            report = json.loads(done.stdout)
            return "yes" if report.get("install") else "no"
        except json.JSONDecodeError:
            return "?"
    return "no" if "No matching distribution" in done.stderr else "?"


# report ------------------------------------------------------------------------------------------

def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--queries", type=int, default=2000, help="queries per shape pair")
    parser.add_argument("--poses", type=int, default=2000, help="random poses per accuracy check")
    parser.add_argument("--write", action="store_true", help="write docs/benchmarks.md")
    parser.add_argument("--child", nargs=2, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        result = (_time_both(args.queries) if args.child[1] == "time" else
                  _run_library(args.child[0], args.queries, args.poses, args.child[1]))
        print(json.dumps(result))
        return

    libs = {"coal": "coal", "python-fcl": "fcl"}
    results = {name: {part: _in_subprocess(mod, args.queries, args.poses, part)
                      for part in ("sphere", "halfspace")}
               for name, mod in libs.items()}
    timed = _in_subprocess("both", args.queries, args.poses, "time")
    for name in libs:
        results[name]["time"] = timed if isinstance(timed, str) else timed[name]
    versions = {}
    for name in libs:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "(not installed)"
    deps = {name: sorted(_closure(name) - {"numpy"}) for name in libs}
    sizes = {name: _size_mb(set(deps[name])) for name in libs}

    lines = ["## Exact narrow phase: coal vs python-fcl (`tools/bench_narrow_phase.py`)", "",
             "One signed-distance query from Python, poses given as NumPy `(4, 4)` arrays "
             "(building the two transforms included), in microseconds per query: the two "
             "libraries interleaved in one process, each the fastest of 20 blocks of "
             f"{args.queries // 20} random poses per pair. The convex mesh is an icosphere (162 "
             "vertices) as a convex polytope; the torus (non-convex) is a "
             "triangle mesh with a bounding-volume tree.", ""]
    names = list(libs)
    lines.append("| pair | " + " | ".join(f"{n} {versions[n]} [us]" for n in names) + " |")
    lines.append("|---|" + "---:|" * len(names))
    timing = {n: results[n]["time"] for n in names}
    keys = next((list(t) for t in timing.values() if isinstance(t, dict)), [])
    for k in keys:
        cells = []
        for n in names:
            t = timing[n]
            cells.append(t if isinstance(t, str) else
                         (f"{t[k] * 1e3:.1f} ms" if k.startswith("build") else f"{t[k] * 1e6:.1f}"))
        lines.append(f"| {k} | " + " | ".join(cells) + " |")
    lines += ["", f"Signed distance against closed forms, {args.poses} random poses per pair: "
              "largest error when apart / when overlapping [m] (overlapping poses).", ""]
    lines.append("| pair | " + " | ".join(names) + " |")
    lines.append("|---|" + "---|" * len(names))
    for part in ("sphere", "halfspace"):
        rows = next((list(results[n][part]) for n in names
                     if isinstance(results[n][part], dict)), [])
        for k in rows:
            cells = []
            for n in names:
                r = results[n][part]
                cells.append(r if isinstance(r, str)
                             else f"{r[k][0]:.1e} / {r[k][1]:.1e} ({r[k][2]})")
            lines.append(f"| {k} | " + " | ".join(cells) + " |")
    lines += ["", "Installed size with everything it pulls in (NumPy aside):", ""]
    for n in names:
        lines.append(f"* {n}: {sizes[n]:.0f} MB ({', '.join(deps[n])})")
    lines += ["", "Wheels on PyPI per Python version (asked with `pip install --dry-run "
              "--only-binary :all: --python-version V --platform P`):", "",
              "| library | " + " | ".join(PLATFORMS) + " |", "|---|" + "---|" * len(PLATFORMS)]
    for n in names:
        for py in PYTHONS:
            cells = [_has_wheel(n, py, plat) for plat in PLATFORMS]
            lines.append(f"| {n}, Python {py} | " + " | ".join(cells) + " |")
    lines += ["", CHOICE]
    md = "\n".join(lines)
    print(md)
    if args.write:
        from _benchdoc import write_section

        cmd = "python tools/bench_narrow_phase.py --write"
        if args.queries != 2000 or args.poses != 2000:
            cmd += f" --queries {args.queries} --poses {args.poses}"
        print(write_section("narrow-phase", md, cmd))


if __name__ == "__main__":
    main()
