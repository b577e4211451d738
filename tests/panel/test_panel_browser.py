"""The control panel as a person uses it: in a real headless browser (Debian's chromium).

The page is served in-process over a robot on the built-in simulated bus (wall-clock time, so
that Stop lands mid-move). The test types a target and presses Move, presses Stop mid-move,
records two keyframes, plays them and saves them, and checks each step on the simulated
servos themselves (their positions through the joint mapping, read from the simulator, not
from the page or the panel) and in the saved file (read by the keyframe file reader of
``armctl play``). A screenshot of each step is written to ``$ARMCTL_ARTEFACTS/panel_browser``
(``.ci/run`` sets it), or to a temporary folder; the folder is printed.

Needs the ``chromium`` and ``chromium-driver`` packages and selenium (the test extra); CI
installs them. Without them the test fails and says what to install.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from armctl.config.motion import ExitPolicy
from armctl.motion.keyframe_file import load_keyframes
from armctl.panel import ControlPanel, Phase
from armctl.panel.page import CameraView, PanelPage
from armctl.robot import Robot
from armctl.spatial import quat_to_matrix

pytestmark = pytest.mark.realtime  # wall-clock motion: Stop must land mid-move

CHROMIUM_FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                  "--no-first-run", "--disable-background-networking",
                  "--disable-component-update", "--disable-sync", "--window-size=1200,800")


def _browser(profile: Path) -> Any:
    """A headless chromium driven by chromedriver, or a failure that says what is missing."""
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        pytest.fail("the browser test needs selenium: pip install -e '.[test]'")
    binary = shutil.which("chromium") or shutil.which("chromium-browser")
    driver = shutil.which("chromedriver")
    if binary is None or driver is None:
        pytest.fail("the browser test needs Debian's chromium and chromium-driver packages "
                    "(apt-get install -y chromium chromium-driver; .ci/run installs them): "
                    f"chromium {binary or 'missing'}, chromedriver {driver or 'missing'}")
    options = webdriver.ChromeOptions()
    options.binary_location = binary
    for flag in CHROMIUM_FLAGS:
        options.add_argument(flag)
    options.add_argument(f"--user-data-dir={profile}")
    return webdriver.Chrome(service=Service(driver), options=options)


def _new(outcome: object, before: object) -> bool:
    """Whether a new outcome came (by identity: two outcomes may say the same words)."""
    return outcome is not None and outcome is not before


def _until(check: Callable[[], object], timeout: float, what: str) -> Any:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = check()
        if value:
            return value
        time.sleep(0.05)
    pytest.fail(f"timed out after {timeout} s waiting for {what}")


class Page:
    """The page in the browser, used by labels and button texts as a person reads them."""

    def __init__(self, driver: Any, shots: Path):
        from selenium.webdriver.common.by import By
        from selenium.webdriver.common.keys import Keys

        self.d = driver
        self.by = By
        self.keys = Keys
        self.shots = shots
        self.n = 0

    def button(self, text: str) -> Any:
        """The button with this text in the open tab (or above the tabs)."""
        found = self.d.find_elements(
            self.by.XPATH, f"//button[.//span[normalize-space(.)='{text}']]")
        shown = [el for el in found if el.is_displayed()]
        assert shown, f"no button {text!r} shown in the page ({len(found)} hidden)"
        return shown[0]

    def press(self, text: str) -> None:
        el = self.button(text)
        self.d.execute_script("arguments[0].scrollIntoView({block: 'center'});", el)
        el.click()

    def tab(self, title: str) -> None:
        self.d.find_element(self.by.XPATH, f"//div[@role='tab'][@title='{title}']").click()

    def stop_in_view(self) -> bool:
        """Whether the STOP button is shown inside the window (never scrolled away)."""
        return bool(self.d.execute_script(
            "const r = arguments[0].getBoundingClientRect();"
            "return r.height > 0 && r.top >= 0 && r.bottom <= window.innerHeight;",
            self.button("STOP")))

    def inputs(self, label: str) -> list[Any]:
        return [el for el in self.d.find_elements(
            self.by.XPATH, f"//label[normalize-space(.)='{label}']/ancestor::div"
            "[contains(@class,'mantine-Flex-root')][1]//input")
            if el.get_attribute("type") != "hidden"]

    def type(self, label: str, values: list[str]) -> None:
        fields = self.inputs(label)
        assert len(fields) == len(values), f"{label!r}: {len(fields)} fields in the page"
        for el, v in zip(fields, values, strict=True):
            self.d.execute_script("arguments[0].scrollIntoView({block: 'center'});", el)
            el.click()
            el.send_keys(self.keys.CONTROL, "a")
            el.send_keys(v)
            el.send_keys(self.keys.TAB)

    def drag_on_canvas(self, cam: CameraView, start: np.ndarray, end: np.ndarray) -> None:
        """Press the mouse on the canvas where ``start`` [m] is seen, drag to ``end``, release.

        The screen positions are the projection of the page's camera (its position, look-at
        point, z up and vertical field of view) onto the WebGL canvas.
        """
        from selenium.webdriver.common.action_chains import ActionChains

        canvas = self.d.find_element(self.by.TAG_NAME, "canvas")
        w, h = self.d.execute_script(
            "const r = arguments[0].getBoundingClientRect(); return [r.width, r.height];",
            canvas)
        a, b = _project(cam, start, w, h), _project(cam, end, w, h)
        chain = ActionChains(self.d)
        chain.move_to_element_with_offset(canvas, round(a[0] - w / 2), round(a[1] - h / 2))
        chain.click_and_hold().pause(0.2)
        done = np.zeros(2)
        for i in range(1, 11):  # in steps, as a hand moves
            step = np.round(a + (b - a) * i / 10 - (a + done))
            chain.move_by_offset(int(step[0]), int(step[1])).pause(0.03)
            done += step
        chain.release().perform()

    def text(self) -> str:
        return str(self.d.find_element(self.by.TAG_NAME, "body").text)

    def shot(self, name: str) -> Path:
        self.n += 1
        path = self.shots / f"{self.n:02d}_{name}.png"
        self.d.save_screenshot(str(path))
        return path


def _shot_folder() -> Path:
    """``$ARMCTL_ARTEFACTS/panel_browser`` (emptied of old shots), else a new temporary folder."""
    root = os.environ.get("ARMCTL_ARTEFACTS")
    if not root:
        return Path(tempfile.mkdtemp(prefix="armctl_panel_screens_"))
    folder = Path(root) / "panel_browser"
    folder.mkdir(parents=True, exist_ok=True)
    for old in folder.glob("*.png"):
        old.unlink()
    return folder


@pytest.fixture
def served(tmp_path: Path) -> Iterator[tuple[Robot, ControlPanel, PanelPage, Page]]:
    shots = _shot_folder()
    with Robot.open("so101", sim=True, exit_policy=ExitPolicy.HOLD) as robot:
        panel = ControlPanel(robot)
        page = PanelPage(panel, connection="simulated bus", rate=10.0)
        url = page.start()
        driver = _browser(tmp_path / "profile")
        try:
            driver.get(url)
            yield robot, panel, page, Page(driver, shots)
        finally:
            driver.quit()
            page.stop()
    print(f"screenshots of the browser test: {shots}")


def _servos(robot: Robot) -> np.ndarray:
    """The simulated servos' positions through the joint mapping, in the arm's joint order."""
    sim = robot.bus.simulator  # type: ignore[attr-defined]
    values = sim.joint_positions()
    return np.array([values[n] for n in robot.arm.joint_names])


def _project(cam: CameraView, point: np.ndarray, width: float, height: float) -> np.ndarray:
    """Where a point [m] is seen on a canvas of ``width`` x ``height`` pixels (pinhole, z up)."""
    forward = cam.look_at - cam.position
    forward = forward / np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    d = np.asarray(point) - cam.position
    f = height / 2.0 / np.tan(cam.fov / 2.0)  # the focal length [px]
    depth = d @ forward
    return np.array([width / 2.0 + f * (d @ right) / depth, height / 2.0 - f * (d @ up) / depth])


def _orange_box(png: Path) -> tuple[float, float]:
    """Height and width of the box holding the arm's orange links, as fractions of the shot."""
    from PIL import Image

    img = np.asarray(Image.open(png).convert("RGB")).astype(int)
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    orange = (r > 150) & (g > 0.45 * r) & (g < 0.85 * r) & (b < 0.45 * r)
    h, w = orange.shape
    orange[: int(0.2 * h), : int(0.25 * w)] = False  # the browser's notice about WebGL
    ys, xs = np.nonzero(orange)
    if ys.size < 50:
        return 0.0, 0.0
    return (ys.max() - ys.min()) / img.shape[0], (xs.max() - xs.min()) / img.shape[1]


