"""Benchmark: collision checks of one configuration, armctl's compiled kernels against coal.

For the UR5e, SO-101 and Panda, each with a scene of 10 obstacles (boxes, spheres and
cylinders around the workspace, three of them close to the base) on top of the table, it
measures on random configurations inside the joint limits:

* ``CollisionModel.free(q)`` called from Python, one configuration per call (median, p90);
* ``CollisionModel.free_batch(qs)`` on one core (numba runs single-threaded), configurations
  per second of CPU time and of wall time;
* the same check done with coal (the exact collision library) on the same shapes: a
  ``coal.Capsule`` per link capsule, the obstacles as the model checks them (boxes, spheres,
  cylinders as the capsule around them) and the table as a half-space, the same pairs (from
  ``CollisionModel.pair_names``), the same paddings, ``ComputeCollision`` per pair with the
  padding as security margin and stopping at the first pair in contact, the capsules'
  poses given (computed before the clock starts);

and checks that both agree on free/colliding for every configuration compared, and that the
distances agree per checked link pair (``ComputeDistance``).

Usage: ``python tools/bench_collision.py [--configs N] [--batch N] [--peer N] [--no-write]``.
Writes the "collision" section of docs/benchmarks.md.
"""

from __future__ import annotations

import os

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import argparse
import math
import sys
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _benchdoc import write_section

import armctl
from armctl.collision.contact import ContactKind
from armctl.collision.model import CollisionModel
from armctl.config.scene import TABLE, Obstacle, SceneSpec
from armctl.config.schema import Box, Cylinder, Origin, Sphere
from armctl.kinematics.capsules import collision_capsules

ARMS = ("ur5e", "so101", "panda")


def make_scene(arm: Any, rng: np.random.Generator) -> SceneSpec:
    """Ten obstacles around the arm (sizes and places relative to its reach), on a table."""
    reach = arm.reach(arm.tool)
    obstacles = []
    for i in range(10):
        near = i < 3
        rad = reach * (rng.uniform(0.2, 0.4) if near else rng.uniform(0.45, 0.85))
        ang = rng.uniform(-math.pi, math.pi)
        z = reach * rng.uniform(0.05, 0.6)
        r, p, y = (float(v) for v in rng.uniform(-math.pi, math.pi, 3))
        rpy = (r, p, y)
        origin = Origin(xyz=(rad * math.cos(ang), rad * math.sin(ang), z), rpy=rpy)
        kind = i % 3
        shape: Box | Sphere | Cylinder
        if kind == 0:
            size = tuple(float(v) for v in reach * rng.uniform(0.05, 0.15, 3))
            shape = Box(size=size, origin=origin)  # type: ignore[arg-type]
        elif kind == 1:
            shape = Sphere(radius=float(reach * rng.uniform(0.03, 0.08)), origin=origin)
        else:
            shape = Cylinder(radius=float(reach * rng.uniform(0.02, 0.05)),
                             length=float(reach * rng.uniform(0.1, 0.3)), origin=origin)
        obstacles.append(Obstacle(name=f"obstacle{i}", shape=shape))
    return SceneSpec(obstacles=tuple(obstacles))


