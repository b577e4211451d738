"""Collision checks on the command line: refusals, ``--scene``, ``--plan`` and the clearance.

Motions run on the simulated bus in simulated time. The contacts and clearances the commands
report are checked against a brute-force distance: points sampled densely along each link's
capsules (placed by FK), measured against the table plane and an axis-aligned box in closed
form, independent of the collision kernels.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from armctl.arm import load_arm
from armctl.cli import main
from armctl.kinematics.capsules import collision_capsules
from armctl.servo import Register
from armctl.servo.sim.bus import SimulatedBus
from armctl.servo_tables import table_for

pytestmark = [pytest.mark.timeout(120), pytest.mark.usefixtures("simulated_time")]

STS = table_for("sts3215")
#: Addresses whose writes move or release a servo: goal position and torque enable.
COMMANDS = {STS.spec(Register.GOAL_POSITION).address, STS.spec(Register.TORQUE_ENABLE).address}
#: Feetech WRITE, REG_WRITE and SYNC_WRITE: the address is their first parameter.
WRITES = (0x03, 0x04, 0x83)

#: A post beside the SO-101 at rest (all joints 0): turning the shoulder by +1 rad sweeps the
#: gripper through it (the tool turns towards -y).
POST_CENTRE = np.array([0.342, -0.187, 0.15])
POST_SIZE = np.array([0.04, 0.04, 0.3])
POST_SCENE = f"""\
armctl: 1
padding: 0.005
obstacles:
  - name: post
    shape: box
    size: [{POST_SIZE[0]}, {POST_SIZE[1]}, {POST_SIZE[2]}]
    origin: {{xyz: [{POST_CENTRE[0]}, {POST_CENTRE[1]}, {POST_CENTRE[2]}]}}
"""
TURN = ["1", "0", "0", "0", "0", "0"]


class Traces:
    """What every simulated bus started from now on received."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch):
        self.traces: list[list[tuple[str, bytes]]] = []
        original = SimulatedBus.start

        def start(sim: SimulatedBus) -> str:
            port = original(sim)
            self.traces.append(sim.start_trace())
            return port

        monkeypatch.setattr(SimulatedBus, "start", start)

    def commands(self) -> list[int]:
        """Addresses of the goal and torque writes received."""
        return [pkt[5] for trace in self.traces for direction, pkt in trace
                if direction == "rx" and pkt[4] in WRITES and pkt[5] in COMMANDS]


@pytest.fixture(scope="module")
def so101() -> Any:
    return load_arm("so101")


@pytest.fixture()
def post(tmp_path: Path) -> Path:
    path = tmp_path / "post.yaml"
    path.write_text(POST_SCENE)
    return path


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, Any, str]:
    code = main([*argv, "--json"])
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, json.loads(out) if out.strip() else None, err


# ---- brute force --------------------------------------------------------------------------
def capsule_points(arm: Any, q: Any, link: str, per_segment: int = 400) -> tuple[Any, Any]:
    """Points along the axes of a link's capsules (base frame) and their radii."""
    pose = arm.fk(np.asarray(q, dtype=float), link)
    pts, radii = [], []
    for cap in collision_capsules(arm.spec)[link]:
        s = np.linspace(0.0, 1.0, per_segment)[:, None]
        local = np.asarray(cap.a) + s * (np.asarray(cap.b) - np.asarray(cap.a))
        pts.append(local @ pose[:3, :3].T + pose[:3, 3])
        radii.append(np.full(per_segment, cap.radius))
    return np.vstack(pts), np.concatenate(radii)


def table_distance(arm: Any, q: Any, link: str, height: float = 0.0) -> float:
    """Distance of a link's capsules from the table top (negative: below it) [m]."""
    pts, radii = capsule_points(arm, q, link)
    return float(np.min(pts[:, 2] - radii - height))


