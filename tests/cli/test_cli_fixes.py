"""Command-line defects a newcomer met: options among positionals, unit and DOF mistakes of
relative moves, ``--deg`` where nothing is an angle, ``teach --log``, swapped teleop arms, the
render title and labels, ``collisions --samples``, and two options that exclude each other.

Every run is in process on the built-in simulated bus, in simulated time.
"""

from __future__ import annotations

import io
import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from armctl_testpaths import CONFIGS

from armctl.cli import main
from armctl.config import load_spec
from armctl.config.source import load_yaml
from armctl.errors import ConfigError

pytestmark = [pytest.mark.timeout(60), pytest.mark.usefixtures("simulated_time")]


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


def run_json(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, Any, str]:
    code, out, err = run(capsys, *argv, "--json")
    return code, json.loads(out), err


def one_error_line(err: str) -> str:
    """The one stderr line of a refused command (no usage block, no second line)."""
    lines = [line for line in err.strip().splitlines() if line]
    assert len(lines) == 1 and "usage:" not in err, err
    assert lines[0].startswith("armctl: error: "), err
    return lines[0]


# ---- 1. options before the optional positionals ----------------------------------------------
@pytest.mark.parametrize("argv", [
    ["reboot", "so101", "--port", "sim", "wrist_flex", "gripper"],
    ["reboot", "so101", "wrist_flex", "--port", "sim", "gripper"],
    ["reboot", "--port", "sim", "so101", "wrist_flex", "gripper"],
    ["reboot", "so101", "--sim", "wrist_flex", "gripper"],
    ["reboot", "so101", "wrist_flex", "gripper", "--sim"],
])
def test_reboot_takes_the_joints_wherever_the_port_is(capsys: pytest.CaptureFixture[str],
                                                      argv: list[str]) -> None:
    code, data, err = run_json(capsys, *argv)
    assert code == 0, err
    assert data["rebooted"] == ["wrist_flex", "gripper"]


def test_torque_takes_its_state_and_joints_after_the_port(capsys: pytest.CaptureFixture[str]
                                                          ) -> None:
    code, _, err = run(capsys, "torque", "so101", "--port", "sim", "off", "elbow_flex")
    assert code == 0, err
    code, _, err = run(capsys, "torque", "so101", "--port", "sim", "sideways")
    assert code == 2 and "invalid choice: 'sideways'" in one_error_line(err)


