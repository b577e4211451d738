"""The control panel's state machine on the built-in simulated bus, in simulated time.

Who commands, what a preview shows (the ghost, or the Robot's own reason for a refusal), Move
and Stop (checked on the bus, independent of the panel), and the keyframe list (recorded,
edited, played, saved in the keyframe file format and read back by the file reader).
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import pytest

from armctl.clock import SimulatedClock, WallClock
from armctl.config.motion import ExitPolicy
from armctl.errors import InputError
from armctl.ik.errors import IKFailedError
from armctl.motion import Interpolation
from armctl.motion.keyframe_file import load_keyframes
from armctl.panel import ControlDenied, ControlPanel, PanelBusy, Phase, PreviewKind
from armctl.robot import Robot

#: A reachable, collision-free configuration of the SO-101 away from home [rad].
Q_GOAL = np.array([0.5, -0.4, 0.6, 0.3, 0.2, 0.0])


@pytest.fixture
def robot():
    with Robot.open("so101", sim=True, exit_policy=ExitPolicy.HOLD) as r:
        yield r


def _panel(robot: Robot, **kw: object) -> ControlPanel:
    panel = ControlPanel(robot, **kw)  # type: ignore[arg-type]
    panel.join("a")
    panel.join("b")
    return panel


def test_the_first_tab_commands_and_the_others_see_who(robot):
    panel = _panel(robot)
    assert panel.controller == "a" and set(panel.clients) == {"a", "b"}
    with pytest.raises(ControlDenied, match="a has control"):
        panel.preview_joints("b", Q_GOAL)
    with pytest.raises(ControlDenied, match="a has control"):
        panel.take_control("b")
    panel.take_control("b", force=True)  # a handover while the arm is at rest
    assert panel.controller == "b"
    with pytest.raises(ControlDenied):
        panel.record("a")
    panel.leave("b")  # leaving releases control
    assert panel.controller is None
    with pytest.raises(ControlDenied, match="nobody has control"):
        panel.move("a")


def test_a_token_protects_taking_control(robot):
    panel = _panel(robot, token="s3cret")
    assert panel.controller is None  # nobody gets it without the token
    with pytest.raises(ControlDenied, match="wrong token"):
        panel.take_control("a", "guess")
    with pytest.raises(ControlDenied, match="wrong token"):
        panel.take_control("a")
    panel.take_control("a", "s3cret")
    assert panel.controller == "a"
    with pytest.raises(InputError, match="empty token"):
        ControlPanel(robot, token="")


def test_a_reachable_target_shows_its_ghost_and_moves_nothing(robot):
    panel = _panel(robot)
    before = robot.joints()
    target = robot.arm.fk(Q_GOAL)
    p = panel.preview_pose("a", target, oriented=False)
    assert p.ok and p.kind is PreviewKind.OK and p.duration > 0
    assert p.ghost is not None
    # the ghost puts the tool on the target (FK of the ghost, not the panel's word)
    np.testing.assert_allclose(robot.arm.fk(p.ghost)[:3, 3], target[:3, 3], atol=1e-4)
    np.testing.assert_allclose(robot.joints(), before, atol=1e-9)  # nothing moved


def test_refused_targets_carry_the_robots_reason(robot):
    panel = _panel(robot)
    far = np.eye(4)
    far[:3, 3] = [2.0, 0.0, 0.3]  # 2 m away: beyond the arm's reach
    p = panel.preview_pose("a", far, oriented=False)
    assert p.kind is PreviewKind.UNREACHABLE and p.ghost is None
    with pytest.raises(IKFailedError) as exc:  # the same refusal the CLI gets
        robot.plan_pose(p.goal)
    assert str(exc.value) == p.message
    below = np.eye(4)
    below[:3, 3] = [0.2, 0.0, -0.05]  # under the table top
    p = panel.preview_pose("a", below, oriented=False)
    assert p.kind is PreviewKind.COLLIDES and "table" in p.message, p.message
    before = robot.joints()
    q = before.copy()
    q[1] = robot.arm.upper[1] + 0.3  # beyond shoulder_lift's effective limit
    p = panel.preview_joints("a", q)
    assert p.kind is PreviewKind.OUTSIDE_LIMITS and "shoulder_lift" in p.message
    with pytest.raises(InputError, match="outside limits"):
        panel.move("a")  # a refused preview never moves
    np.testing.assert_allclose(robot.joints(), before, atol=1e-9)


def test_move_reaches_the_target_on_the_bus(robot):
    panel = _panel(robot)
    target = robot.arm.fk(Q_GOAL)
    assert panel.preview_pose("a", target, oriented=False).ok
    panel.move("a")
    assert panel.wait(60.0)
    out = panel.outcome
    assert out is not None and out.ok, out
    reached = robot.arm.fk(robot.bus.read_joints())  # the bus, not the panel
    assert np.linalg.norm(reached[:3, 3] - target[:3, 3]) < 3e-3
    assert panel.phase is Phase.IDLE and panel.preview is None


def test_a_joint_slider_moves_one_joint_with_the_same_checks(robot):
    panel = _panel(robot)
    q0 = robot.joints()
    p = panel.preview_joint("a", "elbow_flex", 0.5)
    assert p.ok
    panel.move("a")
    assert panel.wait(60.0) and panel.outcome.ok
    q1 = robot.bus.read_joints()
    i = robot.arm.joint_index("elbow_flex")
    assert abs(q1[i] - 0.5) < 0.01
    others = [k for k in range(robot.arm.dof) if k != i]
    np.testing.assert_allclose(q1[others], q0[others], atol=0.01)


class _PressStop(SimulatedClock):
    """Simulated time in which a person presses Stop once, ``at`` seconds after ``arm()``."""

    def __init__(self) -> None:
        super().__init__()
        self.when = math.inf
        self.panel: ControlPanel | None = None
        self.pressed = False

    def arm(self, panel: ControlPanel, at: float) -> None:
        self.panel, self.when = panel, self.now() + at

    def sleep_until(self, t: float) -> None:
        super().sleep_until(t)
        if not self.pressed and self.now() >= self.when and self.panel is not None:
            self.pressed = True
            self.panel.stop("b")  # any tab may stop, even one without control


def test_stop_mid_move_decelerates_and_holds():
    clock = _PressStop()
    with Robot.open("so101", sim=True, clock=clock, exit_policy=ExitPolicy.HOLD) as robot:
        panel = _panel(robot)
        start = robot.joints()
        goal = np.array([1.2, -0.8, 0.9, 0.6, 0.8, 0.0])
        assert panel.preview_joints("a", goal).ok
        clock.arm(panel, 0.4)
        panel.move("a")
        assert panel.wait(60.0)
        out = panel.outcome
        assert clock.pressed and out is not None and out.stopped and not out.ok
        held = robot.bus.read_joints()
        assert np.max(np.abs(held - start)) > 0.05  # it had moved
        assert np.max(np.abs(held - goal)) > 0.05  # ... and stopped short of the goal
        clock.advance(1.0)
        np.testing.assert_allclose(robot.bus.read_joints(), held, atol=0.003)  # holding
        assert robot.bus.torque_enabled() if hasattr(robot.bus, "torque_enabled") else True
        assert panel.phase is Phase.IDLE


def test_commands_that_need_rest_are_refused_while_moving(robot):
    panel = _panel(robot)
    robot.pause()  # the move starts held: it runs until stopped
    assert panel.preview_joints("a", Q_GOAL).ok
    panel.move("a")
    try:
        with pytest.raises(PanelBusy):
            panel.preview_joints("a", Q_GOAL)
        with pytest.raises(PanelBusy):
            panel.move("a")
        with pytest.raises(ControlDenied, match="runs a moving motion"):
            panel.take_control("b", force=True)
    finally:
        assert panel.stop("b")
        assert panel.wait(30.0)
    assert panel.outcome.stopped and not robot.control.paused


def test_keyframes_record_edit_play_and_save(robot, tmp_path: Path):
    panel = _panel(robot)
    panel.record("a", "first")
    assert panel.preview_joints("a", Q_GOAL).ok
    panel.move("a")
    assert panel.wait(60.0) and panel.outcome.ok
    panel.record("a")
    kfs = panel.program.keyframes
    assert [k.name for k in kfs] == ["first", "k2"]
    panel.rename("a", 1, "second")
    panel.set_timing("a", 0, dwell=0.2)
    with pytest.raises(InputError, match="dwell"):
        panel.set_timing("a", 0, dwell=-1.0)
    with pytest.raises(InputError, match="no keyframe 5"):
        panel.rename("a", 5, "x")
    with pytest.raises(ControlDenied):
        panel.rename("b", 0, "x")
    ts, qs = panel.preview_playback("a")
    assert ts[-1] > 0 and qs.shape == (ts.size, robot.arm.dof)
    np.testing.assert_allclose(qs[-1], Q_GOAL, atol=0.01)  # ends at the last keyframe
    panel.move_keyframe("a", 1, 0)  # now: second, first
    assert [k.name for k in panel.program.keyframes] == ["second", "first"]
    panel.play("a")
    assert panel.wait(60.0) and panel.outcome.ok, panel.outcome
    first = panel.program.keyframes[1]
    q_end = robot.bus.read_joints()
    idx = [robot.arm.joint_index(n) for n in panel.program.joints]
    np.testing.assert_allclose(q_end[idx], first.q, atol=0.01)  # at the last keyframe
    path = tmp_path / "panel.yaml"
    panel.save("a", path)
    back = load_keyframes(path, robot.arm)  # the file reader of armctl play
    assert [k.name for k in back.keyframes] == ["second", "first"]
    assert back.keyframes[1].dwell == pytest.approx(0.2)
    np.testing.assert_allclose(back.keyframes[0].q, panel.program.keyframes[0].q, atol=1e-6)
    np.testing.assert_allclose(back.keyframes[0].q, Q_GOAL[idx], atol=0.01)  # recorded there
    text = path.read_text()
    with pytest.raises(InputError, match="exists already"):
        panel.save("a", path)  # no silent overwrite
    assert path.read_text() == text
    panel.delete_keyframe("a", 0)
    panel.save("a", path, overwrite=True)
    assert len(load_keyframes(path, robot.arm).keyframes) == 1
    with pytest.raises(InputError, match=r"\.yaml"):
        panel.save("a", tmp_path / "panel.txt")
    panel.load("a", path)
    assert [k.name for k in panel.program.keyframes] == ["first"]


def test_pause_resume_and_speed_go_to_the_robots_motion_control(robot):
    panel = _panel(robot)
    panel.pause("a")
    assert robot.control.paused
    panel.resume("a")
    assert not robot.control.paused
    assert panel.set_speed("a", 0.5) == pytest.approx(0.5)
    assert robot.control.speed == pytest.approx(0.5)
    with pytest.raises(InputError):
        panel.set_speed("a", 0.0)
    with pytest.raises(ControlDenied):
        panel.pause("b")


def test_continuous_recording_in_simulated_time():
    """Who records, what is refused meanwhile, the time stamps, and the samples on the bus."""
    clock = SimulatedClock()
    with Robot.open("so101", sim=True, clock=clock, exit_policy=ExitPolicy.HOLD) as robot:
        panel = _panel(robot)
        with pytest.raises(ControlDenied, match="a has control"):
            panel.start_recording("b")
        with pytest.raises(InputError, match="outside 1 to 100 Hz"):
            panel.start_recording("a", rate_hz=500.0)
        panel.start_recording("a", rate_hz=10.0, duration=1.0)
        assert _ended(panel)
        program = panel.program
        assert len(program.keyframes) == 11  # 0 to 1 s at 10 Hz, both ends
        times = [kf.time for kf in program.keyframes]
        np.testing.assert_allclose(times, np.arange(11) * 0.1, atol=1e-9)
        bus = robot.bus.read_joints()
        idx = [robot.arm.joint_index(n) for n in program.joints]
        for kf in program.keyframes:
            np.testing.assert_allclose(kf.q, bus[idx], atol=1e-3)  # the arm did not move
        # a second recording continues the time stamps after the last one
        panel.start_recording("a", rate_hz=20.0, duration=0.5)
        assert _ended(panel)
        later = [kf.time for kf in panel.program.keyframes[11:]]
        assert len(later) == 11 and later[0] == pytest.approx(1.05)
        assert np.all(np.diff(later) > 0)


def _ended(panel: ControlPanel, timeout: float = 30.0) -> bool:
    """Wait for a recording with a duration to end (simulated time: at once, in real time)."""
    end = time.monotonic() + timeout
    while panel.recording and time.monotonic() < end:
        time.sleep(0.01)
    return not panel.recording


def test_a_running_recording_refuses_edits_and_ends_with_control(robot):
    panel = _panel(robot)
    panel.start_recording("a", rate_hz=5.0)
    try:
        assert panel.recording
        with pytest.raises(PanelBusy, match="stop the recording first"):
            panel.record("a")
        with pytest.raises(PanelBusy, match="stop the recording first"):
            panel.load("a", "any.yaml")
        with pytest.raises(PanelBusy, match="runs already"):
            panel.start_recording("a")
        with pytest.raises(ControlDenied):
            panel.stop_recording("b")
        panel.take_control("b", force=True)  # a handover ends the recording of a
        assert _ended(panel, 10.0)
    finally:
        panel.stop_recording()


@pytest.mark.realtime  # the recording samples a motion that runs in its own thread
def test_recording_a_move_saves_a_timed_keyframe_file(tmp_path: Path):
    """Recorded while Move runs (wall-clock time): the samples go from the start to the goal."""
    with Robot.open("so101", sim=True, clock=WallClock(), exit_policy=ExitPolicy.HOLD) as robot:
        _record_a_move(robot, tmp_path)


def _record_a_move(robot: Robot, tmp_path: Path) -> None:
    panel = _panel(robot)
    start = robot.bus.read_joints()
    goal = start.copy()
    goal[0] += 0.4
    panel.set_speed("a", 0.5)  # a move of a second or two
    assert panel.preview_joints("a", goal).ok
    panel.start_recording("a", rate_hz=20.0)
    panel.move("a")
    assert panel.wait(60.0) and panel.outcome is not None and panel.outcome.ok
    end = robot.bus.read_joints()
    n_moved = len(panel.program.keyframes)
    deadline = time.monotonic() + 30.0
    while len(panel.program.keyframes) < n_moved + 3 and time.monotonic() < deadline:
        time.sleep(0.02)  # a few samples at rest at the goal
    panel.stop_recording("a")
    assert not panel.recording
    kfs = panel.program.keyframes
    i0 = robot.arm.joint_index(panel.program.joints[0])
    first = np.array([kf.q[0] for kf in kfs])
    assert abs(first[0] - start[i0]) < 0.02 and abs(first[-1] - end[i0]) < 2e-3
    between = (first > start[i0] + 0.05) & (first < goal[i0] - 0.05)
    assert between.sum() >= 3, first  # it sampled the arm on its way
    assert np.all(np.diff([kf.time for kf in kfs]) > 0)
    out = panel.save("a", tmp_path / "recorded.yaml")
    back = load_keyframes(out, robot.arm)  # the keyframe reader of armctl play
    assert len(back.keyframes) == len(kfs)
    np.testing.assert_allclose([kf.time for kf in back.keyframes], [kf.time for kf in kfs],
                               atol=1e-4)
    np.testing.assert_allclose([kf.q for kf in back.keyframes], [kf.q for kf in kfs],
                               atol=1e-6)


def test_a_loaded_pose_keyframe_is_edited_through_the_robots_checks(robot, tmp_path: Path):
    path = tmp_path / "poses.yaml"
    path.write_text(
        "armctl_keyframes: 1\narm: so101\nunits: {angle: deg, length: m}\n"
        "joints: [shoulder_pan, shoulder_lift, elbow_flex, wrist_flex, wrist_roll]\n"
        "keyframes:\n- {name: start, q: [0, -30, 60, 20, 0]}\n"
        "- {name: above, pose: {xyz: [0.22, 0.0, 0.12]}}\n")
    panel = _panel(robot)
    panel.load("a", path)
    new = robot.arm.fk(Q_GOAL)  # a pose the arm reaches (FK of a valid configuration)
    with pytest.raises(ControlDenied):
        panel.set_keyframe_pose("b", 1, new, orientation=False)
    with pytest.raises(InputError, match="holds joint values, not a pose"):
        panel.set_keyframe_pose("a", 0, new)
    preview = panel.set_keyframe_pose("a", 1, new, orientation=False)
    assert preview.ok and preview.ghost is not None
    assert np.linalg.norm(robot.arm.fk(preview.ghost)[:3, 3] - new[:3, 3]) < 1e-3
    kf = panel.program.keyframes[1]
    np.testing.assert_allclose(kf.pose, new)
    assert kf.orientation is False
    far = new.copy()
    far[:3, 3] = [2.0, 0.0, 0.5]  # metres beyond the reach
    with pytest.raises(InputError, match="keeps its pose: the new one is unreachable"):
        panel.set_keyframe_pose("a", 1, far, orientation=False)
    assert panel.preview is not None and panel.preview.kind is PreviewKind.UNREACHABLE
    np.testing.assert_allclose(panel.program.keyframes[1].pose, new)  # unchanged
    out = panel.save("a", tmp_path / "edited.yaml")
    back = load_keyframes(out, robot.arm)  # the file reader of armctl play
    np.testing.assert_allclose(back.keyframes[1].pose[:3, 3], new[:3, 3], atol=1e-6)
    assert back.keyframes[1].orientation is False


def test_a_keyframe_takes_its_own_interpolation_into_the_file(robot, tmp_path: Path):
    panel = _panel(robot)
    panel.record("a", "here")
    panel.record("a", "again")
    panel.set_keyframe_interpolation("a", 1, Interpolation.LINEAR)
    assert panel.program.keyframes[1].interpolation is Interpolation.LINEAR
    with pytest.raises(ControlDenied):
        panel.set_keyframe_interpolation("b", 1, Interpolation.CUBIC)
    with pytest.raises(InputError, match="no keyframe 2"):
        panel.set_keyframe_interpolation("a", 2, Interpolation.CUBIC)
    path = panel.save("a", tmp_path / "kinds.yaml")
    back = load_keyframes(path, robot.arm)  # the file reader of armctl play
    assert [k.interpolation for k in back.keyframes] == [None, Interpolation.LINEAR]
    panel.set_keyframe_interpolation("a", 1, None)
    assert panel.program.keyframes[1].interpolation is None