def box_distance(arm: Any, q: Any, link: str, centre: Any, size: Any) -> float:
    """Signed distance of a link's capsules from an axis-aligned box [m].

    Negative: the capsules overlap the box, by the radius plus how deep the axis goes inside.
    """
    pts, radii = capsule_points(arm, q, link)
    d = np.abs(pts - centre) - np.asarray(size) / 2.0
    outside = np.linalg.norm(np.maximum(d, 0.0), axis=1)
    inside = np.minimum(d.max(axis=1), 0.0)  # minus the depth of a point inside the box
    return float(np.min(outside + inside - radii))


# ---- refusals -------------------------------------------------------------------------------
def test_a_goal_below_the_table_is_refused_naming_the_pair_and_nothing_moves(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], so101: Any) -> None:
    traces = Traces(monkeypatch)
    code, data, err = run(capsys, "move-to-pose", "so101", "--xyz", "0.2", "0", "-0.15", "--sim")
    assert code == 3, err
    assert data["ok"] is False
    error = data["error"]
    assert error["type"] == "CollisionError" and error["exit_code"] == 3
    details = error["details"]
    link, other = details["pair"]
    assert other == "table" and link in [lk.name for lk in so101.spec.links]
    assert details["kind"] == "scene"
    # every IK answer of the goal is under the table: refused before a plan (no time), with the
    # configuration IK found and how deep it puts the link
    assert details["time"] is None
    assert details["depth"] > 0.05 and details["padding"] == pytest.approx(0.005)
    assert set(details["q"]) == set(so101.joint_names)
    q = [details["q"][n] for n in so101.joint_names]
    assert table_distance(so101, q, link) == pytest.approx(details["distance"], abs=2e-4)
    assert details["distance"] < -0.05  # the goal is 15 cm under the table
    assert f"'{link}' and 'table'" in error["message"] and "nothing was moved" in error["message"]
    assert "armctl: error: every IK answer found for the goal collides" in err
    assert traces.commands() == []  # no goal written, torque never switched on


def test_the_text_error_names_the_pair_and_the_exit_code_is_3(
        capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["move-to-pose", "so101", "--xyz", "0.2", "0", "-0.15", "--sim"])
    out, err = capsys.readouterr()
    assert code == 3
    assert "Traceback" not in out + err
    assert "'table' " in err and "nothing was moved" in err and "plan:" not in out


def test_a_scene_file_is_checked_and_refuses_a_move_through_its_obstacle(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], so101: Any,
        post: Path) -> None:
    traces = Traces(monkeypatch)
    code, data, err = run(capsys, "move-joints", "so101", *TURN, "--sim", "--scene", str(post))
    assert code == 3, err
    details = data["error"]["details"]
    link, other = details["pair"]
    assert other == "post"
    q = [details["q"][n] for n in so101.joint_names]
    assert 0.0 < q[0] < 1.0  # on the way, before the goal
    assert box_distance(so101, q, link, POST_CENTRE, POST_SIZE) == pytest.approx(
        details["distance"], abs=2e-4)
    assert traces.commands() == []
    # the same move without the scene file: the arm's own scene has no post
    code, data, err = run(capsys, "move-joints", "so101", *TURN, "--sim", "--dry-run")
    assert code == 0, err


def test_a_playback_through_the_post_is_refused(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Path,
        so101: Any, post: Path) -> None:
    kf = tmp_path / "kf.yaml"
    kf.write_text("armctl_keyframes: 1\narm: so101\nunits: {angle: rad, length: m}\n"
                  "joints: [shoulder_pan, shoulder_lift, elbow_flex, wrist_flex, wrist_roll]\n"
                  "keyframes:\n- {q: [1, 0, 0, 0, 0]}\n")
    traces = Traces(monkeypatch)
    code, data, err = run(capsys, "play", str(kf), "so101", "--sim", "--scene", str(post))
    assert code == 3, err
    details = data["error"]["details"]
    assert details["pair"][1] == "post"
    q = [details["q"][n] for n in so101.joint_names]
    assert box_distance(so101, q, details["pair"][0], POST_CENTRE, POST_SIZE) == pytest.approx(
        details["distance"], abs=2e-4)
    assert traces.commands() == []
    code, _, err = run(capsys, "play", str(kf), "so101", "--sim", "--dry-run")
    assert code == 0, err  # the config's scene has no post