def _frame_along(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A rotation whose z axis points from ``a`` to ``b``, and the midpoint."""
    d = b - a
    n = float(np.linalg.norm(d))
    if n < 1e-15:
        return np.eye(3), (a + b) / 2.0
    z = d / n
    x = np.cross(z, [1.0, 0.0, 0.0] if abs(z[0]) < 0.9 else [0.0, 1.0, 0.0])
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z]), (a + b) / 2.0


class CoalPeer:
    """The same check with coal: the model's link capsules, obstacles, pairs and paddings."""

    def __init__(self, arm: Any, cm: CollisionModel, scene: SceneSpec) -> None:
        import coal

        self.coal = coal
        self.arm = arm
        self.caps: list[tuple[str, np.ndarray, np.ndarray, float]] = []
        by_link: dict[str, list[int]] = defaultdict(list)
        for link, caps in collision_capsules(arm.spec).items():
            for c in caps:
                by_link[link].append(len(self.caps))
                self.caps.append((link, np.asarray(c.a, float), np.asarray(c.b, float), c.radius))
        self.geoms = [coal.Capsule(r, float(np.linalg.norm(b - a))) for _, a, b, r in self.caps]
        obs: dict[str, tuple[Any, Any]] = {}
        if scene.table is not None:
            obs[TABLE] = (coal.Halfspace(np.array([0.0, 0.0, 1.0]), scene.table.height),
                          coal.Transform3s())
        for ob in scene.obstacles:
            m = ob.shape.origin.matrix()
            sh = ob.shape
            if isinstance(sh, Box):
                g = coal.Box(*sh.size)
            elif isinstance(sh, Sphere):
                g = coal.Sphere(sh.radius)
            else:  # the model checks a cylinder as the capsule around it
                assert isinstance(sh, Cylinder)
                g = coal.Capsule(sh.radius, sh.length)
            obs[ob.name] = (g, coal.Transform3s(m[:3, :3].copy(), m[:3, 3].copy()))
        # the pairs the model checks, by name; every capsule of each link
        self.pairs: list[tuple[int, Any, Any, float, tuple[str, str]]] = []
        seen = set()
        for idx in range(cm.pair_count):
            a, b, kind = cm.pair_names(idx)
            if (a, b) in seen:
                continue
            seen.add((a, b))
            pad = scene.padding if kind is ContactKind.SCENE else 0.0
            for i in by_link[a]:
                if kind is ContactKind.SELF:
                    for j in by_link[b]:
                        self.pairs.append((i, j, None, pad, (a, b)))
                else:
                    self.pairs.append((i, -1, obs[b], pad, (a, b)))
        if len(self.pairs) != cm.pair_count:
            raise RuntimeError(f"peer has {len(self.pairs)} pairs, the model {cm.pair_count}")
        self.collide = []
        self.dist = []
        self.requests = []
        for i, j, ob, pad, _ in self.pairs:
            g2 = self.geoms[j] if j >= 0 else ob[0]
            self.collide.append(coal.ComputeCollision(self.geoms[i], g2))
            self.dist.append(coal.ComputeDistance(self.geoms[i], g2))
            req = coal.CollisionRequest()
            req.security_margin = pad
            self.requests.append(req)
        self.cres = coal.CollisionResult()
        self.dreq = coal.DistanceRequest()
        self.dreq.gjk_tolerance = 1e-12
        self.dres = coal.DistanceResult()

    def segments(self, q: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        """The world rotations and centres of the capsules at ``q`` (armctl's FK)."""
        poses = self.arm.fk_all(q)
        out = []
        for link, a, b, _ in self.caps:
            t = poses[link]
            out.append(_frame_along(t[:3, :3] @ a + t[:3, 3], t[:3, :3] @ b + t[:3, 3]))
        return out

    def free(self, segs: list[tuple[np.ndarray, np.ndarray]]) -> bool:
        """Whether no pair is closer than its padding (capsule poses given)."""
        tfs = [self.coal.Transform3s(r, c) for r, c in segs]
        res = self.cres
        for (i, j, ob, _, _), cc, req in zip(self.pairs, self.collide, self.requests,
                                             strict=True):
            res.clear()
            if cc(tfs[i], tfs[j] if j >= 0 else ob[1], req, res):
                return False
        return True

    def link_slacks(self, segs: list[tuple[np.ndarray, np.ndarray]]) -> dict[tuple[str, str],
                                                                             float]:
        """Per checked link pair (or link and obstacle) the least distance minus padding."""
        tfs = [self.coal.Transform3s(r, c) for r, c in segs]
        out: dict[tuple[str, str], float] = {}
        for (i, j, ob, pad, key), cd in zip(self.pairs, self.dist, strict=True):
            self.dres.clear()
            d = cd(tfs[i], tfs[j] if j >= 0 else ob[1], self.dreq, self.dres) - pad
            out[key] = min(out.get(key, math.inf), d)
        return out


def model_link_slacks(cm: CollisionModel, slacks: np.ndarray) -> dict[tuple[str, str], float]:
    """Per checked link pair the least slack, from the model's per-pair slacks."""
    out: dict[tuple[str, str], float] = {}
    for idx in range(cm.pair_count):
        a, b, _ = cm.pair_names(idx)
        out[(a, b)] = min(out.get((a, b), math.inf), float(slacks[idx]))
    return out


def bench_arm(name: str, configs: int, batch: int, peer_n: int) -> dict[str, Any]:
    arm = armctl.load_arm(name)
    rng = np.random.default_rng(13)
    scene = make_scene(arm, rng)
    cm = CollisionModel.of(arm, scene=scene)
    qs = arm.sample(rng, max(configs, peer_n))
    cm.free(qs[0])
    cm.free_batch(qs[:8])
    out: dict[str, Any] = {"dof": arm.dof, "pairs": cm.pair_count}
    # single calls
    ts = np.empty(configs)
    clock = time.perf_counter
    for k in range(configs):
        q = qs[k]
        t = clock()
        cm.free(q)
        ts[k] = clock() - t
    out["single"] = (float(np.median(ts)) * 1e6, float(np.percentile(ts, 90)) * 1e6)
    # batch, one core
    big = arm.sample(rng, batch)
    wall, cpu = math.inf, math.inf
    for _ in range(3):
        t0, c0 = time.perf_counter(), time.thread_time()
        free = cm.free_batch(big)
        wall = min(wall, time.perf_counter() - t0)
        cpu = min(cpu, time.thread_time() - c0)
    # continuous check of straight joint-space lines from free configurations
    starts = big[free][:301]
    lines = np.empty(300)
    hits = 0
    for k in range(300):
        q0 = starts[k]
        q1 = q0 + 0.3 * (starts[k + 1] - q0)
        t = clock()
        hits += cm.first_contact_on_segment(q0, q1) is not None
        lines[k] = clock() - t
    out["segment"] = (float(np.median(lines)) * 1e6, float(np.percentile(lines, 90)) * 1e6,
                      hits / 300)
    out["batch_cpu"] = batch / cpu
    out["batch_wall"] = batch / wall
    out["free_fraction"] = float(free.mean())
    # the peer, on the first peer_n configurations
    peer = CoalPeer(arm, cm, scene)
    pq = qs[:peer_n]
    segs = [peer.segments(q) for q in pq]
    ours = cm.free_batch(pq)
    theirs = np.empty(peer_n, dtype=bool)
    pt = np.empty(peer_n)
    for k in range(peer_n):
        t = clock()
        theirs[k] = peer.free(segs[k])
        pt[k] = clock() - t
    out["peer_single"] = (float(np.median(pt)) * 1e6, float(np.percentile(pt, 90)) * 1e6)
    out["peer_rate"] = peer_n / float(pt.sum())
    out["agree"] = int((ours == theirs).sum())
    out["peer_n"] = peer_n
    # distances per link pair
    slacks = cm.slacks_batch(pq)
    boxes = {ob.name for ob in scene.obstacles if isinstance(ob.shape, Box)}
    sep_err = 0.0
    pen_err_caps = 0.0
    for k in range(peer_n):
        mine = model_link_slacks(cm, slacks[k])
        ref = peer.link_slacks(segs[k])
        for key, v in mine.items():
            r = ref[key]
            if v >= 0.0 and r >= 0.0:
                sep_err = max(sep_err, abs(v - r))
            elif key[1] not in boxes:
                pen_err_caps = max(pen_err_caps, abs(v - r))
    out["sep_err"] = sep_err
    out["pen_err"] = pen_err_caps
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--configs", type=int, default=20000, help="single calls timed per arm")
    parser.add_argument("--batch", type=int, default=1_000_000, help="configurations per batch")
    parser.add_argument("--peer", type=int, default=2000,
                        help="configurations checked with coal (timed and compared)")
    parser.add_argument("--no-write", action="store_true", help="do not write docs/benchmarks.md")
    args = parser.parse_args()
    import coal

    load = os.getloadavg()[0]
    rows = []
    agree_rows = []
    seg_rows = []
    for name in ARMS:
        r = bench_arm(name, args.configs, args.batch, args.peer)
        s, p = r["single"], r["peer_single"]
        rows.append(
            f"| {name} | {r['dof']} | {r['pairs']} | {r['free_fraction']:.2f} | "
            f"{s[0]:.2f} / {s[1]:.2f} | {r['batch_cpu'] / 1e6:.2f} M/s "
            f"({r['batch_wall'] / 1e6:.2f} M/s wall) | {p[0]:.0f} / {p[1]:.0f} | "
            f"{r['peer_rate'] / 1e3:.1f} k/s | {r['batch_cpu'] / r['peer_rate']:.0f}x |")
        seg = r["segment"]
        seg_rows.append(f"| {name} | {seg[0]:.0f} / {seg[1]:.0f} | {seg[2]:.2f} |")
        agree_rows.append(
            f"| {name} | {r['agree']} / {r['peer_n']} | {r['sep_err']:.1e} | "
            f"{r['pen_err']:.1e} |")
        print(rows[-1], flush=True)
        print(agree_rows[-1], flush=True)
    md = "\n".join([
        "## Collision checks (tools/bench_collision.py)",
        "",
        "One configuration checked against itself (the link capsules, less the allowed pairs), "
        "the table and a scene of 10 obstacles (4 boxes, 3 spheres, 3 cylinders around the "
        "workspace, 3 of them close to the base; 5 mm padding), on random configurations "
        "inside the joint limits. armctl: `CollisionModel.free(q)` from Python, one call per "
        "configuration, and `CollisionModel.free_batch(qs)` on one core (best of 3, per second "
        "of CPU time, wall time in brackets: the machine is shared). coal "
        f"{coal.__version__}: the same shapes (a `coal.Capsule` per link capsule, cylinders as "
        "the capsule around them as the model checks them, the table as a half-space), the "
        "same pairs and paddings, `ComputeCollision` per pair with the padding as security "
        "margin, stopping at the first pair in contact, the capsules' poses computed before "
        "the clock starts (Python loop over the pairs). Targets: <= 5 us per call, >= 1 M "
        "configurations/s per core.",
        "",
        "| arm | DOF | pairs | free | armctl free(q) median / p90 [us] | armctl free_batch "
        "| coal per configuration median / p90 [us] | coal rate | batch vs coal |",
        "|---|---|---|---|---|---|---|---|---|",
        *rows,
        "",
        "Agreement on the compared configurations: free/colliding, and per checked link pair "
        "the least distance minus padding against coal's `ComputeDistance` "
        "(GJK tolerance 1e-12), largest difference where both say apart, and where they "
        "overlap with capsules, spheres and the table (depths in boxes, the penetration "
        "depth in both since, are checked against a brute-force search in "
        "`tests/collision/test_kernels.py` and against coal in "
        "`tests/collision/test_distance_truth.py`, not in this run).",
        "",
        "| arm | same answer | distance, apart [m] | depth, no boxes [m] |",
        "|---|---|---|---|",
        *agree_rows,
        "",
        "Continuous check of a straight joint-space line (`first_contact_on_segment`) from a "
        "free configuration 30 % of the way to another one (wall time per call, and the "
        "fraction of lines with a contact):",
        "",
        "| arm | first_contact_on_segment median / p90 [us] | lines in contact |",
        "|---|---|---|",
        *seg_rows,
        "",
        f"Load average at the start: {load:.1f} on {os.cpu_count()} CPUs.",
    ])
    if not args.no_write:
        cmd = "python tools/bench_collision.py " + " ".join(sys.argv[1:])
        print(write_section("collision", md, cmd.strip()))
    else:
        print(md)


if __name__ == "__main__":
    main()