def test_render_takes_joint_values_after_its_options(tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    png = tmp_path / "a.png"
    code, data, err = run_json(capsys, "render", "so101", "-o", str(png), "--deg", "90", "0",
                               "0", "0", "0", "0")
    assert code == 0, err
    code, plain, err = run_json(capsys, "render", "so101", "90", "0", "0", "0", "0", "0", "-o",
                                str(png), "--deg")  # the order argparse alone understands
    assert code == 0, err
    assert data["q"] == plain["q"] and math.degrees(data["q"][0]) == pytest.approx(90.0)
    assert data["tool_position"] == plain["tool_position"]


def test_torque_and_reboot_take_sim_but_not_with_port(capsys: pytest.CaptureFixture[str]
                                                      ) -> None:
    code, data, err = run_json(capsys, "torque", "so101", "off", "--sim")
    assert code == 0, err
    assert set(data["torque"].values()) == {False}
    code, _, err = run(capsys, "reboot", "so101", "--sim", "--port", "sim")
    assert code == 2 and "not allowed with argument" in one_error_line(err)


def test_calibrate_takes_no_sim(capsys: pytest.CaptureFixture[str]) -> None:
    # a calibration measured on the built-in simulated bus would overwrite the arm's own file
    code, _, err = run(capsys, "calibrate", "so101", "--sim")
    assert code == 2 and "--sim" in err


def test_reboot_without_config_still_shows_the_usage(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "reboot", "--port", "sim")
    assert code == 2 and "usage: armctl reboot" in err and "CONFIG" in err


# ---- 2. move-to-pose --relative before CONFIG ------------------------------------------------
def goal_of(capsys: pytest.CaptureFixture[str], *argv: str) -> list[float]:
    code, data, err = run_json(capsys, "move-to-pose", *argv, "--sim", "--dry-run")
    assert code == 0, err
    return [float(v) for v in data["relative"]["goal_xyz"]]


@pytest.mark.parametrize("frame", [[], ["base"], ["tool"]])
def test_relative_before_config_is_the_same_move(capsys: pytest.CaptureFixture[str],
                                                 frame: list[str]) -> None:
    offset = ["--xyz", "0", "0.01", "0.02"]
    after = goal_of(capsys, "so101", "--relative", *frame, *offset)
    before = goal_of(capsys, "--relative", *frame, "so101", *offset)
    assert before == pytest.approx(after, abs=1e-12)


@pytest.mark.parametrize("argv", [
    ["--relative", "tol", "so101", "--xyz", "0", "0", "0.01"],  # a near miss of 'tool'
    ["so101", "--relative", "world", "--xyz", "0", "0", "0.01"],  # CONFIG is given already
])
def test_a_wrong_relative_frame_is_still_refused(capsys: pytest.CaptureFixture[str],
                                                 argv: list[str]) -> None:
    code, _, err = run(capsys, "move-to-pose", *argv, "--sim", "--dry-run")
    line = one_error_line(err)
    assert code == 2 and "argument --relative: invalid choice" in line
    assert "'base', 'tool'" in line


# ---- 3. offsets and positions in millimetres --------------------------------------------------
def test_relative_offset_in_millimetres_is_refused_before_the_bus(
        capsys: pytest.CaptureFixture[str]) -> None:
    # a port that does not exist: a refusal after the bus opened would be a bus error (4)
    code, _, err = run(capsys, "move-to-pose", "so101", "--relative", "--xyz", "0", "0", "50",
                       "--port", "/dev/armctl-no-such-port")
    line = one_error_line(err)
    assert code == 2
    assert "did you mean --xyz 0 0 0.05 (0 0 50 mm)?" in line
    reach = load_spec("so101")  # the reach printed is the arm's (twice it bounds any move)
    assert reach.name in line and "twice its reach" in line


def test_relative_offset_within_the_workspace_moves(capsys: pytest.CaptureFixture[str]) -> None:
    start = goal_of(capsys, "so101", "--relative", "--xyz", "0", "0", "0")
    goal = goal_of(capsys, "so101", "--relative", "--xyz", "0", "0", "0.05")
    assert np.subtract(goal, start) == pytest.approx([0.0, 0.0, 0.05], abs=1e-12)


def test_absolute_position_in_millimetres_gets_the_hint(capsys: pytest.CaptureFixture[str]
                                                        ) -> None:
    code, _, err = run(capsys, "move-to-pose", "so101", "--xyz", "200", "0", "150", "--sim",
                       "--dry-run")
    assert code == 3, err
    assert "did you mean 0.2 0 0.15 (200 0 150 mm)?" in err
    code, _, err = run(capsys, "move-to-pose", "so101", "--xyz", "2000", "0", "1500", "--sim",
                       "--dry-run")
    assert code == 3 and "did you mean" not in err  # 2 m away either way: no hint


# ---- 4. relative rotations of a 5-joint arm ---------------------------------------------------
def turn_residual(name: str, q: np.ndarray, axis: np.ndarray) -> float:
    """How far a turn about ``axis`` (base frame) with the tool point held is from what the
    joints can do at ``q``: least squares over rates of finite differences of FK (not the
    arm's own Jacobian)."""
    from armctl.arm import load_arm

    arm = load_arm(name)
    t0, eps, cols = arm.fk(q), 1e-7, []
    for j in arm.chain():
        dq = np.zeros_like(q)
        dq[j] = eps
        t = arm.fk(q + dq)
        d = t[:3, :3] @ t0[:3, :3].T
        w = np.array([d[2, 1] - d[1, 2], d[0, 2] - d[2, 0], d[1, 0] - d[0, 1]]) / (2 * eps)
        cols.append(np.concatenate([(t[:3, 3] - t0[:3, 3]) / eps, w]))
    jac = np.array(cols).T
    want = np.concatenate([np.zeros(3), axis])
    rates = np.linalg.lstsq(jac, want, rcond=None)[0]
    return float(np.linalg.norm(jac @ rates - want))


def start_of(capsys: pytest.CaptureFixture[str], name: str) -> tuple[list[str], np.ndarray]:
    """The joint names and the joints a simulated arm starts at (from a dry run's plan)."""
    code, data, err = run_json(capsys, "move-to-pose", name, "--relative", "--xyz", "0", "0",
                               "0.005", "--sim", "--dry-run")
    assert code == 0, err
    names = list(data["plan"]["start"])
    return names, np.array([data["plan"]["start"][n] for n in names])


@pytest.mark.parametrize("name", ["so101", "koch_follower"])
def test_rotation_offsets_of_5_joint_arms_are_checked_at_the_present_pose(
        capsys: pytest.CaptureFixture[str], name: str) -> None:
    from armctl.arm import load_arm

    arm = load_arm(name)
    names, q0 = start_of(capsys, name)
    assert names == list(arm.joint_names)
    tool = arm.fk(q0)[:3, :3]
    residual = [turn_residual(name, q0, tool[:, k]) for k in range(3)]
    impossible = int(np.argmax(residual))
    assert residual[impossible] > 0.1  # five joints: at least one axis cannot turn in place
    rpy = ["0", "0", "0"]
    rpy[impossible] = "2"
    code, _, err = run(capsys, "move-to-pose", name, "--relative", "tool", "--rpy", *rpy,
                       "--deg", "--sim", "--dry-run")
    line = err.strip().splitlines()[-1]  # after the simulated bus's banner: nothing moved
    assert line.startswith("armctl: error: ") and err.count("error") == 1, err
    assert code == 2 and "with 5 joints" in line and "--force-pose" in line
    assert "cannot turn about at the present pose at all" in line
    named = re.findall(r"tool ([xyz])", line.split("can turn 2 deg about")[1])
    possible = {"xyz"[k] for k in range(3) if residual[k] < 0.01}
    assert set(named) <= possible, (line, residual)  # named only where the joints can turn
    for k in named:  # and a turn about each named axis is made
        rpy = ["0", "0", "0"]
        rpy["xyz".index(k)] = "2"
        code, _, err = run(capsys, "move-to-pose", name, "--relative", "tool", "--rpy", *rpy,
                           "--deg", "--sim", "--dry-run")
        assert code == 0, err


def test_large_turn_of_a_5_joint_arm_is_refused_with_smaller_steps(
        capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "move-to-pose", "so101", "--relative", "base", "--rpy", "0", "30",
                       "0", "--deg", "--sim", "--dry-run")
    line = err.strip().splitlines()[-1]
    assert code == 3 and "only for small angles" in line and "smaller steps" in line, err
    code, _, err = run(capsys, "move-to-pose", "so101", "--relative", "base", "--rpy", "0", "2",
                       "0", "--deg", "--sim", "--dry-run")
    assert code == 0, err


def test_koch_turn_about_its_roll_axis_is_made_in_place(capsys: pytest.CaptureFixture[str]
                                                        ) -> None:
    assert tcp_off_roll_axis_mm("koch_follower") < 0.1  # the tool point is on the roll axis
    code, data, err = run_json(capsys, "move-to-pose", "koch_follower", "--relative", "tool",
                               "--rpy", "0", "0", "30", "--deg", "--sim", "--dry-run")
    assert code == 0, err
    start, goal = data["plan"]["start"], data["plan"]["target"]
    turned = {n: math.degrees(goal[n] - start[n]) for n in start}
    assert {n for n, d in turned.items() if abs(d) > 0.05} == {"wrist_roll"}, turned
    assert abs(turned["wrist_roll"]) == pytest.approx(30.0, abs=0.05)


def tcp_off_roll_axis_mm(name: str) -> float:
    """The tool point's distance from the last joint's axis, from the config's numbers.

    In both bundled 5-joint arms the tool frame hangs from the roll joint's child link, whose
    origin lies on the joint's axis (given in that link's frame): the distance is the part of
    the tool origin across the axis.
    """
    spec = load_spec(name)
    tcp = next(f for f in spec.frames if f.name == spec.tool)
    roll = next(j for j in spec.joints if j.name == "wrist_roll")
    assert tcp.parent == roll.child
    p, a = np.array(tcp.origin.xyz, dtype=float), np.array(roll.axis, dtype=float)
    a /= np.linalg.norm(a)
    return float(np.linalg.norm(p - (p @ a) * a)) * 1000.0


def test_six_joint_arm_still_turns_its_tool(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "move-to-pose", "ur5e", "--relative", "tool", "--rpy", "0", "0",
                       "30", "--deg", "--sim", "--dry-run")
    assert code == 0, err


# ---- 5. --deg where nothing is an angle -------------------------------------------------------
def test_deg_on_a_move_without_angles_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    for argv in (["--xyz", "0.3", "0", "0.2"], ["--relative", "--xyz", "0", "0", "0.01"]):
        code, _, err = run(capsys, "move-to-pose", "so101", *argv, "--deg", "--sim",
                           "--dry-run")
        line = one_error_line(err)
        assert code == 2 and "--deg" in line and "--xyz is in metres" in line
    code, _, err = run(capsys, "move-to-pose", "ur5e", "--xyz", "0.4", "0.1", "0.4", "--rpy",
                       "180", "0", "0", "--deg", "--sim", "--dry-run")
    assert code == 0, err


# ---- 6. teach --log ---------------------------------------------------------------------------
def test_teach_logs_every_jog(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                              monkeypatch: pytest.MonkeyPatch) -> None:
    from armctl.robot.motion_log import read_log

    out, log = tmp_path / "taught.yaml", tmp_path / "teach.csv"
    monkeypatch.setattr("sys.stdin", io.StringIO("j shoulder_pan 10\n\nj elbow_flex -15\n\nq\n"))
    code, _, err = run(capsys, "teach", "so101", "-o", str(out), "--sim", "--stiff", "--log",
                       str(log))
    assert code == 0, err
    assert f"cycles written to {log}" in err
    cycles = read_log(log)
    pan, elbow = cycles.joints.index("shoulder_pan"), cycles.joints.index("elbow_flex")
    tick = 360.0 / 4096  # a jog starts from the joints read back: within a servo tick
    assert math.degrees(cycles.cmd[-1, pan]) == pytest.approx(10.0, abs=tick)
    assert math.degrees(cycles.cmd[-1, elbow]) == pytest.approx(-15.0, abs=tick)
    # both jogs, one after the other on one time axis: the pan moved first, then the elbow
    first_elbow = int(np.argmax(np.abs(cycles.cmd[:, elbow] - cycles.cmd[0, elbow]) > 1e-3))
    assert 0 < first_elbow
    assert math.degrees(cycles.cmd[first_elbow, pan]) == pytest.approx(10.0, abs=tick)
    assert np.all(np.diff(cycles.t) > 0)


def test_teach_refuses_an_existing_log_before_the_bus(tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "old.csv"
    log.write_text("keep me\n")
    code, _, err = run(capsys, "teach", "so101", "-o", str(tmp_path / "t.yaml"), "--port",
                       "/dev/armctl-no-such-port", "--log", str(log))
    assert code == 2 and "already exists" in err
    assert log.read_text() == "keep me\n"


@pytest.mark.parametrize("verb", [["teach", "so101", "-o", "t.yaml"], ["home", "so101"]])
def test_a_log_not_named_csv_is_refused_before_the_bus(tmp_path: Path, verb: list[str],
                                                       capsys: pytest.CaptureFixture[str]
                                                       ) -> None:
    argv = [str(tmp_path / a) if a.endswith(".yaml") else a for a in verb]
    code, _, err = run(capsys, *argv, "--port", "/dev/armctl-no-such-port", "--log",
                       str(tmp_path / "session.yaml"))
    assert code == 2 and "does not end in '.csv'" in err and "session.csv" in err
    assert not any(tmp_path.iterdir())


# ---- 7. teleop with LEADER and FOLLOWER swapped -----------------------------------------------
def test_teleop_refuses_swapped_arms(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "teleop", "so101", "so101_leader", "--sim", "--duration", "0.1")
    line = one_error_line(err)
    assert code == 2 and "look swapped" in line
    assert "'armctl teleop so101_leader so101'" in line and "--leader-as-follower" in line
    code, _, err = run(capsys, "teleop", "koch_leader", "so101_leader", "--sim")
    assert code == 2 and "is a leader arm" in one_error_line(err)


def test_teleop_override_and_warning(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "teleop", "so101", "so101_leader", "--sim", "--duration", "0.1",
                       "--leader-as-follower")
    assert code == 0, err
    assert "LEADER 'so101' is not a leader arm" in err  # it goes limp: said before it does
    code, _, err = run(capsys, "teleop", "so101_leader", "so101", "--sim", "--duration", "0.1")
    assert code == 0 and "warning" not in err


@pytest.mark.parametrize("name", ["so101_leader", "koch_leader"])
def test_bundled_leaders_say_so_in_their_files(name: str) -> None:
    raw = yaml.safe_load((CONFIGS / f"{name}.yaml").read_text())
    assert raw["role"] == "leader"
    assert load_spec(name).role.value == "leader"
    follower = {"so101_leader": "so101", "koch_leader": "koch_follower"}[name]
    assert "role" not in yaml.safe_load((CONFIGS / f"{follower}.yaml").read_text())


def test_a_bad_role_names_file_line_and_choices(tmp_path: Path) -> None:
    from armctl.config.arm_yaml import parse_arm
    from armctl.config.writer import dump_arm_yaml

    text = (CONFIGS / "so101_leader.yaml").read_text().replace("role: leader", "role: leeder")
    bad = tmp_path / "arm.yaml"
    bad.write_text(text)
    with pytest.raises(ConfigError) as info:
        parse_arm(load_yaml(bad))
    message = str(info.value)
    line = text.splitlines().index(next(t for t in text.splitlines() if t.startswith("role:")))
    assert "role" in message and f":{line + 1}" in message and "'leader'" in message
    again = tmp_path / "again.yaml"  # the writer keeps the role
    again.write_text(dump_arm_yaml(load_spec("so101_leader")))
    assert load_spec(str(again)).role.value == "leader"


# ---- 8. render: the title in the unit of Q, the labels inside the picture ---------------------
def test_render_title_in_degrees_and_labels_inside(tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str],
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    import armctl.render.picture as picture

    figures: list[Any] = []
    save = picture.save_figure

    def keep(fig: Any, path: Any, *args: Any, **kwargs: Any) -> Any:
        figures.append(fig)
        return save(fig, path, *args, **kwargs)

    monkeypatch.setattr(picture, "save_figure", keep)
    png = tmp_path / "deg.png"
    code, _, err = run(capsys, "render", "so101", "10", "20", "-30", "40", "0", "0", "--deg",
                       "-o", str(png))
    assert code == 0, err
    fig = figures[-1]
    title = fig._suptitle.get_text()
    assert title.endswith("q = [10.0, 20.0, -30.0, 40.0, 0.0, 0.0] deg"), title
    renderer = fig.canvas.get_renderer()
    width, height = fig.bbox.width, fig.bbox.height
    (ax,) = fig.axes
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        box = axis.label.get_window_extent(renderer)
        assert 0 <= box.x0 and box.x1 <= width and 0 <= box.y0 and box.y1 <= height, (
            axis.label.get_text(), box)
    code, _, err = run(capsys, "render", "so101", "0.5", "0", "0", "0", "0", "0", "-o", str(png))
    assert code == 0, err
    assert figures[-1]._suptitle.get_text().endswith("q = [0.500, 0.000, 0.000, 0.000, 0.000, "
                                                     "0.000] rad")


def test_pose_title_gives_prismatic_joints_in_metres() -> None:
    from armctl.arm import load_arm
    from armctl.render.picture import pose_title

    panda = load_arm("panda")
    title = pose_title(panda, panda.named_pose("home"), deg=True)
    assert title.startswith("panda  q = [0.0, -45.0,") and title.endswith("0.035 m] deg")


# ---- 9. collisions --samples ------------------------------------------------------------------
def test_samples_without_generate_says_it_only_matters_with_generate(
        capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "collisions", "so101", "--samples", "10")
    line = one_error_line(err)
    assert code == 2 and "--samples only matters with --generate" in line
    assert "add --generate" in line


def test_few_samples_say_what_they_can_miss(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "collisions", "so101", "--generate", "--samples", "10")
    assert code == 0, err
    m = re.search(r"only 10 samples: 1 time in 20 they all miss a pair that touches in "
                  r"([\d.]+)% of the joint space", out)
    assert m is not None, out
    share = float(m.group(1)) / 100
    assert (1 - share) ** 10 == pytest.approx(0.05, abs=0.002)  # all 10 samples miss it
    code, data, err = run_json(capsys, "collisions", "so101", "--generate", "--samples", "10")
    assert (1 - data["missable_share"]) ** 10 == pytest.approx(0.05, rel=1e-9)


# ---- 10. two options that exclude each other --------------------------------------------------
@pytest.mark.parametrize("argv", [
    ["render", "so101", "-o", "x.png", "--scene", "s.yaml", "--no-scene"],
    ["move-joints", "so101", *["0"] * 6, "--sim", "--port", "/dev/ttyX"],
])
def test_exclusive_options_are_one_line(capsys: pytest.CaptureFixture[str],
                                        argv: list[str]) -> None:
    code, out, err = run(capsys, *argv)
    line = one_error_line(err)
    assert code == 2 and out == ""
    assert "not allowed with argument" in line and "give one or the other" in line
    assert f"see 'armctl {argv[0]} --help'" in line
