"""LeRobot calibration files: import, export, round trips, bad files, and the normalisation.

The expected values are computed here from LeRobot's documented definitions (the calibration file
layout of ``MotorCalibration`` and the normalisation of ``MotorsBus._normalize`` in
``lerobot/motors/motors_bus.py``), written out below, not taken from armctl's module.
"""

from __future__ import annotations

import hashlib
import json
import math
import random
from dataclasses import asdict, replace
from pathlib import Path

import pytest
from armctl_testpaths import DATA

from armctl.cli import main
from armctl.config import load_spec
from armctl.config.schema import ArmSpec
from armctl.errors import ConfigError
from armctl.servo import ArmBus, Register
from armctl.servo.calibration import Calibration, JointCalibration
from armctl.servo.lerobot_calibration import (
    MotorRecord,
    export_lerobot,
    from_lerobot,
    import_lerobot,
    parse_lerobot,
    to_lerobot,
)
from armctl.servo.mapping import JointMapping

pytestmark = pytest.mark.timeout(60)
LEROBOT = DATA / "lerobot"
#: (bundled arm, example file, servo family reverses in software (Feetech))
EXAMPLES = [("so101", "so101_follower", True), ("so101_leader", "so101_follower", True),
            ("koch_follower", "koch_follower", False), ("koch_leader", "koch_leader", False)]
KEYS = ["id", "drive_mode", "homing_offset", "range_min", "range_max"]


def _doc(name: str) -> dict:
    return json.loads((LEROBOT / f"{name}.json").read_text())


def _write(tmp_path: Path, doc: object, name: str = "cal.json") -> Path:
    p = tmp_path / name
    p.write_text(json.dumps(doc, indent=4))
    return p


# ---- LeRobot's normalisation, written from its definition -------------------------------------
def lerobot_normalize(p: int, entry: dict, mode: str, software_drive: bool) -> float:
    """Mirror of LeRobot's ``MotorsBus._normalize`` for one motor (resolution 4096).

    RANGE_M100_100: clamp p to [min, max], 200 (p - min) / (max - min) - 100, negated when the
    bus applies drive modes (Feetech: ``apply_drive_mode = True``) and drive_mode is 1.
    RANGE_0_100: 100 (p - min) / (max - min), 100 - x when reversed likewise.
    DEGREES: (p - (min + max) / 2) * 360 / 4095, no clamp, no drive mode.
    """
    lo, hi = entry["range_min"], entry["range_max"]
    reverse = software_drive and entry["drive_mode"] == 1
    b = min(hi, max(lo, p))
    if mode == "range_m100_100":
        x = (b - lo) / (hi - lo) * 200 - 100
        return -x if reverse else x
    if mode == "range_0_100":
        x = (b - lo) / (hi - lo) * 100
        return 100 - x if reverse else x
    return (p - (lo + hi) / 2) * 360 / 4095


# ---- the example files -----------------------------------------------------------------------
@pytest.mark.parametrize(("arm", "name", "feetech"), EXAMPLES)
def test_example_imports_to_lerobot_zero_and_range(arm: str, name: str, feetech: bool) -> None:
    spec = load_spec(arm)
    cal = import_lerobot(spec, LEROBOT / f"{name}.json")
    doc = _doc(name)
    assert cal.arm == spec.name and set(cal.joints) == set(doc)
    for motor, e in doc.items():
        jc = cal.joints[motor]
        assert (jc.servo_id, jc.homing_offset, jc.drive_mode) == (
            e["id"], e["homing_offset"], e["drive_mode"])
        assert (jc.min_tick, jc.max_tick) == (e["range_min"], e["range_max"])
        if motor == "gripper":  # LeRobot's 0 % is the config's lower limit
            joint = next(j for j in spec.actuated_joints if j.name == motor)
            assert jc.zero_tick == e["range_min"] and jc.zero_value == joint.limits.lower
        else:  # LeRobot's zero is the middle of the range
            assert jc.zero_tick == (e["range_min"] + e["range_max"]) / 2 and jc.zero_value == 0