def test_a_person_moves_stops_records_plays_and_saves(served, tmp_path: Path):
    robot, panel, page, ui = served
    _until(lambda: "This page is tab" in ui.text(), 60.0, "the page to load and connect")
    _until(lambda: panel.controller is not None, 10.0, "the tab to get control")

    # -- the arm is framed: its links fill a good part of the picture, not 40 pixels
    def framed() -> bool:
        height, width = _orange_box(ui.shot("opened"))
        return height > 0.2 and width > 0.2

    _until(framed, 60.0, "the arm to fill a fifth of the picture's height and width")

    assert ui.stop_in_view()

    # -- drag the gizmo's blue arrow (its z axis) with the mouse on the WebGL canvas: the
    # target follows the pointer along that axis, the ghost shows the solution, Move reaches it
    cam, gizmo = page.camera, page.target_gizmo
    assert cam is not None
    p0, axis = np.asarray(gizmo.position), quat_to_matrix(np.asarray(gizmo.wxyz))[:, 2]
    length = page.gizmo_scale  # its arrows' length [m]
    ui.drag_on_canvas(cam, p0 + 0.7 * length * axis, p0 + 0.3 * length * axis)
    _until(lambda: panel.preview is not None, 90.0, "the preview of the dragged target")
    dragged = np.asarray(gizmo.position)
    moved = dragged - p0
    along = float(moved @ axis)  # a pixel of the drag is about a millimetre here
    assert -0.4 * length - 0.006 < along < -0.4 * length + 0.006, (moved, axis)
    assert np.linalg.norm(moved - along * axis) < 0.003, (moved, axis)
    assert panel.preview.ok, panel.preview
    assert panel.preview.ghost is not None
    ghost_tool = robot.arm.fk(panel.preview.ghost)[:3, 3]
    assert np.linalg.norm(ghost_tool - dragged) < 3e-3, (ghost_tool, dragged)
    typed = [float(el.get_attribute("value")) for el in ui.inputs("xyz [mm]")]
    np.testing.assert_allclose(typed, dragged * 1000.0, atol=0.11)  # the fields follow
    _until(lambda: "target: ok" in ui.text(), 30.0, "the page to show the preview")
    ui.shot("target_dragged")
    before = panel.outcome
    ui.press("Move")
    _until(lambda: _new(panel.outcome, before), 90.0, "the move to the dragged target")
    assert panel.outcome.ok, panel.outcome
    reached = robot.arm.fk(_servos(robot))[:3, 3]
    assert np.linalg.norm(reached - dragged) < 3e-3, (reached, dragged)

    # -- type a target, preview it (ghost), Move: the servos reach it
    q_goal = np.array([0.4, -0.5, 0.7, 0.4, 0.0, 0.0])
    target = robot.arm.fk(q_goal)[:3, 3]
    ui.type("xyz [mm]", [f"{v * 1000:.1f}" for v in target])
    ui.press("Preview typed pose")
    _until(lambda: panel.preview is not None, 90.0, "the preview")
    assert panel.preview.ok, panel.preview
    _until(lambda: "target: ok" in ui.text(), 30.0, "the page to show the preview")
    ui.shot("target_previewed")
    before = panel.outcome
    ui.press("Move")
    _until(lambda: _new(panel.outcome, before), 90.0, "the move to end")
    assert panel.outcome.ok, panel.outcome
    reached = robot.arm.fk(_servos(robot))[:3, 3]
    assert np.linalg.norm(reached - target) < 3e-3, (reached, target)
    ui.shot("moved")
    ui.tab("Keyframes")
    ui.press("Record")
    _until(lambda: len(panel.program.keyframes) == 1, 30.0, "the first keyframe")
    kf1 = _servos(robot)

    # -- a long, slow joint move from the slider's field, Stop mid-move: it decelerates, holds
    ui.type("speed override", ["0.03"])
    _until(lambda: abs(robot.control.speed - 0.03) < 1e-9, 30.0, "the speed override")
    start = _servos(robot)
    ui.tab("Joints")
    ui.type("shoulder_pan [deg]", ["-100"])
    _until(lambda: panel.preview is not None and panel.preview.joints is not None, 60.0,
           "the slider's preview")
    assert panel.preview.ok, panel.preview
    stop = ui.button("STOP")  # in its own window over the scene, always in view
    ui.press("Move")
    _until(lambda: abs(_servos(robot)[0] - start[0]) > 0.02, 60.0, "the arm to start moving")
    assert ui.stop_in_view()  # the control panel scrolled to Move: Stop is still in view
    stop.click()
    _until(lambda: panel.phase is Phase.IDLE and panel.outcome is not None, 60.0, "the stop")
    assert panel.outcome is not None and panel.outcome.stopped, panel.outcome
    held = _servos(robot)
    assert held[0] > np.radians(-95.0), "it stopped short of the goal"
    ui.tab("Keyframes")
    ui.type("speed override", ["1"])
    _until(lambda: abs(robot.control.speed - 1.0) < 1e-9, 30.0, "the speed override")
    time.sleep(0.6)
    np.testing.assert_allclose(_servos(robot), held, atol=0.004)  # holding still
    _until(lambda: "stopped" in ui.text(), 30.0, "the page to say it stopped")
    ui.shot("stopped")
    ui.tab("Keyframes")
    ui.press("Record")
    _until(lambda: len(panel.program.keyframes) == 2, 30.0, "the second keyframe")
    kf2 = _servos(robot)

    # -- back to the first keyframe's pose by Move, then play both keyframes
    ui.type("keyframe #", ["0"])
    ui.press("Preview keyframe")
    _until(lambda: panel.preview is not None and panel.preview.ok, 60.0, "keyframe preview")
    before = panel.outcome
    ui.tab("Target")
    ui.press("Move")
    _until(lambda: _new(panel.outcome, before), 90.0, "the move to keyframe 0")
    assert panel.outcome.ok, panel.outcome
    np.testing.assert_allclose(_servos(robot)[:5], kf1[:5], atol=0.01)
    before = panel.outcome
    ui.tab("Keyframes")
    ui.press("Play")
    ui.shot("playing")
    _until(lambda: _new(panel.outcome, before), 90.0, "the playback to end")
    assert panel.outcome.what == "playback" and panel.outcome.ok, panel.outcome
    np.testing.assert_allclose(_servos(robot)[:5], kf2[:5], atol=0.01)  # at the last one

    # -- save: the keyframe file of armctl teach/play, and no silent overwrite
    out = tmp_path / "from_the_page.yaml"
    ui.type("file", [str(out)])
    ui.press("Save")
    _until(out.exists, 30.0, "the keyframe file")
    program = load_keyframes(out, robot.arm)
    assert len(program.keyframes) == 2
    idx = [robot.arm.joint_index(n) for n in program.joints]
    np.testing.assert_allclose(program.keyframes[0].q, kf1[idx], atol=0.01)
    np.testing.assert_allclose(program.keyframes[1].q, kf2[idx], atol=0.01)
    text = out.read_text()
    ui.press("Save")
    _until(lambda: "exists already" in ui.text(), 30.0, "the refusal to overwrite")
    assert out.read_text() == text
    ui.shot("saved")

    # -- continuous recording from the page: time-stamped samples of the arm at rest
    n = len(panel.program.keyframes)
    ui.press("Start recording")
    _until(lambda: panel.recording, 30.0, "the recording to start")
    _until(lambda: len(panel.program.keyframes) >= n + 3, 30.0, "three samples")
    _until(lambda: "recording" in ui.text(), 30.0, "the page to say it records")
    ui.shot("recording")
    ui.press("Stop recording")
    _until(lambda: not panel.recording, 30.0, "the recording to end")
    samples = panel.program.keyframes[n:]
    assert all(kf.time is not None for kf in samples)
    assert np.all(np.diff([kf.time for kf in samples]) > 0)
    np.testing.assert_allclose(samples[-1].q, _servos(robot)[idx], atol=0.004)
