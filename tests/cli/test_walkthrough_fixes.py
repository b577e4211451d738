"""What a new user met on a first walk through the command line: units in tables, the limit's
source, Ctrl-C before anything started, checks before the bus opens, messages of teach, convert
and play, and the report after a joint move (simulated bus)."""

from __future__ import annotations

import io
import json
import math
import re
import sys
import types
from pathlib import Path

import numpy as np
import pytest
from armctl_testpaths import REPO

import armctl.cli as cli
from armctl.arm import load_arm
from armctl.cli import main
from armctl.config import bundled_configs
from armctl.motion import load_keyframes

URDF = REPO / "tests" / "data" / "urdf" / "ur5e.urdf"
SO101_JOINTS = "[shoulder_pan, shoulder_lift, elbow_flex, wrist_flex, wrist_roll]"

pytestmark = pytest.mark.usefixtures("simulated_time")  # motions run in simulated time


def run(capsys: pytest.CaptureFixture[str], *argv: str, stdin: str | None = None,
        monkeypatch: pytest.MonkeyPatch | None = None) -> tuple[int, str, str]:
    if stdin is not None:
        assert monkeypatch is not None
        monkeypatch.setattr("sys.stdin", io.StringIO(stdin))
    code = main(list(argv))
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


def keyframes(path: Path, body: str, units: str = "") -> Path:
    path.write_text(f"armctl_keyframes: 1\narm: so101\n{units}joints: {SO101_JOINTS}\n"
                    f"keyframes:{body}\n", encoding="utf-8")
    return path