def test_every_motion_verb_takes_a_scene_file(capsys: pytest.CaptureFixture[str],
                                              tmp_path: Path, post: Path) -> None:
    from armctl.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    for verb in ("move-to-pose", "move-joints", "home", "park", "gripper", "play", "teach",
                 "teleop", "fk", "status", "render"):
        p = sub.choices[verb]  # type: ignore[index]
        assert "--scene" in p.format_help(), verb
    for verb in ("move-to-pose", "move-joints", "home", "park"):
        assert "--plan" in sub.choices[verb].format_help(), verb  # type: ignore[index]


@pytest.mark.parametrize(("text", "words"), [
    ("obstacles: [\n", ["scene.yaml", "line"]),
    ("tabel: {height: 0}\n", ["scene.yaml", "tabel"]),
    ("obstacles:\n  - {name: a, shape: box, size: [0.1, 0.1, -1]}\n", ["scene.yaml", "size"]),
    ("obstacles:\n  - {name: gripper_link, shape: sphere, radius: 0.1}\n",
     ["scene.yaml", "gripper_link"]),
])
@pytest.mark.parametrize("verb", [["move-joints", "so101", *TURN], ["home", "so101"],
                                  ["fk", "so101", *TURN], ["render", "so101", "-o", "x.png"]])
def test_a_bad_scene_file_is_a_clear_error_with_exit_2(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Path,
        text: str, words: list[str], verb: list[str]) -> None:
    monkeypatch.chdir(tmp_path)
    traces = Traces(monkeypatch)
    (tmp_path / "scene.yaml").write_text(text)
    bus = ["--sim"] if verb[0] in ("move-joints", "home") else []
    code, data, err = run(capsys, *verb, "--scene", "scene.yaml", *bus)
    assert code == 2, err
    assert data["error"]["exit_code"] == 2
    for word in words:
        assert word in err
    assert traces.traces == []  # refused before any bus opened
    assert not (tmp_path / "x.png").exists()


def test_a_missing_scene_file_is_named(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "move-joints", "so101", *TURN, "--sim", "--scene",
                       "/nonexistent_armctl/scene.yaml")
    assert code == 2, err
    assert "/nonexistent_armctl/scene.yaml" in err


# ---- --plan -------------------------------------------------------------------------------
def test_plan_is_refused_with_a_straight_line(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "move-to-pose", "so101", "--xyz", "0.2", "0", "0.1",
                       "--linear", "--plan", "--sim")
    assert code == 2
    assert "never replaced by a detour" in err


def test_plan_time_needs_plan(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "home", "so101", "--plan-time", "2", "--sim")
    assert code == 2
    assert "--plan-time" in err and "add --plan" in err


#: Where the tool is with the shoulder turned by 1 rad (the goal of TURN), by FK.
TURNED_XYZ = ["0.2293", "-0.2967", "0.2265"]


@pytest.mark.parametrize("goal", [["move-joints", "so101", *TURN],
                                  ["move-to-pose", "so101", "--xyz", *TURNED_XYZ]])