@pytest.mark.parametrize(("arm", "name", "feetech"), EXAMPLES)
def test_import_then_export_gives_identical_json(arm: str, name: str, feetech: bool,
                                                 tmp_path: Path) -> None:
    spec = load_spec(arm)
    cal = import_lerobot(spec, LEROBOT / f"{name}.json")
    out = export_lerobot(spec, cal, tmp_path / "back.json")
    assert out.shifts == ()
    back = json.loads((tmp_path / "back.json").read_text())
    assert back == _doc(name)
    # byte for byte what LeRobot's draccus.dump(indent=4) wrote (the examples were)
    assert (tmp_path / "back.json").read_bytes() == (LEROBOT / f"{name}.json").read_bytes()
    for entry in back.values():  # the layout LeRobot's loader expects, in its key order
        assert list(entry) == KEYS and all(type(v) is int for v in entry.values())


@pytest.mark.parametrize(("arm", "name", "feetech"), EXAMPLES)
def test_export_then_import_gives_identical_calibration(arm: str, name: str, feetech: bool,
                                                       tmp_path: Path) -> None:
    spec = load_spec(arm)
    cal = import_lerobot(spec, LEROBOT / f"{name}.json")
    saved = Calibration.load(cal.save(tmp_path / "arm.calibration.yaml"))
    assert saved == cal and saved.hash == cal.hash
    export_lerobot(spec, saved, tmp_path / "x.json")
    again = import_lerobot(spec, tmp_path / "x.json")
    assert again == cal


# ---- the property: LeRobot's normalised positions and armctl's joint values agree -------------
def _cases(feetech: bool, name: str) -> list[tuple[str, dict]]:
    """The example's entries, plus (Feetech) a copy with every drive mode reversed."""
    doc = _doc(name)
    out = [("as written", doc)]
    if feetech:
        out.append(("reversed", {m: {**e, "drive_mode": 1} for m, e in doc.items()}))
    return out


@pytest.mark.parametrize(("arm", "name", "feetech"), EXAMPLES)
def test_normalised_positions_and_joint_values_agree(arm: str, name: str, feetech: bool,
                                                     tmp_path: Path) -> None:
    spec = load_spec(arm)
    rng = random.Random(14)
    for label, doc in _cases(feetech, name):
        cal = import_lerobot(spec, _write(tmp_path, doc))
        mapping = JointMapping.from_spec(spec, cal)
        for motor, e in doc.items():
            j = mapping.joint(motor)
            lo, hi = e["range_min"], e["range_max"]
            rad_per_tick = 2 * math.pi / 4096
            lower = next(x for x in spec.actuated_joints if x.name == motor).limits.lower
            for _ in range(200):
                p = rng.randint(lo, hi)
                q = j.to_joint(p)
                if motor == "gripper":
                    x = lerobot_normalize(p, e, "range_0_100", feetech)
                    assert q == pytest.approx(lower + x / 100 * (hi - lo) * rad_per_tick,
                                              abs=1e-9), (label, motor, p)
                    continue
                x = lerobot_normalize(p, e, "range_m100_100", feetech)
                want = x / 100 * (hi - lo) / 2 * rad_per_tick
                if hi - lo >= 4095:  # a full turn: both ends are the same physical angle
                    q = want + math.remainder(q - want, 2 * math.pi)
                assert q == pytest.approx(want, abs=1e-9), (label, motor, p)
                if label == "as written":  # LeRobot's degrees ignore a Feetech drive mode
                    deg = lerobot_normalize(p, e, "degrees", feetech)
                    assert math.degrees(q) == pytest.approx(deg * 4095 / 4096, abs=1e-9)


def test_reversed_feetech_motor_counts_against_the_config(tmp_path: Path) -> None:
    spec = load_spec("so101")
    doc = _doc("so101_follower")
    doc["elbow_flex"]["drive_mode"] = 1
    mapping = JointMapping.from_spec(spec, import_lerobot(spec, _write(tmp_path, doc)))
    assert mapping.joint("elbow_flex").direction == -1
    assert mapping.joint("elbow_flex").servo_reverse is None  # no Drive Mode register
    assert mapping.joint("shoulder_lift").direction == 1


