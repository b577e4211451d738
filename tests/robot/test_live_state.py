"""The live state a port's owner publishes, and watching it from another connection.

Publisher and watchers run in this process over a real Unix domain socket; the end-to-end check
with separate processes is in ``tests/cli/test_status_attach.py``.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import socket
import stat
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from armctl_testpaths import CONFIGS

from armctl.robot.live_publisher import ControlReading, LivePublisher, cycle_hook, hello_for
from armctl.robot.live_state import (
    PROTOCOL_VERSION,
    Activity,
    LiveHello,
    LiveSnapshot,
    LiveStateError,
    decode_line,
    runtime_dir,
    socket_path,
)
from armctl.robot.live_watch import OwnerGone, attach

pytestmark = pytest.mark.timeout(60)

PORT = "/dev/null"  # any existing path names a port here; nothing opens it
JOINTS = ("a", "b", "slide")
UNITS = ("rad", "rad", "m")


@pytest.fixture(autouse=True)
def runtime(monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """A private runtime directory with a short path (Unix socket paths are short)."""
    base = Path(tempfile.mkdtemp(prefix="al"))
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(base))
    try:
        yield base
    finally:
        shutil.rmtree(base, ignore_errors=True)


def publisher(rate_hz: float = 50.0, joints: tuple[str, ...] = JOINTS,
              units: tuple[str, ...] = UNITS, **kw: object) -> LivePublisher:
    hello = hello_for("arm1", "arm1.yaml", PORT, joints, units, rate_hz,
                      argv=["/usr/bin/armctl", "play", "arm1.yaml", "p.yaml", "--port", PORT])
    return LivePublisher(hello, rate_hz, **kw).start()  # type: ignore[arg-type]


def test_snapshots_arrive_with_the_stored_values() -> None:
    with publisher() as pub:
        pub.cycle(Activity.PLAY, "play p.yaml", 0.5, 2.0, np.array([0.1, -0.2, 0.03]),
                  np.array([0.11, -0.19, 0.031]))
        watcher = attach(PORT)
        assert watcher is not None
        with watcher:
            h = watcher.hello
            assert (h.arm, h.config, h.port, h.pid, h.verb) == ("arm1", "arm1.yaml", PORT,
                                                                 os.getpid(), "play")
            assert h.command == f"armctl play arm1.yaml p.yaml --port {PORT}"
            assert h.joints == JOINTS and h.units == UNITS
            first = watcher.next()
            assert first.activity is Activity.PLAY and first.description == "play p.yaml"
            assert first.t == 0.5 and first.duration == 2.0 and first.progress == 0.25
            assert first.commanded == (0.1, -0.2, 0.03)
            assert first.measured == (0.11, -0.19, 0.031)
            pub.cycle(Activity.PLAY, "play p.yaml", 1.5, 2.0, np.array([0.4, 0.0, 0.0]), None)
            later = watcher.next()
            while later.t != 1.5:
                later = watcher.next()
            assert later.commanded == (0.4, 0.0, 0.0)
            assert later.measured == (0.11, -0.19, 0.031)  # None kept the last reading
            assert later.seq > first.seq
            pub.idle()
            idle = watcher.next()
            while idle.activity is not Activity.IDLE:
                idle = watcher.next()
            assert idle.t is None and idle.duration is None and idle.progress is None
            assert idle.commanded == (0.4, 0.0, 0.0)


def test_the_line_format(runtime: Path) -> None:
    """Every line is one JSON object with the documented fields, and round-trips."""
    with publisher() as pub:
        pub.cycle(Activity.MOVE, "move", 0.25, 1.0, np.zeros(3), np.ones(3), stopping=True)
        pub.torque = True
        conn = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        conn.connect(str(socket_path(PORT)))
        stream = conn.makefile("rb")
        lines = [stream.readline() for _ in range(3)]
        conn.close()
    hello, snap = json.loads(lines[0]), json.loads(lines[1])
    assert set(hello) == {"type", "version", "arm", "config", "port", "real_port", "pid",
                          "command", "verb", "joints", "units", "rate_hz", "started"}
    assert hello["type"] == "hello" and hello["version"] == PROTOCOL_VERSION
    assert set(snap) == {"type", "seq", "time", "activity", "description", "t", "duration",
                         "measured", "commanded", "age", "stopping", "paused", "speed", "torque"}
    assert snap["type"] == "snapshot" and snap["activity"] == "move"
    assert snap["measured"] == [1.0, 1.0, 1.0] and snap["commanded"] == [0.0, 0.0, 0.0]
    assert snap["stopping"] is True and snap["torque"] is True
    assert snap["paused"] is None and snap["speed"] is None  # no control given
    assert abs(snap["time"] - time.time()) < 5.0 and 0.0 <= snap["age"] < 5.0
    parsed = decode_line(lines[1])
    assert isinstance(parsed, LiveSnapshot) and parsed.as_json() == snap
    parsed_hello = decode_line(lines[0])
    assert isinstance(parsed_hello, LiveHello) and parsed_hello.as_json() == hello
    assert decode_line(b'{"type": "end"}') is None
    for bad in (b"not json", b'{"type": "what"}', b'{"type": "snapshot", "seq": 1}',
                json.dumps({**hello, "version": PROTOCOL_VERSION + 1}).encode()):
        with pytest.raises(LiveStateError):
            decode_line(bad)


def test_pause_and_speed_come_from_the_control() -> None:
    state = {"reading": ControlReading(paused=True, speed=0.4)}
    with publisher(control=lambda: state["reading"]) as pub:
        assert (pub.snapshot().paused, pub.snapshot().speed) == (True, 0.4)
        state["reading"] = ControlReading(paused=False, speed=1.0)
        assert (pub.snapshot().paused, pub.snapshot().speed) == (False, 1.0)

        def broken() -> ControlReading:
            raise RuntimeError("control gone")

        pub.control = broken
        snap = pub.snapshot()  # a failing control shows nothing and breaks nothing
        assert snap.paused is None and snap.speed is None


def test_a_stalled_watcher_is_dropped_and_others_go_on() -> None:
    """A watcher that never reads fills its socket and is dropped; the others keep up."""
    many = tuple(f"j{i}" for i in range(3000))  # ~60 kB per snapshot: buffers fill at once
    with publisher(rate_hz=100.0, joints=many, units=("rad",) * len(many)) as pub:
        pub.cycle(Activity.MOVE, "move", 0.0, 1.0, np.full(len(many), 0.123456789),
                  np.full(len(many), 0.987654321))
        stalled = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        stalled.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        stalled.connect(pub.path)
        watcher = attach(PORT)
        assert watcher is not None
        with watcher:
            got = 0
            deadline = time.monotonic() + 20.0
            while (pub.dropped == 0 or got < 50) and time.monotonic() < deadline:
                watcher.next(timeout=5.0)
                got += 1
                if got % 10 == 0:  # the owner's loop goes on storing, never blocked
                    t0 = time.perf_counter()
                    pub.cycle(Activity.MOVE, "move", got / 100, 1.0, None, None)
                    assert time.perf_counter() - t0 < 0.05
            assert pub.dropped >= 1, "the stalled watcher was never dropped"
            assert got >= 50 and pub.watchers == 1
        stalled.close()


def test_a_watcher_that_went_away_is_dropped() -> None:
    with publisher() as pub:
        gone = attach(PORT)
        stay = attach(PORT)
        assert gone is not None and stay is not None
        deadline = time.monotonic() + 5.0
        while pub.watchers < 2 and time.monotonic() < deadline:
            time.sleep(0.01)
        assert pub.watchers == 2
        gone.close()
        for _ in range(10):
            stay.next()
        assert pub.watchers == 1 and pub.dropped == 1
        stay.close()


def test_close_ends_the_watch_and_removes_the_socket() -> None:
    pub = publisher()
    path = Path(pub.path)
    assert stat.S_ISSOCK(path.stat().st_mode) and stat.S_IMODE(path.stat().st_mode) == 0o600
    watcher = attach(PORT)
    assert watcher is not None
    watcher.next()
    pub.close()
    with pytest.raises(OwnerGone, match=f"pid {os.getpid()} .*released the port"):
        while True:
            watcher.next()
    assert watcher.ended is not None and "released the port" in watcher.ended
    assert list(watcher.snapshots()) == []
    watcher.close()
    assert not path.exists()
    assert attach(PORT) is None
    pub.close()  # twice is fine


def test_a_stale_socket_is_replaced() -> None:
    """An owner that died left its socket: watchers find nobody, a new owner replaces it."""
    path = socket_path(PORT, create_dir=True)
    dead = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    dead.bind(str(path))
    dead.listen(1)
    dead.close()  # the file stays, nobody listens: connecting is refused
    assert path.exists()
    assert attach(PORT) is None
    with publisher() as pub:
        assert pub.path == str(path)
        watcher = attach(PORT)
        assert watcher is not None and watcher.hello.pid == os.getpid()
        watcher.close()
    assert not path.exists()


def test_an_old_owner_leaves_a_new_owners_socket() -> None:
    """Closing removes the socket only while it is its own (a new owner may have replaced it)."""
    first = publisher()
    second = publisher()  # the port changed hands (the first owner was stuck, say)
    first.close()
    assert Path(second.path).exists()
    watcher = attach(PORT)
    assert watcher is not None
    watcher.close()
    second.close()
    assert not Path(second.path).exists()


def test_the_wait_for_an_owner_that_opens_the_port() -> None:
    t0 = time.monotonic()
    assert attach(PORT, wait=0.3) is None
    assert time.monotonic() - t0 >= 0.3


def test_the_runtime_directory_is_private(runtime: Path) -> None:
    path = runtime_dir(create=True)
    assert path == runtime / "armctl"
    assert stat.S_IMODE(path.stat().st_mode) == 0o700
    path.chmod(0o755)  # opened to others: a false owner could plant a socket
    with pytest.raises(LiveStateError, match="not a private directory"):
        runtime_dir()
    with pytest.raises(LiveStateError):
        LivePublisher(hello_for("a", "a", PORT, JOINTS, UNITS))
    path.chmod(0o700)
    assert runtime_dir() == path


def test_a_socket_path_too_long_is_refused(monkeypatch: pytest.MonkeyPatch,
                                           runtime: Path) -> None:
    deep = runtime / ("d" * 120)
    deep.mkdir()
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(deep))
    with pytest.raises(LiveStateError, match="longer than a Unix socket allows"):
        socket_path(PORT)


def test_ports_are_named_by_their_real_path(runtime: Path) -> None:
    link = runtime / "by-id-link"
    link.symlink_to(PORT)
    assert socket_path(str(link)) == socket_path(PORT)
    assert socket_path("/dev/zero") != socket_path(PORT)
    with publisher():
        watcher = attach(str(link))
        assert watcher is not None and watcher.hello.real_port == PORT
        watcher.close()


def test_the_cycle_hook_stores_every_cycle_and_calls_on() -> None:
    from armctl.robot.executor import CycleInfo

    seen: list[float] = []
    with publisher() as pub:
        hook = cycle_hook(pub, Activity.JOG, "jog x", lambda info: seen.append(info.t))
        hook(CycleInfo(0.2, 0.8, np.array([1.0, 2.0, 0.01]), np.array([1.1, 2.1, 0.011]),
                       0.1, False))
        snap = pub.snapshot()
    assert seen == [0.2]
    assert snap.activity is Activity.JOG and snap.description == "jog x"
    assert (snap.t, snap.duration) == (0.2, 0.8)
    assert snap.commanded == (1.0, 2.0, 0.01) and snap.measured == (1.1, 2.1, 0.011)


@pytest.mark.usefixtures("simulated_time")
def test_a_robot_on_a_port_publishes_its_motions() -> None:
    """A robot on an ``armctl sim`` pty publishes every cycle; on the built-in bus it does not."""
    from armctl.config import load_spec
    from armctl.robot import Robot
    from armctl.servo import simulated_bus

    spec = load_spec(CONFIGS / "so101.yaml")
    goal = np.array([0.3, -0.2, 0.2, 0.1, 0.2, 0.3])
    with simulated_bus(spec) as sim, Robot.open(CONFIGS / "so101.yaml", port=sim.port) as robot:
        live = robot.live
        assert live is not None
        watcher = attach(sim.port)
        assert watcher is not None
        with watcher:
            assert watcher.hello.arm == "so101" and watcher.hello.port == sim.port
            assert watcher.hello.joints == robot.bus.joint_names
            cycles: list[tuple[LiveSnapshot, np.ndarray, np.ndarray, float]] = []
            robot.move_joints(goal, on_cycle=lambda i: cycles.append(
                (live.snapshot(), i.command.copy(), i.measured.copy(), i.t)))
            assert len(cycles) > 20
            for snap, cmd, meas, t in cycles:
                assert snap.activity is Activity.MOVE and snap.t == t
                assert snap.commanded == tuple(cmd) and snap.measured == tuple(meas)
                assert snap.torque is True and snap.paused is False and snap.speed == 1.0
            assert cycles[-1][0].duration == pytest.approx(cycles[-1][3], abs=0.05)
            after = live.snapshot()
            assert after.activity is Activity.IDLE
            assert np.allclose(after.measured, goal, atol=3 * 2 * math.pi / 4096)
            with_play: list[LiveSnapshot] = []
            from armctl.motion import Keyframe, KeyframeProgram

            program = KeyframeProgram("so101", robot.arm.joint_names, (Keyframe(q=(0.0,) * 6),))
            robot.play(program, on_cycle=lambda i: with_play.append(live.snapshot()))
            assert with_play and {s.activity for s in with_play} == {Activity.PLAY}
            assert watcher.next().measured is not None
        path = live.path
    assert robot.live is None and not Path(path).exists()
    with Robot.open(CONFIGS / "so101.yaml", sim=True) as robot:
        assert robot.live is None  # the built-in bus: no other process can reach it


@pytest.mark.usefixtures("simulated_time")
def test_teleoperation_publishes_both_arms() -> None:
    """Leader and follower on ``armctl sim`` ptys: each publishes its side of every cycle."""
    from armctl.config import load_spec
    from armctl.config.motion import ExitPolicy
    from armctl.robot import Robot
    from armctl.robot.teleop import Teleop, TeleopCycle, TeleopOptions
    from armctl.servo import simulated_bus

    lead_spec, fol_spec = load_spec("so101_leader"), load_spec("so101")
    with simulated_bus(lead_spec) as lead_sim, simulated_bus(fol_spec) as fol_sim, \
            Robot.open("so101_leader", port=lead_sim.port, hold=False,
                       exit_policy=ExitPolicy.HOLD) as lead, \
            Robot.open("so101", port=fol_sim.port, exit_policy=ExitPolicy.HOLD) as fol:
        assert lead.live is not None and fol.live is not None
        assert lead.live.path != fol.live.path  # one socket per port
        tele = Teleop(lead, fol, TeleopOptions(duration=0.3))
        lead.bus.set_torque(False)
        tele.start()
        seen: list[tuple[LiveSnapshot, LiveSnapshot, TeleopCycle]] = []
        fol_live, lead_live = fol.live, lead.live
        tele.run(lambda c: seen.append((fol_live.snapshot(), lead_live.snapshot(), c)))
        assert len(seen) > 10
        for fs, ls, c in seen:
            assert fs.activity is Activity.TELEOP and ls.activity is Activity.TELEOP
            assert fs.commanded == tuple(c.command) and fs.t == pytest.approx(c.t)
            assert ls.measured == tuple(c.leader) and ls.commanded is None
        assert fol_live.snapshot().activity is Activity.IDLE  # the run ended
        assert lead_live.snapshot().activity is Activity.IDLE


@pytest.mark.usefixtures("simulated_time")
def test_torque_as_watchers_see_it(tmp_path: Path) -> None:
    """On while holding; unknown while teaching leaves the gripper on; off when all are limp."""
    from armctl.config import load_spec
    from armctl.config.motion import ExitPolicy
    from armctl.robot import Robot
    from armctl.robot.teach import TeachSession
    from armctl.servo import simulated_bus

    spec = load_spec(CONFIGS / "so101.yaml")
    with simulated_bus(spec) as sim, Robot.open(CONFIGS / "so101.yaml", port=sim.port,
                                                exit_policy=ExitPolicy.HOLD) as robot:
        live = robot.live
        assert live is not None and live.snapshot().torque is True  # opened holding
        teach = TeachSession(robot, tmp_path / "a.yaml")  # the gripper stays on
        teach.start()
        assert live.snapshot().torque is None
        assert [s.torque for s in sim.servos].count(False) == 5  # the simulator agrees
        teach.set_limp(False)
        assert live.snapshot().torque is True
        every = TeachSession(robot, tmp_path / "b.yaml", release=robot.bus.joint_names)
        every.start()
        assert live.snapshot().torque is False
        assert not any(s.torque for s in sim.servos)
        every.set_limp(False)
        assert live.snapshot().torque is True and all(s.torque for s in sim.servos)


def test_unknown_values_are_null_in_strict_json() -> None:
    """A joint value that is not known (NaN) goes out as null and comes back as NaN."""
    with publisher() as pub:
        pub.cycle(Activity.MOVE, "move", 0.1, 1.0, np.array([0.1, np.nan, 0.0]),
                  np.array([np.nan, 0.2, 0.0]))
        conn = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        conn.connect(pub.path)
        stream = conn.makefile("rb")
        stream.readline()
        line = stream.readline()
        conn.close()
    data = json.loads(line, parse_constant=lambda c: pytest.fail(f"non-strict JSON: {c}"))
    assert data["measured"] == [None, 0.2, 0.0] and data["commanded"] == [0.1, None, 0.0]
    snap = decode_line(line)
    assert isinstance(snap, LiveSnapshot) and snap.measured is not None
    assert math.isnan(snap.measured[0]) and snap.measured[1:] == (0.2, 0.0)


def test_an_owner_that_dies_ends_the_watch() -> None:
    """The connection breaks without an ``end`` line (the owner was killed): the watch ends."""
    import threading

    hello = hello_for("arm1", "arm1", PORT, JOINTS, UNITS)
    server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    server.bind(str(socket_path(PORT, create_dir=True)))
    server.listen(1)

    def die_after_one() -> None:
        conn, _ = server.accept()
        snap = LivePublisher(hello, path=str(socket_path(PORT)) + "x").snapshot()
        conn.sendall((json.dumps(hello.as_json()) + "\n" + json.dumps(snap.as_json())
                      + "\n").encode())
        conn.close()

    thread = threading.Thread(target=die_after_one, daemon=True)
    thread.start()
    watcher = attach(PORT)
    assert watcher is not None
    watcher.follow()
    thread.join(timeout=10)
    deadline = time.monotonic() + 10.0
    while watcher.ended is None and time.monotonic() < deadline:
        watcher.wait_newer(0, 0.1)
    assert watcher.latest is not None and watcher.latest.seq == 0
    assert watcher.ended == f"pid {os.getpid()} ({hello.command}) exited or stopped publishing"
    with pytest.raises(OwnerGone):
        watcher.next()
    watcher.close()
    server.close()
