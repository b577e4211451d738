"""One process owns a port, others watch it: ``status`` and ``view`` attach to a running motion.

End to end: ``armctl sim so101`` runs in its own process, ``armctl move-joints ... --port PTY``
in another (it owns the port), and ``armctl status so101 --port PTY`` in a third attaches to it
instead of failing on the port lock. The joints it reports are checked against the simulator's
own reading of its servos.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from armctl_testpaths import DATA
from sim_process import SO_JOINTS, SimProcess

from armctl.cli import main
from armctl.robot.live_publisher import LivePublisher, hello_for
from armctl.robot.live_state import Activity
from armctl.robot.live_watch import attach

pytestmark = pytest.mark.timeout(120)

GOAL = (0.4, -0.2, 0.2, 0.1, 0.2, 0.2)
#: One STS3215 tick (4096 per turn) [rad].
TICK = 2 * np.pi / 4096


@pytest.fixture
def runtime(monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """A private runtime directory for this process and the ones it starts."""
    base = Path(tempfile.mkdtemp(prefix="al"))
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(base))
    try:
        yield base
    finally:
        shutil.rmtree(base, ignore_errors=True)


def _env() -> dict[str, str]:
    return dict(os.environ, PYTHONUNBUFFERED="1")


@pytest.fixture
def sim(runtime: Path) -> Iterator[SimProcess]:
    s = SimProcess()
    try:
        yield s
    finally:
        s.close()


def _warm(argv: list[str]) -> subprocess.Popen[str]:
    """``armctl ARGV`` in a process that has imported armctl and waits for a line on stdin.

    Starting Python and importing NumPy and armctl takes seconds on a busy machine; the test
    starts the watcher while the motion runs, so it imports first and runs on a signal.
    """
    code = ("import sys\n"
            "import armctl.cli.bus, armctl.cli._watch, armctl.cli.move, armctl.cli._scene\n"
            "import armctl.kinematics.model, armctl.robot, armctl.robot.live_watch\n"
            "from armctl.cli import main\n"
            "sys.stdin.readline()\n"
            f"sys.argv = ['armctl', *{argv!r}]\n"  # as the armctl program has it
            f"sys.exit(main({argv!r}))\n")
    return subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=_env())


def _go(proc: subprocess.Popen[str]) -> None:
    assert proc.stdin is not None
    proc.stdin.write("go\n")
    proc.stdin.flush()


def _wait_for_owner(port: str, mover: subprocess.Popen[str], timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        assert mover.poll() is None, mover.communicate()
        watcher = attach(port)
        if watcher is not None:
            snap = watcher.next()
            watcher.close()
            if snap.activity is Activity.MOVE:
                return
        time.sleep(0.05)
    raise AssertionError("the moving command never published its motion")


def test_status_attaches_to_a_running_motion(sim: SimProcess) -> None:
    start = sim.joints()
    watch = _warm(["status", "so101", "--port", sim.port, "--json", "--follow",
                   "--interval", "0.1"])
    mover = _warm(["move-joints", "so101", *map(str, GOAL), "--port", sim.port, "--speed",
                   "0.15", "--json"])
    try:
        _go(mover)
        _wait_for_owner(sim.port, mover)
        _go(watch)
        out, err = watch.communicate(timeout=60)
        moved_out, moved_err = mover.communicate(timeout=60)
    finally:
        for p in (watch, mover):
            if p.poll() is None:
                p.kill()
                p.wait()
    assert watch.returncode == 0, err
    assert mover.returncode == 0, moved_err
    assert json.loads(moved_out)["ok"] is True
    lines = [json.loads(line) for line in out.splitlines()]
    states = [d for d in lines if "state" in d]
    assert len(states) >= 5, lines
    for d in lines:
        assert d["schema"] == "armctl/1" and d["command"] == "status" and d["ok"] is True
        assert d["attached"] is True
        owner = d["owner"]
        assert owner["pid"] == mover.pid and owner["verb"] == "move-joints"
        assert owner["command"].startswith("armctl move-joints so101 0.4 ")
        assert owner["port"] == sim.port and owner["arm"] == "so101"
        assert owner["joints"] == list(SO_JOINTS)
    assert "released the port" in lines[-1]["ended"]
    measured = np.array([[j["measured"] for j in d["joints"]] for d in states])
    moving = [d["state"]["t"] for d in states if d["state"]["activity"] == "move"]
    assert len(moving) >= 3 and moving == sorted(moving), "plan time goes forward"
    assert all(0.0 <= t <= d + 0.1 for t, d in zip(
        moving, [d["state"]["duration"] for d in states if d["state"]["activity"] == "move"],
        strict=True)), [(d["state"]["t"], d["state"]["duration"]) for d in states]
    # the joints change over time, each towards its goal, and end there
    steps = np.diff(measured, axis=0) * np.sign(np.array(GOAL) - start)
    assert np.all(steps >= -3 * TICK), "a joint went backwards"
    assert float(np.max(np.abs(measured[-1] - measured[0]))) > 0.05
    final = sim.joints()
    assert np.allclose(final, GOAL, atol=3 * TICK)
    assert np.allclose(measured[-1], final, atol=2 * TICK), (measured[-1], final)
    assert states[-1]["state"]["activity"] == "idle"
    # status computed the tool pose and the clearance from the measured joints
    assert states[-1]["tool"]["frame"] == "tcp" and len(states[-1]["tool"]["xyz"]) == 3
    assert states[-1]["clearance"] is not None
    # the port is free again: status reads it itself
    code = main(["status", "so101", "--port", sim.port, "--json"])
    assert code == 0


def test_a_port_held_by_another_program_is_named(sim: SimProcess,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    holder = subprocess.Popen(
        [sys.executable, "-c",
         "import fcntl, os, sys, time\n"
         f"fd = os.open({sim.port!r}, os.O_RDWR | os.O_NOCTTY)\n"
         "fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)\n"
         "print('held', flush=True)\n"
         "sys.stdin.readline()\n"],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "held"
        code = main(["status", "so101", "--port", sim.port, "--once"])
        err = capsys.readouterr().err
    finally:
        holder.communicate("\n", timeout=10)
    assert code == 4
    assert "port busy: in use by another program" in err
    assert f"pid {holder.pid}: " in err, err  # who holds it
    assert "fuser" in err and "armctl status" in err


def test_status_of_the_builtin_simulated_bus(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["status", "so101", "--sim", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["port"] == "sim" and data["attached"] is False
    assert [j["joint"] for j in data["joints"]] == list(SO_JOINTS)
    assert all(abs(j["position"]) <= 2 * TICK for j in data["joints"])
    # a converted URDF has no bus section: --sim gives it one simulated servo per joint
    urdf = DATA / "urdf" / "ur5e.urdf"
    assert main(["status", str(urdf), "--sim", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert len(data["joints"]) == 6
    assert main(["status", str(urdf), "--once"]) == 2
    assert "--sim" in capsys.readouterr().err
    assert main(["status", "so101", "--sim", "--port", "/dev/null"]) == 2


def test_status_follow_on_its_own_bus(capsys: pytest.CaptureFixture[str]) -> None:
    """``--json --follow`` prints one JSON line per reading (until Ctrl-C)."""
    import threading

    from armctl.robot.stop import SignalInterrupt

    timer = threading.Timer(1.5, lambda: os.kill(os.getpid(), 2))
    timer.start()
    try:
        code = main(["status", "so101", "--sim", "--json", "--follow", "--interval", "0.05"])
    except (KeyboardInterrupt, SignalInterrupt):
        code = 130
    finally:
        timer.cancel()
    lines = [json.loads(x) for x in capsys.readouterr().out.splitlines()
             if x.startswith('{"')]  # (the interrupt's error object is printed indented)
    assert code == 130
    assert len(lines) >= 3 and all(d["attached"] is False and d["port"] == "sim"
                                   for d in lines)


class _Owner:
    """An in-process owner publishing so101 joints for ``port``."""

    def __init__(self, port: str, q: tuple[float, ...]):
        hello = hello_for("so101", "so101", port, SO_JOINTS, ("rad",) * 6, 50.0,
                          argv=["armctl", "play", "so101", "x.yaml"])
        self.pub = LivePublisher(hello, 50.0).start()
        self.pub.cycle(Activity.PLAY, "play x.yaml", 0.1, 1.0, np.array(q), np.array(q))


def test_view_follows_the_owner_of_a_port(runtime: Path) -> None:
    """The view's follower shows the owner's joints and watches the port's next owner."""
    from armctl.arm import load_arm
    from armctl.cli._watch import OwnerFollower
    from armctl.render.live import LiveView

    port = "/dev/null"
    arm = load_arm("so101")
    first = _Owner(port, (0.1, 0.2, 0.3, 0.4, 0.5, 0.6))
    said: list[str] = []
    watcher = attach(port)
    assert watcher is not None
    follower = OwnerFollower(watcher, arm.name, arm.joint_names, arm.middle(), said.append)
    with LiveView(arm, port=0) as view:
        view.follow(follower.read, rate=50.0)
        deadline = time.monotonic() + 10.0
        while not np.allclose(view.shown("base_link")[0], first.pub.snapshot().measured) \
                and time.monotonic() < deadline:
            time.sleep(0.02)
        q, _ = view.shown("base_link")
        assert np.allclose(q, (0.1, 0.2, 0.3, 0.4, 0.5, 0.6))
        first.pub.close()  # the owner ends; the next one is watched in turn
        second = _Owner(port, (-0.1, -0.2, -0.3, -0.4, -0.5, -0.6))
        deadline = time.monotonic() + 10.0
        while not np.allclose(view.shown("base_link")[0], second.pub.snapshot().measured) \
                and time.monotonic() < deadline:
            time.sleep(0.02)
        assert np.allclose(view.shown("base_link")[0], (-0.1, -0.2, -0.3, -0.4, -0.5, -0.6))
        second.pub.close()
    follower.close()
    assert said[0].startswith(f"watching pid {os.getpid()}: armctl play so101")
    assert any("released the port" in s for s in said)
    assert sum(s.startswith("watching") for s in said) == 2