def test_koch_leader_drive_mode_is_set_on_the_servo() -> None:
    """The Koch leader's elbow is reversed by the servo (Drive Mode bit 0), not by armctl."""
    spec = load_spec("koch_leader")
    cal = import_lerobot(spec, LEROBOT / "koch_leader.json")
    mapping = JointMapping.from_spec(spec, cal)
    assert mapping.joint("elbow_flex").servo_reverse is True
    assert mapping.joint("elbow_flex").direction == 1
    with ArmBus.from_spec(spec, cal) as ab:
        modes = {i: ab.servo_bus.read(i, Register.DRIVE_MODE) for i in range(1, 7)}
        assert modes[3] & 1 == 1 and all(modes[i] & 1 == 0 for i in (1, 2, 4, 5, 6))
        ticks = ab.read_state().ticks
        q = ab.read_joints()
    elbow = _doc("koch_leader")["elbow_flex"]
    assert int(ticks[2]) == round((elbow["range_min"] + elbow["range_max"]) / 2)
    assert q[2] == pytest.approx(0.0, abs=2e-3)


@pytest.mark.parametrize(("arm", "name", "feetech"), [EXAMPLES[0], EXAMPLES[3]])
def test_positions_read_on_the_bus_agree(arm: str, name: str, feetech: bool) -> None:
    """On the simulated servos: LeRobot's normalisation of the Present Position register that
    its bus would read equals armctl's joint value, wherever the arm is moved by hand."""
    spec = load_spec(arm)
    doc = _doc(name)
    cal = import_lerobot(spec, LEROBOT / f"{name}.json")
    rng = random.Random(7)
    with ArmBus.from_spec(spec, cal) as ab:
        sim = ab.simulator
        assert sim is not None
        for _ in range(5):
            want = {m: rng.randint(e["range_min"] + 1, e["range_max"] - 1)
                    for m, e in doc.items()}
            for m, t in want.items():
                servo = sim.servo(doc[m]["id"])
                servo.set_present_position(t)
                if servo.present_position() != t:  # a hand move counted unreversed
                    servo.set_present_position(2 * servo.present_position() - t)
            q = dict(zip(ab.joint_names, ab.read_joints(), strict=True))
            for m, e in doc.items():
                p = ab.servo_bus.read(e["id"], Register.PRESENT_POSITION)
                assert p == want[m]
                lo, hi = e["range_min"], e["range_max"]
                half = (hi - lo) / 2 * 2 * math.pi / 4096
                if m == "gripper":
                    x = lerobot_normalize(p, e, "range_0_100", feetech)
                    lower = next(j for j in spec.actuated_joints if j.name == m).limits.lower
                    assert q[m] == pytest.approx(lower + x / 50 * half, abs=1e-9)
                else:
                    x = lerobot_normalize(p, e, "range_m100_100", feetech)
                    assert q[m] == pytest.approx(x / 100 * half, abs=1e-9)


# ---- a calibration measured by armctl ---------------------------------------------------------
def _native(spec: ArmSpec) -> Calibration:
    """A calibration as 'armctl calibrate' writes it: zero at the reference pose."""
    joints = {}
    for s in spec.bus.servos:  # type: ignore[union-attr]
        ref = 2048.0 + 10 * s.id
        joints[s.joint] = JointCalibration(s.id, ref, 0.0, 1200.0, 2900.0 + 100 * (s.id % 2))
    return Calibration(spec.name, joints)


def test_native_export_reports_the_zero_shift(tmp_path: Path) -> None:
    spec = load_spec("so101")
    native = _native(spec)
    out = to_lerobot(spec, native)
    rad_per_tick = 2 * math.pi / 4096
    shifts = {s.joint: s.value for s in out.shifts}
    for s in spec.bus.servos:  # type: ignore[union-attr]
        jc = native.joints[s.joint]
        if s.joint == "gripper":  # 0 % = range_min; LeRobot's value there: the lower limit
            lower = next(j for j in spec.actuated_joints if j.name == "gripper").limits.lower
            want = (jc.min_tick - jc.zero_tick) * rad_per_tick - lower
        else:
            want = ((jc.min_tick + jc.max_tick) / 2 - jc.zero_tick) * rad_per_tick
        assert shifts[s.joint] == pytest.approx(want, abs=1e-12)
    assert out.records["wrist_flex"] == MotorRecord(4, 0, 0, 1200, 2900)
    # re-imported, the joint values differ from armctl's by exactly the shift
    again = from_lerobot(spec, out.records)
    a, b = JointMapping.from_spec(spec, native), JointMapping.from_spec(spec, again)
    for name, value in shifts.items():
        for t in (1300, 2000, 2800):
            assert a.joint(name).to_joint_raw(t) - b.joint(name).to_joint_raw(t) == \
                pytest.approx(value, abs=1e-12)