def test_plan_finds_a_way_around_the_post(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                          so101: Any, post: Path, goal: list[str]) -> None:
    from armctl.robot.motion_log import read_log

    code, data, err = run(capsys, *goal, "--sim", "--scene", str(post), "--dry-run")
    assert code == 3 and data["error"]["details"]["pair"][1] == "post", err  # the direct move
    log = tmp_path / "m.csv"
    code, data, err = run(capsys, *goal, "--sim", "--scene", str(post), "--plan",
                          "--plan-time", "5", "--log", str(log))
    assert code == 0, err
    assert "detour" in data["plan"]["description"]
    if goal[0] == "move-joints":
        final = np.array([data["final_joints"][n] for n in so101.joint_names])
        assert np.abs(final - [1, 0, 0, 0, 0, 0]).max() < 0.01
    else:
        assert np.allclose(data["reached_xyz"], [float(v) for v in TURNED_XYZ], atol=2e-3)
    # every commanded sample keeps the gripper and every other link off the post (brute force)
    cmd = read_log(log)
    assert len(cmd.t) > 20
    names = list(cmd.joints)
    for row in cmd.cmd:
        q = np.zeros(so101.dof)
        for i, n in enumerate(so101.joint_names):
            q[i] = row[names.index(n)] if n in names else 0.0
        for link in collision_capsules(so101.spec):
            assert box_distance(so101, q, link, POST_CENTRE, POST_SIZE) > 0.003, (link, q)


@pytest.mark.parametrize("verb", ["home", "park"])
def test_plan_asks_the_robot_for_a_detour(monkeypatch: pytest.MonkeyPatch,
                                          capsys: pytest.CaptureFixture[str], verb: str) -> None:
    from armctl.motion.detour import DetourOptions
    from armctl.robot import Robot

    seen: list[Any] = []
    original = Robot.plan_joints

    def spy(self: Robot, *args: Any, **kwargs: Any) -> Any:
        seen.append(kwargs.get("detour"))
        return original(self, *args, **kwargs)

    monkeypatch.setattr(Robot, "plan_joints", spy)
    code, _, err = run(capsys, verb, "so101", "--sim", "--dry-run", "--plan", "--plan-time", "3")
    assert code == 0, err
    code, _, err = run(capsys, verb, "so101", "--sim", "--dry-run")
    assert code == 0, err
    assert seen == [DetourOptions(time_budget=3.0), None]


# ---- clearance of fk and status -------------------------------------------------------------
def test_fk_reports_the_clearance_to_the_table(capsys: pytest.CaptureFixture[str],
                                               so101: Any) -> None:
    q = ["0", "1.2", "0.3", "0.4", "0", "0"]  # reaching forward and down
    code, data, err = run(capsys, "fk", "so101", *q)
    assert code == 0, err
    c = data["clearance"]
    assert c["pair"][1] == "table"
    link = c["pair"][0]
    assert c["distance"] == pytest.approx(table_distance(so101, [float(v) for v in q], link),
                                          abs=1e-4)
    # no other link is closer to the table than the one reported
    for other in collision_capsules(so101.spec):
        if other != so101.spec.base:
            assert table_distance(so101, [float(v) for v in q], other) >= c["distance"] - 1e-4
    assert c["margin"] == pytest.approx(c["distance"] - c["padding"])
    assert c["in_contact"] is (c["margin"] < 0)
    code = main(["fk", "so101", *q])
    out, _ = capsys.readouterr()
    assert f"clearance: {c['distance'] * 1000:.1f} mm ({link} - table)" in out


def test_fk_clearance_in_a_scene_file(capsys: pytest.CaptureFixture[str], so101: Any,
                                      post: Path) -> None:
    q = ["-0.5", "0", "0", "0", "0", "0"]  # the gripper turned towards +y: far from the post
    far = run(capsys, "fk", "so101", *q, "--scene", str(post))[1]["clearance"]
    q = ["0.5", "0", "0", "0", "0", "0"]  # turned into the post
    code, data, err = run(capsys, "fk", "so101", *q, "--scene", str(post))
    assert code == 0, err
    c = data["clearance"]
    assert c["pair"][1] == "post" and c["in_contact"] is True
    qv = [float(v) for v in q]
    assert c["distance"] == pytest.approx(
        box_distance(so101, qv, c["pair"][0], POST_CENTRE, POST_SIZE), abs=2e-4)
    assert far["pair"][1] != "post"