# ---- ik: units of prismatic joints, joints the goal does not involve --------------------------
def test_ik_all_shows_prismatic_joints_in_metres(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["ik", "panda", "--xyz", "0.4", "0.1", "0.3", "--rpy", "180", "0", "0", "--deg",
            "--solver", "analytic", "--all"]
    code, out, _ = run(capsys, *argv)
    assert code == 0
    head = next(line for line in out.splitlines() if line.startswith("#"))
    assert "panda_finger_joint1 [m]" in head and "panda_finger_joint1 [deg]" not in head
    assert "panda_joint1 [deg]" in head
    rows = [line.split() for line in out.splitlines() if re.match(r"^\d+ +(yes|no) ", line)]
    assert rows and all(r[2 + 7] == "0.020000" for r in rows)  # 0.02 m, not 1.1459 "deg"
    assert "not involved" in out and out.rstrip().endswith("panda_finger_joint1")
    code, out, _ = run(capsys, *argv, "--json")
    assert json.loads(out)["not_involved"] == ["panda_finger_joint1"]


@pytest.mark.parametrize(("arm", "joint"), [("omx", "gripper_left_joint"),
                                            ("wx250s", "left_finger"), ("so101", "gripper")])
def test_ik_marks_the_joints_the_goal_does_not_involve(capsys: pytest.CaptureFixture[str],
                                                       arm: str, joint: str) -> None:
    code, out, _ = run(capsys, "ik", arm, "--xyz", "0.2", "0", "0.1")
    assert code == 0
    row = next(line for line in out.splitlines() if line.startswith(joint))
    assert row.endswith("(not involved)")
    assert sum("(not involved)" in line for line in out.splitlines()) == 1
    assert "keep their start value" in out
    code, out, _ = run(capsys, "ik", arm, "--xyz", "0.2", "0", "0.1", "--json")
    data = json.loads(out)
    assert data["not_involved"] == [joint]
    a = load_arm(arm)
    i = a.joint_index(joint)
    assert data["q"][i] == pytest.approx((a.lower[i] + a.upper[i]) / 2)  # the start value


# ---- the limit's source before the bus opens ----------------------------------------------------
def test_move_joints_outside_the_limits_names_the_config_key(
        capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "move-joints", "so101", "0", "0", "120", "0", "0", "0", "--deg",
                         "--json")
    assert code == 2 and "SIMULATED BUS" not in err
    error = json.loads(out)["error"]
    assert error["type"] == "JointValueError"
    assert error["details"]["limit_source"] == "config"
    assert "120 deg is outside its limits [-96.8299, 96.8299] deg" in error["message"]
    key = re.search(r"[^\s(]+so101\.yaml:\d+: joints\[2\] \(elbow_flex\)\.limits\.upper",
                    error["message"])
    assert key, error["message"]  # file, line and key
    assert key.group(0).startswith(str(bundled_configs()["so101"]))
    # the Python API's check says the same about the same limit
    from armctl.servo.effective_limits import effective_limits

    with pytest.raises(Exception) as exc:
        effective_limits(load_arm("so101").spec).check([0, 0, math.radians(120), 0, 0, 0])
    assert exc.value.details["limit_source"] == "config"  # type: ignore[attr-defined]
    assert key.group(0) in str(exc.value)


# ---- Ctrl-C before the command has started -----------------------------------------------------
def test_ctrl_c_while_parsing_exits_130_without_a_traceback(
        capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    def interrupted() -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "build_parser", interrupted)
    code, out, err = run(capsys, "move-joints", "so101", "0", "0", "0", "0", "0", "0")
    assert code == 130 and out == ""
    assert err.strip() == "armctl: interrupted by SIGINT; nothing moved"
    code, out, _ = run(capsys, "move-joints", "so101", "0", "0", "0", "0", "0", "0", "--json")
    assert code == 130 and json.loads(out)["error"]["exit_code"] == 130


class _InterruptedImport(types.ModuleType):
    """A module whose every attribute access is a Ctrl-C (as while it is being imported)."""

    def __getattr__(self, name: str) -> object:
        raise KeyboardInterrupt


def test_ctrl_c_while_importing_the_signal_guard_exits_130(
        capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "armctl.robot.stop", _InterruptedImport("armctl.robot.stop"))
    code, _, err = run(capsys, "move-joints", "so101", "0", "0", "0", "0", "0", "0",
                       "--dry-run")
    assert code == 130
    assert "armctl: interrupted by SIGINT; nothing moved" in err and "SIMULATED BUS" not in err


# ---- checks before the bus opens ----------------------------------------------------------------
def test_move_to_pose_refuses_a_6dof_pose_on_a_5_joint_arm_like_ik(
        capsys: pytest.CaptureFixture[str]) -> None:
    goal = ["so101", "--xyz", "0.2", "0", "0.05", "--rpy", "180", "0", "0", "--deg"]
    code, _, ik_err = run(capsys, "ik", *goal)
    assert code == 2
    code, _, err = run(capsys, "move-to-pose", *goal)
    assert code == 2 and "SIMULATED BUS" not in err  # before the bus opened
    assert "give --direction AXIS DX DY DZ" in err and "--force-pose" in err
    assert err == ik_err


def test_play_speed_names_the_range_of_the_file(capsys: pytest.CaptureFixture[str],
                                                tmp_path: Path) -> None:
    untimed = keyframes(tmp_path / "pick.yaml",
                        "\n- {q: [0, 0, 0, 0, 0]}\n- {q: [0.1, 0, 0, 0, 0]}")
    timed = keyframes(tmp_path / "rec.yaml", "\n- {q: [0, 0, 0, 0, 0], time: 0}"
                      "\n- {q: [0.01, 0, 0, 0, 0], time: 1}")
    code, _, err = run(capsys, "play", str(untimed), "so101", "--speed", "0")
    assert code == 2 and "the valid range is 0.01 to 1 " in err and "to 4" not in err
    code, _, err = run(capsys, "play", str(timed), "so101", "--speed", "0")
    assert code == 2 and "the valid range is 0.01 to 4" in err
    code, _, err = run(capsys, "play", str(timed), "so101", "--speed", "0", "--ignore-times")
    assert code == 2 and "the valid range is 0.01 to 1 " in err


def test_keyframes_in_degrees_without_units_ask_about_units(capsys: pytest.CaptureFixture[str],
                                                            tmp_path: Path) -> None:
    path = keyframes(tmp_path / "pick.yaml", "\n- {name: start, q: [0, -30, 20, 10, 0]}")
    code, _, err = run(capsys, "play", str(path), "so101", "--dry-run")
    assert code == 2 and "SIMULATED BUS" not in err
    assert "'shoulder_lift' would be -30 rad" in err
    assert "the values look like degrees: set 'units: {angle: deg}' at the top of the file?" in err
    # not when the value is outside the limits in degrees too
    path = keyframes(tmp_path / "far.yaml", "\n- {name: start, q: [0, -300, 20, 10, 0]}")
    code, _, err = run(capsys, "play", str(path), "so101", "--dry-run")
    assert code == 2 and "would be -300 rad" in err and "look like degrees" not in err


def test_an_empty_keyframe_file_is_refused_before_the_bus(capsys: pytest.CaptureFixture[str],
                                                          tmp_path: Path) -> None:
    path = keyframes(tmp_path / "empty.yaml", " []")
    code, _, err = run(capsys, "play", str(path), "so101", "--dry-run")
    assert code == 2 and "SIMULATED BUS" not in err
    assert f"{path}: keyframes: the keyframe file has no keyframes" in err
    assert f"armctl teach so101 -o {path} --append" in err


# ---- teach ------------------------------------------------------------------------------------
def test_teach_messages(capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch,
                        tmp_path: Path) -> None:
    commands = "j elbow_flex 500\nj elbow_flex abc\nx 0 0 300\nk after\nq\n"
    code, out, _ = run(capsys, "teach", "so101", "-o", str(tmp_path / "t.yaml"), "--stiff",
                       "--deg", stdin=commands, monkeypatch=monkeypatch)
    assert code == 0
    errors = [line for line in out.splitlines() if line.startswith("error:")]
    assert len(errors) == 3, out
    assert errors[0].startswith("error: jogging 'elbow_flex' by 500 deg would take it to 500 "
                                "deg, outside its limits [-96.83, 96.83] deg; nothing moved.")
    assert "limits.upper" in errors[0]  # the limit's source
    assert errors[1] == "error: could not read 'j elbow_flex abc': 'abc' is not a number; type " \
                        "'help'"
    assert "Jog in smaller steps" in errors[2] and "--linear" not in errors[2]
    assert "could not convert" not in out


def test_teach_append_to_a_file_of_another_arm(capsys: pytest.CaptureFixture[str],
                                               tmp_path: Path) -> None:
    path = keyframes(tmp_path / "app.yaml", "\n- {q: [0, 0, 0, 0, 0]}")
    code, _, err = run(capsys, "teach", "omx", "-o", str(path), "--append")
    assert code == 2 and "SIMULATED BUS" not in err
    assert "taught on arm 'so101', not 'omx'" in err
    assert "teach 'omx' into a new file" in err and "play them" not in err


def test_teach_wants_a_yaml_name_and_writes_no_empty_file(
        capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch,
        tmp_path: Path) -> None:
    txt = tmp_path / "x.txt"
    code, _, err = run(capsys, "teach", "so101", "-o", str(txt), stdin="",
                       monkeypatch=monkeypatch)
    assert code == 2 and ".yaml" in err and "SIMULATED BUS" not in err and not txt.exists()
    out_file = tmp_path / "x.yaml"
    code, out, _ = run(capsys, "teach", "so101", "-o", str(out_file), stdin="",
                       monkeypatch=monkeypatch)
    assert code == 0 and not out_file.exists()
    assert f"nothing was recorded; {out_file} was not written" in out
    code, out, _ = run(capsys, "teach", "so101", "-o", str(out_file), "--stiff",
                       stdin="k a\nu\nq\n", monkeypatch=monkeypatch)
    assert code == 0 and not out_file.exists()  # its only keyframe was undone
    # --force onto a file, nothing recorded: the file is left as it was
    old = keyframes(tmp_path / "old.yaml", "\n- {name: kept, q: [0, 0, 0, 0, 0]}")
    before = old.read_text()
    code, out, _ = run(capsys, "teach", "so101", "-o", str(old), "--force", stdin="",
                       monkeypatch=monkeypatch)
    assert code == 0 and old.read_text() == before and "left as it was" in out
    # appending nothing keeps the file and its keyframes
    code, _, _ = run(capsys, "teach", "so101", "-o", str(old), "--append", "--stiff",
                     stdin="k b\nu\nq\n", monkeypatch=monkeypatch)
    assert code == 0
    assert [kf.name for kf in load_keyframes(old, load_arm("so101")).keyframes] == ["kept"]


# ---- convert ------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["conv.png", "conv.urdf", "conv"])
def test_convert_writes_only_yaml_names(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                        name: str) -> None:
    out = tmp_path / name
    code, _, err = run(capsys, "convert", str(URDF), "-o", str(out))
    assert code == 2 and not out.exists() and not list(tmp_path.iterdir())
    assert "give a .yaml file name" in err


def test_convert_never_writes_into_the_bundled_configs(capsys: pytest.CaptureFixture[str]
                                                       ) -> None:
    folder = bundled_configs()["so101"].parent
    for target in (folder / "ur5e.yaml", folder / "zz_converted_by_a_test.yaml"):
        before = target.read_bytes() if target.exists() else None
        try:
            code, _, err = run(capsys, "convert", str(URDF), "-o", str(target), "--force")
        finally:
            if before is None:
                target.unlink(missing_ok=True)
            elif target.read_bytes() != before:
                target.write_bytes(before)
                pytest.fail("convert overwrote a bundled config")
        assert code == 2 and "bundled arm configs" in err
        assert (target.read_bytes() if target.exists() else None) == before


# ---- smaller messages ----------------------------------------------------------------------------
def test_calibrate_with_closed_input_says_so(capsys: pytest.CaptureFixture[str],
                                             monkeypatch: pytest.MonkeyPatch,
                                             tmp_path: Path) -> None:
    import os

    with open(os.devnull, encoding="utf-8") as closed:  # select: ready; readline: ""
        monkeypatch.setattr("sys.stdin", closed)
        code, _, err = run(capsys, "calibrate", "so101", "-o", str(tmp_path / "c.yaml"))
    assert code == 2 and "the input was closed" in err and "moved only" not in err
    assert not (tmp_path / "c.yaml").exists()


def test_a_goal_within_one_servo_tick_is_already_there(capsys: pytest.CaptureFixture[str]
                                                       ) -> None:
    code, out, _ = run(capsys, "home", "omx", "--dry-run")
    assert code == 0 and out.strip() == "already at the 'home' pose; nothing to do"


def test_nothing_to_do_is_said_before_the_exit_policy(monkeypatch: pytest.MonkeyPatch) -> None:
    both = io.StringIO()  # stdout and stderr in the order they were written
    monkeypatch.setattr("sys.stdout", both)
    monkeypatch.setattr("sys.stderr", both)
    assert main(["home", "ur5e", "--exit-policy", "release"]) == 0
    text = both.getvalue()
    assert "releasing torque" in text
    assert text.index("already at the 'home' pose") < text.index("releasing torque")


def test_limit_violations_have_units_and_sentences(capsys: pytest.CaptureFixture[str],
                                                   tmp_path: Path) -> None:
    path = keyframes(tmp_path / "rec.yaml", "\n- {q: [0, 0, 0, 0, 0], time: 0}"
                     "\n- {q: [1.5, 0, 0, 0, 0], time: 0.05}")
    code, _, err = run(capsys, "play", str(path), "so101", "--dry-run")
    assert code == 3, err
    assert re.search(r"would be -?[\d.]+ rad/s(\^2|\^3)? at t=", err), err
    assert re.search(r"beyond its limit [\d.]+ rad/s", err)
    assert "nothing was moved. The recorded timing is too fast" in err


@pytest.mark.parametrize("argv", [
    ["move-joints", "so101", "0", "0", "0", "0", "0", "0", "--speed", "nan"],
    ["play", "pick.yaml", "so101", "--loop", "0"],
    ["ik", "so101", "--xyz", "0.2", "0", "0.1", "--tol-pos", "0"],
    ["ik", "so101", "--xyz", "0.2", "0", "nan"],
])
def test_a_bad_value_is_one_line(capsys: pytest.CaptureFixture[str], argv: list[str]) -> None:
    code, out, err = run(capsys, *argv)
    assert code == 2 and out == ""
    assert "usage:" not in err and len(err.strip().splitlines()) == 1
    assert err.startswith("armctl: error: argument ") and f"'armctl {argv[0]} --help'" in err


def test_a_missing_argument_still_shows_the_usage(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "move-joints")
    assert code == 2 and "usage: armctl move-joints" in err


def test_an_unreachable_position_goal_reports_no_rotation(capsys: pytest.CaptureFixture[str]
                                                          ) -> None:
    code, _, err = run(capsys, "move-to-pose", "so101", "--xyz", "2", "0", "0")
    assert code == 3
    assert re.search(r"closest found is [\d.]+ mm away", err) and "deg away" not in err
    code, out, _ = run(capsys, "move-to-pose", "so101", "--xyz", "2", "0", "0", "--json")
    assert code == 3 and json.loads(out)["error"]["details"]["not_involved"] == ["gripper"]


def test_a_tiny_speed_gives_the_real_estimate(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "move-joints", "so101", "0", "0", "0", "0", "0", "0", "--speed",
                       "0.001")
    assert code == 2 and "hours" not in err
    assert "1000 times as long as at the limits: a move of 1 s would take 16.7 min" in err


def test_singular_all_merges_near_duplicates(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "ik", "so101", "--xyz", "0.2", "0", "0.05", "--direction", "z",
                       "0", "0", "-1", "--solver", "analytic", "--all", "--json")
    assert code == 0
    data = json.loads(out)
    assert data["singular"] and data["distinct"] < data["with_variants"]
    q = np.array([s["q"] for s in data["solutions"]])
    rotary = np.array([True] * 6)
    for i in range(len(q)):
        for k in range(i):
            d = np.abs(q[i] - q[k])
            d = np.where(rotary, np.minimum(d % (2 * np.pi), -d % (2 * np.pi)), d)
            assert d.max() >= 0.1, (i, k)  # no two rows within 0.1 rad on every joint
    assert any(s["within_limits"] for s in data["solutions"])
    code, out, _ = run(capsys, "ik", "so101", "--xyz", "0.2", "0", "0.05", "--direction", "z",
                       "0", "0", "-1", "--solver", "analytic", "--all")
    assert "SINGULAR goal: a continuum of solutions" in out


def test_move_joints_reports_the_reached_pose(capsys: pytest.CaptureFixture[str]) -> None:
    goal = [0.2, 0.0, 0.3, 0.0, 0.0, 0.0]
    code, out, _ = run(capsys, "move-joints", "so101", *map(str, goal), "--json")
    assert code == 0
    data = json.loads(out)
    arm = load_arm("so101")
    final = np.array([data["final_joints"][n] for n in arm.joint_names])
    assert data["reached_xyz"] == pytest.approx(arm.fk(final)[:3, 3].tolist(), abs=1e-9)
    assert data["position_error"] == pytest.approx(
        float(np.linalg.norm(arm.fk(final)[:3, 3] - arm.fk(goal)[:3, 3])), abs=1e-9)
    assert data["position_error"] < 5e-3 and data["rotation_error"] < 0.02
    assert data["joint_errors"] == pytest.approx(
        {n: final[i] - goal[i] for i, n in enumerate(arm.joint_names)}, abs=1e-9)
    code, out, _ = run(capsys, "move-joints", "so101", "0.1", "0", "0.2", "0", "0", "0")
    assert code == 0
    assert re.search(r"\nreached xyz \[.*\] m, rpy \[.*\] deg \(FK of the joints read back\)\n"
                     r"remaining error: tool [\d.]+ mm, [\d.]+ deg; joints at most [\d.]+ deg "
                     r"\(\w+\)$", out.rstrip()), out


def test_the_python_api_docs_show_joints_and_pose(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    from armctl.robot import Robot

    doc = (REPO / "docs" / "motion.md").read_text(encoding="utf-8")
    api = doc[doc.index("## Python API"):]
    code = re.search(r"^```python\n(.*?)^```", api, re.S | re.M)
    keyframe_file = re.search(r"^### The keyframe file\n.*?^```yaml\n(.*?)^```", doc,
                              re.S | re.M)
    assert code and keyframe_file
    assert "`robot.joints()`" in api and "`robot.pose(frame=None)`" in api
    monkeypatch.chdir(tmp_path)
    (tmp_path / "pick.yaml").write_text(keyframe_file.group(1))
    scope: dict[str, object] = {}
    exec(compile(code.group(1), "docs/motion.md", "exec"), scope)
    robot, q, tool = scope["robot"], scope["q"], scope["tool"]
    assert isinstance(robot, Robot) and isinstance(q, np.ndarray) and isinstance(tool, np.ndarray)
    assert q.shape == (robot.arm.dof,) and tool.shape == (4, 4)
    assert tool == pytest.approx(robot.arm.fk(q))  # the pose is FK of the joints read back
    assert tool[:3, 3] == pytest.approx([0.25, 0.05, 0.15], abs=3e-3)  # where it had moved
    capsys.readouterr()