def test_calibration_without_drive_mode_keeps_its_hash() -> None:
    """Files written before drive modes were recorded keep their hash (keyframes refer to it)."""
    jc = JointCalibration(1, 2048.0, 0.0, 1000.0, 3000.0, 12, False, True)
    cal = Calibration("arm", {"j": jc})
    old = {"servo_id": 1, "zero_tick": 2048.0, "zero_value": 0.0, "min_tick": 1000.0,
           "max_tick": 3000.0, "homing_offset": 12, "multi_turn": False, "wrap_detected": True}
    body = {"arm": "arm", "version": 1, "joints": {"j": old}}
    text = json.dumps(body, sort_keys=True, separators=(",", ":"))
    assert cal.hash == hashlib.sha256(text.encode()).hexdigest()[:16]
    assert replace(jc, drive_mode=0) != jc
    assert Calibration("arm", {"j": replace(jc, drive_mode=1)}).hash != cal.hash
    assert "drive_mode" not in jc.record() and asdict(jc)["drive_mode"] is None


# ---- bad files -------------------------------------------------------------------------------
def _refused(tmp_path: Path, doc: object, arm: str = "so101") -> ConfigError:
    path = _write(tmp_path, doc)
    with pytest.raises(ConfigError) as exc:
        import_lerobot(load_spec(arm), path)
    assert str(path) in str(exc.value) and exc.value.fix
    return exc.value


def test_missing_key_names_file_motor_and_key(tmp_path: Path) -> None:
    doc = _doc("so101_follower")
    del doc["wrist_flex"]["range_max"]
    err = _refused(tmp_path, doc)
    assert err.details["key"] == "wrist_flex.range_max" and "'range_max'" in err.problem


@pytest.mark.parametrize("value", ["2047", 2047.0, True, None, [1]])
def test_non_integer_is_refused(tmp_path: Path, value: object) -> None:
    doc = _doc("so101_follower")
    doc["gripper"]["homing_offset"] = value
    err = _refused(tmp_path, doc)
    assert err.details["key"] == "gripper.homing_offset" and "not an integer" in err.problem


@pytest.mark.parametrize(("edit", "key", "words"), [
    (lambda d: d.__setitem__("elbow", d.pop("elbow_flex")), "elbow", "not a servo joint"),
    (lambda d: d.pop("gripper"), None, "no entry for 'gripper'"),
    (lambda d: d["shoulder_lift"].__setitem__("id", 7), "shoulder_lift.id", "servo 2"),
    (lambda d: d["wrist_flex"].__setitem__("range_min", 3197), "wrist_flex.range_max",
     "not below"),
    (lambda d: d["wrist_flex"].__setitem__("range_max", 4096), "wrist_flex.range_max",
     "outside"),
    (lambda d: d["elbow_flex"].__setitem__("homing_offset", -2048),
     "elbow_flex.homing_offset", "-2047..2047"),
    (lambda d: d["elbow_flex"].__setitem__("drive_mode", 2), "elbow_flex.drive_mode",
     "outside 0..1"),
    (lambda d: d["elbow_flex"].__setitem__("extra", 1), "elbow_flex.extra", "unknown key"),
])
def test_mismatched_files_are_refused(tmp_path: Path, edit: object, key: str | None,
                                      words: str) -> None:
    doc = _doc("so101_follower")
    edit(doc)  # type: ignore[operator]
    err = _refused(tmp_path, doc)
    assert err.details["key"] == key and words in err.problem


def test_koch_file_for_the_so101_checks_value_ranges(tmp_path: Path) -> None:
    """A Dynamixel file whose offsets a Feetech servo cannot store is refused."""
    doc = _doc("koch_leader")  # elbow_flex: homing offset -2090, beyond the STS3215's 11 bits
    err = _refused(tmp_path, doc, "so101")
    assert err.details["key"] == "elbow_flex.homing_offset" and "-2047..2047" in err.problem