def test_fk_loads_no_compiler(post: Path) -> None:
    """Not with a scene file, nor for an arm without a collision matrix (scene pairs only)."""
    from armctl_testpaths import DATA

    urdf = str(DATA / "urdf" / "so101.urdf")
    code = ("import io, json, sys\nfrom contextlib import redirect_stdout\n"
            "from armctl.cli import main\n"
            "out = io.StringIO()\n"
            "with redirect_stdout(out):\n"
            f"    assert main(['fk', 'so101', '0.5', '0', '0', '0', '0', '0', '--scene',"
            f" {str(post)!r}, '--json']) == 0\n"
            "a = json.loads(out.getvalue())\n"
            "out = io.StringIO()\n"
            "with redirect_stdout(out):\n"
            f"    assert main(['fk', {urdf!r}, '0', '1.6', '0', '0', '0', '0', '--json']) == 0\n"
            "b = json.loads(out.getvalue())\n"
            "print(a['link_pairs_checked'], a['clearance']['pair'][1], b['link_pairs_checked'],"
            " b['clearance']['pair'][1])\n"
            "print('numba' in sys.modules, 'llvmlite' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120, check=True).stdout
    assert out.strip().splitlines()[-2:] == ["True post False table", "False False"]


def test_the_interpreted_clearance_equals_the_compiled_one(so101: Any, post: Path) -> None:
    from armctl.collision import CollisionModel
    from armctl.collision.single import clearance_once
    from armctl.config.scene_yaml import load_scene

    model = CollisionModel.of(so101, load_scene(post))
    rng = np.random.default_rng(3)
    for _ in range(40):
        q = so101.lower + (so101.upper - so101.lower) * rng.random(so101.dof)
        assert clearance_once(model, q) == model.clearance(q)


def test_status_reports_the_clearance(capsys: pytest.CaptureFixture[str], so101: Any,
                                      post: Path) -> None:
    code, data, err = run(capsys, "status", "so101", "--port", "sim", "--once")
    assert code == 0, err
    q = [next(j["position"] for j in data["joints"] if j["joint"] == n)
         for n in so101.joint_names]
    c = data["clearance"]
    assert c["in_contact"] is False
    from armctl.collision import CollisionModel

    ref = CollisionModel.of(so101).clearance(q)
    assert c["pair"] == [ref.a, ref.b]
    assert c["distance"] == pytest.approx(ref.distance)
    code = main(["status", "so101", "--port", "sim", "--once", "--scene", str(post)])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "clearance: " in out and " mm (" in out


# ---- the documented examples ---------------------------------------------------------------
def test_the_command_line_examples_of_the_collision_docs_run(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
        tmp_path: Path) -> None:
    import re
    import shlex

    from armctl_testpaths import REPO

    text = (REPO / "docs" / "collision.md").read_text(encoding="utf-8")
    section = text.split("## Command line", 1)[1]
    scene = re.search(r"^```yaml\n(.*?)^```", section, re.S | re.M)
    assert scene
    block = re.search(r"^```\n(.*?)^```", section[scene.end():], re.S | re.M)
    assert block
    monkeypatch.chdir(tmp_path)
    (tmp_path / "post.yaml").write_text(scene.group(1))
    lines = [ln for ln in block.group(1).splitlines() if ln.startswith("armctl ")]
    assert len(lines) == 4
    for line in lines:
        command, _, comment = line.partition("#")
        want = re.search(r"exit (\d)", comment)
        code = main([*shlex.split(command)[1:], "--json"])
        out, err = capsys.readouterr()
        assert code == (int(want.group(1)) if want else 0), (line, err)
        for name in re.findall(r"'(\w+)'", comment):
            assert f'"{name}"' in out, (line, name)
    assert (tmp_path / "contact.png").stat().st_size > 1000
