"""The live view: serves its page on localhost, shows the arm at FK, follows a joint source,
runs IK from the draggable target, and stops cleanly."""

from __future__ import annotations

import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest
from render_indep import IndependentArm

from armctl.arm import load_arm
from armctl.render.live import LiveView

DATA = Path(__file__).parent / "data"


@pytest.fixture(scope="module")
def view():
    arm = load_arm(DATA / "shapes5.yaml")
    v = LiveView(arm, "127.0.0.1", 0)
    v.start()
    yield v
    v.stop()


def test_serves_its_page_on_localhost(view):
    assert view.port > 0 and view.url == f"http://127.0.0.1:{view.port}/"
    with urllib.request.urlopen(view.url, timeout=10) as resp:
        assert resp.status == 200
        assert resp.headers.get("content-type", "").startswith("text/html")
        assert b"<html" in resp.read(4096).lower()


def test_link_nodes_sit_at_fk(view):
    ind = IndependentArm(DATA / "shapes5.yaml")
    q = np.array([0.4, -0.3, 0.9, 0.02])
    view.set_q(q)
    for link in ("l1", "l2", "l3", "flange", "l4"):
        np.testing.assert_allclose(view.link_pose(link), ind.link_pose(link, q), atol=1e-6)


def test_follows_a_joint_source():
    arm = load_arm(DATA / "shapes5.yaml")
    q = np.array([0.1, 0.2, -0.3, 0.01])
    with LiveView(arm, "127.0.0.1", 0) as v:
        v.follow(lambda: q, rate=50.0)
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline and not np.allclose(v.q, q):
            time.sleep(0.02)
        np.testing.assert_allclose(v.q, q)


def test_stops_cleanly():
    arm = load_arm(Path(__file__).parent.parent / "data" / "planar3r.yaml")
    v = LiveView(arm, "127.0.0.1", 0)
    url = v.start()
    with urllib.request.urlopen(url, timeout=10) as resp:
        assert resp.status == 200
    v.stop()
    v.stop()  # idempotent
    with pytest.raises(OSError):
        urllib.request.urlopen(url, timeout=2)


def test_draggable_target_runs_ik(view):
    arm = view.arm
    view.set_q([0.3, -0.2, 0.4, 0.02])
    goal = arm.fk(np.array([0.5, -0.4, 0.6, 0.03]))
    view.set_target(goal)
    np.testing.assert_allclose(view.target_pose(), goal, atol=1e-6)
    assert view.solve_target() is True
    assert "converged" in view.ik_status
    np.testing.assert_allclose(arm.fk(view.q), goal, atol=1e-4)
    # an unreachable target leaves the arm where it is and says why
    before = view.q.copy()
    far = goal.copy()
    far[:3, 3] = [5.0, 0.0, 0.0]
    view.set_target(far)
    assert view.solve_target() is False
    assert "unreachable" in view.ik_status or "error" in view.ik_status
    np.testing.assert_allclose(view.q, before)


def test_follows_the_simulated_servo_bus():
    from armctl.servo import ArmBus

    arm = load_arm("so101")
    with ArmBus.from_spec(arm.spec) as bus, LiveView(arm, "127.0.0.1", 0) as v:
        bus.set_torque(True)
        goal = arm.middle()
        goal[0] += 0.3
        bus.write_joints(goal)
        v.follow(bus.read_joints, rate=50.0)
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline and abs(v.q[0] - goal[0]) > 0.01:
            time.sleep(0.05)
        assert abs(v.q[0] - goal[0]) < 0.01
        q, pose = v.shown("shoulder_link")  # one consistent reading while the view follows
        np.testing.assert_allclose(pose, arm.fk(q, "shoulder_link"), atol=1e-6)