def test_range_outside_the_config_limits_is_refused(tmp_path: Path) -> None:
    """A config whose joint cannot reach LeRobot's zero (the middle of the range) is refused."""
    text = Path(load_spec("so101").file).read_text()  # type: ignore[arg-type]
    text = text.replace("limits: {lower: -1.91986, upper: 1.91986,",
                        "limits: {lower: 0.5, upper: 1.5,")
    text = text.replace("home: {shoulder_pan: 0,", "home: {shoulder_pan: 1,")
    text = text.replace("park: {shoulder_pan: 0,", "park: {shoulder_pan: 1,")
    cfg = tmp_path / "so101.yaml"
    cfg.write_text(text)
    doc = _doc("so101_follower")
    doc["shoulder_pan"].update(range_min=1800, range_max=2200)  # +-0.31 rad about its middle
    err = _refused(tmp_path, doc, str(cfg))
    assert err.details["key"] == "shoulder_pan" and "calibrated range" in err.problem
    doc["shoulder_pan"].update(range_min=0, range_max=4095)  # +-180 deg: reaches 0.5..1.5
    import_lerobot(load_spec(cfg), _write(tmp_path, doc))


@pytest.mark.parametrize("text", ["", "[1, 2]", "{}", '{"a": 1}', "{not json",
                                  '{"gripper": {"id": 6}, "gripper": {"id": 6}}'])
def test_not_a_calibration_file(text: str) -> None:
    with pytest.raises(ConfigError) as exc:
        parse_lerobot(text, Path("x.json"))
    assert str(exc.value.details["file"]) == "x.json" and exc.value.fix


def test_missing_file_is_a_config_error(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="cannot read"):
        import_lerobot(load_spec("so101"), tmp_path / "none.json")


def test_export_never_overwrites_silently(tmp_path: Path) -> None:
    spec = load_spec("so101")
    cal = import_lerobot(spec, LEROBOT / "so101_follower.json")
    out = tmp_path / "cal.json"
    out.write_text("keep me")
    with pytest.raises(ConfigError, match="exists already"):
        export_lerobot(spec, cal, out)
    assert out.read_text() == "keep me"
    export_lerobot(spec, cal, out, overwrite=True)
    assert json.loads(out.read_text()) == _doc("so101_follower")
    with pytest.raises(ConfigError, match="folder"):
        export_lerobot(spec, cal, tmp_path, overwrite=True)


def test_export_of_another_arms_calibration_is_refused() -> None:
    cal = import_lerobot(load_spec("so101"), LEROBOT / "so101_follower.json")
    with pytest.raises(ConfigError, match="is for arm 'so101'"):
        to_lerobot(load_spec("koch_follower"), cal)


# ---- the command line ------------------------------------------------------------------------
def test_cli_import_and_export(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = tmp_path / "so101.yaml"
    cfg.write_text(Path(load_spec("so101").file).read_text())  # type: ignore[arg-type]
    src = LEROBOT / "so101_follower.json"
    assert main(["calibrate", str(cfg), "--from-lerobot", str(src), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    written = tmp_path / "so101.calibration.yaml"
    assert out["file"] == str(written) and Calibration.load(written).hash == out["hash"]
    before = written.read_text()
    assert main(["calibrate", str(cfg), "--from-lerobot", str(src)]) == 2
    assert "exists already" in capsys.readouterr().err and written.read_text() == before
    assert main(["calibrate", str(cfg), "--from-lerobot", str(src), "--force"]) == 0
    capsys.readouterr()
    back = tmp_path / "back.json"
    assert main(["calibrate", str(cfg), "--to-lerobot", str(back), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["zero_shifts"] == {} and json.loads(back.read_text()) == _doc("so101_follower")
    assert main(["calibrate", str(cfg), "--to-lerobot", str(back)]) == 2
    assert "--force" in capsys.readouterr().err
    assert main(["calibrate", str(cfg), "--to-lerobot", str(tmp_path / "y.json"), "-o",
                 str(tmp_path / "z.yaml")]) == 2
    assert main(["calibrate", str(cfg), "--from-lerobot", str(src), "--reference", "home",
                 "--force"]) == 2
    assert "--reference is for measuring" in capsys.readouterr().err
    assert not (tmp_path / "y.json").exists() and not (tmp_path / "z.yaml").exists()


def test_cli_export_without_calibration_says_how(tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    cfg = tmp_path / "so101.yaml"
    cfg.write_text(Path(load_spec("so101").file).read_text())  # type: ignore[arg-type]
    assert main(["calibrate", str(cfg), "--to-lerobot", str(tmp_path / "x.json")]) == 2
    err = capsys.readouterr().err
    assert "no calibration file" in err and "--from-lerobot" in err
    assert not (tmp_path / "x.json").exists()
