"""The ``render``, ``workspace`` and ``view`` commands, and every bundled arm drawn."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from armctl_testpaths import BUNDLED
from PIL import Image, ImageSequence

from armctl.arm import load_arm
from armctl.cli import main
from armctl.render import BoundGeometry

PLANAR = str(Path(__file__).parent.parent / "data" / "planar3r.yaml")
SHAPES5 = str(Path(__file__).parent / "data" / "shapes5.yaml")


def run(capsys, *argv: str) -> tuple[int, dict | None, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    data = json.loads(out) if "--json" in argv and out.strip().startswith("{") else None
    return code, data, err


def test_render_pose_json(tmp_path, capsys):
    out = tmp_path / "pose.png"
    code, data, _ = run(capsys, "render", PLANAR, "0", "90", "0", "--deg", "-o", str(out),
                        "--target-xyz", "0.3", "0.3", "0", "--target-rpy", "0", "0", "90",
                        "--view", "top", "--frames", "tool,l2", "--json", "--size", "2",
                        "--dpi", "50")
    assert code == 0 and data["ok"] and data["command"] == "render"
    assert data["tool_position"] == pytest.approx([0.3, 0.3, 0.0], abs=1e-12)
    assert data["target_distance"] == pytest.approx(0.0, abs=1e-12)
    assert data["q"] == pytest.approx([0.0, np.pi / 2, 0.0])
    assert Image.open(out).size == (100, 100)


def test_render_camera_and_named_pose(tmp_path, capsys):
    out = tmp_path / "pose.png"
    code, _, _ = run(capsys, "render", "so101", "--pose", "home", "--elev", "10", "--azim", "30",
                     "-o", str(out), "--size", "2", "--dpi", "50")
    assert code == 0 and out.is_file()


@pytest.mark.parametrize(("argv", "message"), [
    (["0", "0"], "expected 3 values"),
    (["0", "0", "x"], "is not a number"),
    (["--frames", "tipp"], "unknown frame 'tipp'"),
    (["--target-rpy", "0", "0", "0"], "--target-rpy needs --target-xyz"),
    (["0", "0", "0", "--pose", "home"], "not both"),
    (["--pose", "nope"], "unknown pose 'nope'"),
])
def test_render_bad_input(tmp_path, capsys, argv, message):
    code, _, err = run(capsys, "render", PLANAR, *argv, "-o", str(tmp_path / "a.png"))
    assert code == 2 and message in err
    assert not (tmp_path / "a.png").exists()


def test_render_unwritable_output(tmp_path, capsys):
    code, data, err = run(capsys, "render", PLANAR, "-o", str(tmp_path / "no" / "a.png"),
                          "--json")
    assert code == 2 and "does not exist" in err
    assert data["ok"] is False and data["error"]["type"] == "OutputError"


def test_workspace_command(tmp_path, capsys):
    out = tmp_path / "reach.png"
    code, data, _ = run(capsys, "workspace", SHAPES5, "-o", str(out), "--samples", "500",
                        "--json")
    assert code == 0 and out.is_file()
    assert data["samples"] == 500 and data["hull_volume"] > 0
    assert all(lo < hi for lo, hi in zip(data["lower"], data["upper"], strict=True))
    code, _, err = run(capsys, "workspace", SHAPES5, "-o", str(out), "--frame", "nope")
    assert code == 2 and "unknown frame 'nope'" in err


def test_view_command_serves_and_stops(capsys):
    code, data, _ = run(capsys, "view", SHAPES5, "--http-port", "0", "--duration", "0.3", "--json")
    assert code == 0 and data["url"].startswith("http://127.0.0.1:") and data["bus"] is False


def test_view_follows_the_simulated_bus(capsys):
    code, data, _ = run(capsys, "view", "so101", "--bus", "--sim", "--http-port", "0", "--duration",
                        "0.3", "--json")
    assert code == 0 and data["bus"] is True
    code, _, err = run(capsys, "view", PLANAR, "--bus", "--http-port", "0", "--duration", "0.1")
    assert code == 2 and "no 'bus:' section" in err


@pytest.mark.parametrize("name", BUNDLED)
def test_bundled_arms_render(name, tmp_path):
    arm = load_arm(name)
    geo = BoundGeometry(arm)
    assert {s.link for s in geo.shapes} == {lk.name for lk in arm.spec.links}
    out = tmp_path / f"{name}.png"
    assert main(["render", name, "-o", str(out), "--size", "2.5", "--dpi", "50"]) == 0
    img = np.asarray(Image.open(out).convert("RGB")).astype(int)
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    orange = (r - b > 80) & (r > g) & (g > b + 30)
    assert orange.sum() > 100  # the links are drawn, not an empty frame


KEYS = str(Path(__file__).parent / "data" / "planar_keys.yaml")


def test_render_keyframe_playback(tmp_path, capsys):
    from PIL import ImageSequence

    out = tmp_path / "play.gif"
    code, data, _ = run(capsys, "render", PLANAR, "0", "0", "0", "--keyframes", KEYS, "-o",
                        str(out), "--fps", "4", "--size", "2", "--dpi", "40", "--view", "top",
                        "--frames", "none", "--json")
    assert code == 0 and data["ok"]
    # the plan ends at the last keyframe (90, 60, 30 deg) and the GIF has one frame per 1/fps
    assert data["goal"] == pytest.approx(np.radians([90.0, 60.0, 30.0]), abs=1e-6)
    frames = [f.convert("RGB") for f in ImageSequence.Iterator(Image.open(out))]
    assert len(frames) == data["frames"]
    assert abs(len(frames) - (data["duration"] * 4 + 1)) < 1.0

    def centroid(img):
        a = np.asarray(img).astype(int)
        r, g, b = a[..., 0], a[..., 1], a[..., 2]
        ys, xs = np.nonzero((r - b > 80) & (r > g) & (g > b + 30))
        return np.array([xs.mean(), ys.mean()])

    c0, c1 = centroid(frames[0]), centroid(frames[-1])
    assert c1[1] < c0[1] - 5  # from pointing along +x to pointing towards +y: up in the top view


def test_render_straight_line_path(tmp_path, capsys):
    out = tmp_path / "line.png"
    code, data, _ = run(capsys, "render", PLANAR, "0", "0.5", "0.5", "--path", "--target-xyz",
                        "0.3", "0.3", "0", "-o", str(out), "--json", "--size", "2.5")
    assert code == 0 and out.is_file()
    assert data["samples"] >= 9 and data["max_deviation"] < 1e-3
    arm = load_arm(PLANAR)
    assert arm.fk(data["goal"])[:3, 3] == pytest.approx([0.3, 0.3, 0.0], abs=1e-4)


@pytest.mark.parametrize(("argv", "message"), [
    (["--keyframes", KEYS, "-o", "a.png"], "give -o a .gif or .mp4"),
    (["--path", "-o", "a.png"], "--path needs the goal"),
    (["--path", "--target-xyz", "3", "0", "0", "-o", "a.png"], "no IK solution"),
])
def test_render_motion_bad_input(tmp_path, capsys, argv, message):
    argv = [a if a not in ("a.png",) else str(tmp_path / a) for a in argv]
    code, _, err = run(capsys, "render", PLANAR, *argv)
    assert code in (2, 3) and message in err
    assert not (tmp_path / "a.png").exists()


def test_render_keyframes_with_pose_keyframes(tmp_path, capsys):
    keys = tmp_path / "pick.yaml"
    keys.write_text(
        "armctl_keyframes: 1\narm: so101\nunits: {angle: deg}\n"
        "joints: [shoulder_pan, shoulder_lift, elbow_flex, wrist_flex, wrist_roll]\n"
        "keyframes:\n  - {name: a, q: [0, -20, 30, 10, 0]}\n"
        "  - {name: above, pose: {xyz: [0.22, 0.0, 0.12]}}\n"
        "  - {name: down, pose: {xyz: [0.2, 0.0, 0.05], rpy: [180, 0, 180]}}\n")
    out = tmp_path / "pick.gif"
    code, data, err = run(capsys, "render", "so101", "--keyframes", str(keys), "-o", str(out),
                          "--fps", "4", "--size", "2", "--dpi", "40", "--json")
    assert code == 0 and data["ok"] and out.is_file(), err
    # the plan ends at the last (full pose) keyframe: FK of its joints is that pose
    arm = load_arm("so101")
    end = arm.fk(np.array(data["goal"]))
    assert end[:3, 3] == pytest.approx([0.2, 0.0, 0.05], abs=1e-3)
    assert end[:3, 2] == pytest.approx([0.0, 0.0, -1.0], abs=1e-3)  # tool z axis down
    assert data["goal"][arm.joint_index("gripper")] == pytest.approx(0.0)
    assert len(list(ImageSequence.Iterator(Image.open(out)))) == data["frames"]


def test_a_given_http_port_in_use_is_refused(capsys):
    import socket

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        code, _, err = run(capsys, "view", SHAPES5, "--http-port", str(port), "--duration", "0.1")
    assert code == 2 and f"--http-port {port} is in use" in err and "--http-port 0" in err
    assert "Traceback" not in err


def test_the_default_http_port_moves_on_and_says_so(capsys):
    import argparse

    from armctl.cli._panel import DEFAULT_HTTP_PORT, choose_http_port, say_http_port

    args = argparse.Namespace(http_port=None, host="127.0.0.1")
    choose_http_port(args)
    assert args.http_port == DEFAULT_HTTP_PORT and args.http_port_given is False
    say_http_port(args, DEFAULT_HTTP_PORT)
    assert capsys.readouterr().err == ""
    say_http_port(args, DEFAULT_HTTP_PORT + 1)
    err = capsys.readouterr().err
    assert f"port {DEFAULT_HTTP_PORT} is in use" in err and f"port {DEFAULT_HTTP_PORT + 1}" in err
    given = argparse.Namespace(http_port=0, host="127.0.0.1")
    choose_http_port(given)  # 0: any free port, nothing to say
    say_http_port(given, 45678)
    assert capsys.readouterr().err == ""


def test_a_long_title_fits_the_picture(tmp_path: Path) -> None:
    """The figure's 30 joint values (quaternions of its ball joints) do not fit one line: the
    title shrinks and wraps, and stays inside the picture."""
    import matplotlib

    matplotlib.use("Agg")
    from armctl.arm import load_arm
    from armctl.render.picture import pose_title, set_title
    from armctl.render.plots import new_figure

    arm = load_arm("figure")
    text = pose_title(arm, arm.named_pose("stand"))
    for size in (2.0, 4.0, 8.0):
        fig, _ = new_figure(size=(size, size), dpi=100)
        set_title(fig, text)
        title = fig._suptitle
        assert title is not None
        assert title.get_text().replace("\n", " ") == text  # every value kept
        renderer = fig.canvas.get_renderer()
        box = title.get_window_extent(renderer)
        assert 0 <= box.x0 and box.x1 <= fig.bbox.width, (size, box)
    fig, _ = new_figure(size=(5.0, 5.0), dpi=100)
    set_title(fig, "so101  q = [0.1, 0.2] rad")
    assert fig._suptitle is not None and "\n" not in fig._suptitle.get_text()
    assert fig._suptitle.get_fontsize() == 9
