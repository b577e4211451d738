"""A corpus of user mistakes on every command: each is refused with a message and an exit code.

Every case runs ``armctl.cli.main`` in-process and must return its documented exit code (2 bad
input, 3 no solution, 4 bus), print ``armctl ... error`` on stderr, and never a traceback (an
exception escaping ``main`` fails the case with it). Cases that concern motion fail before the
bus opens: the simulated bus would announce itself on stderr.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from armctl_testpaths import CONFIGS, DATA

from armctl.cli import main

SO = "so101"
URDF = str(DATA / "urdf" / "so101.urdf")
PLANAR = str(DATA / "planar3r.yaml")
Q6 = ["0", "0", "0", "0", "0", "0"]
XYZ = ["--xyz", "0.2", "0", "0.1"]

KEYFRAMES_DEG = """\
armctl_keyframes: 1
arm: so101
units: {angle: deg, length: m}
joints: [shoulder_pan, shoulder_lift, elbow_flex, wrist_flex, wrist_roll]
keyframes:
- {q: [0, -10, 20, 10, 0], gripper: 30}
- {q: [10, -20, 30, 10, 0]}
"""


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    """Files the corpus refers to as ``{name}`` in its arguments."""
    d = tmp_path_factory.mktemp("corpus")
    (d / "kf.yaml").write_text(KEYFRAMES_DEG)
    shutil.copy(CONFIGS / "so101.yaml", d / "arm.yaml")
    (d / "bad_units.yaml").write_text(KEYFRAMES_DEG.replace("angle: deg", "angle: grad"))
    (d / "wrong_arm.yaml").write_text(KEYFRAMES_DEG.replace("arm: so101", "arm: omx"))
    (d / "outside.yaml").write_text(KEYFRAMES_DEG.replace("[10, -20, 30, 10, 0]",
                                                          "[10, -20, 300, 10, 0]"))
    (d / "grip_far.yaml").write_text(KEYFRAMES_DEG.replace("gripper: 30", "gripper: 3000"))
    (d / "nan.yaml").write_text(KEYFRAMES_DEG.replace("gripper: 30", "gripper: .nan"))
    (d / "mm_angle.yaml").write_text(KEYFRAMES_DEG.replace("gripper: 30", "gripper: '3 mm'"))
    (d / "empty.yaml").write_text("")
    (d / "list.yaml").write_text("- 1\n- 2\n")
    (d / "broken.yaml").write_text("armctl_keyframes: [1\n")
    (d / "binary.yaml").write_bytes(b"\xff\xfe\x00\x01")
    (d / "existing.yaml").write_text(KEYFRAMES_DEG)
    (d / "other_joints.yaml").write_text(KEYFRAMES_DEG.replace(
        "wrist_flex, wrist_roll]", "wrist_flex]").replace(", 0]", "]"))
    (d / "goals_bad.yaml").write_text("goals: 3\n")
    (d / "far.yaml").write_text(KEYFRAMES_DEG.replace(
        "- {q: [10, -20, 30, 10, 0]}", "- {name: far, pose: {xyz: [2, 0, 0.1]}}"))
    (d / "scenario_bad.yaml").write_text("nonsense: [\n")
    (d / "folder").mkdir()
    return {"d": str(d), "urdf": URDF, **{p.stem: str(p) for p in d.iterdir()}}


# (argv, expected exit code); "{name}" is replaced by the fixture's file of that name.
CORPUS: list[tuple[list[str], int]] = [
    # -- no command, unknown command, unknown option --------------------------------------
    ([], 2),
    (["frobnicate"], 2),
    (["fk", SO, *Q6, "--bogus"], 2),
    # -- arms, info ------------------------------------------------------------------------
    (["arms", "extra"], 2),
    (["info"], 2),
    (["info", "no_such_arm"], 2),
    (["info", "so10"], 2),
    (["info", "{kf}"], 2),
    (["info", "{empty}"], 2),
    (["info", "{list}"], 2),
    (["info", "{broken}"], 2),
    (["info", "{binary}"], 2),
    (["info", "{folder}"], 2),
    (["info", "{urdf}", "--tip", "no_link"], 2),
    # -- fk --------------------------------------------------------------------------------
    (["fk", SO, "0", "0", "nan", "0", "0", "0"], 2),
    (["fk", SO, "0", "0", "inf", "0", "0", "0"], 2),
    (["fk", SO, "0", "0", "-inf", "0", "0", "0"], 2),
    (["fk", SO, "0", "0", "-nan", "0", "0", "0"], 2),
    (["fk", SO, "0", "0", "180", "0", "0", "0"], 2),
    (["fk", SO, "0", "0", "-90", "0", "0", "0"], 2),
    (["fk", SO, "0", "0", "0"], 2),
    (["fk", SO, *Q6, "0"], 2),
    (["fk", SO, "0", "0", "x", "0", "0", "0"], 2),
    (["fk", SO, "0", "0", "1e999", "0", "0", "0"], 2),
    (["fk", SO, *Q6, "--frame", "no_frame"], 2),
    (["fk", "omx", "0", "0", "0", "0", "10"], 2),
    (["fk", "{kf}", *Q6], 2),
    (["fk", PLANAR, "0", "0", "nan", "--json"], 2),
    # -- convert ---------------------------------------------------------------------------
    (["convert", "{urdf}", "-o", "/nonexistent_dir_armctl/x.yaml"], 2),
    (["convert", "{urdf}", "-o", "{folder}"], 2),
    (["convert", "{urdf}", "-o", "{existing}"], 2),
    (["convert", "/nonexistent_armctl.urdf", "-o", "{d}/new.yaml"], 2),
    (["convert", "{kf}", "-o", "{d}/new2.yaml"], 2),
    (["convert", "{urdf}", "-o", "{d}/new3.yaml", "--tip", "no_link"], 2),
    (["convert", "{urdf}"], 2),
    # -- ik --------------------------------------------------------------------------------
    (["ik", SO, "--xyz", "0.2", "0", "nan"], 2),
    (["ik", SO, "--xyz", "0.2", "inf", "0.1"], 2),
    (["ik", SO, "--xyz", "0.2", "0"], 2),
    (["ik", SO], 2),
    (["ik", "ur5e", *XYZ, "--rpy", "180", "0", "0"], 2),
    (["ik", "ur5e", *XYZ, "--rpy", "0", "nan", "0"], 2),
    (["ik", "ur5e", *XYZ, "--quat", "0", "0", "0", "0"], 2),
    (["ik", "ur5e", *XYZ, "--quat", "1", "0", "nan", "0"], 2),
    (["ik", SO, *XYZ, "--direction", "w", "0", "0", "1"], 2),
    (["ik", SO, *XYZ, "--direction", "z", "0", "0", "0"], 2),
    (["ik", SO, *XYZ, "--direction", "z", "0", "0", "nan"], 2),
    (["ik", SO, *XYZ, "--direction", "z", "0", "x", "1"], 2),
    (["ik", SO, *XYZ, "--tol-pos", "0"], 2),
    (["ik", SO, *XYZ, "--tol-pos", "-1"], 2),
    (["ik", SO, *XYZ, "--tol-rot", "nan"], 2),
    (["ik", SO, *XYZ, "--time-limit", "0"], 2),
    (["ik", SO, *XYZ, "--time-limit", "inf"], 2),
    (["ik", SO, *XYZ, "--max-iterations", "0"], 2),
    (["ik", SO, *XYZ, "--restarts", "-1"], 2),
    (["ik", SO, *XYZ, "--seed", "x"], 2),
    (["ik", SO, *XYZ, "--solver", "no_solver"], 2),
    (["ik", SO, *XYZ, "--from", "0", "0", "0", "0", "0", "180"], 2),
    (["ik", SO, *XYZ, "--from", "0", "0"], 2),
    (["ik", SO, *XYZ, "--from", "0", "0", "0", "0", "0", "nan"], 2),
    (["ik", SO, *XYZ, "--frame", "no_frame"], 2),
    (["ik", SO, *XYZ, "--all"], 2),
    (["ik", SO, *XYZ, "--variants"], 2),
    (["ik", SO, *XYZ, "--plane", "0", "0", "0", "0", "0", "nan"], 2),
    (["ik", SO, *XYZ, "--keep-out", "0", "0", "0"], 2),
    (["ik", SO, *XYZ, "--keep-out", "0", "0", "0", "inf"], 2),
    (["ik", SO, "--goals", "{goals_bad}"], 2),
    (["ik", SO, "--goals", "/nonexistent_armctl_goals.yaml"], 2),
    # control: a valid goal (XYZ with the tool's z axis up puts the wrist in the table)
    (["ik", "ur5e", "--xyz", "0.2", "0", "0.4", "--rpy", "0", "0", "0"], 0),
    (["ik", SO, "--xyz", "5", "0", "0.1"], 3),
    (["ik", "ur5e", "--xyz", "3", "0", "0", "--solver", "analytic", "--all"], 3),
    (["ik", SO, "--xyz", "5", "0", "0.1", "--json"], 3),
    # -- move-to-pose ----------------------------------------------------------------------
    (["move-to-pose", SO], 2),
    (["move-to-pose", SO, "--xyz", "0.2", "0", "nan"], 2),
    (["move-to-pose", SO, *XYZ, "--rpy", "0", "180", "0"], 2),
    (["move-to-pose", SO, *XYZ, "--speed", "0"], 2),
    (["move-to-pose", SO, *XYZ, "--speed", "-0.5"], 2),
    (["move-to-pose", SO, *XYZ, "--speed", "nan"], 2),
    (["move-to-pose", SO, *XYZ, "--speed", "inf"], 2),
    (["move-to-pose", SO, *XYZ, "--speed", "1e-9"], 2),
    (["move-to-pose", SO, *XYZ, "--speed", "1.5"], 2),
    (["move-to-pose", SO, *XYZ, "--solver", "no_solver"], 2),
    (["move-to-pose", SO, *XYZ, "--frame", "no_frame"], 2),
    (["move-to-pose", SO, *XYZ, "--exit-policy", "explode"], 2),
    (["move-to-pose", SO, "--xyz", "5", "0", "0.1"], 3),
    (["move-to-pose", SO, "--xyz", "5", "0", "0.1", "--json"], 3),
    (["move-to-pose", SO, "--xyz", "5", "0", "0.1", "--linear"], 3),
    (["move-to-pose", SO, "--xyz", "5", "0", "0.1", "--direction", "z", "0", "0", "-1"], 3),
    (["move-to-pose", "{kf}", *XYZ], 2),
    # -- move-joints, home, park -----------------------------------------------------------
    (["move-joints", SO, "0", "0", "nan", "0", "0", "0"], 2),
    (["move-joints", SO, "0", "0", "inf", "0", "0", "0"], 2),
    (["move-joints", SO, "0", "0", "180", "0", "0", "0"], 2),
    (["move-joints", SO, "0", "0", "0", "0", "0", "90"], 2),
    (["move-joints", SO, "0", "0", "1.8", "0", "0", "0"], 2),
    (["move-joints", SO, "0", "0", "170", "0", "0", "0", "--deg"], 2),
    (["move-joints", SO, "0", "0"], 2),
    (["move-joints", SO, *Q6, "--speed", "0"], 2),
    (["move-joints", SO, *Q6, "--speed", "1e-6"], 2),
    (["move-joints", SO, *Q6, "--speed", "2"], 2),
    (["move-joints", SO, *Q6, "--speed", "nan"], 2),
    (["move-joints", SO, *Q6, "--speed", "x"], 2),
    (["move-joints", "omx", "0", "0", "0", "0", "15"], 2),
    (["move-joints", "{kf}", *Q6], 2),
    (["move-joints", SO, "0", "0", "nan", "0", "0", "0", "--json"], 2),
    (["home", SO, "--speed", "0"], 2),
    (["home", SO, "--speed", "-1"], 2),
    (["park", SO, "--speed", "5"], 2),
    (["park", SO, "--speed", "inf"], 2),
    (["home", "no_such_arm"], 2),
    (["home", PLANAR], 2),
    # -- play ------------------------------------------------------------------------------
    (["play", "{kf}", SO, "--preview", "/nonexistent_dir_armctl/x.png"], 2),
    (["play", "{kf}", SO, "--preview", "{d}/x.bmp"], 2),
    (["play", "{kf}", SO, "--preview", "{folder}"], 2),
    (["play", "{kf}", SO, "--speed", "4"], 2),
    (["play", "{kf}", SO, "--speed", "0"], 2),
    (["play", "{kf}", SO, "--speed", "0.001"], 2),
    (["play", "{kf}", SO, "--speed", "nan"], 2),
    (["play", "{kf}", SO, "--speed", "5"], 2),
    (["play", "{kf}", SO, "--loop", "0"], 2),
    (["play", "{kf}", SO, "--loop", "x"], 2),
    (["play", "{kf}", SO, "--interpolation", "bezier"], 2),
    (["play", "{arm}", SO], 2),
    (["play", SO, SO], 2),
    (["play", "{urdf}", SO], 2),
    (["play", SO, "{kf}"], 2),
    (["play", "{kf}", "{kf}"], 2),
    (["play", "{bad_units}", SO], 2),
    (["play", "{wrong_arm}", SO], 2),
    (["play", "{outside}", SO], 2),
    (["play", "{grip_far}", SO], 2),
    (["play", "{nan}", SO], 2),
    (["play", "{mm_angle}", SO], 2),
    (["play", "{empty}", SO], 2),
    (["play", "{list}", SO], 2),
    (["play", "{broken}", SO], 2),
    (["play", "{binary}", SO], 2),
    (["play", "{folder}", SO], 2),
    (["play", "/nonexistent_armctl_kf.yaml", SO], 2),
    (["play", "{far}", SO], 3),
    (["play", "{far}", SO, "--json"], 3),
    (["play", "{kf}", SO, "--speed", "4", "--json"], 2),
    # -- teach (refused before the bus opens) -----------------------------------------------
    (["teach", SO], 2),
    (["teach", SO, "-o", "{existing}"], 2),
    (["teach", SO, "-o", "{existing}", "--force", "--append"], 2),
    (["teach", SO, "-o", "{arm}", "--force"], 2),
    (["teach", SO, "-o", "{urdf}", "--force"], 2),
    (["teach", SO, "-o", "{folder}"], 2),
    (["teach", SO, "-o", "/nonexistent_dir_armctl/k.yaml"], 2),
    (["teach", SO, "-o", "{wrong_arm}", "--append"], 2),
    (["teach", SO, "-o", "{other_joints}", "--append"], 2),
    (["teach", SO, "-o", "{broken}", "--append"], 2),
    (["teach", SO, "-o", "{d}/new_kf.yaml", "--release", "no_joint"], 2),
    (["teach", "{kf}", "-o", "{d}/new_kf.yaml"], 2),
    # -- render, workspace, view -----------------------------------------------------------
    (["render", SO, "-o", "{d}/x.bmp"], 2),
    (["render", SO, "-o", "/nonexistent_dir_armctl/x.png"], 2),
    (["render", SO, *Q6[:5], "nan", "-o", "{d}/x.png"], 2),
    (["render", SO, *Q6[:5], "180", "-o", "{d}/x.png"], 2),
    (["render", SO, "-o", "{d}/x.png", "--target-xyz", "0.2", "0", "nan"], 2),
    (["render", SO, "-o", "{d}/x.png", "--target-xyz", "0.2", "0", "0.1", "--target-rpy",
      "0", "180", "0"], 2),
    (["render", SO, "-o", "{d}/x.png", "--elev", "nan"], 2),
    (["render", SO, "-o", "{d}/x.png", "--fps", "0"], 2),
    (["render", SO, "-o", "{d}/x.png", "--size", "-1"], 2),
    (["render", SO, "-o", "{d}/x.png", "--dpi", "inf"], 2),
    (["render", SO, "-o", "{d}/x.png", "--pose", "no_pose"], 2),
    (["render", SO, "-o", "{d}/x.gif", "--keyframes", "{arm}"], 2),
    (["render", SO, "-o", "{d}/x.gif", "--keyframes", SO], 2),
    (["render", SO, "-o", "{d}/x.gif", "--keyframes", "{kf}", "--speed", "0"], 2),
    (["render", SO, "-o", "{d}/x.png", "--path", "--target-xyz", "0.2", "0", "0.1",
      "--speed", "2"], 2),
    (["render", SO, "-o", "{d}/x.png", "--keyframes", "{kf}"], 2),
    (["workspace", SO, "-o", "{d}/w.bmp"], 2),
    (["workspace", SO, "-o", "{d}/w.png", "--samples", "0"], 2),
    (["workspace", SO, "-o", "{d}/w.png", "--voxel", "nan"], 2),
    (["workspace", SO, "-o", "{d}/w.png", "--frame", "no_frame"], 2),
    (["view", SO, "--http-port", "70000"], 2),
    (["view", SO, "--port", "8080"], 2),
    (["view", SO, "--rate", "0"], 2),
    (["view", SO, "--duration", "nan"], 2),
    (["view", PLANAR, "--bus"], 2),
    # -- bus commands ----------------------------------------------------------------------
    (["scan"], 2),
    (["scan", "--port", "/nonexistent_armctl_port"], 4),
    (["scan", "--port", "/nonexistent_armctl_port", "--protocol", "canbus"], 2),
    (["status", SO, "--interval", "0"], 2),
    (["status", SO, "--interval", "nan"], 2),
    (["status", PLANAR, "--once"], 2),
    (["status", SO, "--once", "--port", "/nonexistent_armctl_port"], 4),
    (["torque", SO, "sideways"], 2),
    (["torque", PLANAR, "on"], 2),
    (["sim", SO, "--scenario", "/nonexistent_armctl_scenario.yaml"], 2),
    (["calibrate", PLANAR], 2),
    (["reboot", SO, "elbow"], 2),
    (["reboot", PLANAR], 2),
    (["reboot", SO, "--port", "/nonexistent_armctl_port"], 4),
    (["setup-motors", SO], 2),
    (["setup-motors", PLANAR], 2),
    (["setup-motors", SO, "--port", "/nonexistent_armctl_port"], 4),
    # -- gripper, --port/--sim ----------------------------------------------------------------
    (["gripper", SO], 2),
    (["gripper", SO, "ajar"], 2),
    (["gripper", SO, "inf"], 2),
    (["gripper", SO, "90"], 2),
    (["gripper", SO, "5", "--mm"], 2),
    (["gripper", PLANAR, "open"], 2),
    (["gripper", SO, "open", "--sim", "--port", "/nonexistent_armctl_port"], 2),
    (["gripper", SO, "open", "--port", "/nonexistent_armctl_port"], 4),
    (["move-joints", SO, "0", "0", "0", "0", "0", "0", "--port", ""], 2),
    (["move-to-pose", SO, "--relative"], 2),
    (["move-to-pose", SO, "--xyz", "0.2", "0", "0.2", "--tcp-speed", "0.1"], 2),
    (["move-to-pose", SO, "--xyz", "0.2", "0", "0.2", "--linear", "--tcp-speed", "-1"], 2),
    # -- teleop ---------------------------------------------------------------------------------
    (["teleop", "so101_leader"], 2),
    (["teleop", "so101_leader", SO, "--rate", "0"], 2),
    (["teleop", "so101_leader", SO, "--start-speed", "2"], 2),
    (["teleop", "so101_leader", SO, "--scale", "elbow=2"], 2),
    (["teleop", "so101_leader", SO, "--scale", "elbow_flex=fast"], 2),
    (["teleop", "so101_leader", SO, "--scales", "{broken}"], 2),
    (["teleop", "so101_leader", SO, "--every", "20"], 2),
    (["teleop", "so101_leader", SO, "--record", "{existing}", "--every", "20"], 2),
    (["teleop", "so101_leader", SO, "--record", "{d}/x.txt"], 2),
    (["teleop", "so101_leader", SO, "--record", "{d}/r.yaml", "--every", "5"], 2),
    (["teleop", "so101_leader", "omx", "--json"], 2),
    (["teleop", "so101_leader", PLANAR], 2),
    # -- --scene and --plan --------------------------------------------------------------------
    (["move-joints", SO, *Q6, "--scene", "{broken}"], 2),
    (["move-to-pose", SO, *XYZ, "--scene", "{list}"], 2),
    (["home", SO, "--scene", "/nonexistent_armctl/scene.yaml"], 2),
    (["park", SO, "--plan-time", "2"], 2),
    (["park", SO, "--plan", "--plan-time", "0"], 2),
    (["move-to-pose", SO, *XYZ, "--linear", "--plan"], 2),
    (["gripper", SO, "open", "--scene", "{kf}"], 2),
    (["play", "{kf}", SO, "--scene", "{broken}"], 2),
    (["teach", SO, "-o", "{d}/taught.yaml", "--scene", "{empty}"], 2),
    (["teleop", "so101_leader", SO, "--scene", "{broken}"], 2),
    (["fk", SO, *Q6, "--scene", "{broken}"], 2),
    (["status", SO, "--once", "--scene", "{list}"], 2),
    (["render", SO, "-o", "{d}/x.png", "--scene", "{broken}"], 2),
    (["render", SO, "-o", "{d}/x.png", "--scene", "{list}", "--no-scene"], 2),
    # -- jog -------------------------------------------------------------------------------------
    (["jog", "no_such_arm"], 2),
    (["jog", SO, "--speed", "0"], 2),
    (["jog", SO, "--deg-steps", "nan"], 2),
    (["jog", SO, "--mm-steps", "1", "2", "500"], 2),
    (["jog", SO, "-o", "{existing}"], 2),
    (["jog", SO, "--force"], 2),
    (["jog", SO, "--sim"], 2),  # standard input is not a terminal
    # -- collisions ------------------------------------------------------------------------------
    (["collisions", "no_such_arm"], 2),
    (["collisions", "{kf}"], 2),
    (["collisions", SO, "--generate", "--write"], 2),
    (["collisions", URDF, "--generate", "--write"], 2),
    (["collisions", "{arm}", "--write"], 2),
    (["collisions", "{arm}", "--seed", "3"], 2),
    (["collisions", "{arm}", "--generate", "--samples", "0"], 2),
    (["collisions", "{arm}", "--generate", "--seed", "-2"], 2),
    (["collisions", "{arm}", "--scene", "{broken}"], 2),
    # -- --log of the motion commands, plot --------------------------------------------------
    (["move-joints", SO, *Q6, "--log", "{existing}"], 2),
    (["home", SO, "--log", "/nonexistent_dir_armctl/h.csv"], 2),
    (["plot", "{kf}", "-o", "{d}/p.png"], 2),
    (["plot", "{d}/no_log.csv", "-o", "{d}/p.png"], 2),
    (["plot", "{kf}", "-o", "{d}/p.bmp"], 2),
    (["plot", "{kf}"], 2),
]


def _argv(case: list[str], files: dict[str, str]) -> list[str]:
    return [a.format(**files) if "{" in a else a for a in case]


def test_corpus_is_large_and_covers_every_command() -> None:
    from armctl.cli import build_parser

    assert len(CORPUS) >= 100
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    commands = set(sub.choices)  # type: ignore[union-attr]
    covered = {argv[0] for argv, _ in CORPUS if argv}
    assert commands - {"ports"} <= covered, commands - covered


@pytest.mark.parametrize(("case", "code"), CORPUS,
                         ids=[" ".join(c) or "(none)" for c, _ in CORPUS])
def test_bad_input_is_refused_without_traceback(case: list[str], code: int,
                                                files: dict[str, str],
                                                capsys: pytest.CaptureFixture[str]) -> None:
    argv = _argv(case, files)
    folder = Path(files["d"])
    before = {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}
    rc = main(argv)  # an exception escaping main fails the test with its traceback
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    assert rc == code, f"exit {rc}, expected {code}\nstdout: {out}\nstderr: {err}"
    if code == 0:
        return
    assert "error" in err or (not case and "usage:" in out), err
    assert "SIMULATED BUS" not in err, "refused only after the bus was opened"
    after = {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}
    assert after == before, "a refused command wrote or changed a file"
    if "--json" in argv and out.strip():
        doc = json.loads(out)
        assert doc["ok"] is False and doc["error"]["exit_code"] == code