def test_view_port_options(runtime: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``--port`` is the bus the view follows, ``--http-port`` its server."""
    owner = _Owner("/dev/null", (0.0,) * 6)
    try:
        code = main(["view", "so101", "--port", "/dev/null", "--http-port", "0", "--duration",
                     "0.3", "--json"])
        data: dict[str, Any] = json.loads(capsys.readouterr().out)
    finally:
        owner.pub.close()
    assert code == 0 and data["bus"] is True and data["bus_port"] == "/dev/null"
    assert data["attached"]["pid"] == os.getpid() and data["url"].startswith("http://127.0.0.1:")
    assert data["http_port"] == int(data["url"].rsplit(":", 1)[1].strip("/"))
    assert main(["view", "so101", "--port", "8080"]) == 2
    err = capsys.readouterr().err
    assert "--http-port 8080" in err and "servo bus port" in err
    assert main(["view", "so101", "--http-port", "70000"]) == 2
    assert main(["view", "so101", "--sim", "--http-port", "0", "--duration", "0.2",
                 "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["bus"] is True and data["attached"] is None and data["bus_port"] == "sim"


def test_status_text_and_one_object(runtime: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The attached status as text and as one JSON object; another arm's config is refused."""
    q = (0.1, -0.2, 0.3, 0.0, 0.5, 0.6)
    owner = _Owner("/dev/null", q)
    owner.pub.torque = True
    try:
        assert main(["status", "so101", "--port", "/dev/null", "--once", "--deg"]) == 0
        text = capsys.readouterr().out
        assert main(["status", "so101", "--port", "/dev/null", "--json"]) == 0
        data = json.loads(capsys.readouterr().out)
        assert main(["status", "koch_follower", "--port", "/dev/null", "--once"]) == 2
        err = capsys.readouterr().err
    finally:
        owner.pub.close()
    assert f"is owned by pid {os.getpid()}: armctl play so101 x.yaml" in text
    assert "play: play x.yaml" in text and "0.10 / 1.00 s (10%)" in text and "torque on" in text
    row = next(line for line in text.splitlines() if line.startswith("elbow_flex"))
    assert row.split()[1:] == ["17.19", "17.19", "deg"]  # 0.3 rad, --deg
    assert "tool 'tcp'" in text and "clearance:" in text
    assert data["attached"] is True and data["owner"]["pid"] == os.getpid()
    assert [j["measured"] for j in data["joints"]] == list(q)
    state = data["state"]
    assert (state["activity"], state["t"], state["duration"]) == ("play", 0.1, 1.0)
    # the tool pose is forward kinematics of the measured joints
    from armctl.arm import load_arm

    pose = load_arm("so101").fk(np.array(q))
    assert np.allclose(data["tool"]["xyz"], pose[:3, 3], atol=1e-9)
    assert "driven by arm 'so101'" in err and "give its config (so101)" in err


def test_an_owner_that_sends_nothing_is_reported(runtime: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    """An owner that greets but sends no state (stopped, say) is an error, not a hang."""
    import socket
    import threading

    from armctl.robot.live_state import socket_path

    hello = hello_for("so101", "so101", "/dev/null", SO_JOINTS, ("rad",) * 6)
    server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    server.bind(str(socket_path("/dev/null", create_dir=True)))
    server.listen(1)

    def greet() -> None:
        conn, _ = server.accept()
        conn.sendall((json.dumps(hello.as_json()) + "\n").encode())
        conn.recv(1)  # until the watcher hangs up
        conn.close()

    thread = threading.Thread(target=greet, daemon=True)
    thread.start()
    try:
        code = main(["status", "so101", "--port", "/dev/null", "--once"])
    finally:
        thread.join(timeout=10)
        server.close()
    assert code != 0
    err = capsys.readouterr().err
    assert f"owned by pid {os.getpid()}" in err and "has sent no state for 2 s" in err


def test_an_owner_still_opening_the_port_is_waited_for(
        sim: SimProcess, capsys: pytest.CaptureFixture[str]) -> None:
    """The port is locked by an armctl command that starts publishing only a moment later."""
    code = ("import fcntl, os, sys, time\n"
            "from armctl.robot.live_publisher import LivePublisher, hello_for\n"
            f"fd = os.open({sim.port!r}, os.O_RDWR | os.O_NOCTTY)\n"
            "fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)\n"
            "print('locked', flush=True)\n"
            "time.sleep(1.5)\n"
            f"pub = LivePublisher(hello_for('so101', 'so101', {sim.port!r}, {SO_JOINTS!r}, "
            "('rad',) * 6, argv=['armctl', 'play', 'so101', 'p.yaml'])).start()\n"
            "sys.stdin.readline()\n"
            "pub.close()\n")
    # argv[0] 'armctl': the process looks like an armctl command (as 'ps' shows it)
    owner = subprocess.Popen(["armctl", "-c", code], executable=sys.executable,
                             stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                             env=_env())
    try:
        assert owner.stdout is not None and owner.stdout.readline().strip() == "locked"
        t0 = time.monotonic()
        code_status = main(["status", "so101", "--port", sim.port, "--json"])
        waited = time.monotonic() - t0
        data = json.loads(capsys.readouterr().out)
    finally:
        owner.communicate("\n", timeout=10)
    assert code_status == 0 and data["attached"] is True
    assert data["owner"]["pid"] == owner.pid and data["owner"]["verb"] == "play"
    assert waited < 5.0
